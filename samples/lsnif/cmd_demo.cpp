// lsnif demo: the README's main job on the bundled default: train the CGAL bunny, save the model,
// evaluate it on held-out rays against exact ray casting and the voxel-only baseline.
#include <cstdio>
#include <filesystem>
#include <string>

#include "args.h"
#include "commands.h"
#include "evaluate.h"
#include "mesh.h"
#include "train_options.h"

namespace lsnif::cli {

int cmd_demo(int argc, char** argv) {
  TrainOptions opts;
  std::string mesh_path = std::string(LSNIF_DATA_DIR) + "/meshes/bunny00.off";
  opts.output = "out/bunny.lsnif";
  uint32_t rays = 100000;
  Args args("demo", "Trains an LSNIF model of the bundled bunny (from scripts/setup.sh), writes it to\n"
                    "out/bunny.lsnif and evaluates it on held-out rays against exact ray casting.");
  args.option("mesh", "mesh to train", &mesh_path);
  args.option("eval-rays", "held-out rays for the evaluation", &rays);
  opts.add_to(args);
  if (int r = args.parse(argc, argv)) return r == 1 ? 0 : 2;
  if (!std::filesystem::exists(mesh_path)) {
    std::fprintf(stderr, "lsnif demo: %s not found: run scripts/setup.sh first (it fetches the test meshes)\n",
                 mesh_path.c_str());
    return 1;
  }
  std::error_code ec;
  std::filesystem::path parent = std::filesystem::path(opts.output).parent_path();
  if (!parent.empty()) std::filesystem::create_directories(parent, ec);
  Model model;
  if (int r = run_training(mesh_path, opts, &model)) return r;
  Mesh mesh;
  if (Status s = load_mesh(mesh_path, mesh); !s) {
    std::fprintf(stderr, "lsnif demo: %s\n", s.message().c_str());
    return 1;
  }
  EvalSettings settings;
  settings.rays = rays;
  EvalReport report;
  if (Status s = evaluate_model(model, mesh, settings, report); !s) {
    std::fprintf(stderr, "lsnif demo: %s\n", s.message().c_str());
    return 1;
  }
  std::printf("\nevaluation (%.1f s)\n%s", report.seconds, report.to_text().c_str());
  return 0;
}

}  // namespace lsnif::cli
