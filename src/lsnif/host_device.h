/* host_device.h -- the one definition of LSNIF constants and layouts shared by C++ (src/lsnif/format/, src/lsnif/core/, src/lsnif/plugin/)
 * and GLSL (src/lsnif/shaders/). Include from C++ as-is; from GLSL after #extension GL_GOOGLE_include_directive.
 * Anything both sides must agree on (output layout of the network, hash primes, limits) lives here. */
#ifndef LSNIF_HOST_DEVICE_H
#define LSNIF_HOST_DEVICE_H

/* Hard limits of the formats and shaders. */
#define LSNIF_MAX_POINTS 32u        /* upper bound for H, the boundary points fed to the network */
#define LSNIF_MAX_LEVELS 4u         /* upper bound for L, hash-grid levels */
#define LSNIF_MAX_FEATURES 4u       /* upper bound for F, features per hash-table entry */
#define LSNIF_MAX_MATERIALS 64u     /* upper bound for Nmat */
#define LSNIF_MAX_HIDDEN_WIDTH 256u /* upper bound for W */
#define LSNIF_MAX_HIDDEN_LAYERS 4u

/* Network output layout (raw, before activations): 8 + Nmat values per ray, then, for a model with
 * surface channels (LsnifGpuModelHeader::surface_channels, Config::surface_channels),
 * LSNIF_OUT_SURFACE_COUNT more starting at LSNIF_OUT_MATERIAL + Nmat.
 * occlusion: sigmoid; distance: sigmoid (see hit parametrization); normal: identity;
 * albedo: sigmoid; material: softmax over Nmat.
 * Surface channels (the glTF metallic-roughness material's textured values at the hit, learned as
 * the albedo is): metallic, roughness and ambient occlusion (glTF's occlusion texture, strength
 * applied): sigmoid; emission (emissiveFactor x emissiveTexture x KHR_materials_emissive_strength,
 * linear RGB): sigmoid x the model's emission scale. */
#define LSNIF_OUT_OCCLUSION 0u
#define LSNIF_OUT_DISTANCE 1u
#define LSNIF_OUT_NORMAL 2u
#define LSNIF_OUT_ALBEDO 5u
#define LSNIF_OUT_MATERIAL 8u
#define LSNIF_OUT_FIXED 8u
#define LSNIF_OUT_SURFACE_METALLIC 0u  /* offsets from LSNIF_OUT_MATERIAL + Nmat */
#define LSNIF_OUT_SURFACE_ROUGHNESS 1u
#define LSNIF_OUT_SURFACE_AMBIENT_OCCLUSION 2u
#define LSNIF_OUT_SURFACE_EMISSION 3u
#define LSNIF_OUT_SURFACE_COUNT 6u
/* Texture coordinates (a model whose Config::uv_materials is not 0): hits of those materials report
 * the texture coordinate of the predicted hit point, read from the model's uv cells
 * (src/lsnif/core/uv_cells.h), and the application samples the material's own textures there.
 * Largest |coordinate| a uv cell holds: what the hit attributes' 28-bit fixed point
 * (LSNIF_UV_FRACTION_BITS fractional bits, two's complement) carries. */
#define LSNIF_MAX_UV 2047.0
#define LSNIF_UV_FRACTION_BITS 16u
/* Most uv cell maps a model may have (Config::uv_cell_maps): 384 MiB of them. */
#define LSNIF_MAX_UV_CELL_MAPS 16777216u
/* Largest emission scale a model may have (the emission head's range). */
#define LSNIF_MAX_EMISSION_SCALE 65504.0

/* Packed surface channels of a hit (LsnifQueryHit::surface, LsnifQueryResult::surface,
 * LsnifReferenceHit::surface): bytes 0, 1, 2 metallic, roughness and ambient occlusion as unorm8
 * (packUnorm4x8), byte 3 LSNIF_SURFACE_LEARNED when the model learned them; 0 for a model without
 * surface channels (the application takes them from the material index's material). */
#define LSNIF_SURFACE_LEARNED 1u

/* Hit-distance parametrization (paper: AABB interval; ours: crossed voxel segments). */
#define LSNIF_HIT_PARAM_AABB_INTERVAL 0u
#define LSNIF_HIT_PARAM_VOXEL_SEGMENTS 1u

/* Spatial hash of an integer grid vertex (Teschner et al. / instant-ngp primes). */
#define LSNIF_HASH_PRIME_X 1u
#define LSNIF_HASH_PRIME_Y 2654435761u
#define LSNIF_HASH_PRIME_Z 805459861u

/* Occlusion threshold on sigmoid(logit): a hit when the probability is >= 0.5 (logit >= 0). */
#define LSNIF_OCCLUSION_THRESHOLD 0.5

