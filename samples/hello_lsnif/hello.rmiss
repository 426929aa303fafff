// hello.rmiss -- a miss: the background color.
#version 460
#extension GL_EXT_ray_tracing : require
#extension GL_GOOGLE_include_directive : require
#include "hello_common.glsl"

layout(location = 0) rayPayloadInEXT HelloPixel payload;

void main() {
  payload.kind = HELLO_KIND_MISS;
  payload.t = 0.0;
  payload.normal_x = 0.0;
  payload.normal_y = 0.0;
  payload.normal_z = 0.0;
  payload.r = kHelloBackground.r;
  payload.g = kHelloBackground.g;
  payload.b = kHelloBackground.b;
}
