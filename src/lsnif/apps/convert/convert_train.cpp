// convert_train.cpp -- flattening, hashing, skipping and parallel training of the planned models
// (convert_train.h).
#include "lsnif/apps/convert/convert_train.h"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <mutex>
#include <thread>
#include <tuple>

#include <nlohmann/json.hpp>

#include "lsnif/format/atomic_file.h"
#include "lsnif/import/json_text.h"
#include "lsnif/import/mesh_gltf.h"
#include "lsnif/core/model.h"
#include "lsnif/apps/common/progress.h"
#include "lsnif/train/settings_io.h"
#include "lsnif/train/trainer.h"

namespace lsnif::convert {
namespace fs = std::filesystem;

namespace {

// What the sidecar holds.
struct Sidecar {
  std::string hash;
  bool evaluated = false;
  EvalMetrics metrics;
};

bool read_sidecar(const std::string& path, Sidecar& out) {
  std::vector<unsigned char> bytes;
  if (!gltf::read_whole_file(&bytes, nullptr, path, nullptr)) return false;
  nlohmann::json j;
  if (!json::parse(std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()), path, j) ||
      !j.is_object() || !j.contains("hash") || !j["hash"].is_string())
    return false;
  out.hash = j["hash"].get<std::string>();
  if (j.contains("eval") && j["eval"].is_object()) {
    const nlohmann::json& e = j["eval"];
    auto num = [&](const char* key) { return e.contains(key) && e[key].is_number() ? e[key].get<double>() : 0.0; };
    out.evaluated = true;
    out.metrics.rays = uint64_t(num("rays"));
    out.metrics.accuracy = num("accuracy");
    out.metrics.t_error_median = num("t_error_median");
    out.metrics.normal_error_median = num("normal_error_median");
    out.metrics.surface_mae = num("surface_mae");
    out.metrics.emission_mae = num("emission_mae");
  }
  return true;
}

Status write_sidecar(const std::string& path, const PlannedModel& m, const ModelResult& r,
                     const TrainSettings& train) {
  nlohmann::json j;
  j["hash"] = r.hash;
  j["object"] = m.group.empty() ? "mesh" : "group";
  j["name"] = m.name;
  j["triangles"] = r.mesh.triangles.size();
  j["materials"] = r.mesh.materials.size();
  j["settings"] = settings_to_json(train);
  if (r.evaluated)
    j["eval"] = {{"rays", r.metrics.rays},
                 {"accuracy", r.metrics.accuracy},
                 {"t_error_median", r.metrics.t_error_median},
                 {"normal_error_median", r.metrics.normal_error_median},
                 {"surface_mae", r.metrics.surface_mae},
                 {"emission_mae", r.metrics.emission_mae}};
  return write_file_atomic(path, json::dump(j) + "\n").context("sidecar");
}

// Flattens the model's mesh(es): a mesh model in the mesh's object space, a group in world space.
Status flatten(const Plan& plan, const PlannedModel& m, bool allow_dropping_most, ModelResult& r) {
  std::vector<GltfMeshPart> parts;
  if (m.group.empty()) {
    parts.push_back({m.mesh, glm::dmat4(1.0)});
  } else {
    for (int ni : m.nodes) parts.push_back({plan.nodes[size_t(ni)].mesh, plan.nodes[size_t(ni)].world});
  }
  MeshImportReport report;
  const std::string label = (m.group.empty() ? "mesh '" : "group '") + m.name + "'";
  Status s = flatten_gltf_meshes(plan.gltf, parts, label, r.mesh, r.material_sources, &report, allow_dropping_most);
  r.warnings = std::move(report.warnings);
  return s;
}

// Warnings about material channels a model of `mesh` does not learn: its materials' metallic-roughness,
// emission, occlusion and normal textures when the settings turn surface channels and normal-map
// baking off (LSNIF hits then take those materials' factors and the unmapped normal).
void unlearned_channel_warnings(const Mesh& mesh, const TrainSettings& train, std::vector<std::string>& warnings) {
  const bool surface = learns_surface_channels(mesh, train.surface_maps), normal = bakes_normal_maps(train.surface_maps);
  for (const Material& m : mesh.materials) {
    std::string slots;
    for (const auto& [texture, name, learned] : {std::tuple{m.metallic_roughness_texture, "metallic-roughness", surface},
                                                 std::tuple{m.emission_texture, "emissive", surface},
                                                 std::tuple{m.occlusion_texture, "occlusion", surface},
                                                 std::tuple{m.normal_texture, "normal", normal}})
      if (texture >= 0 && !learned) slots += (slots.empty() ? "" : ", ") + std::string(name);
    if (!slots.empty())
      warnings.push_back(format("material '%s': %s texture not learned (--surface-maps off): LSNIF hits use the "
                                "material's factors", printable(m.name).c_str(), slots.c_str()));
  }
}

// Largest mean errors of learned surface channels on held-out rays that pass without a warning:
// metallic / roughness / occlusion in [0, 1], emission relative to the model's emission scale.
// On the textured material of tests/pbr_convert_test.cpp the default model reaches 0.028 and 0.4%
// of its scale (a quarter of these and less), the test's 600-step W=64 model 0.115 (warned) and
// 1.3%; a model of the base colour only (--surface-maps off) misses by 0.39 and 97% of the scale.
constexpr double kSurfaceMaeWarning = 0.1, kEmissionMaeWarning = 0.05;

// "material 'a'" / "materials 'a', 'b'": the materials of `mesh` for which `pick` holds.
template <class Pick>
std::string materials_text(const Mesh& mesh, Pick pick) {
  std::string names;
  size_t count = 0;
  for (const Material& m : mesh.materials)
    if (pick(m)) names += (count++ ? ", '" : "'") + printable(m.name) + "'";
  return count ? (count == 1 ? "material " : "materials ") + names : "its materials";
}

// A warning, naming the channels and the materials whose textures drive them, when the model's
// learned surface channels missed the reference by more than the bounds above on the evaluation rays.
void surface_quality_warnings(const Model& model, const Mesh& mesh, const EvalMetrics& metrics,
                              std::vector<std::string>& warnings) {
  if (!model.config.surface_channels) return;
  if (metrics.surface_mae > kSurfaceMaeWarning)
    warnings.push_back(format(
        "%s: metallic / roughness / occlusion learned with a mean error of %.3f on held-out rays (above %.2f): more "
        "--steps or a wider network (--width) learn them better",
        materials_text(mesh, [](const Material& m) { return m.metallic_roughness_texture >= 0 || m.occlusion_texture >= 0; })
            .c_str(),
        metrics.surface_mae, kSurfaceMaeWarning));
  const double scale = model.config.emission_scale;
  if (scale > 0.0 && metrics.emission_mae > kEmissionMaeWarning * scale)
    warnings.push_back(format(
        "%s: emission learned with a mean error of %.3f on held-out rays (above %.2f of its scale %.3g): more "
        "--steps or a wider network (--width) learn it better",
        materials_text(mesh, [](const Material& m) { return m.emission_texture >= 0; }).c_str(), metrics.emission_mae,
        kEmissionMaeWarning, scale));
}

// Whether the .lsnif at `path` is the model `train` gives of r.mesh (of hash `mesh`), by the model's
// own training record, with a sidecar of the same content hash (prepare_models): sets
// r.up_to_date_on_disk and what the sidecar caches, or r.stale when a model file is there but is
// retrained.
void check_on_disk(const std::string& path, const TrainSettings& train, uint64_t mesh, ModelResult& r) {
  std::error_code ec;
  if (!fs::exists(fs::symlink_status(path, ec))) return;
  Model existing;
  if (Status s = load_model(path, existing); !s) {
    r.stale = s.message();
    return;
  }
  if (std::string why = training_record_difference(existing.training, train, mesh); !why.empty()) {
    r.stale = "the model on disk is not of these settings and this mesh: " + why;
    return;
  }
  Sidecar side;
  if (!read_sidecar(sidecar_path(path), side) || side.hash != r.hash) {
    r.stale = "its sidecar " + sidecar_path(path) + " is missing or of another run (an interrupted or concurrent one)";
    return;
  }
  r.up_to_date_on_disk = true;
  r.bytes = memory_breakdown(existing).total();
  r.evaluated = side.evaluated;
  r.metrics = side.metrics;
}

// "model 'NAME' (node 'a')" / "(nodes 'a', 'b', 'c' and 2 more)": the object an error is about.
std::string object_label(const Plan& plan, const PlannedModel& m) {
  std::string nodes;
  for (size_t k = 0; k < m.nodes.size() && k < 3; ++k)
    nodes += (k ? ", '" : "'") + printable(plan.nodes[size_t(m.nodes[k])].name) + "'";
  if (m.nodes.size() > 3) nodes += format(" and %zu more", m.nodes.size() - 3);
  return format("model '%s' (node%s %s)", m.name.c_str(), m.nodes.size() == 1 ? "" : "s", nodes.c_str());
}

}  // namespace

