#include "lsnif/train/evaluate.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <vector>

#include "lsnif/train/ground_truth.h"
#include "lsnif/core/intersector.h"
#include "lsnif/import/json_text.h"
#include "lsnif/import/uv_layout.h"

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
  std::vector<double> uv_err;
  uint64_t uv_wrong = 0;
  void add_uv(double texel_error, bool wrong_chart) {
    uv_err.push_back(texel_error);
    uv_wrong += wrong_chart;
  }
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
    m.uv_hits = uv_err.size();
    if (m.uv_hits) m.uv_wrong_chart = double(uv_wrong) / double(m.uv_hits);
    m.uv_texel_error_median = percentile(uv_err, 0.5);
    m.uv_texel_error_p90 = percentile(uv_err, 0.9);
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
          {"emission_mae", m.emission_mae},
          {"uv_hits", m.uv_hits},
          {"uv_texel_error_median", m.uv_texel_error_median},
          {"uv_texel_error_p90", m.uv_texel_error_p90},
          {"uv_wrong_chart", m.uv_wrong_chart}};
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
  if (albedo && m.uv_hits)
    s += format(" | uv texel err median %.2f p90 %.2f, wrong chart %.2f%% of %llu hits", m.uv_texel_error_median,
                m.uv_texel_error_p90, 100 * m.uv_wrong_chart, (unsigned long long)m.uv_hits);
  return s;
}

// The largest side of material m's textures (1 when it has none the mesh holds).
uint32_t texture_size(const Mesh& mesh, const Material& m) {
  uint32_t size = 1;
  for (const int* slot : m.textures())
    if (*slot >= 0 && size_t(*slot) < mesh.textures.size())
      size = std::max({size, mesh.textures[size_t(*slot)].width, mesh.textures[size_t(*slot)].height});
  return size;
}

// A material's chart map and texel size, for the texture-coordinate metrics.
struct UvTruth {
  UvLayout layout;
  std::unique_ptr<UvChartMap> map;
  uint32_t texels = 1;
  Accumulator acc;
  double channels_textures = 0, channels_colours = 0;  // sums of channel_error
};

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

// The mean absolute difference of the 9 material channel values (albedo, metallic, roughness,
// ambient occlusion, emission) of `a` and `b`.
double channel_error(const SurfaceSample& a, const SurfaceSample& b) {
  double sum = 0;
  for (int k = 0; k < 3; ++k) sum += std::fabs(double(a.albedo[k]) - double(b.albedo[k]));
  for (int k = 0; k < 3; ++k) sum += std::fabs(double(a.emission[k]) - double(b.emission[k]));
  sum += std::fabs(double(a.metallic) - double(b.metallic)) + std::fabs(double(a.roughness) - double(b.roughness)) +
         std::fabs(double(a.ambient_occlusion) - double(b.ambient_occlusion));
  return sum / 9.0;
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
         metrics_text(" outside", model_outer, false) + "\n" + metrics_text(" surface", model_surface, false) + "\n" +
         uv_text();
}

std::string EvalReport::uv_text() const {
  std::string s;
  for (const UvMaterialEval& u : uv_materials)
    s += format("uv material %u '%s' (%u charts, %u-texel texture): %llu hits, texel err median %.2f p90 %.2f, "
                "wrong chart %.2f%%; channels MAE %.4f with its textures, %.4f with learned colours\n", u.material,
                printable(u.name).c_str(), u.charts, u.texture_size, (unsigned long long)u.hits, u.texel_error_median,
                u.texel_error_p90, 100 * u.wrong_chart, u.channel_error_textures, u.channel_error_colours);
  return s;
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
  nlohmann::ordered_json uv = nlohmann::ordered_json::array();
  for (const UvMaterialEval& u : uv_materials)
    uv.push_back({{"material", u.material},
                  {"name", u.name},
                  {"texture_size", u.texture_size},
                  {"charts", u.charts},
                  {"hits", u.hits},
                  {"texel_error_median", u.texel_error_median},
                  {"texel_error_p90", u.texel_error_p90},
                  {"wrong_chart", u.wrong_chart},
                  {"channel_error_textures", u.channel_error_textures},
                  {"channel_error_colours", u.channel_error_colours}});
  nlohmann::ordered_json out = j;
  out["uv_materials"] = uv;
  return json::dump(out);
}

