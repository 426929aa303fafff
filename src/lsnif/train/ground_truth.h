// ground_truth.h -- exact ray casting against the triangle mesh with Embree: the reference that
// training targets and evaluation compare against.
#pragma once
#include <cstdint>
#include <memory>

#include "lsnif/core/geometry.h"
#include "lsnif/import/mesh.h"
#include "lsnif/format/status.h"

namespace lsnif {

struct ReferenceHit {
  bool hit = false;
  float t = 0.0f;                    // ray parameter of the closest hit
  glm::vec3 normal{0.0f};            // interpolated shading normal, normalized, as stored (outward)
  glm::vec3 geometric_normal{0.0f};  // face normal, normalized, as wound
  glm::vec3 albedo{0.0f};            // Mesh::albedo at the hit
  SurfaceSample surface;             // Mesh::surface at the hit (its albedo == albedo)
  glm::vec2 uv{0.0f};                // Mesh::uv_at the hit: where its textures are read (0 without uvs)
  uint32_t material = 0;
  uint32_t triangle = 0;
};

class GroundTruth {
 public:
  GroundTruth();
  ~GroundTruth();
  GroundTruth(const GroundTruth&) = delete;
  GroundTruth& operator=(const GroundTruth&) = delete;

  // Builds an Embree scene over `mesh` (kept by reference: it must outlive this object).
  Status build(const Mesh& mesh);
  // Closest hit within [ray.tmin, ray.tmax] that passes the alpha test (Mesh::opaque_at: the holes
  // of MASK and BLEND materials are no surface). Thread-safe after build().
  ReferenceHit trace(const Ray& ray) const;
  // The same hit with only hit, t, triangle and geometric_normal set, the normal facing either way
  // (Embree's, normalized; no material, shading normal, surface or texture coordinate, so no read
  // of the mesh's arrays): for rays that only look for a surface point (the ray sampler's finding
  // rays).
  ReferenceHit trace_geometry(const Ray& ray) const;
  // hits[i] = trace(rays[i]) for i < count, the rays traced 16 at a time in Embree's packets.
  void trace(const Ray* rays, size_t count, ReferenceHit* hits) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace lsnif
