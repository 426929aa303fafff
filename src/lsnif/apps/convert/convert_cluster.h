// convert_cluster.h -- converting on the machines a user already schedules work on (docs/cluster.md).
// `lsnif convert --plan DIR` writes one self-contained training job per planned model into DIR
// instead of training; any scheduler (a Slurm job array, `xargs -P`, GNU parallel over ssh, a
// Kubernetes Indexed Job) runs DIR/jobs.txt, one `lsnif train` command per line, in any order and
// anywhere the folder is shared; `lsnif convert --assemble DIR` adopts the models the jobs wrote,
// by content hash, and writes the scene.
//
// DIR holds: manifest.json (the plan: input, output, settings, one entry per job), jobs.txt, and per
// job jobs/HASH/ (NAME.lsmesh, the flattened training mesh, training_mesh.h; settings.json, its
// `--config`; job.json, its hash, model and command line). The jobs write models/HASH.lsnif, each
// atomically, and a job whose model is already there and current exits at once (`lsnif train
// --keep-current`). Commands run from DIR: every path in them is relative to it.
#pragma once
#include <cstdio>
#include <string>
#include <vector>

#include "lsnif/apps/convert/convert_plan.h"
#include "lsnif/apps/convert/convert_settings.h"
#include "lsnif/apps/convert/convert_train.h"

namespace lsnif::convert {

// The plan folder's files.
inline constexpr const char* kPlanManifest = "manifest.json";
inline constexpr const char* kPlanJobList = "jobs.txt";
inline constexpr const char* kPlanJobFolder = "jobs";
inline constexpr const char* kPlanModelFolder = "models";

// The model a plan's job writes, relative to the plan folder: models/HASH.lsnif.
std::string planned_model_path(const std::string& hash);

// The one rule for text that lands in a command line of a plan (jobs.txt, job.json, the next steps
// printed): no control character. A newline would end the command there and start another (that
// `sh -c` runs), and every later line of jobs.txt would no longer be its job (a Slurm array index).
// Returns why `text` breaks it, naming `what`; empty when it holds none.
std::string command_line_problem(const std::string& what, const std::string& text);

// The program the jobs run: `job_command` when given, else the running program's absolute path
// (the build that hashed the settings), else "lsnif".
std::string job_program(const std::string& job_command);

// Writes the plan folder settings.plan_dir for the models prepare_models made ready (every one
// that is not Failed gets a job; an up-to-date model in the output folder gets one too, so that the
// folder is complete on its own), replacing an earlier plan there: its job folders that this plan
// does not have are removed, its models are kept (a job of the same hash reuses them). Each file
// is written atomically; the manifest last. The job list and the next steps go to `out`.
Status write_job_plan(const ConvertSettings& settings, const Plan& plan, const std::vector<ModelResult>& models,
                      FILE* out);

// For `--assemble DIR`: checks every Planned model's DIR/models/HASH.lsnif (it loads, and its
// training record holds the model's mesh hash and settings). The ones that fail stay Planned, each
// with a line in `missing` naming the model, the file and why (absent, not loadable, another mesh or
// settings, a hash no job of the plan has). Then, unless some failed and settings.retrain_missing is
// off (nothing is written), the checked models are copied into the output folder (atomically),
// evaluated and recorded as convert_train.h does for a model it trains, and become Adopted. An
// unreadable manifest is an error.
Status adopt_planned_models(const ConvertSettings& settings, const Plan& plan, const std::string& out_dir,
                            std::vector<ModelResult>& models, std::vector<std::string>& missing);

}  // namespace lsnif::convert
