// consumer MODEL MESH RAYS -- evaluates MODEL against MESH on RAYS held-out rays (evaluate.h) and
// prints the model's confusion counts, one "name value" per line, then the plugin's version: a C++
// program with its own config.h, status.h, mesh.h, model.h and host_device.h (own_headers.h) that
// links the CPU libraries and the plugin.
#include <cstdio>
#include <cstdlib>

#include <lsnif/lsnif.hpp>

#include "lsnif/core/model.h"
#include "lsnif/import/mesh.h"
#include "lsnif/train/evaluate.h"
#include "own_headers.h"

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: consumer MODEL MESH RAYS\n");
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
    std::fprintf(stderr, "consumer: %s\n", s.message().c_str());
    return 1;
  }
  const lsnif::EvalMetrics& m = report.model;
  std::printf("rays %llu\ntrue_hits %llu\nfalse_hits %llu\ntrue_misses %llu\nfalse_misses %llu\n",
              static_cast<unsigned long long>(m.rays), static_cast<unsigned long long>(m.true_hits),
              static_cast<unsigned long long>(m.false_hits), static_cast<unsigned long long>(m.true_misses),
              static_cast<unsigned long long>(m.false_misses));
  const uint32_t v = lsnifGetVersion();
  std::printf("plugin %u.%u.%u\n", LSNIF_VERSION_GET_MAJOR(v), LSNIF_VERSION_GET_MINOR(v), LSNIF_VERSION_GET_PATCH(v));
  return 0;
}
