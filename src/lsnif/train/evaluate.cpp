#include "lsnif/train/evaluate.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include "lsnif/train/ground_truth.h"
#include "lsnif/core/intersector.h"
#include "lsnif/import/json_text.h"

namespace lsnif {

namespace {

double percentile(std::vector<double>& v, double q) {
  if (v.empty()) return 0.0;
  size_t k = size_t(std::floor(q * double(v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + long(k), v.end());
  return v[k];
}

double angle_degrees(const glm::vec3& a, const glm::vec3& b) {
  const float la = glm::length(a), lb = glm::length(b);
  if (!(la > 0.0f) || !(lb > 0.0f)) return 180.0;
  const double c = std::clamp(double(glm::dot(a, b)) / (double(la) * lb), -1.0, 1.0);
  return std::acos(c) * 180.0 / 3.14159265358979323846;
}

struct Accumulator {
  EvalMetrics m;
  std::vector<double> t_err, n_err;
  double albedo_sum = 0, surface_sum = 0, emission_sum = 0;
  uint64_t material_ok = 0;
  // The surface channels of an agreed hit: `predicted` (metallic, roughness, ambient occlusion,
  // emission) against the reference's.
  void add_surface(const SurfaceSample& ref, const SurfaceSample& predicted) {
    surface_sum += (std::fabs(double(predicted.metallic) - ref.metallic) +
                    std::fabs(double(predicted.roughness) - ref.roughness) +
                    std::fabs(double(predicted.ambient_occlusion) - ref.ambient_occlusion)) / 3.0;
    const glm::vec3 d = glm::abs(predicted.emission - ref.emission);
    emission_sum += (double(d.x) + d.y + d.z) / 3.0;
  }
  void add(bool ref_hit, bool hit, float t_ref, float t, const glm::vec3& n_ref, const glm::vec3& n,
           const glm::vec3& a_ref, const glm::vec3& a, uint32_t mat_ref, uint32_t mat, float diag,
           bool has_albedo) {
    ++m.rays;
    if (ref_hit && hit) ++m.true_hits;
    if (!ref_hit && hit) ++m.false_hits;
    if (!ref_hit && !hit) ++m.true_misses;
    if (ref_hit && !hit) ++m.false_misses;
    if (!(ref_hit && hit)) return;
    ++m.agreed_hits;
    t_err.push_back(std::fabs(double(t) - t_ref) / diag);
    n_err.push_back(angle_degrees(n, n_ref));
    if (has_albedo) {
      glm::vec3 d = glm::abs(a - a_ref);
      albedo_sum += (d.x + d.y + d.z) / 3.0;
      material_ok += mat == mat_ref;
    }
  }
  EvalMetrics finish(bool has_albedo) {
    const double r = double(std::max<uint64_t>(m.rays, 1));
    m.accuracy = double(m.true_hits + m.true_misses) / r;
    m.precision = m.true_hits + m.false_hits ? double(m.true_hits) / double(m.true_hits + m.false_hits) : 0.0;
    m.recall = m.true_hits + m.false_misses ? double(m.true_hits) / double(m.true_hits + m.false_misses) : 0.0;
    m.t_error_median = percentile(t_err, 0.5);
    m.t_error_p90 = percentile(t_err, 0.9);
    m.normal_error_median = percentile(n_err, 0.5);
    m.normal_error_p90 = percentile(n_err, 0.9);
    if (has_albedo && m.agreed_hits) {
      m.albedo_mae = albedo_sum / double(m.agreed_hits);
      m.material_accuracy = double(material_ok) / double(m.agreed_hits);
      m.surface_mae = surface_sum / double(m.agreed_hits);
      m.emission_mae = emission_sum / double(m.agreed_hits);
    }
    return m;
  }
};

nlohmann::ordered_json metrics_json(const EvalMetrics& m) {
  return {{"rays", m.rays},
          {"true_hits", m.true_hits},
          {"false_hits", m.false_hits},
          {"true_misses", m.true_misses},
          {"false_misses", m.false_misses},
          {"accuracy", m.accuracy},
          {"precision", m.precision},
          {"recall", m.recall},
          {"agreed_hits", m.agreed_hits},
          {"t_error_median", m.t_error_median},
          {"t_error_p90", m.t_error_p90},
          {"normal_error_median_deg", m.normal_error_median},
          {"normal_error_p90_deg", m.normal_error_p90},
          {"albedo_mae", m.albedo_mae},
          {"material_accuracy", m.material_accuracy},
          {"surface_mae", m.surface_mae},
          {"emission_mae", m.emission_mae}};
}

std::string metrics_text(const char* name, const EvalMetrics& m, bool albedo) {
  std::string s = format(
      "%-9s occlusion acc %6.2f%%  precision %6.2f%%  recall %6.2f%% | t err median %.3f%% p90 %.3f%% "
      "of diag | normal err median %5.2f deg p90 %5.2f deg",
      name, 100 * m.accuracy, 100 * m.precision, 100 * m.recall, 100 * m.t_error_median,
      100 * m.t_error_p90, m.normal_error_median, m.normal_error_p90);
  if (albedo)
    s += format(" | albedo MAE %.4f  material acc %.2f%% | metallic/roughness/occlusion MAE %.4f  emission MAE %.4f",
                m.albedo_mae, 100 * m.material_accuracy, m.surface_mae, m.emission_mae);
  return s;
}

// The surface channels a renderer shades an LSNIF hit with: the learned ones, or those of the
// material its material index names (the mesh's factors) for a model without surface channels.
SurfaceSample predicted_surface(const LsnifHit& h, const Mesh& mesh) {
  SurfaceSample s;
  if (h.surface_learned) {
    s.metallic = h.metallic;
    s.roughness = h.roughness;
    s.ambient_occlusion = h.ambient_occlusion;
    s.emission = h.emission;
  } else if (h.material < mesh.materials.size()) {
    const Material& m = mesh.materials[h.material];
    s.metallic = m.metallic;
    s.roughness = m.roughness;
    s.emission = m.emission;
  }
  return s;
}

}  // namespace

std::string EvalReport::to_text() const {
  return format("held-out rays crossing an occupied voxel: %llu (reference hits %.1f%%)\n",
                (unsigned long long)model.rays, 100 * reference_hit_fraction) +
         metrics_text("model", model, true) + "\n" + metrics_text("baseline", baseline, false) + "\n" +
         format("walks truncated at H: %.2f%% of rays; reference hit beyond the last point: %.3f%%\n",
                100 * truncated_fraction, 100 * hit_beyond_walk_fraction) +
         format("by origin: %llu rays from outside, %llu from the surface\n", (unsigned long long)model_outer.rays,
                (unsigned long long)model_surface.rays) +
         metrics_text(" outside", model_outer, false) + "\n" + metrics_text(" surface", model_surface, false) + "\n";
}

std::string EvalReport::to_json() const {
  const nlohmann::ordered_json j = {{"reference_hit_fraction", reference_hit_fraction},
                                    {"truncated_fraction", truncated_fraction},
                                    {"hit_beyond_walk_fraction", hit_beyond_walk_fraction},
                                    {"seconds", seconds},
                                    {"model", metrics_json(model)},
                                    {"voxel_baseline", metrics_json(baseline)},
                                    {"model_from_outside", metrics_json(model_outer)},
                                    {"model_from_surface", metrics_json(model_surface)}};
  return json::dump(j);
}

Status evaluate_model(const Model& model, const Mesh& mesh, const EvalSettings& settings,
                      EvalReport& report) {
  if (Status s = model.validate(); !s) return s.context("evaluate");
  if (settings.rays == 0) return Status::error("evaluation needs at least one ray");
  const auto t0 = std::chrono::steady_clock::now();
  GroundTruth truth;
  if (Status s = truth.build(mesh); !s) return s.context("building the Embree reference");
  RaySampler sampler(mesh, truth, model.voxels, model.config.max_points, settings.sampler);
  std::vector<Sample> samples;
  std::vector<RayWalk> walks;
  sampler.generate(settings.seed, 0, settings.rays, samples, walks);
  if (samples.size() != settings.rays)
    return Status::error("found only %zu of %zu held-out rays crossing an occupied voxel", samples.size(),
                         settings.rays);

  std::vector<Ray> rays(samples.size());
  for (size_t i = 0; i < samples.size(); ++i) rays[i] = samples[i].ray;
  std::vector<LsnifHit> hits(samples.size());
  if (Status s = intersect(model, Transform3x4(), rays.data(), rays.size(), hits.data()); !s) return s;

  const float diag = model.bounds().diagonal();
  Accumulator acc_model, acc_base, acc_outer, acc_surface;
  uint64_t ref_hits = 0, truncated = 0, beyond = 0;
  for (size_t i = 0; i < samples.size(); ++i) {
    const ReferenceHit& ref = samples[i].reference;
    ref_hits += ref.hit;
    truncated += walks[i].truncated;
    beyond += ref.hit && walks[i].count > 0 && ref.t > walks[i].t[walks[i].count - 1];
    const LsnifHit& h = hits[i];
    Accumulator& by_origin = samples[i].from_surface ? acc_surface : acc_outer;
    const glm::vec3 ref_normal = settings.normal_maps ? ref.surface.normal : ref.normal;
    for (Accumulator* acc : {&acc_model, &by_origin}) {
      acc->add(ref.hit, h.hit, ref.t, h.t, ref_normal, h.normal, ref.albedo, h.albedo, ref.material, h.material,
               diag, true);
      if (ref.hit && h.hit) acc->add_surface(ref.surface, predicted_surface(h, mesh));
    }
    const BaselineHit b = voxel_baseline(model.voxels, rays[i], walks[i]);
    acc_base.add(ref.hit, b.hit, ref.t, b.t, ref.normal, b.normal, ref.albedo, glm::vec3(0.0f), 0, 0,
                 diag, false);
  }
  report.model = acc_model.finish(true);
  report.baseline = acc_base.finish(false);
  report.model_outer = acc_outer.finish(true);
  report.model_surface = acc_surface.finish(true);
  report.reference_hit_fraction = double(ref_hits) / double(samples.size());
  report.truncated_fraction = double(truncated) / double(samples.size());
  report.hit_beyond_walk_fraction = double(beyond) / double(samples.size());
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return Status::ok();
}

}  // namespace lsnif