std::string content_hash(uint64_t mesh_hash, const TrainSettings& train) {
  // The mesh's hash and every training setting (settings_io.h), hashed together.
  const std::string key = format("lsnif-convert-2 %016llx ", (unsigned long long)mesh_hash) +
                          settings_to_json(train).dump();
  return format("%016llx", (unsigned long long)fnv1a64(key));
}

std::string sidecar_path(const std::string& model_path) { return model_path + ".json"; }

void prepare_models(const ConvertSettings& settings, const Plan& plan, const std::string& out_dir,
                    std::vector<ModelResult>& results) {
  results.clear();
  results.resize(plan.models.size());
  for (size_t i = 0; i < plan.models.size(); ++i) {
    const PlannedModel& m = plan.models[i];
    ModelResult& r = results[i];
    if (!m.error.empty()) {
      r.state = ModelState::Failed;
      r.error = m.error;
      continue;
    }
    if (Status s = flatten(plan, m, settings.import_options.allow_dropping_most, r); !s) {
      r.state = ModelState::Failed;
      r.error = object_label(plan, m) + ": " + s.message();
      continue;
    }
    // What training would refuse is refused now, by a dry run and a plan too.
    Config checked;
    if (Status s = check_training_inputs(r.mesh, settings.train, checked, &r.warnings); !s) {
      r.state = ModelState::Failed;
      r.error = object_label(plan, m) + ": " + s.message();
      continue;
    }
    unlearned_channel_warnings(r.mesh, settings.train, r.warnings);
    const uint64_t mesh = mesh_hash(r.mesh);
    r.mesh_hash = mesh;
    r.hash = content_hash(mesh, settings.train);
    r.bytes = estimated_model_bytes(settings.train, uint32_t(r.mesh.materials.size()), false, &r.mesh);
    if (settings.force) continue;
    check_on_disk((fs::path(out_dir) / m.file).string(), settings.train, mesh, r);
    if (r.up_to_date_on_disk && !settings.dry_run) r.state = ModelState::UpToDate;
  }
}

