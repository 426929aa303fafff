// render_common.glsl -- what the path tracer's shaders (render.rgen, render.rmiss, render_wave.comp,
// render_triangle.rchit, render_lsnif.rchit) share: the push constants, buffer references to the
// structs of render_host_device.h, and the payload a closest-hit shader fills for the ray
// generation shader, which does all the shading.
#ifndef RENDER_COMMON_GLSL
#define RENDER_COMMON_GLSL

#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_scalar_block_layout : require
#include "lsnif/renderer/shaders/render_host_device.h"

layout(push_constant, scalar) uniform RenderPushBlock {
  RenderPush push;
} pc;

layout(buffer_reference, scalar, buffer_reference_align = 8) readonly buffer RenderFrameRef { RenderFrame f; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer RenderInstanceRef { RenderInstance v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 8) readonly buffer RenderPrimitiveRef { RenderPrimitive v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer RenderMaterialRef { RenderMaterial v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 8) readonly buffer RenderTextureRef { RenderTexture v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer RenderUintRef { uint v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer RenderFloatRef { float v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer RenderVec3Ref { vec3 v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer RenderVec2Ref { vec2 v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 16) buffer RenderVec4Ref { vec4 v[]; };

#define RENDER_HIT_LSNIF 1u

// What a closest-hit shader reports (t < 0: the ray missed everything).
struct RenderHit {
  float t;
  uint flags;              // RENDER_HIT_*
  vec3 normal;             // world shading normal, unit
  vec3 geometric_normal;   // world, unit
  vec3 albedo;
  float metallic, roughness;
  vec3 emission;
  mat3 world_to_object;    // LSNIF hits: for the leaving rule's tmin
  float leaving_distance;  // LSNIF hits: object units (LsnifSurface::leaving_distance)
};

RenderFrame render_frame() { return RenderFrameRef(pc.push.frame).f; }

// Texel (nearest, wrapped) of texture `index` at uv, as linear RGBA (sRGB-decoded when `srgb`).
vec4 render_texture(RenderFrame f, uint index, vec2 uv, bool srgb) {
  const RenderTexture t = RenderTextureRef(f.textures).v[index];
  const vec2 w = uv - floor(uv);
  const uint x = min(uint(w.x * float(t.width)), t.width - 1u);
  const uint y = min(uint(w.y * float(t.height)), t.height - 1u);
  const vec4 c = unpackUnorm4x8(RenderUintRef(t.texels).v[y * t.width + x]);
  return srgb ? vec4(mix(c.rgb / 12.92, pow((c.rgb + 0.055) / 1.055, vec3(2.4)), greaterThan(c.rgb, vec3(0.04045))),
                     c.a)
              : c;
}

#endif
