// train_consumer MODEL MESH RAYS -- evaluates MODEL against MESH on RAYS held-out rays (evaluate.h)
// and prints the model's confusion counts, one "name value" per line.
#include <cstdio>
#include <cstdlib>

#include "evaluate.h"
#include "mesh.h"
#include "model.h"

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: train_consumer MODEL MESH RAYS\n");
    return 2;
  }
  lsnif::Model model;
  lsnif::Mesh mesh;
  lsnif::Status s = lsnif::load_model(argv[1], model);
  if (s) s = lsnif::load_mesh(argv[2], mesh);
  lsnif::EvalSettings settings;
  settings.rays = std::strtoul(argv[3], nullptr, 10);
  lsnif::EvalReport report;
  if (s) s = lsnif::evaluate_model(model, mesh, settings, report);
  if (!s) {
    std::fprintf(stderr, "train_consumer: %s\n", s.message().c_str());
    return 1;
  }
  const lsnif::EvalMetrics& m = report.model;
  std::printf("rays %llu\ntrue_hits %llu\nfalse_hits %llu\ntrue_misses %llu\nfalse_misses %llu\n",
              static_cast<unsigned long long>(m.rays), static_cast<unsigned long long>(m.true_hits),
              static_cast<unsigned long long>(m.false_hits), static_cast<unsigned long long>(m.true_misses),
              static_cast<unsigned long long>(m.false_misses));
  return 0;
}