/* Facing of an LSNIF hit: back-facing when the predicted object-space normal points along the
 * object-space ray direction (dot(n, d) > 0), front-facing when dot(n, d) < 0 (a zero normal is
 * neither). The intersection shader (and the CPU reference, intersect(..., ray_flags)) honours the
 * standard ray flags CullBackFacingTriangles / CullFrontFacingTriangles for LSNIF hits with this
 * facing; these are their SPIR-V values. */
#define LSNIF_RAY_FLAG_CULL_BACK_FACING 0x10u
#define LSNIF_RAY_FLAG_CULL_FRONT_FACING 0x20u
/* The hit kind the intersection shader reports (gl_HitKindEXT in the closest-hit shader; a
 * procedural hit's kind is below 128, so not the triangles' 0xFE / 0xFF): front-facing when
 * dot(n, d) < 0 in object space, back-facing otherwise, as LsnifQueryResult::front_face of the
 * batched query. */
#define LSNIF_HIT_KIND_FRONT_FACING 0u
#define LSNIF_HIT_KIND_BACK_FACING 1u
/* Any-hit queries (LsnifQueryRay::flags of lsnifCmdQuery): the ray is answered by any accepted hit
 * in its interval, not necessarily the closest (SPIR-V's TerminateOnFirstHit). */
#define LSNIF_RAY_FLAG_TERMINATE_ON_FIRST_HIT 0x04u

/* The self-intersection rule for rays leaving an LSNIF surface (docs/self-intersection.md): spawn
 * the ray at the predicted hit point itself (no offset), with the ray flag CullBackFacingTriangles,
 * and tmin = LSNIF_LEAVING_TMIN_VOXELS voxel edges measured in the hit model's object space
 * (lsnif_leaving_tmin in lsnif_hit.glsl, leaving_tmin in src/lsnif/core/intersector.h). The voxel edge of a
 * model is |bounds extent| / (V sqrt(3)) (the edge of a cubic grid). Measured against a fixed
 * origin offset by bench/bench_secondary. */
#define LSNIF_LEAVING_TMIN_VOXELS 0.5

/* ---- GPU model layout (src/lsnif/plugin/gpu_model.cpp packs it, src/lsnif/shaders/lsnif_model.glsl reads it) ----
 * One model is one 32-byte-aligned block of 32-bit words, addressed on the device by its buffer
 * device address. It starts with LsnifGpuModelHeader; every *_offset is in words from the start of
 * the block. Sections:
 *  voxels: V^3 occupancy bits exactly as VoxelGrid::bits (voxel i + V*(j + V*k), bit idx & 31 of
 *          word idx >> 5).
 *  grid:   the hash tables, element order of hash_grid.h: e = (offset_l + entry) * F + feature,
 *          offset_l = the entries of the levels k < l (level l's table has 2^M_l entries, or
 *          index_slots<l> for an indexed level).
 *          grid_bits 16: fp16, two per word (element e in word e >> 1, low half when e is even:
 *          unpackHalf2x16). grid_bits 8: int8 codes in [-127, 127], four per word (element e in
 *          byte e & 3 of word e >> 2, two's complement), the value code * grid_scale<level> in fp32
 *          (as Model::grid on the CPU). lsnif_grid_value (lsnif_model.glsl) reads either.
 *  index:  (only with an indexed level) starts at a multiple of 8 words: the indexed levels'
 *          displacements (Model::grid_index, index_buckets<l> per indexed level in level order) as
 *          u16, two per word (element i in word i >> 1, low half when i is even). The slot of a
 *          vertex: src/lsnif/core/perfect_hash.h, src/lsnif/shaders/lsnif_perfect_hash.glsl.
 *  mlp:    starts at a multiple of 8 words. Per layer (hidden layers, then output) with in/out as
 *          in network.h, the rows in blocks of LSNIF_GPU_ROW_BLOCK = 8 (the last block padded with
 *          zero rows) so that one 32-byte load serves 8 rows (the portable inference path, see
 *          lsnif_mlp.glsl): for block b, input pair i (P = LSNIF_GPU_ROW_WORDS(in) pairs, the last
 *          high half zero when in is odd), 8 consecutive words, word k holding
 *          (W[8b + k][2i], W[8b + k][2i + 1]) as an fp16 pair; blocks of 8 P words one after the
 *          other; then per block 8 words of bias: b[8b .. 8b + 7] as 4 fp16 pairs, 4 zero words.
 *          Every layer has a multiple of 8 words.
 * All fields are 32-bit uint or float, so the struct has identical std430 layout in C++ and GLSL. */
