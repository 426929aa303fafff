// hello_ground.rchit -- the closest hit of the ground's triangles (hit group 0): the checkerboard
// under the light, normal +y.
#version 460
#extension GL_EXT_ray_tracing : require
#extension GL_GOOGLE_include_directive : require
#include "hello_common.glsl"

layout(location = 0) rayPayloadInEXT HelloPixel payload;

void main() {
  const vec3 normal = vec3(0.0, 1.0, 0.0);
  const vec3 color = hello_shade(hello_ground_albedo(gl_WorldRayOriginEXT + gl_HitTEXT * gl_WorldRayDirectionEXT), normal);
#ifdef HELLO_ENGINE_LAYOUT
  payload.kind = HelloObjects(pc.objects).kind[gl_InstanceCustomIndexEXT];  // the application's own table
#else
  payload.kind = HELLO_KIND_GROUND;
#endif
  payload.t = gl_HitTEXT;
  payload.normal_x = normal.x;
  payload.normal_y = normal.y;
  payload.normal_z = normal.z;
  payload.r = color.r;
  payload.g = color.g;
  payload.b = color.b;
}
