// ray_sampler.h -- training and evaluation rays (paper 5.2): half start on a sphere around the
// AABB with cosine-weighted directions toward its centre, half start on the surface (found by rays
// of the first kind) with cosine-weighted directions about the surface normal on the side the
// finding ray came from. Each ray gets its ground truth from Embree and its voxel walk; only rays
// that cross at least one occupied voxel are kept (the others are misses by construction).
#pragma once
#include <cstdint>
#include <vector>

#include "lsnif/train/ground_truth.h"
#include "lsnif/format/settings_table.h"
#include "lsnif/core/ray_walk.h"
#include "lsnif/core/voxel_grid.h"

namespace lsnif {

struct Sample {
  Ray ray;                // object space; direction normalized; tmin = 0, tmax = inf
  bool from_surface = false;
  ReferenceHit reference;
};

struct SamplerSettings {  // defaults: settings_table.h
  float surface_fraction = default_f32(SettingId::SurfaceFraction);  // share of rays starting on the surface
  float sphere_scale = default_f32(SettingId::SphereScale);  // sphere radius = scale * half diagonal of the padded AABB
  float surface_offset = default_f32(SettingId::SurfaceOffset);  // surface origins pushed off by this x AABB diagonal
};

class RaySampler {
 public:
  RaySampler(const Mesh& mesh, const GroundTruth& truth, const VoxelGrid& grid, uint32_t max_points,
             SamplerSettings settings = {});
  // Generates exactly `count` kept samples (with their walks) from (seed, stream), deterministic
  // for a given (seed, stream, count) whatever the thread count. Uses OpenMP.
  void generate(uint64_t seed, uint64_t stream, size_t count, std::vector<Sample>& samples,
                std::vector<RayWalk>& walks) const;

 private:
  const Mesh& mesh_;
  const GroundTruth& truth_;
  const VoxelGrid& grid_;
  uint32_t max_points_;
  SamplerSettings settings_;
  // Fraction of candidates kept so far, to size the next call's first block (a performance hint
  // only: which samples come out never depends on it).
  mutable double keep_rate_ = 0.5;
};

}  // namespace lsnif
