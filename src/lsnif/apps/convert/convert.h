// convert.h -- `lsnif convert IN.gltf -o OUT.gltf` as a library call (docs/convert.md): plan,
// train (or skip up-to-date models), write, and report. The command line (src/lsnif/apps/lsnif/
// cmd_convert.cpp) only parses options into ConvertSettings.
#pragma once
#include <cstdio>
#include <string>
#include <vector>

#include "lsnif/apps/convert/convert_plan.h"
#include "lsnif/apps/convert/convert_settings.h"
#include "lsnif/apps/convert/convert_train.h"
#include "lsnif/apps/convert/convert_write.h"

namespace lsnif::convert {

// Everything a run found out, for the report and for tests.
struct ConvertResult {
  Plan plan;
  std::vector<ModelResult> models;  // one per plan.models
  WriteReport written;
  size_t trained = 0, adopted = 0, up_to_date = 0, failed = 0;
  bool wrote_output = false;
  bool output_loads = true;  // load_scene (the renderer's loader) accepts the written scene
};

// Runs the conversion. The plan and report go to `out`, errors (one line per failed object, each
// naming it) to `err`. A run (not a dry run) holds an exclusive lock on the output folder from before
// it reads the models there until it returns, and first removes the temporary files of its outputs
// an interrupted run left there (docs/convert.md). With settings.plan_dir it writes the cluster jobs
// instead (under the plan folder's lock; the output is not written), with settings.assemble_dir it
// adopts their models before training what is left (convert_cluster.h). Returns the exit code: 0
// when every selected object was converted (or, with dry_run, could be; with plan_dir, got its
// job), 1 when the input could not be read or written, another run holds the output folder, an
// output would overwrite a file the input uses, the scene to be written would not load in the
// renderer's loader (checked before any training, in a dry run too), any object failed (the good
// ones are still trained and written), the written scene does not load (load_scene), or, assembling
// without retrain_missing, a model of the plan is missing (nothing written), 2 for invalid settings.
int run_convert(const ConvertSettings& settings, ConvertResult& result, FILE* out, FILE* err);

}  // namespace lsnif::convert
