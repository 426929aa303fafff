// lsnif-gpu -- the GPU commands of lsnif, in a program that needs only glibc, libstdc++, libgomp and a
// Vulkan loader and driver where it runs: no training (Embree), no OpenImageIO (the portable image
// backend), no window (GLFW). The GPU check folder (scripts/gpu-check.sh) carries it.
#include <iterator>

#include "lsnif/apps/lsnif/commands.h"

namespace {
using lsnif::cli::Command;
const Command kCommands[] = {
    {"check", lsnif::cli::cmd_check, "the GPU check: conformance tests, bench-trace and bench on one device, one report"},
    {"devices", lsnif::cli::cmd_devices, "list the Vulkan devices and the LSNIF paths each supports"},
    {"info", lsnif::cli::cmd_info, "print a model's configuration and memory breakdown"},
    {"bench-trace", lsnif::cli::cmd_bench_trace, "ray-tracing throughput of a model vs the triangle BLAS of its mesh"},
    {"render", lsnif::cli::cmd_render, "path trace a glTF scene with LSNIF objects (or --reference) to an image"},
    {"flip", lsnif::cli::cmd_flip, "FLIP difference of a test image from a reference (LDR or HDR)"},
    {"bench", lsnif::cli::cmd_bench_prepared, "the paper's Table 1 on the bundled scenes with models prepared before (--models)"},
};
}  // namespace

int main(int argc, char** argv) {
  return lsnif::cli::dispatch(argc, argv, "lsnif-gpu",
                              "LSNIF's GPU commands (the lsnif program without training, conversion or a window).",
                              kCommands, std::size(kCommands));
}
