// render_sampling.glsl -- the path tracer's sampling: counter-based random numbers
// (render_random.glsl), the Lambert + GGX BSDF (glTF metallic-roughness) with its sampling and pdf,
// and the equirectangular environment: lookup, importance sampling and pdf, exactly as
// src/lsnif/scene/environment.h specifies (its CPU twins are tested there).
#ifndef RENDER_SAMPLING_GLSL
#define RENDER_SAMPLING_GLSL

#define RENDER_PI 3.14159265358979
#define RENDER_INF uintBitsToFloat(0x7f800000u)

#include "lsnif/renderer/shaders/render_random.glsl"

// ---- BSDF ----
struct RenderBsdf {
  vec3 diffuse;   // (1 - metallic) albedo
  vec3 f0;        // specular reflectance at normal incidence
  float alpha;    // GGX roughness^2
  float p_spec;   // probability of sampling the specular lobe
};
RenderBsdf render_bsdf(vec3 albedo, float metallic, float roughness) {
  RenderBsdf b;
  metallic = clamp(metallic, 0.0, 1.0);
  b.diffuse = (1.0 - metallic) * albedo;
  b.f0 = mix(vec3(0.04), albedo, metallic);
  const float r = clamp(roughness, 0.03, 1.0);
  b.alpha = r * r;
  const float ws = dot(b.f0, vec3(1.0 / 3.0)), wd = dot(b.diffuse, vec3(1.0 / 3.0));
  b.p_spec = clamp(ws / max(ws + wd, 1e-6), 0.1, 0.9);
  return b;
}
float render_ggx_d(float nh, float a) {
  const float a2 = a * a, d = nh * nh * (a2 - 1.0) + 1.0;
  return a2 / (RENDER_PI * d * d);
}
float render_ggx_g1(float nx, float a) {
  const float a2 = a * a;
  return 2.0 * nx / (nx + sqrt(a2 + (1.0 - a2) * nx * nx));
}
vec3 render_bsdf_eval(RenderBsdf b, vec3 n, vec3 wo, vec3 wi) {
  const float no = dot(n, wo), ni = dot(n, wi);
  if (no <= 0.0 || ni <= 0.0) return vec3(0.0);
  const vec3 h = normalize(wo + wi);
  const float nh = max(dot(n, h), 0.0), oh = max(dot(wo, h), 0.0);
  const vec3 F = b.f0 + (1.0 - b.f0) * pow(1.0 - oh, 5.0);
  const vec3 spec = F * render_ggx_d(nh, b.alpha) * render_ggx_g1(no, b.alpha) * render_ggx_g1(ni, b.alpha) / (4.0 * no * ni);
  return b.diffuse / RENDER_PI + spec;
}
float render_bsdf_pdf(RenderBsdf b, vec3 n, vec3 wo, vec3 wi) {
  const float ni = dot(n, wi);
  if (ni <= 0.0 || dot(n, wo) <= 0.0) return 0.0;
  const vec3 h = normalize(wo + wi);
  const float nh = max(dot(n, h), 0.0), oh = max(dot(wo, h), 1e-6);
  const float p_spec = render_ggx_d(nh, b.alpha) * nh / (4.0 * oh);
  return b.p_spec * p_spec + (1.0 - b.p_spec) * ni / RENDER_PI;
}
mat3 render_frame_of(vec3 n) {
  const vec3 a = abs(n.x) > 0.9 ? vec3(0, 1, 0) : vec3(1, 0, 0);
  const vec3 t = normalize(cross(a, n));
  return mat3(t, cross(n, t), n);
}
// Samples wi (u in [0,1)^3); pdf w.r.t. solid angle (the mixture's), 0 when the sample is invalid.
vec3 render_bsdf_sample(RenderBsdf b, vec3 n, vec3 wo, vec3 u, out float pdf) {
  const mat3 tbn = render_frame_of(n);
  vec3 wi;
  if (u.z < b.p_spec) {
    const float a2 = b.alpha * b.alpha;
    const float cos_t = sqrt((1.0 - u.x) / (1.0 + (a2 - 1.0) * u.x));
    const float sin_t = sqrt(max(0.0, 1.0 - cos_t * cos_t)), phi = 2.0 * RENDER_PI * u.y;
    const vec3 h = tbn * vec3(sin_t * cos(phi), sin_t * sin(phi), cos_t);
    wi = reflect(-wo, h);
  } else {
    const float r = sqrt(u.x), phi = 2.0 * RENDER_PI * u.y;
    wi = tbn * vec3(r * cos(phi), r * sin(phi), sqrt(max(0.0, 1.0 - u.x)));
  }
  pdf = render_bsdf_pdf(b, n, wo, wi);
  return wi;
}

