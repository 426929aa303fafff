// train_options.h -- the training options shared by `lsnif train` and `lsnif demo` (one Settings
// struct, as in gltfpack), and the run that loads the mesh, trains, saves and summarizes.
#pragma once
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "lsnif/apps/lsnif/args.h"
#include "lsnif/import/mesh.h"
#include "lsnif/core/model.h"
#include "lsnif/train/settings_io.h"
#include "lsnif/train/trainer.h"

namespace lsnif::cli {

// Held-out rays of the evaluation `lsnif train --time-budget` prints (a few seconds on 2 cores).
inline constexpr size_t kEvalRaysAfterBudget = 20000;

struct TrainOptions {
  std::string output;
  std::string config;  // --config FILE.json: settings under those given on the command line
  // The settings of src/lsnif/format/settings_table.h given on the command line (each is the option --NAME),
  // and the presets (--quality low, --paper) as given: (option, choice; "" for a flag).
  SettingLayer given;
  std::vector<std::pair<std::string, std::string>> presets;
  uint32_t threads = 0;
  // `lsnif train --time-budget SECONDS` (TrainSettings::time_budget; 0: none): the model reachable in
  // that time, its held-out metrics printed after training.
  float time_budget = 0;
  std::string csv;
  bool quiet = false;
  // `lsnif train --keep-current` (a cluster job, docs/cluster.md): keep -o when it already holds the
  // model of this mesh and these settings (its training record says so), and let one run at a time
  // train it (run_training).
  bool keep_current = false;
  MeshImportOptions import_options;  // --allow-outside-refs, --allow-dropped-triangles

  // Registers the training options (every setting, the presets, --config), the mesh import flags
  // and -o/--output (described by `output_help`).
  void add_to(Args& args, const char* output_help = "output model file (.lsnif)");
  // Builds trainer settings: defaults, then the --config file, then the command line (presets
  // first); returns false (message printed, naming the option, or the file and the key) on an
  // invalid value or combination.
  bool to_settings(TrainSettings& settings) const;
  // The loss curve's path: --csv, or MODEL.csv.
  std::string csv_path() const { return csv.empty() ? output + ".csv" : csv; }
};

// Records `text` as the value of setting `d` in `layer`, as the option --NAME does: "" when it is
// a number of the setting's kind, else why not (a choice's name and every range are checked when
// resolved).
std::string set_setting_text(SettingLayer& layer, const SettingDef& d, const std::string& text);

// Loads the mesh, trains, writes the model (+ CSV) and prints a summary. Returns the exit code.
// The outputs are checked before any work: writable, not a link or device, not the mesh itself.
// With opts.keep_current the run first holds the lock file .MODEL.lock beside -o (waiting while
// another run holds it), removes the temporary files of -o and the CSV that a killed run left, and
// ends at once (0) when -o holds the model these settings give of this mesh.
int run_training(const std::string& mesh_path, const TrainOptions& opts, Model* trained);

// The same for a mesh already in memory (`label` names it in the summary): trains, writes
// opts.output and then the CSV (each atomically: a failure leaves the old files), prints the
// summary; `trained` and `report` (either may be null) receive the model and the trainer's report.
// Returns the exit code (0 ok, 1 failure, 2 invalid options).
int train_mesh(const Mesh& mesh, const std::string& label, const TrainOptions& opts, Model* trained,
               TrainReport* report = nullptr);

}  // namespace lsnif::cli