#define LSNIF_GPU_MAGIC 0x4647534Cu /* "LSGF" little-endian */
#define LSNIF_GPU_VERSION 7u
#define LSNIF_GPU_ROW_WORDS(n) (((n) + 1u) >> 1)
/* M_l of level l from LsnifGpuModelHeader::table_log2. */
#define LSNIF_GPU_TABLE_LOG2(packed, level) (((packed) >> (8u * (level))) & 0xffu)
#define LSNIF_GPU_ROW_BLOCK 8u
#define LSNIF_GPU_ROW_BLOCKS(n) (((n) + LSNIF_GPU_ROW_BLOCK - 1u) / LSNIF_GPU_ROW_BLOCK)

#if defined(__cplusplus)
#include <cstdint>
typedef uint32_t lsnif_uint;
#elif defined(GL_core_profile) || defined(GL_es_profile) || defined(VULKAN) /* GLSL */
#define LSNIF_GLSL 1
#define lsnif_uint uint
#else /* C */
#include <stdint.h>
typedef uint32_t lsnif_uint;
#endif

struct LsnifGpuModelHeader {
  lsnif_uint magic;            /* LSNIF_GPU_MAGIC */
  lsnif_uint version;          /* LSNIF_GPU_VERSION */
  lsnif_uint total_words;      /* size of the whole block in words */
  lsnif_uint voxel_resolution; /* V */
  lsnif_uint max_points;       /* H */
  lsnif_uint grid_levels;      /* L */
  lsnif_uint grid_resolution0, grid_resolution1, grid_resolution2, grid_resolution3; /* R_l, 0 unused */
  lsnif_uint table_log2;       /* M_l of level l in bits [8l, 8l + 8): LSNIF_GPU_TABLE_LOG2 */
  lsnif_uint features;         /* F */
  lsnif_uint hidden_width;     /* W */
  lsnif_uint hidden_layers;
  lsnif_uint material_count;   /* Nmat */
  lsnif_uint hit_param;        /* LSNIF_HIT_PARAM_* */
  float leaky_slope;
  float bounds_lo_x, bounds_lo_y, bounds_lo_z; /* padded object AABB (VoxelGrid::bounds) */
  float bounds_hi_x, bounds_hi_y, bounds_hi_z;
  lsnif_uint voxel_offset;     /* words */
  lsnif_uint grid_offset;      /* words */
  lsnif_uint mlp_offset;       /* words */
  lsnif_uint grid_bits;        /* 16 (fp16 grid) or 8 (int8 codes times the level's scale) */
  float grid_scale0, grid_scale1, grid_scale2, grid_scale3; /* grid_bits 8: per level, else 0 */
  lsnif_uint index_offset;     /* words: the indexed levels' displacements (0 when none is indexed) */
  /* Per level: 0 for a hashed level, else its perfect hash (Config::index_slots / index_buckets). */
  lsnif_uint index_slots0, index_slots1, index_slots2, index_slots3;
  lsnif_uint index_buckets0, index_buckets1, index_buckets2, index_buckets3;
  lsnif_uint surface_channels; /* 1: the output has LSNIF_OUT_SURFACE_COUNT surface channels, else 0 */
  float emission_scale;        /* the emission head's scale (0 without surface channels) */
  /* Bit m of (uv_materials_hi << 32 | uv_materials_lo): hits of material m report the texture
   * coordinate (Config::uv_materials); 0 for a model without uv cells. */
  lsnif_uint uv_materials_lo, uv_materials_hi;
  /* The uv cells (src/lsnif/format/uv_cell_layout.h), 0 without: cells per voxel edge S, then in
   * words from the block's start the occupied voxels before each voxel word (ceil(V^3 / 32) words:
   * a voxel's record is number rank[i >> 5] + the occupied voxels below it in its word), the voxel
   * records and the maps. */
  lsnif_uint uv_cells, uv_rank_offset, uv_record_offset, uv_map_offset; /* 48 words */
};
#define LSNIF_GPU_HEADER_WORDS 48u

/* Test interface of tests/gpu/lsnif_reference.comp: one world-space ray in, one result out. */
struct LsnifReferenceRay {
  float origin_x, origin_y, origin_z, tmin;
  float direction_x, direction_y, direction_z, tmax;
};
struct LsnifReferenceHit {
  lsnif_uint hit;       /* 1 when accepted (occlusion >= 0.5 and tmin <= t <= tmax) */
  lsnif_uint points;    /* boundary points of the walk (0: the network was not evaluated) */
  float occlusion_logit; /* raw occlusion output (0 when points == 0) */
  float t;              /* ray parameter, also when not accepted */
  float normal_x, normal_y, normal_z; /* world space, normalized */
  lsnif_uint material;
  float albedo_x, albedo_y, albedo_z;
  lsnif_uint surface;   /* packed surface channels (LSNIF_SURFACE_LEARNED) */
  float leaving_tmin;   /* lsnif_leaving_tmin for the ray's own direction (0 without a hit) */
  float emission_r, emission_g, emission_b;
  lsnif_uint instance;  /* the ray-tracing tests' closest-hit shaders: gl_InstanceID | hit kind << 15 |
                           gl_InstanceCustomIndexEXT << 16 (~0u when none ran); 0 from lsnif_reference.comp */
  lsnif_uint reports_uv; /* 1: a hit reporting its texture coordinate (uv_u, uv_v), else 0 and zero */
  float uv_u, uv_v;
};

