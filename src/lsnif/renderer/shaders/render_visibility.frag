// render_visibility.frag -- the visibility pass's texel: which record (and mesh primitive of it),
// which triangle, the barycentrics at the pixel centre (perspective-correct), and the distance
// from the camera (render_visibility.vert); the closest surface wins by the depth test.
#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "lsnif/renderer/shaders/render_host_device.h"

layout(push_constant, scalar) uniform RenderRasterPushBlock {
  RenderRasterPush p;
} pc;

layout(location = 0) in vec2 barycentrics;
layout(location = 1) in vec3 camera_position;
layout(location = 2) flat in uint primitive;
layout(location = 0) out uvec4 texel;     // RenderVisibility
layout(location = 1) out float distance;  // RenderFrame::visibility_t

void main() {
  texel = uvec4(pc.p.instance, primitive, floatBitsToUint(barycentrics.x), floatBitsToUint(barycentrics.y));
  distance = length(camera_position);
}
