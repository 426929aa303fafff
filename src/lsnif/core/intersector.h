// intersector.h -- the CPU reference LSNIF intersector: world-space rays against one instance of a
// model (object-to-world affine transform). Walks each ray through the voxels (ignoring tmax, so the
// network input never depends on the query interval), encodes, runs the MLP for the rays that cross
// an occupied voxel, decodes, and reports a hit when occlusion >= 0.5 and tmin <= t <= tmax. This is
// what the Vulkan intersection shader is tested against.
#pragma once
#include <cstddef>
#include <cstdint>

#include "lsnif/core/geometry.h"
#include "lsnif/core/model.h"
#include "lsnif/format/status.h"

namespace lsnif {

struct LsnifHit {
  bool hit = false;
  float t = 0.0f;             // ray parameter (world ray)
  glm::vec3 normal{0.0f};     // world space, normalized, as predicted (outward)
  glm::vec3 albedo{0.0f};
  uint32_t material = 0;
  float occlusion = 0.0f;     // predicted probability (0 when the ray crosses no occupied voxel)
  // The surface channels (Prediction, src/lsnif/core/head.h): false and zero for a model without
  // them and for misses. pack_surface / pack_rgbe (head.h) give what the device packs of them.
  bool surface_learned = false;
  float metallic = 0.0f, roughness = 0.0f, ambient_occlusion = 0.0f;
  glm::vec3 emission{0.0f};   // linear RGB, emission_scale x sigmoid
  // Hits of a texture-coordinate material (Config::uv_materials): the texture coordinate of the
  // predicted hit point (uv_cells.h) with reports_uv true; else zero and false (no uv cell piece near
  // the point facing its way: the hit keeps the learned colours). pack_uv (head.h) gives what the
  // device packs of it.
  glm::vec2 uv{0.0f};
  bool reports_uv = false;
};

// Row-major 3x4 object-to-world matrix (the layout of VkTransformMatrixKHR).
struct Transform3x4 {
  float m[3][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};
};

// The linear part A and translation T of an object-to-world transform (world = A object + T), and
// A^-1 (object = A^-1 (world - T); normals go to world space by transpose(A^-1)). Fails on a
// non-finite entry or a singular A.
Status split_transform(const Transform3x4& object_to_world, glm::mat3& A, glm::vec3& T, glm::mat3& A_inv);

// Intersects `count` world-space rays with the instance. Fails (hits untouched) if the transform
// has a non-finite entry or is singular, or if the model is inconsistent. Rays with non-finite
// origin or direction, or a zero direction, are misses. `ray_flags` (LSNIF_RAY_FLAG_CULL_*_FACING
// of src/lsnif/host_device.h, for every ray) rejects hits by the facing of the predicted normal, as
// the intersection shader does with the ray's flags. Uses OpenMP and Eigen for the batch.
Status intersect(const Model& model, const Transform3x4& object_to_world, const Ray* rays,
                 size_t count, LsnifHit* hits, uint32_t ray_flags = 0);

// The self-intersection rule (src/lsnif/host_device.h, LSNIF_LEAVING_TMIN_VOXELS): tmin of a ray
// leaving a hit on this instance in world direction `world_direction`, i.e.
// LSNIF_LEAVING_TMIN_VOXELS voxel edges of the model along the object-space direction, as a world
// ray parameter. 0 for a zero or non-finite direction or an invalid transform.
float leaving_tmin(const Model& model, const Transform3x4& object_to_world, glm::vec3 world_direction);

}  // namespace lsnif
