// convert.cpp -- the conversion run and its report (convert.h).
#include "lsnif/apps/convert/convert.h"

#include <algorithm>
#include <filesystem>
#include <map>
#include <set>
#include <tuple>

#include "lsnif/apps/convert/convert_cluster.h"
#include "lsnif/format/atomic_file.h"
#include "lsnif/format/folder_lock.h"

#include "lsnif/scene/gltf_build.h"
#include "lsnif/scene/scene_gltf.h"
#include "lsnif/train/uv_materials.h"

namespace lsnif::convert {
namespace fs = std::filesystem;

namespace {

double mib(uint64_t bytes) { return double(bytes) / 1048576.0; }

// "140 B", "12.5 KiB", "1.564 MiB".
std::string size_text(uint64_t bytes) {
  if (bytes < 1024) return format("%llu B", (unsigned long long)bytes);
  if (bytes < 1048576) return format("%.1f KiB", double(bytes) / 1024.0);
  return format("%.3f MiB", mib(bytes));
}

std::string eval_text(const ModelResult& r) {
  if (!r.evaluated) return "";
  // The material channels besides the albedo, where they vary (textured or emissive materials).
  const std::string channels =
      r.metrics.surface_mae > 0.0 || r.metrics.emission_mae > 0.0
          ? format(", mean metallic/roughness/occlusion error %.3f, emission error %.3f", r.metrics.surface_mae,
                   r.metrics.emission_mae)
          : "";
  return format("accuracy %.2f%%, median t error %.2f%% of the diagonal, median normal error %.1f deg%s (%llu rays)",
                100.0 * r.metrics.accuracy, 100.0 * r.metrics.t_error_median, r.metrics.normal_error_median,
                channels.c_str(), (unsigned long long)r.metrics.rays);
}

const char* state_text(const ModelResult& r, bool dry_run) {
  if (r.state == ModelState::Failed) return "FAILED";
  if (dry_run) return r.up_to_date_on_disk ? "up to date, would be kept" : "would be trained";
  switch (r.state) {
    case ModelState::Trained: return "trained";
    case ModelState::Adopted: return "adopted from the plan's models";
    case ModelState::UpToDate: return "up to date, not retrained";
    default: return "not trained";
  }
}

void print_plan(const ConvertSettings& s, const ConvertResult& res, FILE* out) {
  const Plan& plan = res.plan;
  std::fprintf(out, "input     %s: %zu mesh nodes in the %s\n", s.input.c_str(), plan.nodes.size(),
               plan.scene >= 0 ? format("scene %d", plan.scene).c_str() : "root nodes");
  for (const PlannedNode& n : plan.nodes) {
    std::string target;
    if (n.model >= 0) target = " -> model '" + plan.models[size_t(n.model)].name + "'";
    std::fprintf(out, "  node '%s' (mesh '%s', %llu triangles): %s%s\n", printable(n.name).c_str(),
                 printable(n.mesh_name).c_str(),
                 (unsigned long long)n.triangles, decision_text(n.decision), target.c_str());
  }
}

void print_models(const ConvertSettings& s, const ConvertResult& res, FILE* out) {
  const Plan& plan = res.plan;
  uint64_t total = 0;
  std::fprintf(out, "models    %zu for %zu instances\n", plan.models.size(), plan.instances_converted());
  for (size_t i = 0; i < plan.models.size(); ++i) {
    const PlannedModel& m = plan.models[i];
    const ModelResult& r = res.models[i];
    const uint64_t bytes = r.bytes ? r.bytes : planned_model_bytes(s.train, plan, m);
    if (r.state != ModelState::Failed) total += bytes;
    const std::string what = m.group.empty()
                                 ? format("mesh '%s'", printable(plan.nodes[size_t(m.nodes[0])].mesh_name).c_str())
                                 : format("group '%s'", printable(m.group).c_str());
    std::fprintf(out, "  model '%s' (%s, %llu triangles, %zu materials): %zu %s, %.3f MiB, %s [%s]", m.name.c_str(),
                 what.c_str(), (unsigned long long)m.triangles,
                 r.mesh.materials.empty() ? size_t(planned_material_count(plan, m)) : r.mesh.materials.size(),
                 m.nodes.size(), m.group.empty() ? (m.nodes.size() == 1 ? "instance" : "instances sharing it")
                                                 : (m.nodes.size() == 1 ? "node" : "nodes in one object"),
                 mib(bytes), m.file.c_str(), state_text(r, s.dry_run));
    if (r.state == ModelState::Trained) std::fprintf(out, " in %.1f s", r.seconds);
    std::fprintf(out, "\n");
    if (!r.stale.empty() && r.state != ModelState::Failed)
      std::fprintf(out, "      %s: %s\n", s.dry_run ? "would be retrained" : "retrained", r.stale.c_str());
    if (std::string e = eval_text(r); !e.empty()) std::fprintf(out, "      %s\n", e.c_str());
  }
  std::fprintf(out, "memory    %.3f MiB of models%s\n", mib(total), s.dry_run ? " (estimated from the settings)" : "");
}

// The granularity trade of each group: one model instead of one per distinct member mesh.
void print_groups(const ConvertSettings& s, const ConvertResult& res, FILE* out) {
  const Plan& plan = res.plan;
  std::map<int, size_t> mesh_model;
  for (size_t i = 0; i < plan.models.size(); ++i)
    if (plan.models[i].group.empty()) mesh_model[plan.models[i].mesh] = i;
  for (size_t i = 0; i < plan.models.size(); ++i) {
    const PlannedModel& m = plan.models[i];
    if (m.group.empty()) continue;
    std::set<int> meshes;
    for (int ni : m.nodes) meshes.insert(plan.nodes[size_t(ni)].mesh);
    uint64_t separate = 0;
    for (int mesh : meshes) {
      PlannedModel one;
      one.mesh = mesh;
      separate += planned_model_bytes(s.train, plan, one);
    }
    const ModelResult& r = res.models[i];
    const uint64_t grouped = r.bytes ? r.bytes : planned_model_bytes(s.train, plan, m);
    std::fprintf(out, "group     '%s': 1 model (%.3f MiB) for %zu nodes instead of %zu models, one per distinct mesh "
                      "(%.3f MiB): %.1fx less memory",
                 printable(m.group).c_str(), mib(grouped), m.nodes.size(), meshes.size(), mib(separate),
                 grouped ? double(separate) / double(grouped) : 0.0);
    if (std::string e = eval_text(r); !e.empty()) std::fprintf(out, "; its error: %s", e.c_str());
    std::fprintf(out, "\n");
    for (int mesh : meshes) {
      auto it = mesh_model.find(mesh);
      if (it == mesh_model.end()) continue;
      if (std::string e = eval_text(res.models[it->second]); !e.empty())
        std::fprintf(out, "          per-object model '%s' of a member mesh: %s\n", plan.models[it->second].name.c_str(),
                     e.c_str());
    }
    if (!r.evaluated)
      std::fprintf(out, "          (%s)\n", s.dry_run ? "its error is measured once it is trained"
                                                     : "no error measured: --eval-rays 0");
  }
}

const char* short_decision(Decision d) {
  switch (d) {
    case Decision::Convert: return "convert";
    case Decision::BelowThreshold: return "stays: < --min-triangles";
    case Decision::NoMemorySaved: return "stays: frees < margin x model";
    case Decision::NotSelected: return "stays: not --select";
    case Decision::Excluded: return "stays: --exclude";
    case Decision::TaggedOff: return "stays: lsnif false";
    case Decision::AlreadyLsnif: return "already LSNIF";
    case Decision::Failed: return "FAILED";
  }
  return "?";
}

// A row's decision: its nodes' (with counts when they differ) and the model it converts into.
std::string row_decision(const Plan& plan, const MemoryRow& row) {
  std::map<Decision, size_t> counts;
  for (int i : row.nodes) ++counts[plan.nodes[size_t(i)].decision];
  std::string text;
  for (const auto& [d, n] : counts) {
    if (!text.empty()) text += ", ";
    text += short_decision(d);
    if (counts.size() > 1) text += format(" (%zu)", n);
  }
  if (row.model >= 0) text += " -> model '" + plan.models[size_t(row.model)].name + "'";
  return text;
}

// Bytes of the distinct textures (by name and size, decoded RGBA8) that the materials reporting
// texture coordinates (choose_uv_materials) of the models not failed sample.
uint64_t uv_texture_bytes(const ConvertSettings& s, const ConvertResult& res) {
  std::set<std::tuple<std::string, uint32_t, uint32_t>> seen;
  uint64_t bytes = 0;
  for (const ModelResult& r : res.models) {
    if (r.state == ModelState::Failed) continue;
    const uint64_t materials = choose_uv_materials(r.mesh, s.train.texture_coordinates).materials;
    for (uint32_t m = 0; m < r.mesh.materials.size() && m < 64; ++m) {
      if (!((materials >> m) & 1u)) continue;
      for (const int* slot : r.mesh.materials[m].textures()) {
        if (*slot < 0 || size_t(*slot) >= r.mesh.textures.size()) continue;
        const Texture& t = r.mesh.textures[size_t(*slot)];
        if (seen.insert({t.name, t.width, t.height}).second) bytes += uint64_t(t.width) * t.height * 4u;
      }
    }
  }
  return bytes;
}

// The memory table: per mesh and group, the triangle BLAS converting it frees against its model,
// the ratio and the decision; then the scene's memory before and after (the renderer's LSNIF mode), and
// with the textures texture-coordinate hits sample.
void print_memory(const ConvertSettings& s, const ConvertResult& res, FILE* out) {
  const Plan& plan = res.plan;
  std::vector<uint64_t> model_bytes(plan.models.size(), 0);
  for (size_t i = 0; i < plan.models.size() && i < res.models.size(); ++i) model_bytes[i] = res.models[i].bytes;
  const std::string rule =
      s.convert_when == ConvertWhen::Memory
          ? format("convert where the BLAS freed >= %g x the model (--memory-margin) and >= %llu triangles",
                   s.memory_margin, (unsigned long long)s.min_triangles)
          : format("convert meshes of >= %llu triangles (--convert-when triangles)",
                   (unsigned long long)s.min_triangles);
  std::fprintf(out, "trade     the triangle BLASes a conversion frees vs its model; %s; BLAS sizes: %s\n", rule.c_str(),
               plan.blas_source.c_str());
  std::vector<std::string> names;
  int width = 4;
  for (const MemoryRow& row : plan.memory) {
    names.push_back(row.group ? "group '" + printable(row.name) + "'" : printable(row.name));
    width = std::max(width, std::min(40, int(names.back().size())));
  }
  std::fprintf(out, "  %-*s %10s %9s %10s %10s %9s  %s\n", width, "mesh", "triangles", "instances", "BLAS MiB",
               "model MiB", "ratio", "decision");
  bool shared = false;
  for (size_t k = 0; k < plan.memory.size(); ++k) {
    const MemoryRow& row = plan.memory[k];
    const uint64_t model = row.model >= 0 && model_bytes[size_t(row.model)] ? model_bytes[size_t(row.model)]
                                                                          : row.model_bytes;
    const bool partly = row.freed_bytes < row.blas_bytes;
    shared |= partly;
    std::fprintf(out, "  %-*s %10llu %9zu %9.3f%s %10.3f %8.2fx  %s\n", width, names[k].c_str(),
                 (unsigned long long)row.triangles, row.nodes.size(), mib(row.freed_bytes), partly ? "*" : " ",
                 mib(model), model ? double(row.freed_bytes) / double(model) : 0.0, row_decision(plan, row).c_str());
  }
  if (shared)
    std::fprintf(out, "  * other nodes still draw the mesh as triangles: its BLAS (or part of it) is not freed\n");
  const SceneMemory m = scene_memory(plan, model_bytes);
  std::fprintf(out, "scene     %.3f MiB of triangle BLASes before; after: %.3f MiB of triangle BLASes + %.3f MiB of "
                    "LSNIF models = %.3f MiB (%.2fx)%s\n",
               mib(m.blas_before), mib(m.blas_after), mib(m.models), mib(m.after()),
               m.blas_before ? double(m.after()) / double(m.blas_before) : 0.0,
               s.dry_run ? ", models estimated from the settings" : "");
  // Textures the converted objects' texture-coordinate materials sample: kept in both cases.
  if (const uint64_t textures = uv_texture_bytes(s, res); textures)
    std::fprintf(out, "textures  %.3f MiB of textures the converted objects' hits sample at their texture coordinates "
                      "(--texture-coordinates; decoded RGBA8, needed with triangles too): before %.3f MiB of triangle "
                      "BLASes + textures, after %.3f MiB of triangle BLASes + LSNIF models + textures (%.2fx)\n",
                 mib(textures), mib(m.blas_before + textures), mib(m.after() + textures),
                 m.blas_before + textures ? double(m.after() + textures) / double(m.blas_before + textures) : 0.0);
}

// The output files are none of the files the input uses, and can be written (the folder is made):
// checked before training.
Status check_outputs(const ConvertSettings& settings, const Plan& plan, const std::string& out_dir) {
  const std::string bin = (fs::path(out_dir) / (fs::path(settings.output).stem().string() + ".bin")).string();
  for (const std::string& input : referenced_files(plan, settings.input))
    for (const std::string& output : {settings.output, bin})
      if (fs::path(output).lexically_normal().string() == input || same_file(output, input))
        return Status::error("%s would overwrite %s, which the input scene %s uses; write the output elsewhere",
                             output.c_str(), input.c_str(), settings.input.c_str());
  if (settings.dry_run || !settings.plan_dir.empty()) return Status::ok();  // the output is not written now
  if (!out_dir.empty()) {
    std::error_code ec;
    fs::create_directories(out_dir, ec);
    if (ec) return Status::error("%s: cannot create the output folder: %s", out_dir.c_str(), ec.message().c_str());
  }
  if (Status s = check_output_path(settings.output); !s) return s;
  return check_output_path(bin);
}

// The lock file of a run in its output folder (docs/convert.md).
constexpr const char* kLockFile = ".lsnif-convert.lock";

// What a run writes into its output folder: models, their sidecars, the scene and its buffer.
bool is_convert_output(const ConvertSettings& settings, const std::string& name) {
  const auto ends_with = [&](std::string_view tail) {
    return name.size() > tail.size() && name.compare(name.size() - tail.size(), tail.size(), tail) == 0;
  };
  const fs::path output = fs::path(settings.output).filename();
  return ends_with(".lsnif") || ends_with(".lsnif.json") || name == output.string() ||
         name == output.stem().string() + ".bin";
}

// Locks the output folder for the whole run, then removes the temporary files of our outputs that
// an interrupted run left there. A dry run writes nothing: it takes no lock and only warns when
// another run holds it. Returns the exit code of a failure, or 0.
int lock_output_folder(const ConvertSettings& settings, const std::string& out_dir, FolderLock& lock, FILE* out,
                       FILE* err) {
  const std::string folder = out_dir.empty() ? std::string(".") : out_dir;
  if (!settings.plan_dir.empty()) return 0;  // the plan folder's lock is taken in plan_jobs
  if (settings.dry_run) {
    if (folder_lock_busy(folder, kLockFile))
      std::fprintf(err, "lsnif convert: warning: another lsnif convert is writing into the output folder '%s' (it "
                        "holds %s/%s): its models may change this plan\n", folder.c_str(), folder.c_str(), kLockFile);
    return 0;
  }
  bool busy = false;
  if (Status s = lock.acquire(folder, kLockFile, busy); !s) {
    if (busy)
      std::fprintf(err, "lsnif convert: another lsnif convert is writing into the output folder '%s' (it holds the "
                        "lock %s/%s); wait for it to finish or write elsewhere\n", folder.c_str(), folder.c_str(),
                   kLockFile);
    else
      std::fprintf(err, "lsnif convert: cannot lock the output folder '%s': %s\n", folder.c_str(), s.message().c_str());
    return 1;
  }
  std::vector<std::string> removed;
  const Status s = remove_stale_temp_files(
      folder, [&](const std::string& target) { return is_convert_output(settings, target); }, removed);
  for (const std::string& path : removed)
    std::fprintf(out, "cleanup   removed %s, a temporary file an interrupted run left\n", path.c_str());
  if (!s) {
    std::fprintf(err, "lsnif convert: %s\n", s.message().c_str());
    return 1;
  }
  return 0;
}

Status validate_output(const ConvertSettings& settings, const ConvertResult& result, const std::string& out_dir) {
  tinygltf::Model out;
  WriteReport unused;
  if (Status s = build_output(settings, result.plan, result.models, true, out, unused); !s) return s;
  if (!out.buffers.empty() && out.buffers[0].data.empty()) out.buffers.clear();  // as save_gltf writes it
  std::string text;  // buffers embedded as data URIs: nothing is written
  if (Status s = scene::gltf_text_embedded(out, text); !s) return s.context(settings.output);
  const std::string base = out_dir.empty() ? std::string(".") : out_dir;
  scene::SceneLoadOptions options;
  options.quiet = true;
  options.allow_outside_refs = settings.import_options.allow_outside_refs;
  for (size_t i = 0; i < result.plan.models.size(); ++i)
    if (result.models[i].state != ModelState::Failed)
      options.pending_models.push_back((fs::path(base) / result.plan.models[i].file).lexically_normal().string());
  scene::Scene scene;
  return scene::load_scene_from_memory(text, false, settings.output, base, options, scene);
}

// `--plan DIR`: the jobs instead of training, under the plan folder's lock. Returns the exit code.
int plan_jobs(const ConvertSettings& settings, ConvertResult& result, FILE* out, FILE* err) {
  for (const ModelResult& r : result.models)
    if (r.state == ModelState::Failed) std::fprintf(err, "lsnif convert: error: %s\n", r.error.c_str());
  std::error_code ec;
  fs::create_directories(settings.plan_dir, ec);
  if (ec) {
    std::fprintf(err, "lsnif convert: %s: cannot create the plan folder: %s\n", settings.plan_dir.c_str(),
                 ec.message().c_str());
    return 1;
  }
  FolderLock lock;
  bool busy = false;
  if (Status s = lock.acquire(settings.plan_dir, ".lsnif-plan.lock", busy); !s) {
    std::fprintf(err, "lsnif convert: %s%s\n", s.message().c_str(),
                 busy ? " (another lsnif convert --plan writes into this plan folder)" : "");
    return 1;
  }
  if (Status s = write_job_plan(settings, result.plan, result.models, out); !s) {
    std::fprintf(err, "lsnif convert: %s\n", s.message().c_str());
    return 1;
  }
  for (const ModelResult& r : result.models) result.failed += r.state == ModelState::Failed;
  return result.failed ? 1 : 0;
}

// `--assemble DIR`: adopts the models the plan's jobs wrote; the others are listed and, with
// --retrain-missing, left to train_models. Returns -1 to go on, else the exit code.
int assemble_models(const ConvertSettings& settings, ConvertResult& result, const std::string& out_dir, FILE* err) {
  std::vector<std::string> missing;
  if (Status s = adopt_planned_models(settings, result.plan, out_dir, result.models, missing); !s) {
    std::fprintf(err, "lsnif convert: %s\n", s.message().c_str());
    return 1;
  }
  for (const std::string& line : missing)
    std::fprintf(err, "lsnif convert: %s %s\n", settings.retrain_missing ? "retraining here:" : "missing:", line.c_str());
  if (missing.empty() || settings.retrain_missing) return -1;
  std::fprintf(err, "lsnif convert: %zu of the plan's models are missing or not current: run their jobs (%s/%s) or "
                    "add --retrain-missing; nothing written\n", missing.size(), settings.assemble_dir.c_str(),
               kPlanJobList);
  return 1;
}

}  // namespace

int run_convert(const ConvertSettings& settings, ConvertResult& result, FILE* out, FILE* err) {
  result = ConvertResult();
  if (settings.input.empty() || settings.output.empty()) {
    std::fprintf(err, "lsnif convert: need an input and an output file\n");
    return 2;
  }
  if (fs::path(settings.output).extension() != ".gltf") {
    std::fprintf(err, "lsnif convert: %s: the output must be a .gltf file\n", settings.output.c_str());
    return 2;
  }
  if (Status s = check_settings(settings); !s) {
    std::fprintf(err, "lsnif convert: %s\n", s.message().c_str());
    return 2;
  }
  if (Status s = settings.train.config.validate(); !s) {
    std::fprintf(err, "lsnif convert: invalid model settings: %s\n", s.message().c_str());
    return 2;
  }
  if (Status s = make_plan(settings, result.plan); !s) {
    std::fprintf(err, "lsnif convert: %s\n", s.message().c_str());
    return 1;
  }
  for (const std::string& w : result.plan.warnings) std::fprintf(err, "lsnif convert: warning: %s\n", w.c_str());
  print_plan(settings, result, out);
  std::fflush(out);

  const std::string out_dir = fs::path(settings.output).parent_path().string();
  if (Status s = check_outputs(settings, result.plan, out_dir); !s) {
    std::fprintf(err, "lsnif convert: %s\n", s.message().c_str());
    return 1;
  }
  FolderLock lock;  // held until the run returns
  if (int code = lock_output_folder(settings, out_dir, lock, out, err)) return code;
  prepare_models(settings, result.plan, out_dir, result.models);
  // The scene about to be written must load in the renderer before any model is trained, in a dry
  // run too (a missing environment image, a broken camera or transform, a missing model).
  if (Status s = validate_output(settings, result, out_dir); !s) {
    // The objects that already failed may be why (their nodes are left out).
    for (const ModelResult& r : result.models)
      if (r.state == ModelState::Failed) std::fprintf(err, "lsnif convert: error: %s\n", r.error.c_str());
    std::fprintf(err, "lsnif convert: error: the converted scene would not load: %s\n", s.message().c_str());
    return 1;
  }
  if (!settings.plan_dir.empty()) return plan_jobs(settings, result, out, err);
  if (!settings.assemble_dir.empty())
    if (int code = assemble_models(settings, result, out_dir, err); code >= 0) return code;
  train_models(settings, result.plan, out_dir, result.models);
  for (size_t i = 0; i < result.models.size(); ++i) {
    const ModelResult& r = result.models[i];
    result.trained += r.state == ModelState::Trained;
    result.adopted += r.state == ModelState::Adopted;
    result.up_to_date += r.state == ModelState::UpToDate;
    result.failed += r.state == ModelState::Failed;
    for (const std::string& w : r.warnings)
      std::fprintf(err, "lsnif convert: warning: model '%s': %s\n", result.plan.models[i].name.c_str(), w.c_str());
    if (r.state == ModelState::Failed) std::fprintf(err, "lsnif convert: error: %s\n", r.error.c_str());
  }
  print_models(settings, result, out);
  print_groups(settings, result, out);
  print_memory(settings, result, out);
  size_t unique_meshes = 0, group_models = 0;
  for (const PlannedModel& m : result.plan.models) (m.group.empty() ? unique_meshes : group_models) += 1;
  std::fprintf(out, "instances %zu nodes become LSNIF objects: %zu mesh models (each trained once however many "
                    "nodes use it) + %zu group models\n",
               result.plan.instances_converted(), unique_meshes, group_models);
  if (settings.dry_run) {
    std::fprintf(out, "dry run   nothing trained or written\n");
    return result.failed ? 1 : 0;
  }
  if (settings.assemble_dir.empty())
    std::fprintf(out, "trained   %zu, up to date %zu, failed %zu\n", result.trained, result.up_to_date, result.failed);
  else
    std::fprintf(out, "trained   %zu, adopted %zu, up to date %zu, failed %zu\n", result.trained, result.adopted,
                 result.up_to_date, result.failed);
  if (Status s = write_output(settings, result.plan, result.models, result.written); !s) {
    std::fprintf(err, "lsnif convert: %s\n", s.message().c_str());
    return 1;
  }
  result.wrote_output = true;
  for (const std::string& n : result.written.notes) std::fprintf(err, "lsnif convert: warning: %s\n", n.c_str());
  // The renderer must be able to read what was written.
  scene::Scene check;
  scene::SceneLoadOptions quiet;
  quiet.quiet = true;
  quiet.allow_outside_refs = settings.import_options.allow_outside_refs;
  if (Status s = scene::load_scene(settings.output, quiet, check); !s) {
    std::fprintf(err, "lsnif convert: error: the written scene does not load: %s\n", s.message().c_str());
    result.output_loads = false;
  }
  std::fprintf(out, "wrote     %s: %zu LSNIF nodes (%zu group nodes), %zu meshes removed%s, binary data %s -> %s\n",
               settings.output.c_str(), result.written.converted_nodes, result.written.group_nodes,
               result.written.meshes_removed, settings.keep_meshes ? " (--keep-meshes)" : "",
               size_text(result.written.buffer_bytes_in).c_str(), size_text(result.written.buffer_bytes_out).c_str());
  std::fflush(out);
  return result.failed || !result.output_loads ? 1 : 0;
}

}  // namespace lsnif::convert
