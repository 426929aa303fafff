// ray_sampler.h -- training and evaluation rays (paper 5.2): half start on a sphere around the
// AABB with cosine-weighted directions toward its centre, half start on the surface (found by rays
// of the first kind) with cosine-weighted directions about the surface normal on the side the
// finding ray came from. Each ray gets its ground truth from Embree and its voxel walk; only rays
// that cross at least one occupied voxel are kept (the others are misses by construction).
//
// Rays of the first kind are uniformly distributed lines through the sphere (a uniform point, a
// cosine-weighted direction), and only those that cross a convex body around the mesh and its
// occupied voxels can be kept or find the surface. The sampler draws them among the lines through
// such a body directly (a uniform point on its surface, a cosine-weighted direction into it, the
// origin moved back to the sphere): the kept rays have the same distribution, fewer candidates are
// drawn, walked and traced, and the share of surface candidates is raised so that the kept rays
// hold the same mix of both kinds (RaySampler::surface_share). The body is the tightest polytope
// with faces normal to the axes, the face diagonals and the body diagonals (LineBody).
//
// A finding ray's hit (the sampler's costliest trace) serves SamplerSettings::surface_rays surface
// rays, each with its own cosine-weighted direction; the share of surface candidates is lowered by
// that factor's odds, so that the kept rays hold the same mix and each ray the same law. The rays
// from one point are not independent of each other: evaluation draws one per point.
//
// A finding ray's hit has the law of an outer ray's hit, and every outer ray that hits is kept and
// traced for its reference: a surface candidate takes the hit of an earlier outer candidate when
// one is unused (SamplerSettings::surface_points_from_outer_hits), and casts its own finding rays
// only when none is. Each ray keeps its law; a surface ray may start where an outer ray of the same
// call ends (evaluation draws independent rays).
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
  // Draw the first kind's rays among the lines through the body (above); false draws them on the
  // whole sphere, as the paper describes it (the same kept rays in distribution, more candidates):
  // the tests' reference, and evaluation's held-out rays (draw_held_out: those of every version).
  bool lines_through_body = true;
  uint32_t surface_rays = default_u32(SettingId::SurfaceRays);  // surface rays per found surface point
  // A surface candidate takes its point from an earlier outer candidate's reference hit when one is
  // unused (the same law as its own finding ray's hit, without tracing one); false: always its own
  // finding ray, as the paper describes it (the tests' reference, and evaluation's held-out rays).
  bool surface_points_from_outer_hits = true;
};

// Where a surface ray starts from: a finding ray's hit and the face normal turned toward that ray.
struct SurfacePoint {
  glm::vec3 point{0.0f}, normal{0.0f};
  static SurfacePoint of(const Ray& finder, const ReferenceHit& hit) {
    const glm::vec3 n = hit.geometric_normal;
    return {finder.origin + hit.t * finder.direction, glm::dot(n, finder.direction) > 0.0f ? -n : n};
  }
};

// A candidate's kind (SamplerScratch::kind): an outer candidate holds one ray of the first kind, a
// surface candidate surface_rays rays from a surface point.
enum CandidateKind : uint8_t { kOuterCandidate = 0, kSurfaceCandidate = 1 };

// The candidates of one block of a generate call (their rays, walks and keep flags), kept by a
// caller that samples again and again (the trainer) so that each call allocates (and faults in)
// nothing; its contents between calls mean nothing.
struct SamplerScratch {
  std::vector<Sample> samples;
  std::vector<RayWalk> walks;
  std::vector<uint8_t> keep;
  std::vector<size_t> slot;
  std::vector<Ray> rays;  // the block's rays to walk (kNoWalkRay where a slot has none)
  std::vector<CandidateKind> kind;  // per candidate
  std::vector<size_t> given;       // per surface candidate: its point in `unused`, or SIZE_MAX
  std::vector<SurfacePoint> unused;  // the outer candidates' hits, in candidate order
  size_t next_unused = 0;          // the oldest hit not yet given
  std::vector<RayWalk> chunk_walks;  // each thread's walks of one chunk's surface rays
  std::vector<size_t> to_trace;    // the samples without their reference hit yet
};

// A convex body around a mesh and its occupied voxels for the first kind's rays: the polytope cut
// by kDirections slabs (the axes, the 6 face diagonals, the 4 body diagonals: a 26-DOP), each as
// thin as the points it must hold allow; its boundary as triangles, to draw points on by area.
// Through it, a finding ray hits the bunny, the armadillo and the dragon 1.4-1.5 times as often as
// through their bounding box (docs/results.md, "A tighter body for the rays").
struct LineBody {
  static constexpr int kDirections = 13;
  // Empty; build() makes it the tightest body holding `points` (grown by `margin` on every side),
  // its axis slabs cut to `clip`.
  LineBody();
  void build(const std::vector<glm::vec3>& points, float margin, const Aabb& clip);
  bool valid() const { return !faces.empty(); }
  // Whether p lies in every slab (each widened by `tolerance`).
  bool contains(const glm::vec3& p, float tolerance = 0.0f) const;
  // Whether `ray` meets the body within [ray.tmin, ray.tmax].
  bool crossed_by(const Ray& ray) const;

  glm::vec3 direction[kDirections];  // unit normals of the slabs
  float lo[kDirections] = {}, hi[kDirections] = {};  // each slab: lo <= dot(direction, p) <= hi
  Aabb bounds;                       // the axis slabs
  struct Face {                      // a triangle of the boundary: p0, p0 + e1, p0 + e2
    glm::vec3 p0, e1, e2, inward;    // inward: the unit normal into the body
  };
  std::vector<Face> faces;
  std::vector<float> cdf;            // the faces by area, cumulative (the last is 1)
  std::vector<glm::vec3> corners;    // the vertices of the boundary
  double area = 0;
};

class RaySampler {
 public:
  RaySampler(const Mesh& mesh, const GroundTruth& truth, const VoxelGrid& grid, uint32_t max_points,
             SamplerSettings settings = {});
  // Generates exactly `count` kept samples (with their walks) from (seed, stream), deterministic
  // for a given (seed, stream, count) whatever the thread count. Uses OpenMP. `scratch` (optional)
  // holds the candidates between calls.
  void generate(uint64_t seed, uint64_t stream, size_t count, std::vector<Sample>& samples,
                std::vector<RayWalk>& walks, SamplerScratch* scratch = nullptr) const;
  // The body the first kind's rays are drawn through (empty when they are drawn on the whole
  // sphere: lines_through_body off, or a sphere that does not contain the body), the share of the
  // sphere's lines that cross it (its area over the sphere's, by Cauchy-Crofton) and the share of
  // candidates that are surface candidates.
  const LineBody& line_body() const { return line_body_; }
  double line_body_share() const { return line_body_share_; }
  double surface_share() const { return surface_share_; }

 private:
  const Mesh& mesh_;
  const GroundTruth& truth_;
  const VoxelGrid& grid_;
  uint32_t max_points_;
  SamplerSettings settings_;
  LineBody line_body_;
  double line_body_share_ = 1.0;
  double surface_share_ = 0.5;
  // Rays kept per candidate so far (up to surface_rays), to size the next call's first block (a
  // performance hint only: which samples come out never depends on it).
  mutable double keep_rate_ = 0.5;
  void set_surface_share();
};

}  // namespace lsnif