/* ---- Ray tracing binding convention (src/lsnif/shaders/lsnif.rint, src/lsnif/lsnif_hit.glsl) ----
 * Every LSNIF object is one instance of a BLAS holding one AABB geometry (VK_GEOMETRY_TYPE_AABBS_KHR,
 * flag OPAQUE) whose box is the model's object-space AABB (LsnifGpuModelHeader bounds, may be padded:
 * the intersection shader clips to the model's own bounds) and whose hit group is
 * (lsnif.rint, the application's closest-hit shader). The intersection shader finds the instance's
 * model in one of two ways (two SPIR-V variants, LsnifModelLookup in src/lsnif/lsnif.h):
 *  instance table (default): the push constant block of the pipeline starts (offset 0, 16 bytes,
 *    LsnifRtPushConstants) with the buffer device address of the instance model table, an array of
 *    uint64 model block addresses indexed by the instance's custom index
 *    (VkAccelerationStructureInstanceKHR::instanceCustomIndex = gl_InstanceCustomIndexEXT), and the
 *    number of entries of that table. The push constant range must include
 *    VK_SHADER_STAGE_INTERSECTION_BIT_KHR; the application's own push constants follow at offset
 *    >= LSNIF_RT_PUSH_APP_OFFSET.
 *  shader record (compiled with LSNIF_MODEL_FROM_SHADER_RECORD): the hit group's shader record
 *    holds the model's block address (uint64) at byte LSNIF_SHADER_RECORD_MODEL_OFFSET after the
 *    group handle; no push constants, and the custom index stays the application's.
 * An application with other conventions builds the shader from lsnif/shaders/lsnif_intersection.glsl,
 * whose macros move the table (push-constant offset, storage buffer), the record offset or the index.
 * Broken conventions are misses, never faults: a table address of 0, a custom index >= the table's
 * entry count, a table entry or shader record of 0 (a hole), or a block whose header is not
 * LSNIF_GPU_MAGIC / LSNIF_GPU_VERSION make the shader report no intersection. */
#define LSNIF_RT_PUSH_MODEL_TABLE_OFFSET 0u
#define LSNIF_RT_PUSH_MODEL_COUNT_OFFSET 8u
#define LSNIF_RT_PUSH_APP_OFFSET 16u
#define LSNIF_SHADER_RECORD_MODEL_OFFSET 0u
#define LSNIF_SHADER_RECORD_SIZE 8u
#ifndef LSNIF_GLSL
/* The push constants of the instance-table convention, as C/C++ see them (offset 0 of the
 * application's push constant block). */
struct LsnifRtPushConstants {
  uint64_t model_table;  /* device address of uint64 model block addresses; 0: every LSNIF instance misses */
  uint32_t model_count;  /* entries of the table */
  uint32_t reserved;     /* zero */
};
#endif

/* Hit attributes that lsnif.rint reports (32 bytes = maxRayHitAttributeSize 32 of lavapipe); decode
 * them in a closest-hit shader with lsnif_hit.glsl. The hit distance is gl_HitTEXT (world = object
 * ray parameter), the instance gl_InstanceID / gl_InstanceCustomIndexEXT, the model the table entry.
 *  normal_*:      object-space unit normal as predicted (fp32); world normal = normalize(A^-T n)
 *  albedo_material: packUnorm4x8(albedo.r, albedo.g, albedo.b, 0) with the material index
 *                 (< LSNIF_MAX_MATERIALS <= 64) in byte 3
 *  surface_points: bytes 0-2 metallic, roughness, ambient occlusion as unorm8 (0 without surface
 *                 channels), byte 3 the boundary points of the walk (<= 32) in bits 0-5,
 *                 LSNIF_HIT_UV_BIT for a hit reporting its texture coordinate (then emission_rgbe and
 *                 albedo_material's bytes 0-2 hold the coordinate) and LSNIF_HIT_SURFACE_LEARNED_BIT
 *                 when the model learned the surface channels
 *  emission_rgbe: emission (linear RGB, >= 0) as shared-exponent RGBE: bytes 0-2 mantissas m, byte 3
 *                 exponent e, each channel m x 2^(e - 136); 0 is black (lsnif_pack_rgbe)
 *  occlusion_logit: raw occlusion output (>= 0 for every reported hit)
 *  leaving_distance: LSNIF_LEAVING_TMIN_VOXELS x the model's voxel edge, object units (for
 *                 lsnif_leaving_tmin) */
