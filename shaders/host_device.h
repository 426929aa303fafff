/* host_device.h -- the one definition of LSNIF constants and layouts shared by C++ (host/, plugin/)
 * and GLSL (shaders/). Include from C++ as-is; from GLSL after #extension GL_GOOGLE_include_directive.
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

/* Network output layout (raw, before activations): 8 + Nmat values per ray.
 * occlusion: sigmoid; distance: sigmoid (see hit parametrization); normal: identity;
 * albedo: sigmoid; material: softmax over Nmat. */
#define LSNIF_OUT_OCCLUSION 0u
#define LSNIF_OUT_DISTANCE 1u
#define LSNIF_OUT_NORMAL 2u
#define LSNIF_OUT_ALBEDO 5u
#define LSNIF_OUT_MATERIAL 8u
#define LSNIF_OUT_FIXED 8u

/* Hit-distance parametrization (paper: AABB interval; ours: crossed voxel segments). */
#define LSNIF_HIT_PARAM_AABB_INTERVAL 0u
#define LSNIF_HIT_PARAM_VOXEL_SEGMENTS 1u

/* Spatial hash of an integer grid vertex (Teschner et al. / instant-ngp primes). */
#define LSNIF_HASH_PRIME_X 1u
#define LSNIF_HASH_PRIME_Y 2654435761u
#define LSNIF_HASH_PRIME_Z 805459861u

/* Occlusion threshold on sigmoid(logit): a hit when the probability is >= 0.5 (logit >= 0). */
#define LSNIF_OCCLUSION_THRESHOLD 0.5

#endif
