/* render_host_device.h -- the path tracer's structs shared by C++ (src/lsnif/renderer/) and GLSL
 * (src/lsnif/renderer/shaders/render_*.glsl, render.rgen/.rmiss/.rchit). Every struct holds only 32-bit scalars and
 * 64-bit device addresses at 8-byte offsets, so its std430 (scalar) layout is the same on both sides.
 * The LSNIF binding convention (src/lsnif/host_device.h) holds: the push constant block starts with
 * the model table address, indexed by gl_InstanceCustomIndexEXT; the renderer gives every TLAS
 * instance its own custom index i, and RenderInstance i says what it is. */
#ifndef LSNIF_RENDER_HOST_DEVICE_H
#define LSNIF_RENDER_HOST_DEVICE_H

#include "lsnif/host_device.h"

#ifdef __cplusplus
typedef uint64_t lsnif_address;
#else
#define lsnif_address uint64_t
#endif

#define RENDER_INSTANCE_TRIANGLES 0u /* a triangle BLAS: one geometry per mesh primitive */
#define RENDER_INSTANCE_LSNIF 1u     /* an LSNIF model through src/lsnif/shaders/lsnif.rint */

#define RENDER_NO_TEXTURE 0xffffffffu
#define RENDER_NO_MESH 0xffffffffu

/* Per TLAS instance (index = instanceCustomIndex). */
struct RenderInstance {
  lsnif_uint kind;             /* RENDER_INSTANCE_* */
  lsnif_uint first_primitive;  /* triangles: RenderPrimitive of geometry 0 (gl_GeometryIndexEXT adds); LSNIF: the
                                  first RenderPrimitive of the node's kept mesh (rasterized primary visibility),
                                  RENDER_NO_MESH without one */
  lsnif_uint material_map;     /* LSNIF: first entry in RenderFrame::material_maps (model material -> scene) */
  lsnif_uint material_count;   /* LSNIF: entries of the map */
};

/* One triangle list (a mesh primitive), object space. */
struct RenderPrimitive {
  lsnif_address positions;  /* float3 per vertex, tightly packed */
  lsnif_address normals;    /* float3 per vertex, 0: use the face normal */
  lsnif_address uvs;        /* float2 per vertex, 0: uv = 0 */
  lsnif_address indices;    /* uint32, 3 per triangle */
  lsnif_uint material;      /* RenderFrame::materials index */
  lsnif_uint pad0, pad1, pad2;
};

/* glTF metallic-roughness material; textures index RenderFrame::textures or RENDER_NO_TEXTURE. */
struct RenderMaterial {
  float base_r, base_g, base_b, base_a;
  float metallic, roughness;
  float emission_r, emission_g, emission_b;
  lsnif_uint base_texture, metallic_roughness_texture, emission_texture;
  lsnif_uint occlusion_texture;  /* R = ambient occlusion (linear) */
  float occlusion_strength;      /* occlusion = 1 + strength x (R - 1) */
  lsnif_uint normal_texture;     /* tangent-space normal map (linear, +Y up) */
  float normal_scale;
  float alpha_cutoff;            /* a triangle point of lower alpha (base_a x base texture alpha) is a hole; 0: opaque */
  /* Per texture slot (base colour, metallic-roughness, emission, occlusion, normal: TextureSlot of
     src/lsnif/import/mesh.h) the uv transform uv' = M (u, v, 1), M's three columns of two floats
     (KHR_texture_transform; the identity without one). */
  float uv_transform[30];
};
#define RENDER_SLOT_BASE 0u
#define RENDER_SLOT_METALLIC_ROUGHNESS 1u
#define RENDER_SLOT_EMISSION 2u
#define RENDER_SLOT_OCCLUSION 3u
#define RENDER_SLOT_NORMAL 4u

/* RGBA8 texels, row 0 at v = 0, one uint per texel (R in the low byte). */
struct RenderTexture {
  lsnif_address texels;
  lsnif_uint width, height;
};

/* Everything one frame needs, in one buffer addressed from the push constants. */
struct RenderFrame {
  lsnif_address instances;      /* RenderInstance[] */
  lsnif_address primitives;     /* RenderPrimitive[] */
  lsnif_address materials;      /* RenderMaterial[] */
  lsnif_address material_maps;  /* uint[] */
  lsnif_address textures;       /* RenderTexture[] */
  lsnif_address environment;    /* float3 radiance per texel (EnvironmentMap::radiance), 0: constant color */
  lsnif_address env_tables;     /* EnvironmentMap::packed(): marginal CDF, conditional CDFs, pdf table */
  lsnif_address world_to_object; /* float3x3 (column-major) per instance custom index: the inverse of the
                                   instance's linear part (the wavefront pipeline's gl_WorldToObjectEXT) */
  lsnif_address accumulation;   /* float4 per pixel: running sum of radiance, w = samples */
  lsnif_address visibility;     /* rasterized primary visibility: RenderVisibility per (sample of the pass, pixel) */
  lsnif_address visibility_t;   /* float per (sample of the pass, pixel): distance from the camera to the hit */
  lsnif_uint width, height;
  lsnif_uint env_width, env_height;
  float env_r, env_g, env_b, env_rotation; /* constant radiance without an image; rotation about +y (radians) */
  float cam_to_world[12];       /* rows of the 3x4 camera-to-world matrix (camera looks down -z) */
  float tan_half_fov_y, aspect;
  lsnif_uint max_bounces;       /* path vertices after the camera (paper: 4) */
  lsnif_uint rr_depth;          /* Russian roulette from this bounce on */
  lsnif_uint env_importance;    /* 1: next-event estimation with the environment tables */
  lsnif_uint sun_enabled;       /* 1: the sun below is a light (next-event estimation + MIS) */
  float sun_x, sun_y, sun_z;    /* unit direction towards the sun (world) */
  float sun_cos_max;            /* cosine of the sun disk's angular radius */
  float sun_r, sun_g, sun_b;    /* radiance of the disk = irradiance / solid angle */
  float pad_sun;
  lsnif_uint primary_raster;    /* 1: the camera rays' hits come from `visibility` (rasterized), not traced */
  lsnif_uint visibility_first_sample; /* sample index of the visibility buffer's first layer */
};

