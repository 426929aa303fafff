#include "lsnif/apps/lsnif/train_options.h"

#include <omp.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <thread>
#include <utility>

#include "lsnif/apps/lsnif/commands.h"
#include "lsnif/format/atomic_file.h"
#include "lsnif/format/folder_lock.h"
#include "lsnif/import/mesh.h"
#include "lsnif/train/evaluate.h"
#include "lsnif/apps/common/progress.h"

namespace lsnif::cli {

namespace {

// "N", "X" or "segments|aabb": what a setting's option takes.
std::string value_name(const SettingDef& d) {
  if (d.kind == SettingKind::F32) return "X";
  if (d.kind == SettingKind::U32PerLevel) return "N[,N...]";
  if (d.kind != SettingKind::Choice) return "N";
  std::string s;
  for (uint32_t c = 0; c < d.choice_count; ++c) {
    if (c) s += '|';
    s += d.choices[c].name;
  }
  return s;
}

// The help of a setting's option: its text and, where bounded, its range.
std::string setting_help(const SettingDef& d) {
  std::string help = d.help;
  if ((d.kind == SettingKind::U32 || d.kind == SettingKind::U32PerLevel) && d.max < kU32Max)
    help += format(" [%u, %u]", uint32_t(d.min), uint32_t(d.max));
  else if (d.kind == SettingKind::U32)
    help += format(" (at least %u)", uint32_t(d.min));
  if (d.kind == SettingKind::F32 && d.max < kF32Max)
    help += format(" %c%g, %g%c", d.min_open ? '(' : '[', d.min, d.max, d.max_open ? ')' : ']');
  return help;
}

// The help of a preset option: its text, then what each choice sets ("high or low (--width 64 ...)").
std::string preset_help(const std::string& option) {
  std::string help, choices;
  for (const Preset& p : kPresets) {
    if (option != p.option) continue;
    if (help.empty()) help = p.help;
    std::string sets;
    for (uint32_t k = 0; k < p.count; ++k) {
      const SettingDef& d = setting_def(p.values[k].id);
      sets += k ? " --" : "--";
      sets += d.name;
      sets += ' ';
      sets += setting_text(d, setting_value(d, p.values[k].value));
    }
    if (p.choice) {
      choices += choices.empty() ? ": " : " or ";
      choices += p.choice;
      if (!sets.empty()) choices += " (" + sets + ")";
    } else {
      choices = ": " + sets;
    }
  }
  return help + choices;
}

// Why `text` is no 32-bit whole number (parse_u32 refused it).
std::string number_error_u32(const std::string& text) {
  std::string why = whole_number_error(text);
  return why.empty() ? "larger than 4294967295" : why;
}

}  // namespace

std::string set_setting_text(SettingLayer& layer, const SettingDef& d, const std::string& text) {
  SettingValue v;
  switch (d.kind) {
    case SettingKind::U32: {
      uint32_t x = 0;
      if (!parse_u32(text, x)) return number_error_u32(text);
      v.u = x;
      break;
    }
    case SettingKind::U32PerLevel: {
      uint32_t values[LSNIF_MAX_LEVELS];
      size_t count = 0, at = 0;
      while (at <= text.size()) {
        size_t comma = text.find(',', at);
        if (comma == std::string::npos) comma = text.size();
        const std::string item = text.substr(at, comma - at);
        if (count == LSNIF_MAX_LEVELS) return format("at most %u values (one per level)", LSNIF_MAX_LEVELS);
        if (!parse_u32(item, values[count]))
          return "N or a comma list N,N,... of decimal whole numbers expected (" + number_error_u32(item) + ")";
        ++count;
        at = comma + 1;
      }
      if (!per_level_value(values, count, v)) return "N or a comma list N,N,... expected";
      break;
    }
    case SettingKind::U64:
      if (!parse_u64(text, v.u)) return whole_number_error(text);
      break;
    case SettingKind::F32:
      if (!parse_f32(text, v.f)) return float_error(text);
      break;
    case SettingKind::Choice: break;  // checked when resolved, naming the choices
  }
  layer.set(d.id, v, d.kind == SettingKind::Choice ? text : std::string());
  return "";
}

void TrainOptions::add_to(Args& args, const char* output_help) {
  args.alias("-o", "output");
  args.option("output", output_help, &output);
  args.option("config", "JSON file of settings (name -> value, as `lsnif info --settings` prints); the options "
              "given here override it", &config);
  const SettingValues defaults = SettingValues::defaults();
  for (const SettingDef& d : kSettingDefs) {
    args.checked_option(d.name, setting_help(d), value_name(d), setting_text(d, defaults[d.id]),
                        [this, &d](const std::string& text) { return set_setting_text(given, d, text); });
  }
  for (const Preset& p : kPresets) {
    if (&p != &kPresets[0] && std::string_view(p.option) == (&p)[-1].option) continue;  // one option per name
    const bool flag = p.choice == nullptr;
    // No default shown: the defaults are none of a preset's choices.
    args.option(p.option, preset_help(p.option), flag ? "" : "TEXT", "", [this, &p](const std::string& text) {
      presets.emplace_back(p.option, text);
      return true;
    });
  }
  args.option("threads", "worker threads (0 = all cores)", &threads, 0, kMaxThreads);
  args.option("csv", "loss curve CSV (default: MODEL.csv)", &csv);
  args.flag("quiet", "no progress bar", &quiet);
  add_import_flags(args, &import_options);
}

bool TrainOptions::to_settings(TrainSettings& s) const {
  s.time_budget = time_budget;
  SettingLayer command_line = given;
  for (const auto& [option, choice] : presets) {
    const bool flag = find_preset(option, nullptr) != nullptr;
    const Preset* p = find_preset(option, flag ? nullptr : choice.c_str());
    if (!p) {
      std::string names;
      for (const Preset& q : kPresets)
        if (option == q.option) {
          names += names.empty() ? "'" : "' or '";
          names += q.choice;
        }
      std::fprintf(stderr, "lsnif: --%s must be %s' (got '%s')\n", option.c_str(), names.c_str(),
                   printable(choice).c_str());
      return false;
    }
    command_line.presets.push_back(p);
  }
  std::vector<const SettingLayer*> layers;
  SettingLayer file;
  if (!config.empty()) {
    if (Status st = read_settings_file(config, file); !st) {
      std::fprintf(stderr, "lsnif: %s\n", st.message().c_str());
      return false;
    }
    layers.push_back(&file);
  }
  layers.push_back(&command_line);
  if (Status st = resolve_settings(layers, s); !st) {
    std::fprintf(stderr, "lsnif: %s\n", st.message().c_str());
    return false;
  }
  s.loss_curve = true;
  return true;
}

namespace {

// The model and the CSV can be written, and neither is the mesh or the other: checked before the
// work, so that a bad -o fails in a second, not after the training.
int check_outputs(const TrainOptions& opts, const std::string& mesh_path) {
  const std::string csv = opts.csv_path();
  Status s = check_not_an_input(opts.output, "-o", {mesh_path});
  if (s) s = check_not_an_input(csv, "--csv", {mesh_path, opts.output});
  if (s && csv == opts.output) s = Status::error("--csv and -o name the same file '%s'", csv.c_str());
  if (s) s = check_output_path(opts.output).context("-o");
  if (s) s = check_output_path(csv).context("--csv");
  if (!s) {
    std::fprintf(stderr, "lsnif: %s\n", s.message().c_str());
    return 1;
  }
  return 0;
}

// The folder of `path` for the file system calls ("." for a bare name).
std::string folder_of(const std::string& path) {
  const std::string folder = std::filesystem::path(path).parent_path().string();
  return folder.empty() ? std::string(".") : folder;
}

// --keep-current, before any training: holds the model's lock (waiting for another run of the same
// model to end), clears what a killed run left, and tells whether -o is already this model.
// Returns -1 to go on training, else the exit code.
int keep_current_model(const TrainOptions& opts, const TrainSettings& settings, const Mesh& mesh, FolderLock& lock) {
  namespace fs = std::filesystem;
  const std::string folder = folder_of(opts.output), name = fs::path(opts.output).filename().string();
  const std::string lock_name = "." + name + ".lock";
  bool told = false;
  for (;;) {
    bool busy = false;
    Status s = lock.acquire(folder, lock_name, busy);
    if (s) break;
    if (!busy) {
      std::fprintf(stderr, "lsnif: %s\n", s.message().c_str());
      return 1;
    }
    if (!told)
      std::printf("waiting   another run is training %s (it holds %s/%s)\n", opts.output.c_str(), folder.c_str(),
                  lock_name.c_str());
    told = true;
    std::fflush(stdout);
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
  }
  for (const std::string& target : {opts.output, opts.csv_path()}) {
    std::vector<std::string> removed;
    const std::string file = fs::path(target).filename().string();
    Status s = remove_stale_temp_files(folder_of(target), [&](const std::string& t) { return t == file; }, removed);
    for (const std::string& r : removed) std::printf("cleanup   removed %s, a temporary file a killed run left\n", r.c_str());
    if (!s) {
      std::fprintf(stderr, "lsnif: %s\n", s.message().c_str());
      return 1;
    }
  }
  std::error_code ec;
  if (!fs::exists(fs::symlink_status(opts.output, ec))) return -1;
  Model existing;
  std::string why;
  if (Status s = load_model(opts.output, existing); !s)
    why = s.message();
  else
    why = training_record_difference(existing.training, settings, mesh_hash(mesh));
  if (why.empty()) {
    std::printf("current   %s already holds the model of this mesh and these settings: kept\n", opts.output.c_str());
    return 0;
  }
  std::printf("retrain   %s: %s\n", opts.output.c_str(), why.c_str());
  return -1;
}

}  // namespace

int run_training(const std::string& mesh_path, const TrainOptions& opts, Model* trained) {
  TrainSettings settings;
  if (!opts.to_settings(settings)) return 2;
  if (int r = check_outputs(opts, mesh_path)) return r;
  Mesh mesh;
  MeshImportReport import;
  if (Status s = load_mesh(mesh_path, mesh, &import, opts.import_options); !s) {
    std::fprintf(stderr, "lsnif: %s\n", s.message().c_str());
    return 1;
  }
  for (const std::string& w : import.warnings) std::fprintf(stderr, "lsnif: warning: %s\n", w.c_str());
  FolderLock lock;  // --keep-current: held until the model is written
  if (opts.keep_current)
    if (int r = keep_current_model(opts, settings, mesh, lock); r >= 0) return r;
  return train_mesh(mesh, mesh_path, opts, trained);
}

int train_mesh(const Mesh& mesh, const std::string& label, const TrainOptions& opts, Model* trained,
               TrainReport* report) {
  TrainSettings settings;
  if (!opts.to_settings(settings)) return 2;
  if (int r = check_outputs(opts, "")) return r;
  start_threads(opts.threads);
  std::printf("mesh      %s: %zu triangles, %zu materials\n", label.c_str(), mesh.triangles.size(),
              mesh.materials.size());
  std::printf("settings  %s (%d threads)\n", settings.describe().c_str(), omp_get_max_threads());
  std::fflush(stdout);
  {
    Config config;
    std::vector<std::string> warnings;
    if (Status s = check_training_inputs(mesh, settings, config, &warnings); !s) {
      std::fprintf(stderr, "lsnif: training failed: %s\n", s.message().c_str());
      return 1;
    }
    for (const std::string& w : warnings) std::fprintf(stderr, "lsnif: warning: %s\n", w.c_str());
  }
  Model model;
  TrainReport rep;
  // Under a time budget the bar counts milliseconds of it (the steps are planned as it runs).
  const bool budget = settings.time_budget > 0;
  ProgressBar bar("train", budget ? uint64_t(settings.time_budget * 1000.0) : settings.steps, !opts.quiet);
  const Status result = train_model(mesh, settings, model, &rep, [&](uint32_t step, const LossTerms& loss, const Model&) {
    if (budget)
      bar.update(std::min(uint64_t(bar.elapsed_seconds() * 1000.0), uint64_t(settings.time_budget * 1000.0)),
                 format("step %u loss %.4f", step, loss.total()));
    else
      bar.update(step, format("loss %.4f", loss.total()));
    return true;
  });
  bar.finish(result ? format("%.0f rays/s", rep.rays_per_second()) : std::string("failed"));
  if (!result) {
    std::fprintf(stderr, "lsnif: training failed: %s\n", result.message().c_str());
    return 1;
  }
  for (const std::string& w : rep.uv_warnings) std::fprintf(stderr, "lsnif: warning: %s\n", w.c_str());
  if (model.config.texture_coordinates())
    std::printf("uv        materials 0x%llx report texture coordinates (uv cells: %u per voxel edge)\n",
                (unsigned long long)model.config.uv_materials, model.config.uv_cells);
  // A budget's run is the run of the steps it planned (its schedule's): the record says so.
  const uint32_t max_steps = settings.steps;
  if (budget) settings.steps = rep.planned_steps;
  model.training = training_record(settings, mesh, recorded_mesh_name(label), omp_get_max_threads());
  if (Status s = save_model(model, opts.output); !s) {
    std::fprintf(stderr, "lsnif: %s\n", s.message().c_str());
    return 1;
  }
  if (Status s = write_file_atomic(opts.csv_path(), rep.loss_curve); !s) {
    std::fprintf(stderr, "lsnif: loss curve: %s\n", s.message().c_str());
    return 1;
  }
  const MemoryBreakdown mem = memory_breakdown(model);
  std::printf("trained   %u steps x %u rays in %.1f s (%.0f rays/s): sampling %.1f s, encoding %.1f s, "
              "MLP %.1f s, loss %.1f s, Adam %.1f s%s\n",
              rep.steps, settings.batch_size, rep.seconds, rep.rays_per_second(), rep.seconds_sampling,
              rep.seconds_encoding, rep.seconds_mlp, rep.seconds_loss, rep.seconds_optimizer,
              rep.rays_cast == rep.rays ? ""
                  : format("; %llu rays cast, each used %.2f times", (unsigned long long)rep.rays_cast,
                           double(rep.rays) / double(rep.rays_cast)).c_str());
  std::printf("loss      final %.4f (occlusion %.4f distance %.4f normal %.4f albedo %.4f material %.4f)\n",
              rep.final_loss.total(), rep.final_loss.occlusion, rep.final_loss.distance, rep.final_loss.normal,
              rep.final_loss.albedo, rep.final_loss.material);
  std::printf("wrote     %s (%.3f MiB, %u occupied voxels%s) and %s\n", opts.output.c_str(),
              double(mem.total()) / 1048576.0, rep.occupied_voxels,
              mem.uv_cell_bytes ? format("; uv cells %.3f MiB, %u maps", double(mem.uv_cell_bytes) / 1048576.0,
                                         model.config.uv_cell_maps).c_str() : "",
              opts.csv_path().c_str());
  if (budget) {
    std::printf("budget    %.1f s: %u steps planned (of at most %u), %u run%s\n", double(settings.time_budget),
                rep.planned_steps, max_steps, rep.steps,
                rep.budget_cut ? "; the budget ran out first (a slower pace than the first steps')" : "");
    EvalSettings es;
    es.rays = kEvalRaysAfterBudget;
    EvalReport ev;
    if (Status s = evaluate_model(model, mesh, es, ev); !s) {
      std::fprintf(stderr, "lsnif: evaluating the model: %s\n", s.message().c_str());
      return 1;
    }
    std::printf("eval      occlusion %.2f%%, t error median %.3f%%, normal error median %.2f deg (%zu held-out rays, "
                "as `lsnif eval --rays %zu`)\n", 100.0 * ev.model.accuracy, 100.0 * ev.model.t_error_median,
                ev.model.normal_error_median, es.rays, es.rays);
  }
  std::fflush(stdout);
  if (trained) *trained = std::move(model);
  if (report) *report = rep;
  return 0;
}

}  // namespace lsnif::cli
