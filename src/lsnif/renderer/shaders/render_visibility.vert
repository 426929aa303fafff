// render_visibility.vert -- the visibility pass of rasterized primary visibility (one draw per
// triangle list of a TLAS record, non-indexed, 3 vertices per triangle): fetches the vertex of
// RenderRasterPush::indices / positions and projects it with the traced camera's pinhole model and
// the sample's sub-pixel offset (render_camera_jitter) folded in, so that the pixel centre
// (px + 0.5, py + 0.5) the rasterizer samples lies on the camera ray render_path_start casts
// through (px + jitter.x, py + jitter.y). Depth is reversed (near / distance along -z, no far plane).
#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "lsnif/renderer/shaders/render_host_device.h"
#include "lsnif/renderer/shaders/render_random.glsl"

layout(push_constant, scalar) uniform RenderRasterPushBlock {
  RenderRasterPush p;
} pc;

layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer RenderRasterUintRef { uint v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer RenderRasterVec3Ref { vec3 v[]; };

layout(location = 0) out vec2 barycentrics;       // weights of the triangle's vertices 1 and 2
layout(location = 1) out vec3 camera_position;    // the point in camera space (its length: the hit distance)
layout(location = 2) flat out uint primitive;     // the triangle (gl_PrimitiveID of this draw)

void main() {
  const uint corner = uint(gl_VertexIndex) % 3u;
  const uint index = RenderRasterUintRef(pc.p.indices).v[gl_VertexIndex];
  const vec3 x = RenderRasterVec3Ref(pc.p.positions).v[index];
  const float[12] m = pc.p.object_to_camera;
  const vec3 q = vec3(m[0] * x.x + m[1] * x.y + m[2] * x.z + m[3], m[4] * x.x + m[5] * x.y + m[6] * x.z + m[7],
                      m[8] * x.x + m[9] * x.y + m[10] * x.z + m[11]);
  camera_position = q;
  barycentrics = vec2(corner == 1u ? 1.0 : 0.0, corner == 2u ? 1.0 : 0.0);
  primitive = uint(gl_VertexIndex) / 3u;
  // The traced ray of pixel (px, py) passes through NDC ((px + j) / W * 2 - 1, ...) = (x / (-z tan aspect),
  // -y / (-z tan)); the rasterizer samples NDC ((px + 0.5) / W * 2 - 1, ...): shift by (1 - 2 j) / W.
  const vec2 jitter = render_camera_jitter(pc.p.sample_index);
  const float w = -q.z;
  gl_Position = vec4(q.x / (pc.p.tan_half_fov_y * pc.p.aspect) + (1.0 - 2.0 * jitter.x) / float(pc.p.width) * w,
                     -q.y / pc.p.tan_half_fov_y + (1.0 - 2.0 * jitter.y) / float(pc.p.height) * w, pc.p.near_plane, w);
}