struct LsnifHitAttributes {
  float normal_x, normal_y, normal_z;
  lsnif_uint albedo_material;
  lsnif_uint surface_points;
  lsnif_uint emission_rgbe;
  float occlusion_logit;
  float leaving_distance;
};
#define LSNIF_HIT_SURFACE_LEARNED_BIT 0x80000000u
/* A hit of a texture-coordinate material (Config::uv_materials) whose uv cells gave its coordinate:
 * surface_points carries this bit, bytes 0-2 of surface_points are zero, and the 56 bits of
 * emission_rgbe (bits 0-31) and albedo_material's bytes 0-2 (bits 32-55) hold the coordinate as
 * src/lsnif/core/head.h pack_uv writes it (u in bits 0-27, v in bits 28-55, each 28-bit two's
 * complement with LSNIF_UV_FRACTION_BITS fractional bits); the material's own textures give the
 * albedo and the other channels there (lsnif_hit.glsl: LsnifSurface::reports_uv, uv). */
#define LSNIF_HIT_UV_BIT 0x40000000u
#define LSNIF_RGBE_BIAS 136

/* ---- Batched queries (the wavefront path: lsnifCmdIntersectModelRays, src/lsnif/shaders/lsnif_batch.comp) ----
 * The application's rays and the hits the library writes, in device buffers addressed by their
 * buffer device addresses (16-byte aligned). Rays are in the model's object space. */
struct LsnifQueryRay { /* 48 bytes */
  float origin_x, origin_y, origin_z, tmin;
  float direction_x, direction_y, direction_z, tmax;
  lsnif_uint flags;     /* LSNIF_RAY_FLAG_CULL_BACK_FACING | LSNIF_RAY_FLAG_CULL_FRONT_FACING, and for
                           lsnifCmdQuery LSNIF_RAY_FLAG_TERMINATE_ON_FIRST_HIT; other bits are ignored */
  lsnif_uint reserved0, reserved1, reserved2; /* zero */
};
#define LSNIF_QUERY_HIT_NONE 0u       /* LsnifQueryHit / LsnifQueryResult::kind: no accepted hit */
#define LSNIF_QUERY_HIT_LSNIF 1u      /* an accepted hit of an LSNIF model */
#define LSNIF_QUERY_HIT_TRIANGLE 2u   /* LsnifQueryResult: a triangle of the application's TLAS */
#define LSNIF_QUERY_HIT_INCOMPLETE 3u /* LsnifQueryResult: a candidate of the ray did not fit the scratch
                                         and could have changed the answer (lsnifCmdQuery) */
struct LsnifQueryHit { /* 80 bytes; every field is written, also for a miss */
  float t;                              /* ray parameter (also when not accepted, if points > 0) */
  float normal_x, normal_y, normal_z;   /* object space, normalized (zero when points == 0) */
  float albedo_r, albedo_g, albedo_b;
  lsnif_uint material;
  lsnif_uint kind;                      /* LSNIF_QUERY_HIT_* */
  lsnif_uint points;                    /* boundary points of the walk (0: the network was not evaluated) */
  float occlusion_logit;                /* raw occlusion output (0 when points == 0) */
  lsnif_uint surface;                   /* packed surface channels (LSNIF_SURFACE_LEARNED); 0 when points == 0 */
  float emission_r, emission_g, emission_b; /* learned emission (0 without surface channels) */
  lsnif_uint reports_uv;                /* 1: an accepted hit of a material whose texture coordinate the
                                           model's uv cells give (Config::reports_uv); 0 otherwise */
  float uv_u, uv_v;                     /* that texture coordinate (fp32; 0 when reports_uv is 0) */
  lsnif_uint reserved0, reserved1;      /* zero */
};

/* Push constants of the batched stages (one block for all of them, 48 bytes). The scratch buffer
 * holds, from its start, in 32-bit words: the count of rays with boundary points (the MLP's batch
 * size) and padding up to LSNIF_BATCH_HEADER_WORDS, then structure-of-arrays sections of `stride`
 * words per row: the ray index of each batch slot (1 row), the walk of each slot (count, t_enter,
 * t_exit, t[0 .. H-1]: 3 + H rows), the network input (2 x LSNIF_GPU_ROW_WORDS(input) rows), the
 * raw network output (8 x LSNIF_GPU_ROW_BLOCKS(output) rows) and the slots in order of walk length
 * (1 row: the order the portable MLP kernel takes them in). */
