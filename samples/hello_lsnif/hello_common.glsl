// hello_common.glsl -- what hello_lsnif's shaders share: the push constants (the C twin is HelloPush
// in hello_lsnif.c: the LSNIF binding convention's LsnifRtPushConstants first, see host_device.h; or,
// compiled with HELLO_ENGINE_LAYOUT for hello_lsnif_engine, the application's own first), the
// per-pixel record written to the output buffer (the payload) and the shading.
#ifndef HELLO_COMMON_GLSL
#define HELLO_COMMON_GLSL

#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

// HelloPixel::kind
#define HELLO_KIND_MISS 0u
#define HELLO_KIND_GROUND 1u
#define HELLO_KIND_LSNIF 2u

// One pixel: what the camera ray hit, its distance and world normal (zero for a miss) and the
// shaded linear color. 32 bytes, the record of the --hits file.
struct HelloPixel {
  uint kind;
  float t;
  float normal_x, normal_y, normal_z;
  float r, g, b;
};

#ifndef HELLO_ENGINE_LAYOUT
layout(push_constant) uniform HelloPush {
  uint64_t model_table;  // LSNIF_RT_PUSH_MODEL_TABLE_OFFSET: uint64 model block addresses
  uint model_count;      // LSNIF_RT_PUSH_MODEL_COUNT_OFFSET: entries of the table
  uint lsnif_reserved;
  uint64_t pixels;       // LSNIF_RT_PUSH_APP_OFFSET: HelloPixel[width * height], row-major from the top
  uint width, height;
  vec4 eye;              // camera position (xyz)
  vec4 forward;          // unit view direction
  vec4 right;            // image-plane half-width vector at unit distance
  vec4 up;               // image-plane half-height vector at unit distance
} pc;
#else
// hello_lsnif_engine: the application's push constants from offset 0, LSNIF's model table after
// them (the intersection shader is built with LSNIF_MODEL_TABLE_PUSH_OFFSET=HELLO_LSNIF_PUSH_OFFSET).
#define HELLO_LSNIF_PUSH_OFFSET 88
layout(push_constant) uniform HelloPush {
  uint64_t pixels;       // HelloPixel[width * height], row-major from the top
  uint width, height;
  vec4 eye;              // camera position (xyz)
  vec4 forward;          // unit view direction
  vec4 right;            // image-plane half-width vector at unit distance
  vec4 up;               // image-plane half-height vector at unit distance
  uint64_t objects;      // the application's object table: HelloObjects, indexed by the custom index
  uint64_t model_table;  // HELLO_LSNIF_PUSH_OFFSET: LSNIF's table, indexed by the TLAS instance index
  uint model_count;
} pc;

// The application's own per-object data, indexed by gl_InstanceCustomIndexEXT.
layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer HelloObjects {
  uint kind[];  // the HelloPixel::kind of the object's hits
};
#endif

// The shading, in linear RGB: Lambert under one directional light plus a constant ambient term.
const vec3 kHelloBackground = vec3(0.06, 0.08, 0.12);
const vec3 kHelloLight = vec3(1.0 / 3.0, 2.0 / 3.0, 2.0 / 3.0);  // unit vector towards the light

vec3 hello_shade(vec3 albedo, vec3 normal) { return albedo * (0.25 + 0.75 * max(dot(normal, kHelloLight), 0.0)); }

// The ground's albedo: a checkerboard of 0.25-unit squares in world x and z.
vec3 hello_ground_albedo(vec3 p) {
  const int cell = int(floor(4.0 * p.x)) + int(floor(4.0 * p.z));
  return vec3((cell & 1) == 0 ? 0.75 : 0.35);
}

#endif
