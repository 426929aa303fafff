// hit_decode.comp -- decodes LsnifHitAttributes with lsnif/lsnif_hit.glsl (LSNIF_HIT_DECODE_ONLY),
// one record per invocation: the twin of hit_decode.hlsl (the same buffers and results), both run
// by hit_decode_test.cpp. Set 0: binding 0 the attributes, binding 1 per record 4 vec4 (the rows of
// the instance's world-to-object linear part, then a world direction), binding 2 the results.
#version 460
#extension GL_GOOGLE_include_directive : require
#define LSNIF_HIT_DECODE_ONLY
#include "lsnif/lsnif_hit.glsl"

layout(local_size_x = 64) in;

struct HitDecodeResult {
  vec4 normal;        // xyz: world normal, w: lsnif_leaving_tmin along the direction
  vec4 albedo;        // xyz: albedo, w: occlusion logit
  uvec4 fields;       // material, points, leaving distance (float bits), object normal x (float bits)
};

layout(set = 0, binding = 0, std430) readonly buffer Attributes { LsnifHitAttributes attributes[]; };
layout(set = 0, binding = 1, std430) readonly buffer Inputs { vec4 inputs[]; };
layout(set = 0, binding = 2, std430) writeonly buffer Results { HitDecodeResult results[]; };
layout(push_constant) uniform Push { uint count; } pc;

void main() {
  const uint i = gl_GlobalInvocationID.x;
  if (i >= pc.count) return;
  // mat3 takes columns: the rows given, transposed.
  const mat3 world_to_object = transpose(mat3(inputs[4 * i].xyz, inputs[4 * i + 1].xyz, inputs[4 * i + 2].xyz));
  const LsnifSurface s = lsnif_decode_hit(attributes[i], world_to_object);
  HitDecodeResult r;
  r.normal = vec4(s.normal, lsnif_leaving_tmin(s, inputs[4 * i + 3].xyz, world_to_object));
  r.albedo = vec4(s.albedo, s.occlusion_logit);
  r.fields = uvec4(s.material, s.points, floatBitsToUint(s.leaving_distance), floatBitsToUint(s.object_normal.x));
  results[i] = r;
}
