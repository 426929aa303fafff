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

// A stage with push constants of its own (render_visibility.frag) defines RENDER_COMMON_OWN_PUSH and
// passes the RenderFrame to the functions it calls.
#ifndef RENDER_COMMON_OWN_PUSH
layout(push_constant, scalar) uniform RenderPushBlock {
  RenderPush push;
} pc;
#endif

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
  float ambient_occlusion; // glTF's occlusion: scales the light the surface reflects (not its emission)
  vec3 emission;
  mat3 world_to_object;    // LSNIF hits: for the leaving rule's tmin
  float leaving_distance;  // LSNIF hits: object units (LsnifSurface::leaving_distance)
};

#ifndef RENDER_COMMON_OWN_PUSH
RenderFrame render_frame() { return RenderFrameRef(pc.push.frame).f; }
#endif

// Texel (x, y) of `t` as linear RGBA (sRGB-decoded when `srgb`).
vec4 render_texel(RenderTexture t, uint x, uint y, bool srgb) {
  const vec4 c = unpackUnorm4x8(RenderUintRef(t.texels).v[y * t.width + x]);
  return srgb ? vec4(mix(c.rgb / 12.92, pow((c.rgb + 0.055) / 1.055, vec3(2.4)), greaterThan(c.rgb, vec3(0.04045))),
                     c.a)
              : c;
}

// Texture `index` at uv, bilinear between decoded texels with repeat wrapping, texel centres at
// (i + 0.5) / size: the lookup the trainer learns textures with (Texture::sample, src/lsnif/import/mesh.h).
vec4 render_texture(RenderFrame f, uint index, vec2 uv, bool srgb) {
  const RenderTexture t = RenderTextureRef(f.textures).v[index];
  const vec2 w = vec2(isinf(uv.x) || isnan(uv.x) ? 0.0 : uv.x - floor(uv.x),
                      isinf(uv.y) || isnan(uv.y) ? 0.0 : uv.y - floor(uv.y));
  const vec2 p = w * vec2(t.width, t.height) - 0.5;
  const vec2 p0 = floor(p), fr = p - p0;
  const uint x0 = uint(int(p0.x) + int(t.width)) % t.width, x1 = (x0 + 1u) % t.width;
  const uint y0 = uint(int(p0.y) + int(t.height)) % t.height, y1 = (y0 + 1u) % t.height;
  const vec4 top = mix(render_texel(t, x0, y0, srgb), render_texel(t, x1, y0, srgb), fr.x);
  const vec4 bottom = mix(render_texel(t, x0, y1, srgb), render_texel(t, x1, y1, srgb), fr.x);
  return mix(top, bottom, fr.y);
}

#endif
