// render_path.glsl -- the path tracer's estimator, one path vertex at a time, shared by the inline
// pipeline (render.rgen: one launch per pixel, rays cast with traceRayEXT) and the wavefront
// pipeline (render_wave.comp: the same steps as compute passes, rays cast in batches through
// lsnifCmdQuery). Materials: Lambert + GGX (glTF metallic-roughness), sampled by a lobe mixture.
// Light: the environment (constant color or an equirectangular HDR image), hit on a miss and, with
// env_importance, sampled by next-event estimation with multiple importance sampling (balance
// heuristic); optionally a sun (a small disk of directions) sampled the same way. Random numbers
// are a hash of (pixel, sample, dimension), drawn in the same order by both pipelines, so both use
// the same sequence per pixel. Rays leaving an LSNIF hit follow the plugin's self-intersection rule
// (docs/self-intersection.md); rays leaving a triangle start off the surface along the geometric
// normal.
#ifndef RENDER_PATH_GLSL
#define RENDER_PATH_GLSL

#include "lsnif/renderer/shaders/render_common.glsl"
#include "lsnif/renderer/shaders/render_sampling.glsl"

// gl_RayFlagsCullBackFacingTrianglesEXT, which is also LSNIF_RAY_FLAG_CULL_BACK_FACING.
#define RENDER_RAY_CULL_BACK 0x10u

// A ray to cast: [tmin, inf), flags RENDER_RAY_*.
struct RenderRay {
  vec3 origin;
  float tmin;
  vec3 direction;
  uint flags;
};

// One path's state between vertices.
struct RenderPath {
  vec3 throughput;
  vec3 radiance;
  float last_pdf;  // solid-angle pdf of the BSDF sample that made the current ray (< 0: camera / delta)
  RenderRng rng;
};

// A light sample of next-event estimation: `value` is added when `ray` reaches infinity unblocked.
struct RenderShadow {
  RenderRay ray;
  vec3 value;
  bool valid;  // false: nothing to test
};
#define RENDER_SHADOWS 2u  // per path vertex: the environment, the sun
RenderShadow render_no_shadow() { return RenderShadow(RenderRay(vec3(0.0), 0.0, vec3(0.0), 0u), vec3(0.0), false); }

// Starts the path of sample `sample_index` of `pixel`: its camera ray through the pixel at the
// sample's sub-pixel offset (render_camera_jitter, shared by all pixels of the sample).
RenderPath render_path_start(RenderFrame f, uint pixel, uint sample_index, out RenderRay ray) {
  RenderPath path;
  path.rng = render_rng(pixel, sample_index);
  path.throughput = vec3(1.0);
  path.radiance = vec3(0.0);
  path.last_pdf = -1.0;
  const uint px = pixel % f.width, py = pixel / f.width;
  const mat4x3 cam = transpose(mat3x4(f.cam_to_world[0], f.cam_to_world[1], f.cam_to_world[2], f.cam_to_world[3],
                                      f.cam_to_world[4], f.cam_to_world[5], f.cam_to_world[6], f.cam_to_world[7],
                                      f.cam_to_world[8], f.cam_to_world[9], f.cam_to_world[10], f.cam_to_world[11]));
  const vec2 jitter = render_camera_jitter(sample_index);
  const vec2 ndc = vec2((float(px) + jitter.x) / float(f.width), (float(py) + jitter.y) / float(f.height)) * 2.0 - 1.0;
  const vec3 dir_camera = normalize(vec3(ndc.x * f.tan_half_fov_y * f.aspect, -ndc.y * f.tan_half_fov_y, -1.0));
  ray.origin = cam[3];
  ray.direction = normalize(mat3(cam) * dir_camera);
  ray.tmin = 0.0;
  ray.flags = 0u;
  return path;
}

// The path's ray left the scene in `direction`: the environment (and sun) it sees, MIS-weighted
// against next-event estimation when a BSDF sample made the ray. The path ends.
void render_path_miss(RenderFrame f, inout RenderPath path, vec3 direction) {
  const vec3 le = render_environment(f, direction);
  float w = 1.0;
  if (path.last_pdf > 0.0 && f.env_importance != 0u) {
    const float pl = render_environment_pdf(f, direction);
    w = path.last_pdf / (path.last_pdf + pl);
  }
  path.radiance += path.throughput * le * w;
  if (render_in_sun(f, direction)) {  // seen directly, or found by BSDF sampling (MIS weight)
    const float pl = render_sun_pdf(f);
    path.radiance += path.throughput * vec3(f.sun_r, f.sun_g, f.sun_b) *
                     (path.last_pdf > 0.0 ? path.last_pdf / (path.last_pdf + pl) : 1.0);
  }
}