#define LSNIF_BATCH_HEADER_WORDS 64u
#define LSNIF_BATCH_GROUP_SIZE 64u /* invocations of a workgroup of every stage; stride is a multiple */
#define LSNIF_BATCH_CHUNK_RAYS 262144u /* rays per run of the stages: larger batches run in chunks that share the scratch */
struct LsnifBatchPushConstants {
  lsnif_uint model_lo, model_hi;       /* the model's block address */
  lsnif_uint rays_lo, rays_hi;         /* LsnifQueryRay[ray_count] */
  lsnif_uint hits_lo, hits_hi;         /* LsnifQueryHit[ray_count] */
  lsnif_uint scratch_lo, scratch_hi;   /* the scratch layout above */
  lsnif_uint ray_count;
  lsnif_uint stride;                   /* ray_count rounded up to a multiple of LSNIF_BATCH_GROUP_SIZE */
  lsnif_uint block_step;               /* stages over batch slots: workgroup w takes the slots of block
                                          (w x block_step) mod (workgroup count); coprime to that count */
  lsnif_uint reserved0;
};

/* ---- Queries against the application's TLAS (lsnifCmdQuery, src/lsnif/shaders/lsnif_query.comp) ----
 * World-space LsnifQueryRay in, one LsnifQueryResult per ray out. An LSNIF hit is what the
 * intersection shader would report for the instance (same walk, network, acceptance, culling);
 * a triangle hit is the closest (or, with LSNIF_RAY_FLAG_TERMINATE_ON_FIRST_HIT, any) triangle
 * the TLAS traversal commits, every triangle taken as opaque. The answer is the closest of both;
 * at equal t the lower instance index wins. */
struct LsnifQueryResult { /* 96 bytes; every field is written */
  float t;                              /* ray parameter of the hit (0 when kind is NONE or INCOMPLETE) */
  float normal_x, normal_y, normal_z;   /* LSNIF: world-space unit normal, normalize(A^-T n) of the
                                           instance's object-to-world A; zero for triangles */
  float albedo_r, albedo_g, albedo_b;   /* LSNIF: predicted albedo; zero for triangles (the application's) */
  lsnif_uint material;                  /* LSNIF: predicted material index; 0 for triangles */
  lsnif_uint kind;                      /* LSNIF_QUERY_HIT_NONE / _TRIANGLE / _LSNIF / _INCOMPLETE */
  lsnif_uint instance_index;            /* index of the instance in the TLAS (gl_InstanceID); ~0u without a hit */
  lsnif_uint instance_custom_index;     /* its instanceCustomIndex; ~0u without a hit */
  lsnif_uint primitive_index;           /* triangle: gl_PrimitiveID; LSNIF: 0; ~0u without a hit */
  lsnif_uint geometry_index;            /* triangle: gl_GeometryIndexEXT; LSNIF: 0; ~0u without a hit */
  float barycentric_u, barycentric_v;   /* triangle: the hit's barycentrics (weights of vertices 1 and 2) */
  lsnif_uint front_face;                /* 1 when front-facing: triangles by winding and instance flags,
                                           LSNIF by the predicted normal (dot(n, d) < 0 in object space) */
  lsnif_uint surface;                   /* LSNIF: packed surface channels (LSNIF_SURFACE_LEARNED); 0 for triangles */
  float emission_r, emission_g, emission_b; /* LSNIF: learned emission (0 without surface channels) */
  lsnif_uint reports_uv;                /* LSNIF: 1 when the hit's material reports its texture coordinate
                                           (the model's uv cells); 0 otherwise and for triangles */
  float uv_u, uv_v;                     /* LSNIF: that texture coordinate (fp32); 0 when reports_uv is 0 */
  lsnif_uint reserved;                  /* zero */
};
/* What lsnifCmdQuery counted, written to LsnifQueryInfo::status when given (24 bytes): candidates
 * the broad phase produced over all chunks, the capacity of one chunk, candidates that did not fit
 * (dropped), rays answered LSNIF_QUERY_HIT_INCOMPLETE, candidates kept but not evaluated
 * because their model-table entry on the device is not the block of the LsnifQueryInfo::pModels
 * entry the command was recorded with (a NULL entry, or another model), and candidates the second
 * round left out because their hit could not be closer than their ray's best after the first
 * (culled: no walk, no network; they change no answer). */
struct LsnifQueryStatus {
  lsnif_uint candidates;
  lsnif_uint capacity;
  lsnif_uint dropped;
  lsnif_uint incomplete_rays;
  lsnif_uint unevaluated;
  lsnif_uint culled;
};
#define LSNIF_QUERY_CHUNK_RAYS 65536u            /* rays per run of the stages; larger batches run in chunks */
#define LSNIF_QUERY_MAX_CANDIDATES_PER_RAY 32u   /* upper bound of LsnifQueryInfo::candidatesPerRay */
#define LSNIF_QUERY_MAX_MODELS 262144u           /* upper bound of LsnifQueryInfo::modelCount (table entries) */

