// lsnif train MESH -o MODEL.lsnif: voxelize, train and save one LSNIF object.
#include <omp.h>

#include <cstdio>
#include <string>

#include "lsnif/apps/lsnif/args.h"
#include "lsnif/apps/lsnif/commands.h"
#include "lsnif/apps/lsnif/train_options.h"
#include "lsnif/train/trainer.h"

namespace lsnif::cli {

int cmd_train(int argc, char** argv) {
  std::string mesh_path;
  TrainOptions opts;
  Args args("train", "Trains an LSNIF model of MESH (.off .obj .ply .gltf .glb .lsmesh) and writes it with a CSV of\n"
                     "the loss curve beside it (MODEL.csv). The default model is smaller and cheaper than the\n"
                     "paper's (8-bit grid, coarse level indexed, docs/results.md) and its training is tuned\n"
                     "for a 2-core CPU; --paper selects the paper's grid and training, --quality high its network.");
  args.positional("MESH", "input mesh", &mesh_path);
  opts.add_to(args);
  args.option("time-budget", format("seconds the training loop may take (0: no limit): as many of --steps as fit, "
                                     "the learning-rate schedule spanning them, then the held-out metrics (%zu rays)",
                                     kEvalRaysAfterBudget),
              &opts.time_budget, 0.0f, float(kMaxTimeBudget));
  args.flag("keep-current", "keep -o when it already holds the model of this mesh and these settings (its "
            "training record); one run at a time trains it (a cluster job: docs/cluster.md)", &opts.keep_current);
  if (int r = args.parse(argc, argv)) return r == 1 ? 0 : 2;
  if (opts.output.empty()) {
    std::fprintf(stderr, "lsnif train: missing -o MODEL.lsnif\n");
    return 2;
  }
  return run_training(mesh_path, opts, nullptr);
}

}  // namespace lsnif::cli
