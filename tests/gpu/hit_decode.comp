// hit_decode.comp -- decodes LsnifHitAttributes with lsnif/lsnif_hit.glsl (LSNIF_HIT_DECODE_ONLY),
// one record per invocation: the twin of hit_decode.hlsl (the same buffers and results), both run
// by hit_decode_test.cpp. Set 0: binding 0 the attributes, binding 1 per record 5 vec4 (the rows of
// the instance's world-to-object linear part, a world direction, then a colour and a channel value
// for the packers), binding 2 the results. The packers exist in GLSL only (the intersection shader
// is GLSL): `packed` is theirs, the HLSL twin writes 0 there.
#version 460
#extension GL_GOOGLE_include_directive : require
#define LSNIF_HIT_DECODE_ONLY
#include "lsnif/lsnif_hit.glsl"

layout(local_size_x = 64) in;

struct HitDecodeResult {
  vec4 normal;        // xyz: world normal, w: lsnif_leaving_tmin along the direction
  vec4 albedo;        // xyz: albedo, w: occlusion logit
  uvec4 fields;       // material, points, leaving distance (float bits), object normal x (float bits)
  vec4 surface;       // metallic, roughness, ambient occlusion, 1 when learned (else 0)
  vec4 emission;      // xyz: emission, w: 0
  uvec4 packed;       // lsnif_pack_rgbe(colour), lsnif_pack_surface(true, v, 1 - v, v / 2), and
                      // lsnif_pack_hit's albedo_material and surface_points (below)
  uvec4 uv;           // 1 when the hit reports a texture coordinate, its u and v (float bits), 0
  uvec4 uv_packed;    // lsnif_pack_uv_hit of the colour's x and y as a coordinate: emission_rgbe,
                      // albedo_material, surface_points, 0
};

layout(set = 0, binding = 0, std430) readonly buffer Attributes { LsnifHitAttributes attributes[]; };
layout(set = 0, binding = 1, std430) readonly buffer Inputs { vec4 inputs[]; };
layout(set = 0, binding = 2, std430) writeonly buffer Results { HitDecodeResult results[]; };
layout(push_constant) uniform Push { uint count; } pc;

void main() {
  const uint i = gl_GlobalInvocationID.x;
  if (i >= pc.count) return;
  // mat3 takes columns: the rows given, transposed.
  const mat3 world_to_object = transpose(mat3(inputs[5 * i].xyz, inputs[5 * i + 1].xyz, inputs[5 * i + 2].xyz));
  const LsnifSurface s = lsnif_decode_hit(attributes[i], world_to_object);
  HitDecodeResult r;
  r.normal = vec4(s.normal, lsnif_leaving_tmin(s, inputs[5 * i + 3].xyz, world_to_object));
  r.albedo = vec4(s.albedo, s.occlusion_logit);
  r.fields = uvec4(s.material, s.points, floatBitsToUint(s.leaving_distance), floatBitsToUint(s.object_normal.x));
  r.surface = vec4(s.metallic, s.roughness, s.ambient_occlusion, s.surface_learned ? 1.0 : 0.0);
  r.emission = vec4(s.emission, 0.0);
  // The packers: the colour as RGBE, v as the three surface channels, and a whole hit of the record's
  // material and points with the colour as albedo (clamped by unorm8) and emission.
  const vec4 c = inputs[5 * i + 4];
  const uint surface = lsnif_pack_surface(true, c.w, 1.0 - c.w, 0.5 * c.w);
  const LsnifHitAttributes a = lsnif_pack_hit(vec3(0.0), c.xyz, s.material, s.points, surface, c.xyz, 0.0, 0.0);
  r.packed = uvec4(lsnif_pack_rgbe(c.xyz), surface, a.albedo_material, a.surface_points);
  r.uv = uvec4(s.reports_uv ? 1u : 0u, floatBitsToUint(s.uv.x), floatBitsToUint(s.uv.y), 0u);
  const LsnifHitAttributes b = lsnif_pack_uv_hit(vec3(0.0), s.material, s.points, c.xy, 0.0, 0.0);
  r.uv_packed = uvec4(b.emission_rgbe, b.albedo_material, b.surface_points, 0u);
  results[i] = r;
}
