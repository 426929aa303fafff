// lsnif -- command-line front end of the LSNIF library.
#include <iterator>

#include "lsnif/apps/lsnif/commands.h"

namespace {
using lsnif::cli::Command;
const Command kCommands[] = {
    {"demo", lsnif::cli::cmd_demo, "train a model of the bundled bunny and print its evaluation"},
    {"train", lsnif::cli::cmd_train, "train an LSNIF model of a mesh (.off .obj .ply .gltf .glb .lsmesh)"},
    {"eval", lsnif::cli::cmd_eval, "measure a model against exact ray casting on held-out rays"},
    {"info", lsnif::cli::cmd_info, "print a model's configuration and memory breakdown"},
    {"devices", lsnif::cli::cmd_devices, "list the Vulkan devices and the LSNIF paths each supports"},
    {"bench-trace", lsnif::cli::cmd_bench_trace, "ray-tracing throughput of a model vs the triangle BLAS of its mesh"},
    {"bench-memory", lsnif::cli::cmd_bench_memory, "device memory of a model vs the triangle BLAS of its mesh"},
    {"render", lsnif::cli::cmd_render, "path trace a glTF scene with LSNIF objects (or --reference) to an image"},
    {"bench-size", lsnif::cli::cmd_bench_size, "model size against quality: bytes, eval metrics and FLIP per mesh and setting"},
    {"view", lsnif::cli::cmd_view, "open a window that path traces a scene progressively (LSNIF / reference toggle)"},
    {"flip", lsnif::cli::cmd_flip, "FLIP difference of a test image from a reference (LDR or HDR)"},
    {"convert", lsnif::cli::cmd_convert, "train LSNIF models for a glTF scene's heavy objects and write the converted scene"},
    {"bench", lsnif::cli::cmd_bench, "the paper's Table 1 on the bundled scenes: memory, time and FLIP of LSNIF vs triangles"},
};
}  // namespace

int main(int argc, char** argv) {
  return lsnif::cli::dispatch(argc, argv, "lsnif", "LSNIF: neural intersection functions for ray tracing.", kCommands,
                              std::size(kCommands));
}
