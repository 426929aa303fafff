// lsnif eval MODEL MESH: accuracy of a model against exact ray casting, with the voxel baseline.
#include <cstdio>
#include <string>

#include "lsnif/apps/lsnif/args.h"
#include "lsnif/apps/lsnif/commands.h"
#include "lsnif/apps/lsnif/train_options.h"
#include "lsnif/train/evaluate.h"
#include "lsnif/train/settings_io.h"
#include "lsnif/import/mesh.h"

namespace lsnif::cli {

int cmd_eval(int argc, char** argv) {
  std::string model_path, mesh_path;
  uint32_t rays = 100000, threads = 0;
  uint64_t seed = EvalSettings().seed;
  bool json = false;
  MeshImportOptions import_options;
  Args args("eval", "Measures MODEL against exact ray casting (Embree) of MESH on fresh held-out rays drawn\n"
                    "like the training rays and crossing at least one occupied voxel: occlusion accuracy,\n"
                    "precision, recall; |t| error as a fraction of the AABB diagonal; normal error in\n"
                    "degrees; albedo MAE; material accuracy. Also scores the voxel-only baseline.");
  args.positional("MODEL", "trained model (.lsnif)", &model_path);
  args.positional("MESH", "the mesh it was trained on", &mesh_path);
  args.option("rays", "held-out rays", &rays, 1, kMaxEvalRays);
  args.option("seed", "held-out ray seed", &seed, 0, UINT64_MAX);
  args.option("threads", "worker threads (0 = all cores)", &threads, 0, kMaxThreads);
  args.flag("json", "print JSON instead of text", &json);
  add_import_flags(args, &import_options);
  if (int r = args.parse(argc, argv)) return r == 1 ? 0 : 2;
  start_threads(threads);
  Model model;
  if (Status s = load_model(model_path, model); !s) {
    std::fprintf(stderr, "lsnif eval: %s\n", s.message().c_str());
    return 1;
  }
  Mesh mesh;
  if (Status s = load_mesh(mesh_path, mesh, nullptr, import_options); !s) {
    std::fprintf(stderr, "lsnif eval: %s\n", s.message().c_str());
    return 1;
  }
  EvalSettings settings;
  settings.rays = rays;
  settings.seed = seed;
  // The reference normal the model learned: with the normal maps applied, if its training baked them.
  settings.normal_maps = recorded_normal_maps(model.training);
  EvalReport report;
  if (Status s = evaluate_model(model, mesh, settings, report); !s) {
    std::fprintf(stderr, "lsnif eval: %s\n", s.message().c_str());
    return 1;
  }
  std::fputs(json ? (report.to_json() + "\n").c_str() : report.to_text().c_str(), stdout);
  return 0;
}

}  // namespace lsnif::cli