Status record_model(const ConvertSettings& settings, const PlannedModel& m, const Model& model,
                    const std::string& path, ModelResult& r) {
  if (settings.eval_rays > 0) {
    EvalSettings es;
    es.rays = settings.eval_rays;
    es.normal_maps = bakes_normal_maps(settings.train.surface_maps);
    EvalReport er;
    if (Status s = evaluate_model(model, r.mesh, es, er); !s) return s;
    r.evaluated = true;
    r.metrics = er.model;
    surface_quality_warnings(model, r.mesh, er.model, r.warnings);
  }
  if (Status s = write_sidecar(sidecar_path(path), m, r, settings.train); !s) return s;
  r.bytes = memory_breakdown(model).total();
  return Status::ok();
}

void train_models(const ConvertSettings& settings, const Plan& plan, const std::string& out_dir,
                  std::vector<ModelResult>& results) {
  std::vector<size_t> todo;
  for (size_t i = 0; i < results.size(); ++i)
    if (results[i].state == ModelState::Planned) todo.push_back(i);
  if (todo.empty() || settings.dry_run) return;

  // Training: `jobs` threads share the cores (OpenMP threads per job = cores / jobs).
  const size_t threads = std::max<size_t>(1, std::min<size_t>(settings.jobs, todo.size()));
  const int omp_before = omp_get_max_threads();
  const int omp_per_job = std::max(1, omp_before / int(threads));
  const uint64_t steps = settings.train.steps;
  ProgressBar bar(format("training %zu models", todo.size()), todo.size() * steps, settings.progress);
  std::mutex mutex;
  uint64_t done_steps = 0;
  size_t finished = 0;
  std::atomic<size_t> next{0};
  auto advance = [&](uint64_t add, bool model_done) {
    std::lock_guard<std::mutex> lock(mutex);
    done_steps += add;
    finished += model_done;
    bar.update(done_steps, format("%zu/%zu models", finished, todo.size()));
  };
  auto worker = [&]() {
    omp_set_num_threads(omp_per_job);
    for (size_t k = next++; k < todo.size(); k = next++) {
      const size_t i = todo[k];
      const PlannedModel& m = plan.models[i];
      ModelResult& r = results[i];
      const std::string path = (fs::path(out_dir) / m.file).string();
      uint64_t counted = 0;
      try {
        TrainSettings train = settings.train;
        train.loss_curve = false;
        Model model;
        TrainReport rep;
        Status s = train_model(r.mesh, train, model, &rep, [&](uint32_t, const LossTerms&, const Model&) {
          ++counted;
          advance(1, false);
          return true;
        });
        model.training = training_record(train, r.mesh, m.name, omp_get_max_threads());
        r.warnings.insert(r.warnings.end(), rep.uv_warnings.begin(), rep.uv_warnings.end());
        if (s) s = save_model(model, path);
        if (s) s = record_model(settings, m, model, path, r);
        if (s) {
          r.state = ModelState::Trained;
          r.seconds = rep.seconds;
        } else {
          r.state = ModelState::Failed;
          r.error = object_label(plan, m) + ": " + s.message();
        }
      } catch (const std::exception& e) {
        r.state = ModelState::Failed;
        r.error = object_label(plan, m) + ": " + e.what();
      }
      advance(steps > counted ? steps - counted : 0, true);
    }
  };
  std::vector<std::thread> pool;
  for (size_t t = 1; t < threads; ++t) pool.emplace_back(worker);
  worker();
  for (std::thread& t : pool) t.join();
  omp_set_num_threads(omp_before);
  bar.finish(format("%zu models", todo.size()));
}

}  // namespace lsnif::convert