// The ray leaving `hit` (at p, geometric normal ng facing the viewer) in direction d.
RenderRay render_leave(RenderHit hit, vec3 p, vec3 ng, vec3 d) {
  RenderRay r;
  r.direction = d;
  if ((hit.flags & RENDER_HIT_LSNIF) != 0u) {
    r.origin = p;
    r.tmin = hit.leaving_distance / max(length(hit.world_to_object * d), 1e-30);
    r.flags = RENDER_RAY_CULL_BACK;
  } else {
    r.origin = p + ng * (1e-4 * (1.0 + max(abs(p.x), max(abs(p.y), abs(p.z)))));
    r.tmin = 0.0;
    r.flags = 0u;
  }
  return r;
}

// Next-event estimation towards a light direction wl sampled with solid-angle pdf pl and radiance le.
RenderShadow render_connect(RenderPath path, RenderHit hit, RenderBsdf bsdf, vec3 p, vec3 ng, vec3 ns, vec3 wo,
                            vec3 wl, float pl, vec3 le) {
  RenderShadow s;
  s.valid = false;
  s.value = vec3(0.0);
  s.ray = render_leave(hit, p, ng, wl);
  const float cos_l = dot(ns, wl);
  if (pl > 0.0 && cos_l > 0.0 && dot(ng, wl) > 0.0) {
    const vec3 fr = render_bsdf_eval(bsdf, ns, wo, wl);
    const float pb = render_bsdf_pdf(bsdf, ns, wo, wl);
    s.valid = any(greaterThan(fr, vec3(0.0)));
    s.value = path.throughput * fr * cos_l * le / (pl + pb);
  }
  return s;
}

// Path vertex `bounce` (0: the camera ray's hit) at `hit`, reached along `direction`: adds the
// emission, samples the lights (shadow[k]: add value when its ray is unblocked, whatever this
// returns) and the BSDF. Returns true when the path goes on along `next`.
bool render_path_hit(RenderFrame f, inout RenderPath path, RenderHit hit, vec3 p, vec3 direction, uint bounce,
                     out RenderShadow shadow[RENDER_SHADOWS], out RenderRay next) {
  for (uint k = 0u; k < RENDER_SHADOWS; ++k) shadow[k] = render_no_shadow();
  next = RenderRay(vec3(0.0), 0.0, vec3(0.0), 0u);
  const vec3 wo = -direction;
  vec3 ng = hit.geometric_normal, ns = hit.normal;
  if (dot(ng, wo) < 0.0) ng = -ng;  // two-sided: face the viewer
  if (dot(ns, ng) < 0.0) ns = -ns;
  path.radiance += path.throughput * hit.emission;
  if (bounce == f.max_bounces) return false;
  // glTF's occlusion map darkens the ambient light a surface reflects; the only lights here are
  // the sky (with its sun disc) and emitters, all of it ambient: every reflection is scaled.
  path.throughput *= hit.ambient_occlusion;
  const RenderBsdf bsdf = render_bsdf(hit.albedo, hit.metallic, hit.roughness);
  // Next-event estimation towards the environment.
  if (f.env_importance != 0u) {
    float pl;
    const vec3 wl = render_sample_environment(f, vec2(render_rand(path.rng), render_rand(path.rng)), pl);
    shadow[0] = render_connect(path, hit, bsdf, p, ng, ns, wo, wl, pl, render_environment(f, wl));
  }
  // Next-event estimation towards the sun (MIS against BSDF sampling, balance heuristic).
  if (f.sun_enabled != 0u) {
    const vec3 wl = render_sample_sun(f, vec2(render_rand(path.rng), render_rand(path.rng)));
    shadow[1] = render_connect(path, hit, bsdf, p, ng, ns, wo, wl, render_sun_pdf(f), vec3(f.sun_r, f.sun_g, f.sun_b));
  }
  // Continue the path by sampling the BSDF.
  float pdf;
  const vec3 wi = render_bsdf_sample(bsdf, ns, wo, vec3(render_rand(path.rng), render_rand(path.rng), render_rand(path.rng)), pdf);
  if (!(pdf > 0.0) || dot(wi, ng) <= 0.0) return false;
  path.throughput *= render_bsdf_eval(bsdf, ns, wo, wi) * dot(ns, wi) / pdf;
  if (bounce + 1u >= f.rr_depth) {  // Russian roulette
    const float q = clamp(max(path.throughput.r, max(path.throughput.g, path.throughput.b)), 0.05, 1.0);
    if (render_rand(path.rng) >= q) return false;
    path.throughput /= q;
  }
  path.last_pdf = pdf;
  next = render_leave(hit, p, ng, wi);
  return true;
}

// The radiance a finished path adds to its pixel (NaN / inf paths are dropped).
vec3 render_path_result(RenderPath path) {
  return all(lessThan(abs(path.radiance), vec3(1e30))) ? path.radiance : vec3(0.0);
}

#endif