namespace {

// The model, the ray count and the mesh, checked before any work (building the Embree reference
// is the first cost).
Status check_held_out(const Model& model, const Mesh& mesh, const EvalSettings& settings) {
  if (Status s = model.validate(); !s) return s.context("evaluate");
  if (settings.rays == 0) return Status::error("evaluation needs at least one ray");
  if (settings.rays > kMaxEvalRays)
    return Status::error("%zu held-out rays asked, at most %u", settings.rays, kMaxEvalRays);
  // The mesh must be the one the model was trained on, in the same object space: training spans the
  // voxels over its padded bounds. Another mesh, or the same moved, scaled or with node transforms
  // flattened into it, gives numbers that mean nothing.
  const Aabb padded = pad_aabb(mesh.bounds()), &own = model.bounds();
  const float tolerance = kEvalBoundsTolerance * own.diagonal();
  if (glm::any(glm::greaterThan(glm::abs(padded.lo - own.lo), glm::vec3(tolerance))) ||
      glm::any(glm::greaterThan(glm::abs(padded.hi - own.hi), glm::vec3(tolerance))))
    return Status::error("the mesh is not the one the model was trained on: its padded bounds (%g %g %g) - (%g %g %g) "
                         "are not the model's (%g %g %g) - (%g %g %g) (evaluate against the training mesh, in its "
                         "object space: a converted glTF node's mesh without its node transform)",
                         double(padded.lo.x), double(padded.lo.y), double(padded.lo.z), double(padded.hi.x),
                         double(padded.hi.y), double(padded.hi.z), double(own.lo.x), double(own.lo.y),
                         double(own.lo.z), double(own.hi.x), double(own.hi.y), double(own.hi.z));
  return Status::ok();
}

// The held-out rays with their reference hits and walks (held_out_rays), after check_held_out.
Status draw_held_out(const Model& model, const Mesh& mesh, const GroundTruth& truth, const EvalSettings& settings,
                     std::vector<Sample>& samples, std::vector<RayWalk>& walks) {
  // Drawn on the whole sphere (the same law as through the body, fewer candidates there), one
  // surface ray per found point and each point found by its own ray (independent rays): the held-out rays stay those of every earlier
  // version, so metrics compare ray for ray.
  SamplerSettings held_out = settings.sampler;
  held_out.lines_through_body = false;
  held_out.surface_rays = 1;
  held_out.surface_points_from_outer_hits = false;
  RaySampler sampler(mesh, truth, model.voxels, model.config.max_points, held_out);
  sampler.generate(settings.seed, 0, settings.rays, samples, walks);
  if (samples.size() != settings.rays)
    return Status::error("found only %zu of %zu held-out rays crossing an occupied voxel", samples.size(),
                         settings.rays);
  return Status::ok();
}

}  // namespace

Status held_out_rays(const Model& model, const Mesh& mesh, const EvalSettings& settings, std::vector<Ray>& rays) {
  if (Status s = check_held_out(model, mesh, settings); !s) return s;
  GroundTruth truth;
  if (Status s = truth.build(mesh); !s) return s.context("building the Embree reference");
  std::vector<Sample> samples;
  std::vector<RayWalk> walks;
  if (Status s = draw_held_out(model, mesh, truth, settings, samples, walks); !s) return s;
  rays.resize(samples.size());
  for (size_t i = 0; i < samples.size(); ++i) rays[i] = samples[i].ray;
  return Status::ok();
}

