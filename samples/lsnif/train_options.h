// train_options.h -- the training options shared by `lsnif train` and `lsnif demo` (one Settings
// struct, as in gltfpack), and the run that loads the mesh, trains, saves and summarizes.
#pragma once
#include <cstdint>
#include <string>

#include "args.h"
#include "mesh.h"
#include "model.h"
#include "trainer.h"

namespace lsnif::cli {

struct TrainOptions {
  std::string output;
  uint32_t voxels = 32, points = 18, levels = 2, res_min = 64, res_max = 128, table_log2 = 17,
           features = 3, width = 128, layers = 2, steps = 2000, batch = 1u << 14, threads = 0;
  uint64_t seed = 1;
  uint32_t ray_reuse = 1;
  std::string normal_loss = "angle";
  float lr = 0.01f;
  std::string hit = "segments";
  std::string csv;
  // The paper's two configurations (section 6): "high" (the defaults above) and "low", which
  // reduces the hidden width W to 64 and the boundary points H to 10 (kLowQuality*).
  std::string quality = "high";
  static constexpr uint32_t kLowQualityWidth = 64, kLowQualityPoints = 10;
  LossSettings loss;
  bool paper = false, quiet = false;
  MeshImportOptions import_options;  // --allow-outside-refs, --allow-dropped-triangles

  // Registers the training options, the mesh import flags and -o/--output (described by
  // `output_help`).
  void add_to(Args& args, const char* output_help = "output model file (.lsnif)");
  // Builds trainer settings; returns false (message printed, naming the option) on an invalid
  // value or combination.
  bool to_settings(TrainSettings& settings) const;
  // The loss curve's path: --csv, or MODEL.csv.
  std::string csv_path() const { return csv.empty() ? output + ".csv" : csv; }
};

// Registers --allow-outside-refs (and, with `meshes`, --allow-dropped-triangles) into `options`:
// the import policy flags of every command that reads a mesh or a scene.
void add_import_flags(Args& args, MeshImportOptions* options, bool meshes = true);

// Loads the mesh, trains, writes the model (+ CSV) and prints a summary. Returns the exit code.
// The outputs are checked before any work: writable, not a link or device, not the mesh itself.
int run_training(const std::string& mesh_path, const TrainOptions& opts, Model* trained);

// The same for a mesh already in memory (`label` names it in the summary): trains, writes
// opts.output and then the CSV (each atomically: a failure leaves the old files), prints the
// summary; `trained` and `report` (either may be null) receive the model and the trainer's report.
// Returns the exit code (0 ok, 1 failure, 2 invalid options).
int train_mesh(const Mesh& mesh, const std::string& label, const TrainOptions& opts, Model* trained,
               TrainReport* report = nullptr);

}  // namespace lsnif::cli
