// render_visibility.frag -- the visibility pass's texel: which record (and mesh primitive of it),
// which triangle, the barycentrics at the pixel centre (perspective-correct), and the distance
// from the camera (render_visibility.vert); the closest surface wins by the depth test. A draw of
// an alpha cut-out discards the fragments in its holes, the test the traced rays' any-hit shader
// runs (render_triangle_opaque), so that rasterized and traced primary hits agree.
#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#define RENDER_COMMON_OWN_PUSH
#include "lsnif/renderer/shaders/render_surface.glsl"

layout(push_constant, scalar) uniform RenderRasterPushBlock {
  RenderRasterPush p;
} pc;

layout(location = 0) in vec2 barycentrics;
layout(location = 1) in vec3 camera_position;
layout(location = 2) flat in uint primitive;
layout(location = 0) out uvec4 texel;     // RenderVisibility
layout(location = 1) out float distance;  // RenderFrame::visibility_t

void main() {
  if (pc.p.alpha_test != 0u &&
      !render_triangle_opaque(RenderFrameRef(pc.p.frame).f, pc.p.instance & ((1u << RENDER_VISIBILITY_GEOMETRY_SHIFT) - 1u),
                              pc.p.instance >> RENDER_VISIBILITY_GEOMETRY_SHIFT, primitive, barycentrics))
    discard;
  texel = uvec4(pc.p.instance, primitive, floatBitsToUint(barycentrics.x), floatBitsToUint(barycentrics.y));
  distance = length(camera_position);
}