/* Push constants: the model table and its entry count first (LSNIF binding convention), then the
 * frame at LSNIF_RT_PUSH_APP_OFFSET. */
struct RenderPush {
  lsnif_address model_table;  /* LSNIF_RT_PUSH_MODEL_TABLE_OFFSET */
  lsnif_uint model_count;     /* LSNIF_RT_PUSH_MODEL_COUNT_OFFSET */
  lsnif_uint reserved;
  lsnif_address frame;        /* RenderFrame, at LSNIF_RT_PUSH_APP_OFFSET */
  lsnif_uint sample_index;    /* index of the first sample of this pass (per-pixel random sequences) */
  lsnif_uint samples;         /* samples per pixel in this pass */
  lsnif_uint stage;           /* wavefront (render_wave.comp): RENDER_WAVE_* */
  lsnif_uint bounce;          /* wavefront: the path vertex the stage works on */
  lsnif_address wave;         /* wavefront: RenderWave */
};

/* ---- Rasterized primary visibility (render_visibility.vert/.frag, render_visibility.glsl) ----
 * A graphics pass draws every TLAS record's triangles (an LSNIF record: its node's kept mesh) once
 * per sample, with that sample's camera jitter folded into the projection. */
#define RENDER_VISIBILITY_NONE 0xffffffffu /* RenderVisibility::instance of a pixel that saw nothing */
#define RENDER_VISIBILITY_GEOMETRY_SHIFT 24u /* instance = custom index | mesh primitive << 24 */
#define RENDER_VISIBILITY_MAX_PRIMITIVES 255u /* mesh primitives of one LSNIF node the pass can draw */

/* One texel of the visibility buffer. */
struct RenderVisibility {
  lsnif_uint instance;    /* TLAS custom index | (mesh primitive of the record << 24), or RENDER_VISIBILITY_NONE */
  lsnif_uint primitive;   /* triangle of that mesh primitive (the vertex shader's gl_VertexIndex / 3) */
  float barycentric_u, barycentric_v;  /* weights of the triangle's vertices 1 and 2 */
};

/* Push constants of the visibility pass: one draw = one triangle list of one TLAS record. */
struct RenderRasterPush {
  float object_to_camera[12];  /* rows of the 3x4 object-to-camera matrix (camera looks down -z) */
  lsnif_address positions;     /* RenderPrimitive::positions */
  lsnif_address indices;       /* RenderPrimitive::indices */
  lsnif_uint instance;         /* RenderVisibility::instance written by this draw */
  lsnif_uint sample_index;     /* the sample whose camera jitter is used */
  lsnif_uint width, height;
  float tan_half_fov_y, aspect;
  float near_plane;            /* closer points are clipped (reversed-z depth = near / distance along -z) */
  lsnif_uint alpha_test;       /* 1: the primitive's material is an alpha cut-out: fragments in its holes
                                  are discarded (render_triangle_opaque, as the traced rays' any-hit) */
  lsnif_address frame;         /* RenderFrame whose instance, primitive, material and texture tables the
                                  alpha test reads (0 without alpha_test) */
};

/* ---- The wavefront pipeline (render_wave.comp; the rays cast by lsnifCmdQuery between stages) ----
 * One path per pixel in flight; a stage runs one invocation per pixel. */
#define RENDER_WAVE_CAMERA 0u     /* start the paths of sample pc.sample_index: camera rays (with
                                     RenderFrame::primary_raster also their first vertex, as SHADE) */
#define RENDER_WAVE_SHADE 1u      /* the path rays' results: shade, shadow rays, next path rays */
#define RENDER_WAVE_CONNECT 2u    /* the shadow rays' results: add the unblocked light samples */
#define RENDER_WAVE_ACCUMULATE 3u /* add each path's radiance to RenderFrame::accumulation */
#define RENDER_WAVE_SHADOWS 2u    /* shadow rays per pixel (render_path.glsl RENDER_SHADOWS) */

/* Per pixel: the path between stages. */
struct RenderWavePath {
  float throughput_r, throughput_g, throughput_b;
  float radiance_r, radiance_g, radiance_b;
  float last_pdf;
  lsnif_uint rng_key, rng_dim;
  lsnif_uint alive;           /* 1: the path ray of this pixel is to be cast */
  lsnif_uint pad0, pad1;
};

/* Per shadow ray: the light sample it tests. */
struct RenderWaveShadow {
  float value_r, value_g, value_b;
  lsnif_uint valid;           /* 1: add value when the ray is unblocked */
};

/* The wavefront buffers (pixels = width x height). */
struct RenderWave {
  lsnif_address paths;          /* RenderWavePath[pixels] */
  lsnif_address rays;           /* LsnifQueryRay[pixels]: the path rays (world space) */
  lsnif_address results;        /* LsnifQueryResult[pixels] */
  lsnif_address shadow_rays;    /* LsnifQueryRay[RENDER_WAVE_SHADOWS x pixels], pixel-major */
  lsnif_address shadow_results; /* LsnifQueryResult[RENDER_WAVE_SHADOWS x pixels] */
  lsnif_address shadows;        /* RenderWaveShadow[RENDER_WAVE_SHADOWS x pixels] */
};

#endif
