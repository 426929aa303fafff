// evaluate.h -- accuracy of a trained model against the Embree reference on a fresh held-out ray
// set drawn like the training rays (another seed), restricted to rays that cross at least one
// occupied voxel. Also scores the voxel-only baseline on the same rays (hit = crosses an occupied
// voxel, t = entry into the first one, normal = that voxel face's normal facing the ray).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "lsnif/import/mesh.h"
#include "lsnif/core/model.h"
#include "lsnif/train/ray_sampler.h"

namespace lsnif {

// The most held-out rays an evaluation takes: each holds ~1.8 KB of host memory (its reference hit,
// the model's walk and answer, the per-ray errors; 10^6 rays measured 1.8 GB resident on the elephant).
inline constexpr uint32_t kMaxEvalRays = 1u << 20;

// How far (a fraction of the model's diagonal) the padded bounds of the mesh an evaluation is given
// may lie from the model's: the same mesh read again gives the same bounds to rounding.
inline constexpr float kEvalBoundsTolerance = 1e-4f;

struct EvalSettings {
  size_t rays = 100000;
  // The reference normal: the materials' normal maps applied (what a model trained with
  // bakes_normal_maps learns) or the interpolated shading normal.
  bool normal_maps = true;
  uint64_t seed = 0x5eed0e7a1ull;  // differs from every training seed's stream space
  SamplerSettings sampler;
};

struct EvalMetrics {
  uint64_t rays = 0, true_hits = 0, false_hits = 0, true_misses = 0, false_misses = 0;
  double accuracy = 0, precision = 0, recall = 0;
  uint64_t agreed_hits = 0;          // rays where reference and prediction both hit
  double t_error_median = 0, t_error_p90 = 0;            // |t error| / AABB diagonal
  double normal_error_median = 0, normal_error_p90 = 0;  // degrees
  double albedo_mae = 0;             // mean |albedo error| over channels and agreed hits
  double material_accuracy = 0;      // over agreed hits
  // The other material channels on agreed hits: the model's learned surface channels, or (a model
  // without them) its material's factors, as the renderer shades them, against Mesh::surface.
  double surface_mae = 0;            // mean |error| of metallic, roughness and ambient occlusion
  double emission_mae = 0;           // mean |emission error| over channels (linear radiance)
  // Texture coordinates, on agreed hits whose reference material reports them
  // (Config::reports_uv): the distance between predicted and reference uv in texels of the
  // material's largest texture, and the share of those hits whose predicted uv is not within a texel
  // of the reference triangle's chart (uv_layout.h: it samples another piece of the texture).
  uint64_t uv_hits = 0;
  double uv_texel_error_median = 0, uv_texel_error_p90 = 0;
  double uv_wrong_chart = 0;
};

// The texture-coordinate metrics of one material that reports them.
struct UvMaterialEval {
  uint32_t material = 0;
  std::string name;
  uint32_t texture_size = 0;   // the largest side of its textures: what a texel is
  uint32_t charts = 0;
  uint64_t hits = 0;
  double texel_error_median = 0, texel_error_p90 = 0, wrong_chart = 0;
  // The mean absolute error of the material channels on those hits (albedo, metallic, roughness,
  // ambient occlusion, emission: 9 values per hit, against Mesh::surface), shaded as a renderer does:
  // with the material's own textures at the predicted coordinate (hits that find no piece keep their
  // learned colours), and with the learned colours alone (--texture-coordinates off's shading).
  double channel_error_textures = 0, channel_error_colours = 0;
};

struct EvalReport {
  EvalMetrics model, baseline;
  EvalMetrics model_outer, model_surface;  // the model on rays from the outer sphere / the surface
  double reference_hit_fraction = 0;  // among the evaluated rays
  double truncated_fraction = 0;      // walks with more than H boundary points
  double hit_beyond_walk_fraction = 0;  // reference hits past the last recorded point (unreachable)
  double seconds = 0;
  std::vector<UvMaterialEval> uv_materials;  // per material reporting texture coordinates
  std::string to_text() const;
  std::string uv_text() const;  // a line per material of uv_materials (to_text's last lines)
  // One JSON object (json::dump of json_text.h, no trailing newline): the fractions and seconds,
  // then "model", "voxel_baseline", "model_from_outside", "model_from_surface" with every metric
  // and "uv_materials" (numbers at full double precision).
  std::string to_json() const;
};

// The held-out rays of an evaluation with `settings` (its seed, ray count and sampler): drawn like
// the training rays from another seed, each crossing an occupied voxel of the model, in the model's
// object space; the rays evaluate_model measures the model on. Fails as evaluate_model does.
Status held_out_rays(const Model& model, const Mesh& mesh, const EvalSettings& settings, std::vector<Ray>& rays);

// `mesh` must be the mesh the model was trained on, in its object space: an error otherwise (its
// padded bounds differ from the model's by more than kEvalBoundsTolerance).
Status evaluate_model(const Model& model, const Mesh& mesh, const EvalSettings& settings,
                      EvalReport& report);

}  // namespace lsnif