/* The library's scratch of lsnifCmdQuery (not an interface: the application only sizes it), in
 * 32-bit words: LSNIF_BATCH_HEADER_WORDS of header (word 0 the candidate counter of the chunk, words
 * LSNIF_QUERY_STATUS_WORD.. the LsnifQueryStatus accumulators, LSNIF_QUERY_SCATTER_ARGS_WORD.. the
 * indirect dispatch of the per-candidate passes), then per model-table entry a
 * LsnifQueryModelCounters, per ray of a chunk a LsnifQueryRayState, per candidate slot a
 * LsnifQueryCandidate, the candidate indices sorted by model (one word per slot), and the batch rows
 * of the narrow phase, MLP and decode (the layout of lsnifCmdIntersectModelRays' rows, `stride`
 * words per row, each model's batch in the columns of its sorted range). */
#define LSNIF_QUERY_STATUS_WORD 4u       /* 6 words, in the order of LsnifQueryStatus */
/* The words of one scratch record of each per-entry section (the structs below; checked in C++). */
#define LSNIF_QUERY_MODEL_COUNTERS_WORDS 14u
#define LSNIF_QUERY_RAY_STATE_WORDS 8u
#define LSNIF_QUERY_CANDIDATE_WORDS 44u
#define LSNIF_QUERY_SCATTER_ARGS_WORD 12u
/* Per table entry; the per-model stages run once per run of consecutive entries of one model
 * (LsnifQueryInfo::pModels), their fields from `batch` on in the run's first entry. */
struct LsnifQueryModelCounters { /* 56 bytes */
  lsnif_uint count;    /* candidates of the entry (broad phase) */
  lsnif_uint start;    /* first sorted slot of the entry (exclusive prefix sum of count) */
  lsnif_uint cursor;   /* scatter counter */
  lsnif_uint batch;    /* candidates with boundary points so far (the run's MLP batch, every round) */
  lsnif_uint narrow_groups_x, narrow_groups_y, narrow_groups_z; /* VkDispatchIndirectCommand of the round's narrow phase */
  lsnif_uint batch_groups_x, batch_groups_y, batch_groups_z;    /* VkDispatchIndirectCommand over the round's slots */
  lsnif_uint round_start, round_end; /* the current round's batch slots [round_start, round_end) */
  lsnif_uint run_count;              /* candidates of the run's entries (sorted slots from `start`) */
  lsnif_uint rest_count;             /* those the first round left to the second (listed from `start`) */
};
struct LsnifQueryRayState { /* 32 bytes; t values as float bits (non-negative: ordered as uint) */
  lsnif_uint best_t;            /* closest accepted t (triangle or LSNIF); +inf bits without one */
  lsnif_uint best_instance;     /* lowest instance index of the LSNIF hits at best_t; ~0u without one */
  lsnif_uint missing_t;         /* smallest t_enter of the ray's candidates not evaluated (did not fit,
                                   or their table entry is not the model recorded for it); +inf bits */
  lsnif_uint triangle_t;        /* the triangle hit's t; +inf bits without one */
  lsnif_uint triangle_instance; /* its instance index; ~0u without one */
  lsnif_uint first_t;           /* smallest t_enter of the ray's candidates kept: the first round's */
  lsnif_uint reserved1, reserved2;
};
struct LsnifQueryCandidate { /* 176 bytes: one (ray, LSNIF instance) pair of the broad phase */
  lsnif_uint ray, instance_index, custom_index, flags;
  float origin_x, origin_y, origin_z, tmin;           /* object space (as the intersection shader sees it) */
  float direction_x, direction_y, direction_z, tmax;  /* tmax: the ray's, cut at the closest triangle hit */
  float t_enter, t_exit;                              /* the ray's interval clipped to the model's box */
  lsnif_uint accepted;                                /* set by the decode */
  float t;
  float normal_matrix[9];                             /* mat3 of WorldToObject, column-major */
  lsnif_uint points;
  float occlusion_logit;
  lsnif_uint material;
  float normal_x, normal_y, normal_z;                 /* world space, normalized */
  float albedo_r, albedo_g, albedo_b;
  lsnif_uint front_face;
  lsnif_uint evaluated;                               /* 1: the narrow phase ran the model recorded for its
                                                         table entry, which the table holds, or found in the
                                                         second round that its hit could not win (0 otherwise) */
  lsnif_uint surface;                                 /* packed surface channels */
  float emission_r, emission_g, emission_b;
  lsnif_uint reports_uv;                              /* the hit's texture coordinate (lsnif_hit_uv) */
  float uv_u, uv_v;
  lsnif_uint reserved;
};
/* Push constants of lsnifCmdQuery's stages (one block for all of them, 104 bytes). */
struct LsnifQueryPushConstants {
  lsnif_uint tlas_lo, tlas_hi;         /* the TLAS's device address */
  lsnif_uint table_lo, table_hi;       /* the model table (uint64 block addresses) */
  lsnif_uint rays_lo, rays_hi;         /* LsnifQueryRay[ray_count] of the chunk */
  lsnif_uint results_lo, results_hi;   /* LsnifQueryResult[ray_count] of the chunk */
  lsnif_uint scratch_lo, scratch_hi;
  lsnif_uint model_lo, model_hi;       /* the model of `bucket` (narrow phase, MLP, decode) */
  lsnif_uint status_lo, status_hi;     /* LsnifQueryStatus or 0 */
  lsnif_uint ray_count;                /* rays of the chunk */
  lsnif_uint model_count;              /* entries of the model table */
  lsnif_uint capacity;                 /* candidate slots of a chunk */
  lsnif_uint stride;                   /* capacity rounded up to a multiple of LSNIF_BATCH_GROUP_SIZE */
  lsnif_uint bucket;                   /* per-model stages: the first model-table entry of the run */
  lsnif_uint cull_mask;
  lsnif_uint first_chunk;              /* 1 for the first chunk: the status accumulators start at 0 */
  lsnif_uint model_index;              /* LSNIF_QUERY_MODEL_INDEX_BY_*: what selects an instance's table entry */
  lsnif_uint model_index_base;         /* subtracted from the custom index (LSNIF_QUERY_MODEL_INDEX_BY_CUSTOM_INDEX) */
  lsnif_uint query_round;              /* narrow phase: LSNIF_QUERY_ROUND_NEAREST or LSNIF_QUERY_ROUND_REST */
  lsnif_uint bucket_last;              /* per-model stages: the run's last entry (entries bucket..bucket_last) */
  lsnif_uint reserved;
};
/* LsnifQueryPushConstants::query_round: the candidates a round's narrow phase takes. The nearest:
 * those entering their model's box at their ray's first_t. The rest: the others, except those
 * whose walk starts beyond their ray's best t after the first round (their hit, never before the
 * walk's start, could not win). */
