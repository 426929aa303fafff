// render.rmiss -- the path tracer's miss shader: t < 0 (the ray generation shader looks up the
// environment itself). Shadow rays start with t = 0 ("occluded") and only this shader clears it.
#version 460
#extension GL_EXT_ray_tracing : require
#extension GL_GOOGLE_include_directive : require
#include "lsnif/renderer/shaders/render_common.glsl"

layout(location = 0) rayPayloadInEXT RenderHit hit;

void main() { hit.t = -1.0; }