// ---- environment: the mapping and tables of src/lsnif/scene/environment.h (read it) ----
vec3 render_rotate_y(vec3 d, float a) { return vec3(cos(a) * d.x + sin(a) * d.z, d.y, -sin(a) * d.x + cos(a) * d.z); }
// Pixel of a world direction.
uvec2 render_env_pixel(RenderFrame f, vec3 d) {
  const vec3 e = render_rotate_y(normalize(d), -f.env_rotation);
  const float theta = acos(clamp(e.y, -1.0, 1.0));
  float phi = atan(-e.x, e.z);
  if (phi < 0.0) phi += 2.0 * RENDER_PI;
  return uvec2(min(uint(phi / (2.0 * RENDER_PI) * float(f.env_width)), f.env_width - 1u),
               min(uint(theta / RENDER_PI * float(f.env_height)), f.env_height - 1u));
}
vec3 render_environment(RenderFrame f, vec3 d) {
  if (f.environment == 0ul) return vec3(f.env_r, f.env_g, f.env_b);
  const uvec2 p = render_env_pixel(f, d);
  return RenderVec3Ref(f.environment).v[p.y * f.env_width + p.x];
}
// Index i in [0, n) with cdf[base + i] <= u (the largest such), cdf[base] = 0.
uint render_find_interval(RenderFloatRef cdf, uint base, uint n, float u) {
  uint lo = 0u, hi = n;
  while (hi - lo > 1u) {
    const uint mid = (lo + hi) >> 1;
    if (cdf.v[base + mid] <= u) lo = mid;
    else hi = mid;
  }
  return lo;
}
float render_environment_pdf(RenderFrame f, vec3 d) {
  if (f.environment == 0ul) return 1.0 / (4.0 * RENDER_PI);
  const uvec2 p = render_env_pixel(f, d);
  const uint W = f.env_width, H = f.env_height;
  return RenderFloatRef(f.env_tables).v[H + 1u + H * (W + 1u) + p.y * W + p.x];
}
vec3 render_sample_environment(RenderFrame f, vec2 u, out float pdf) {
  if (f.environment == 0ul) {  // uniform sphere
    const float z = 1.0 - 2.0 * u.x, r = sqrt(max(0.0, 1.0 - z * z)), phi = 2.0 * RENDER_PI * u.y;
    pdf = 1.0 / (4.0 * RENDER_PI);
    return vec3(r * cos(phi), z, r * sin(phi));
  }
  const uint W = f.env_width, H = f.env_height;
  RenderFloatRef t = RenderFloatRef(f.env_tables);
  u = min(u, vec2(1.0 - 1.0 / 16777216.0));
  const uint y = render_find_interval(t, 0u, H, u.x);
  const uint cbase = H + 1u + y * (W + 1u);
  const uint x = render_find_interval(t, cbase, W, u.y);
  const float fy = clamp((u.x - t.v[y]) / max(t.v[y + 1u] - t.v[y], 1e-30), 0.0, 1.0);
  const float fx = clamp((u.y - t.v[cbase + x]) / max(t.v[cbase + x + 1u] - t.v[cbase + x], 1e-30), 0.0, 1.0);
  const float phi = 2.0 * RENDER_PI * (float(x) + fx) / float(W);
  const float cos_t = mix(cos(RENDER_PI * float(y) / float(H)), cos(RENDER_PI * float(y + 1u) / float(H)), fy);
  const float sin_t = sqrt(max(0.0, 1.0 - cos_t * cos_t));
  pdf = t.v[H + 1u + H * (W + 1u) + y * W + x];
  return render_rotate_y(vec3(-sin_t * sin(phi), cos_t, sin_t * cos(phi)), f.env_rotation);
}

// The sun: a disk of directions within acos(f.sun_cos_max) of the sun direction, uniform radiance.
// Solid angle 2 pi (1 - cos_max); directions are sampled uniformly in it (pdf = 1 / solid angle).
float render_sun_pdf(RenderFrame f) { return 1.0 / (2.0 * RENDER_PI * max(1.0 - f.sun_cos_max, 1e-12)); }
bool render_in_sun(RenderFrame f, vec3 d) {
  return f.sun_enabled != 0u && dot(d, vec3(f.sun_x, f.sun_y, f.sun_z)) >= f.sun_cos_max;
}
vec3 render_sample_sun(RenderFrame f, vec2 u) {
  const vec3 axis = vec3(f.sun_x, f.sun_y, f.sun_z);
  const float cos_t = mix(1.0, f.sun_cos_max, u.x), sin_t = sqrt(max(0.0, 1.0 - cos_t * cos_t));
  const float phi = 2.0 * RENDER_PI * u.y;
  const vec3 t = normalize(abs(axis.x) > 0.9 ? cross(axis, vec3(0, 1, 0)) : cross(axis, vec3(1, 0, 0)));
  const vec3 b = cross(axis, t);
  return normalize(cos_t * axis + sin_t * (cos(phi) * t + sin(phi) * b));
}

#endif