#define LSNIF_QUERY_ROUND_NEAREST 0u
#define LSNIF_QUERY_ROUND_REST 1u
/* LsnifQueryPushConstants::model_index (the values of LsnifQueryModelIndex in lsnif.h). */
#define LSNIF_QUERY_MODEL_INDEX_BY_CUSTOM_INDEX 0u
#define LSNIF_QUERY_MODEL_INDEX_BY_INSTANCE_INDEX 1u

#if defined(__cplusplus)
static_assert(sizeof(LsnifQueryRay) == 48, "LsnifQueryRay layout");
static_assert(sizeof(LsnifQueryHit) == 80, "LsnifQueryHit layout");
static_assert(sizeof(LsnifQueryResult) == 96, "LsnifQueryResult layout");
static_assert(sizeof(LsnifQueryStatus) == 24, "LsnifQueryStatus layout");
static_assert(sizeof(LsnifQueryModelCounters) == 56, "LsnifQueryModelCounters layout");
static_assert(sizeof(LsnifQueryRayState) == 32, "LsnifQueryRayState layout");
static_assert(sizeof(LsnifQueryCandidate) == 176, "LsnifQueryCandidate layout");
static_assert(sizeof(LsnifQueryModelCounters) == 4 * LSNIF_QUERY_MODEL_COUNTERS_WORDS &&
                  sizeof(LsnifQueryRayState) == 4 * LSNIF_QUERY_RAY_STATE_WORDS &&
                  sizeof(LsnifQueryCandidate) == 4 * LSNIF_QUERY_CANDIDATE_WORDS,
              "the scratch record sizes the query shaders use");
static_assert(sizeof(LsnifQueryPushConstants) == 104, "LsnifQueryPushConstants layout");
#endif

#if !defined(LSNIF_GLSL) && !defined(__cplusplus)
/* C: the structs under their plain names too, as in C++ and GLSL. */
typedef struct LsnifGpuModelHeader LsnifGpuModelHeader;
typedef struct LsnifReferenceRay LsnifReferenceRay;
typedef struct LsnifReferenceHit LsnifReferenceHit;
typedef struct LsnifRtPushConstants LsnifRtPushConstants;
typedef struct LsnifHitAttributes LsnifHitAttributes;
typedef struct LsnifQueryRay LsnifQueryRay;
typedef struct LsnifQueryHit LsnifQueryHit;
typedef struct LsnifBatchPushConstants LsnifBatchPushConstants;
typedef struct LsnifQueryResult LsnifQueryResult;
typedef struct LsnifQueryStatus LsnifQueryStatus;
typedef struct LsnifQueryModelCounters LsnifQueryModelCounters;
typedef struct LsnifQueryRayState LsnifQueryRayState;
typedef struct LsnifQueryCandidate LsnifQueryCandidate;
typedef struct LsnifQueryPushConstants LsnifQueryPushConstants;
#endif

#endif
