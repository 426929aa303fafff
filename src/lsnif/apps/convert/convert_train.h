// convert_train.h -- the converter's second stage: for every planned model, flatten its glTF
// mesh(es) into the training mesh, hash mesh + training settings, skip models whose .lsnif is up to
// date (same hash in its sidecar), and train the others, several at once, under one progress bar.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "lsnif/apps/convert/convert_plan.h"
#include "lsnif/train/evaluate.h"
#include "lsnif/import/mesh.h"

namespace lsnif::convert {

enum class ModelState {
  Planned,   // dry run: would be trained
  UpToDate,  // its .lsnif records the mesh and the settings, and its sidecar agrees: not retrained
  Trained,
  Adopted,   // `--assemble`: the model a cluster job wrote (convert_cluster.h)
  Failed,
};

struct ModelResult {
  ModelState state = ModelState::Planned;
  std::string error;                  // Failed: names the object and the problem
  Mesh mesh;                          // the training mesh (the model's object space)
  std::vector<int> material_sources;  // model material i came from glTF material [i] (-1: default)
  uint64_t mesh_hash = 0;             // mesh_hash() of `mesh`
  std::string hash;                   // 16 hex digits over mesh + training settings
  bool up_to_date_on_disk = false;    // the .lsnif on disk already matches (dry run: would be skipped)
  std::string stale;                  // why the .lsnif on disk (when there is one) is retrained
  uint64_t bytes = 0;                 // model size (estimated before training, exact after)
  double seconds = 0;                 // training time
  bool evaluated = false;
  EvalMetrics metrics;                // on ConvertSettings::eval_rays held-out rays
  std::vector<std::string> warnings;  // from flattening the mesh
};

// The content hash of a training mesh (of mesh_hash() `mesh_hash`) and the settings that shape its
// model (everything in TrainSettings but progress and loss_curve), as 16 hex digits.
std::string content_hash(uint64_t mesh_hash, const TrainSettings& train);

// The sidecar of a .lsnif file: MODEL.lsnif.json.
std::string sidecar_path(const std::string& model_path);

// The stage's first half, for plan.models into `results` (one per model, same order): flattens
// each model's mesh(es), hashes them and marks the models whose .lsnif in `out_dir` is up to date
// (UpToDate; a dry run only sets up_to_date_on_disk). Up to date means: the model file loads (its
// training record agrees with its header), its training record holds these training settings and
// the hash of this mesh, and its sidecar holds this content hash (a sidecar of another run, or
// none, means retraining: the sidecar caches the evaluation, it never vouches for the model). The
// others stay Planned (with `stale` saying why an existing model is retrained), or Failed with
// their error (bad mesh data). Nothing is trained or written.
void prepare_models(const ConvertSettings& settings, const Plan& plan, const std::string& out_dir,
                    std::vector<ModelResult>& results);

// What follows a model's file in the output folder, trained here or adopted: the evaluation on
// settings.eval_rays held-out rays (with warnings about surface channels learned poorly) and the
// sidecar; sets r's metrics and bytes. Errors name the failing step.
Status record_model(const ConvertSettings& settings, const PlannedModel& m, const Model& model,
                    const std::string& path, ModelResult& r);

// The second half: trains the Planned models (several at once) into `out_dir`/PlannedModel::file
// (+ sidecar). Nothing when settings.dry_run. A model that fails (training error, unwritable file)
// is Failed with its error; the others go on.
void train_models(const ConvertSettings& settings, const Plan& plan, const std::string& out_dir,
                  std::vector<ModelResult>& results);

}  // namespace lsnif::convert