Status evaluate_model(const Model& model, const Mesh& mesh, const EvalSettings& settings,
                      EvalReport& report) {
  const auto t0 = std::chrono::steady_clock::now();
  if (Status s = check_held_out(model, mesh, settings); !s) return s;
  GroundTruth truth;
  if (Status s = truth.build(mesh); !s) return s.context("building the Embree reference");
  std::vector<Sample> samples;
  std::vector<RayWalk> walks;
  if (Status s = draw_held_out(model, mesh, truth, settings, samples, walks); !s) return s;

  std::vector<Ray> rays(samples.size());
  for (size_t i = 0; i < samples.size(); ++i) rays[i] = samples[i].ray;
  std::vector<LsnifHit> hits(samples.size());
  if (Status s = intersect(model, Transform3x4(), rays.data(), rays.size(), hits.data()); !s) return s;

  const float diag = model.bounds().diagonal();
  const Config& config = model.config;
  std::vector<std::unique_ptr<UvTruth>> uv_truth(config.material_count);
  for (uint32_t m = 0; m < config.material_count && m < mesh.materials.size(); ++m) {
    if (!config.reports_uv(m)) continue;
    auto truth_m = std::make_unique<UvTruth>();
    truth_m->layout = analyze_uv_layout(mesh, m);
    if (truth_m->layout.triangles == 0) continue;
    truth_m->map = std::make_unique<UvChartMap>(mesh, truth_m->layout);
    truth_m->texels = texture_size(mesh, mesh.materials[m]);
    uv_truth[m] = std::move(truth_m);
  }
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
    if (ref.hit && h.hit && ref.material < uv_truth.size() && uv_truth[ref.material]) {
      UvTruth& u = *uv_truth[ref.material];
      const float texel = 1.0f / float(u.texels);
      const double error = double(glm::length(h.uv - ref.uv)) * u.texels;
      const bool wrong = !u.map->on_chart(h.uv, u.layout.triangle_chart[ref.triangle], texel);
      for (Accumulator* acc : {&acc_model, &by_origin, &u.acc}) acc->add_uv(error, wrong);
      // The channels as a renderer shades the hit: the learned ones (colours), and the material's
      // textures where the hit reports a coordinate.
      SurfaceSample colours = predicted_surface(h, mesh);
      colours.albedo = h.albedo;
      const SurfaceSample textures = h.reports_uv ? mesh.material_at(h.material, h.uv) : colours;
      u.channels_colours += channel_error(colours, ref.surface);
      u.channels_textures += channel_error(textures, ref.surface);
    }
    const BaselineHit b = voxel_baseline(model.voxels, rays[i], walks[i]);
    acc_base.add(ref.hit, b.hit, ref.t, b.t, ref.normal, b.normal, ref.albedo, glm::vec3(0.0f), 0, 0,
                 diag, false);
  }
  report.model = acc_model.finish(true);
  report.baseline = acc_base.finish(false);
  report.model_outer = acc_outer.finish(true);
  report.model_surface = acc_surface.finish(true);
  report.uv_materials.clear();
  for (uint32_t m = 0; m < uv_truth.size(); ++m) {
    if (!uv_truth[m]) continue;
    const EvalMetrics u = uv_truth[m]->acc.finish(false);
    const double n = double(std::max<uint64_t>(u.uv_hits, 1));
    report.uv_materials.push_back({m, mesh.materials[m].name, uv_truth[m]->texels, uv_truth[m]->layout.charts, u.uv_hits,
                                   u.uv_texel_error_median, u.uv_texel_error_p90, u.uv_wrong_chart,
                                   uv_truth[m]->channels_textures / n, uv_truth[m]->channels_colours / n});
  }
  report.reference_hit_fraction = double(ref_hits) / double(samples.size());
  report.truncated_fraction = double(truncated) / double(samples.size());
  report.hit_beyond_walk_fraction = double(beyond) / double(samples.size());
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return Status::ok();
}

}  // namespace lsnif
