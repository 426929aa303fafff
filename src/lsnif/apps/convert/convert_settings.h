// convert_settings.h -- every option of the scene converter (`lsnif convert`, docs/convert.md) in
// one struct, as gltfpack keeps its Settings.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "lsnif/apps/convert/convert_blas.h"
#include "lsnif/train/trainer.h"

namespace lsnif::convert {

// `--group NAME=REGEX`: the selected mesh nodes whose name matches REGEX become one LSNIF object
// named NAME (their meshes flattened into world space, one model for all of them).
struct GroupRule {
  std::string name;
  std::string pattern;  // RE2 regular expression, searched in the node name
};

// The default rule for a mesh or group that no tag forces in or out (`--convert-when`).
enum class ConvertWhen {
  Memory,     // the triangle BLASes it frees are at least memory_margin x its model's bytes
  Triangles,  // it has at least min_triangles triangles (the paper's face-count threshold)
};

// The range of `--memory-margin` (check_settings).
constexpr double kMinMemoryMargin = 1.0;
constexpr double kMaxMemoryMargin = 1e6;

struct ConvertSettings {
  std::string input;   // IN.gltf or IN.glb
  std::string output;  // OUT.gltf; the .lsnif files go beside it
  ConvertWhen convert_when = ConvertWhen::Memory;
  // The paper's face-count threshold: meshes (groups: all members together) with fewer triangles
  // stay triangle meshes; the rule of ConvertWhen::Triangles and a lower bound under Memory. Node
  // extras {"lsnif": true} overrides it.
  uint64_t min_triangles = 1000;
  // ConvertWhen::Memory: convert when the freed BLAS bytes >= memory_margin x the model's bytes
  // (in [kMinMemoryMargin, kMaxMemoryMargin]). 2: an LSNIF hit costs more time than a triangle
  // hit, so a conversion has to give back clearly more than it takes, and the BLAS sizes of other
  // drivers than the estimate's differ from it.
  double memory_margin = 2.0;
  // How the BLAS bytes are found: the calibrated estimate (empty query) or a device's size query.
  BlasSizer blas;
  // RE2 regular expressions (linear-time matching: node names are untrusted input) searched in the
  // node name and the mesh name; empty: no rule.
  // A node is a candidate when `select` is empty or matches, and `exclude` is empty or matches
  // neither name.
  std::string select, exclude;
  std::vector<GroupRule> groups;
  bool keep_meshes = false;  // keep the converted nodes' triangles (the renderer's reference mode)
  bool dry_run = false;      // print the plan, train and write nothing
  bool force = false;        // retrain even models whose .lsnif is up to date
  // Cluster conversion (convert_cluster.h, docs/cluster.md): `--plan DIR` writes the training jobs
  // into DIR instead of training, `--assemble DIR` adopts the models they wrote (and with
  // `--retrain-missing` trains the ones missing here); `--job-command` is the program the jobs run.
  std::string plan_dir, assemble_dir;
  bool retrain_missing = false;
  std::string job_command;
  uint32_t jobs = 1;         // models trained at the same time
  uint32_t eval_rays = 20000;  // held-out rays per trained model for the report (0: no evaluation)
  bool progress = true;      // one overall progress bar on stderr
  // --allow-outside-refs (buffers, images, models and the HDR of the input, and the references
  // of the written scene, may leave their folder) and --allow-dropped-triangles.
  MeshImportOptions import_options;
  // Training of every model (TrainSettings::progress and loss_csv are ignored: the converter
  // draws one bar for all models and writes no loss curves).
  TrainSettings train;
};

}  // namespace lsnif::convert
