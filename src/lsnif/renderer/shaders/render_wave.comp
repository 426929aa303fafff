// render_wave.comp -- the wavefront path tracer's stages (RENDER_WAVE_*, render_host_device.h), one
// invocation per pixel, one path per pixel in flight. The host records, per sample: CAMERA, then per
// path vertex lsnifCmdQuery(path rays), SHADE, lsnifCmdQuery(shadow rays, any hit), CONNECT, and
// finally ACCUMULATE. The estimator is render_path.glsl's, as in the inline render.rgen; the
// surfaces are render_surface.glsl's, built from the queries' LsnifQueryResult. With
// RenderFrame::primary_raster, CAMERA takes the camera ray's hit from the visibility buffer
// (render_visibility.glsl) and shades it as SHADE would; the host then casts no camera rays.
#version 460
#extension GL_GOOGLE_include_directive : require
#include "lsnif/renderer/shaders/render_path.glsl"
#include "lsnif/renderer/shaders/render_surface.glsl"
#include "lsnif/shaders/lsnif_model.glsl"
#include "lsnif/renderer/shaders/render_visibility.glsl"

layout(local_size_x = 64) in;

layout(buffer_reference, scalar, buffer_reference_align = 8) readonly buffer RenderWaveRef { RenderWave w; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer RenderWavePathRef { RenderWavePath v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer RenderWaveShadowRef { RenderWaveShadow v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 16) buffer RenderQueryRayRef { LsnifQueryRay v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 16) readonly buffer RenderQueryResultRef { LsnifQueryResult v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer RenderMat3Ref { mat3 v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 8) readonly buffer RenderAddressRef { uint64_t v[]; };

// A query ray; a zero direction makes lsnifCmdQuery answer NONE (nothing to cast).
LsnifQueryRay render_query_ray(RenderRay r, bool send, uint flags) {
  if (!send) return LsnifQueryRay(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0u, 0u, 0u, 0u);
  return LsnifQueryRay(r.origin.x, r.origin.y, r.origin.z, r.tmin, r.direction.x, r.direction.y, r.direction.z,
                       RENDER_INF, r.flags | flags, 0u, 0u, 0u);
}

RenderPath render_load_path(RenderWavePath s) {
  RenderPath p;
  p.throughput = vec3(s.throughput_r, s.throughput_g, s.throughput_b);
  p.radiance = vec3(s.radiance_r, s.radiance_g, s.radiance_b);
  p.last_pdf = s.last_pdf;
  p.rng.key = s.rng_key;
  p.rng.dim = s.rng_dim;
  return p;
}

RenderWavePath render_store_path(RenderPath p, bool alive) {
  return RenderWavePath(p.throughput.r, p.throughput.g, p.throughput.b, p.radiance.r, p.radiance.g, p.radiance.b,
                        p.last_pdf, p.rng.key, p.rng.dim, alive ? 1u : 0u, 0u, 0u);
}

// The surface of a query result of kind TRIANGLE or LSNIF.
RenderHit render_result_hit(RenderFrame f, LsnifQueryResult q) {
  const mat3 w2o = RenderMat3Ref(f.world_to_object).v[q.instance_custom_index];
  if (q.kind == LSNIF_QUERY_HIT_TRIANGLE)
    return render_triangle_hit(f, q.instance_custom_index, q.geometry_index, q.primitive_index,
                               vec2(q.barycentric_u, q.barycentric_v), w2o, q.t);
  LsnifModel m = lsnif_load_model(RenderAddressRef(pc.push.model_table).v[q.instance_custom_index]);
  return render_lsnif_hit(f, q.instance_custom_index, vec3(q.normal_x, q.normal_y, q.normal_z),
                          vec3(q.albedo_r, q.albedo_g, q.albedo_b), q.material,
                          (q.surface >> 24) == LSNIF_SURFACE_LEARNED, unpackUnorm4x8(q.surface).xyz,
                          vec3(q.emission_r, q.emission_g, q.emission_b), q.reports_uv != 0u, vec2(q.uv_u, q.uv_v), w2o,
                          lsnif_leaving_distance(m), q.t);
}

#define RENDER_WAVE_MISS 0u
#define RENDER_WAVE_HIT 1u
#define RENDER_WAVE_UNKNOWN 2u  // an INCOMPLETE query answer: the host fails the render

// Path vertex `bounce` of `pixel` (alive: its ray was cast; `kind` what the ray met, hit and p the
// surface when it hit): shades it and stores the path, its next ray and its shadow rays.
void render_wave_vertex(RenderFrame f, RenderWave w, uint pixel, RenderPath path, bool alive, uint kind, RenderHit hit,
                        vec3 p, vec3 direction, uint bounce) {
  RenderShadow shadow[RENDER_SHADOWS];
  for (uint k = 0u; k < RENDER_SHADOWS; ++k) shadow[k] = render_no_shadow();
  RenderRay next = render_no_shadow().ray;
  bool more = false;
  if (alive) {
    if (kind == RENDER_WAVE_HIT)
      more = render_path_hit(f, path, hit, p, direction, bounce, shadow, next);
    else if (kind == RENDER_WAVE_MISS)
      render_path_miss(f, path, direction);
  }
  RenderWavePathRef(w.paths).v[pixel] = render_store_path(path, more);
  RenderQueryRayRef(w.rays).v[pixel] = render_query_ray(next, more, 0u);
  RenderQueryRayRef shadow_rays = RenderQueryRayRef(w.shadow_rays);
  RenderWaveShadowRef shadows = RenderWaveShadowRef(w.shadows);
  for (uint k = 0u; k < RENDER_SHADOWS; ++k) {
    const uint i = RENDER_WAVE_SHADOWS * pixel + k;
    shadow_rays.v[i] = render_query_ray(shadow[k].ray, shadow[k].valid, LSNIF_RAY_FLAG_TERMINATE_ON_FIRST_HIT);
    shadows.v[i] = RenderWaveShadow(shadow[k].value.r, shadow[k].value.g, shadow[k].value.b, shadow[k].valid ? 1u : 0u);
  }
}

void main() {
  const RenderFrame f = render_frame();
  const uint pixel = gl_GlobalInvocationID.x;
  if (pixel >= f.width * f.height) return;
  const RenderWave w = RenderWaveRef(pc.push.wave).w;
  RenderWavePathRef paths = RenderWavePathRef(w.paths);
  RenderQueryRayRef rays = RenderQueryRayRef(w.rays);
  RenderWaveShadowRef shadows = RenderWaveShadowRef(w.shadows);

  if (pc.push.stage == RENDER_WAVE_CAMERA) {
    RenderRay ray;
    const RenderPath path = render_path_start(f, pixel, pc.push.sample_index, ray);
    if (f.primary_raster != 0u) {
      RenderHit hit;
      vec3 p;
      const bool found = render_visibility_hit(f, pixel, pc.push.sample_index, ray, hit, p);
      render_wave_vertex(f, w, pixel, path, true, found ? RENDER_WAVE_HIT : RENDER_WAVE_MISS, hit, p, ray.direction, 0u);
    } else {
      paths.v[pixel] = render_store_path(path, true);
      rays.v[pixel] = render_query_ray(ray, true, 0u);
    }
  } else if (pc.push.stage == RENDER_WAVE_SHADE) {
    const LsnifQueryRay r = rays.v[pixel];
    const vec3 origin = vec3(r.origin_x, r.origin_y, r.origin_z), direction = vec3(r.direction_x, r.direction_y, r.direction_z);
    const LsnifQueryResult q = RenderQueryResultRef(w.results).v[pixel];
    const bool found = q.kind == LSNIF_QUERY_HIT_TRIANGLE || q.kind == LSNIF_QUERY_HIT_LSNIF;
    RenderHit hit;
    if (found) hit = render_result_hit(f, q);
    // INCOMPLETE is not a miss: the host fails the render on the queries' status.
    const uint kind = found ? RENDER_WAVE_HIT : q.kind == LSNIF_QUERY_HIT_NONE ? RENDER_WAVE_MISS : RENDER_WAVE_UNKNOWN;
    render_wave_vertex(f, w, pixel, render_load_path(paths.v[pixel]), paths.v[pixel].alive != 0u, kind, hit,
                       origin + q.t * direction, direction, pc.push.bounce);
  } else if (pc.push.stage == RENDER_WAVE_CONNECT) {
    RenderQueryResultRef shadow_results = RenderQueryResultRef(w.shadow_results);
    vec3 add = vec3(0.0);
    for (uint k = 0u; k < RENDER_SHADOWS; ++k) {
      const uint i = RENDER_WAVE_SHADOWS * pixel + k;
      const RenderWaveShadow s = shadows.v[i];
      if (s.valid != 0u && shadow_results.v[i].kind == LSNIF_QUERY_HIT_NONE) add += vec3(s.value_r, s.value_g, s.value_b);
    }
    paths.v[pixel].radiance_r += add.r;
    paths.v[pixel].radiance_g += add.g;
    paths.v[pixel].radiance_b += add.b;
  } else if (pc.push.stage == RENDER_WAVE_ACCUMULATE) {
    RenderVec4Ref acc = RenderVec4Ref(f.accumulation);
    acc.v[pixel] += vec4(render_path_result(render_load_path(paths.v[pixel])), 1.0);
  }
}
