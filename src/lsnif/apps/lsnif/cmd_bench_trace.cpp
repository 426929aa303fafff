// lsnif bench-trace MESH MODEL: throughput of the LSNIF intersection shader against a triangle BLAS
// of the same mesh, of the plugin's batched paths and of a CPU GEMM (bench_trace.h describes the
// benchmark). This file is the command: its options and the sequence of steps.
#include <cstdint>
#include <cstdio>
#include <new>
#include <string>
#include <vector>

#include "lsnif/apps/lsnif/args.h"
#include "lsnif/apps/lsnif/bench_trace.h"
#include "lsnif/apps/lsnif/commands.h"
#include "lsnif/apps/lsnif/device_option.h"
#include "lsnif/apps/lsnif/train_options.h"
#include "lsnif/renderer/renderer.h"

namespace lsnif::cli {

namespace bench_trace {

namespace {

constexpr uint32_t kMaxRays = 1u << 24;
constexpr uint32_t kMaxRepeat = 1000;

// Parses and checks the options into `o`: -1 to go on, else the exit code (0 after --help, 2 on an
// invalid option, its message printed).
int parse_options(int argc, char** argv, Options& o) {
  Args args("bench-trace",
            "Throughput of the LSNIF intersection shader (src/lsnif/shaders/lsnif.rint, embedded in the plugin) in a\n"
            "ray-tracing pipeline on the Vulkan device, against a triangle BLAS of the same mesh: the same rays\n"
            "through a TLAS of one LSNIF instance and a TLAS of one triangle instance (identity transforms), in\n"
            "one pipeline. Rays start on a sphere around the mesh AABB and aim at uniform points inside it.\n"
            "Reports the first trace of each (first use of the pipeline) and the median of the repeats\n"
            "(host wall time around submit + wait; device timestamps too where the queue has them), rays/s,\n"
            "LSNIF network evaluations/s, the triangle / LSNIF ratio and the hit agreement of the two.\n"
            "The same rays also go through the plugin's batched path (lsnifCmdIntersectModelRays: narrow phase,\n"
            "MLP, decode in compute), timed the same way with per-stage device times and compared ray by ray\n"
            "with the intersection shader; likewise through lsnifCmdQuery against the LSNIF TLAS (needs\n"
            "VK_KHR_ray_query); and an Eigen GEMM of the model's MLP on the CPU (the trainer's\n"
            "OpenMP threads) gives the CPU limit of the network evaluations/s.\n"
            "MODEL must have been trained on MESH (same object space; checked by the AABB).");
  args.positional("MESH", "the mesh (.off .obj .ply .gltf .glb)", &o.mesh_path);
  args.positional("MODEL", "the model trained on it (.lsnif)", &o.model_path);
  args.option("rays", "rays per trace", &o.rays, 1, kMaxRays);
  args.option("repeat", "timed traces of each kind after the first", &o.repeat, 1, kMaxRepeat);
  args.option("seed", "ray seed", &o.seed, 0, UINT64_MAX);
  args.option("triangle-order",
              "triangle order of the BLAS input: morton (centroid Morton code) or file (as loaded); lavapipe "
              "builds its BVH in this order",
              &o.triangle_order);
  args.option("intersection-shader",
              "SPIR-V file of the intersection shader instead of the plugin's (to compare shader versions; its "
              "hit attributes and model lookup must keep the layouts of the build)",
              &o.intersection_spv);
  args.option("broad-phase",
              "lsnifCmdQuery's broad phase: auto (the plugin's choice), trace-rays (a ray-tracing pipeline) or "
              "ray-query (ray queries in a compute shader)",
              &o.broad_phase);
  args.option("mlp-kernel",
              "the batched paths' MLP kernel: portable (GLSL, every device) or cooperative-matrix "
              "(VK_NV_cooperative_matrix, unverified; an error where the device lacks it)",
              &o.mlp_kernel);
  args.option("gemm-batch", "columns per OpenMP thread of the CPU GEMM", &o.gemm_batch, 1, 65536);
  args.option("gemm-seconds", "least time of the timed CPU GEMM passes, in seconds", &o.gemm_seconds, 0.01f, 60.0f);
  args.flag("json", "print one JSON object instead of text", &o.json);
  args.flag("validation", "enable the Khronos validation layer (slow; exit 1 if it reports anything)",
            &o.validation);
  add_device_option(args, &o.device);
  add_import_flags(args, &o.import_options);
  if (int r = args.parse(argc, argv)) return r == 1 ? 0 : 2;

  if (render::BroadPhase parsed; !render::parse_broad_phase(o.broad_phase, parsed)) {
    std::fprintf(stderr, "lsnif bench-trace: --broad-phase '%s': expected auto, trace-rays or ray-query\n",
                 o.broad_phase.c_str());
    return 2;
  }
  if (o.mlp_kernel != "portable" && o.mlp_kernel != "cooperative-matrix") {
    std::fprintf(stderr, "lsnif bench-trace: --mlp-kernel '%s': expected portable or cooperative-matrix\n",
                 o.mlp_kernel.c_str());
    return 2;
  }
  if (o.triangle_order != "morton" && o.triangle_order != "file") {
    std::fprintf(stderr, "lsnif bench-trace: --triangle-order '%s': expected morton or file\n",
                 o.triangle_order.c_str());
    return 2;
  }
  return -1;
}

// Runs the benchmark of the parsed options `o` and prints its report; returns the exit code.
int run(const Options& o) {
  auto fail = [](const Status& s) {
    std::fprintf(stderr, "lsnif bench-trace: %s\n", s.message().c_str());
    return 1;
  };
  Mesh mesh;
  if (Status s = load_mesh(o.mesh_path, mesh, nullptr, o.import_options); !s) return fail(s);
  Model model;
  if (Status s = load_model(o.model_path, model); !s) return fail(s);
  if (Status s = check_same_object(mesh, model); !s) return fail(s.context(o.mesh_path + " / " + o.model_path));

  Report report;
  report.mesh_path = o.mesh_path;
  report.model_path = o.model_path;
  report.intersection_spv =
      o.intersection_spv.empty() ? "the plugin's (lsnifGetIntersectionShaderSpirv)" : o.intersection_spv;
  report.rays = o.rays;
  report.repeat = o.repeat;
  report.seed = o.seed;
  report.triangles = uint32_t(mesh.triangles.size());
  report.validation = o.validation;
  report.morton_order = o.triangle_order == "morton";
  const std::vector<Ray> ray_list = make_rays(mesh.bounds(), o.rays, o.seed);

  DeviceState st;
  Status s = set_up(st, o, mesh, ray_list, report);
  if (s) s = run_traces(st, o.rays, o.repeat, report);
  if (!s) return fail(s);
  compare_results(st, model, mesh, ray_list, report);
  // After the device work, so that lavapipe's threads are idle while the GEMM has the cores.
  std::fprintf(stderr, "bench-trace: CPU GEMM of the MLP for %.2g s or more\n", double(o.gemm_seconds));
  report.gemm = run_gemm(model, o.gemm_batch, double(o.gemm_seconds));
  // Free everything, then the device, so that validation also sees leaks at vkDestroyDevice.
  st.release();
  st.ctx.destroy_device();
  report.validation_errors = st.ctx.validation_errors();
  report.validation_warnings = st.ctx.validation_warnings();

  if (o.json)
    print_json(report);
  else
    print_text(report);
  if (report.validation_errors + report.validation_warnings > 0) {
    std::fprintf(stderr, "lsnif bench-trace: the validation layer reported %u errors and %u warnings\n",
                 report.validation_errors, report.validation_warnings);
    return 1;
  }
  return 0;
}

}  // namespace

}  // namespace bench_trace

int cmd_bench_trace(int argc, char** argv) {
  bench_trace::Options options;
  if (const int r = bench_trace::parse_options(argc, argv, options); r >= 0) return r;
  try {
    return bench_trace::run(options);
  } catch (const std::bad_alloc&) {
    // The host's copies of the rays and their results (a limited address space, a small machine).
    std::fprintf(stderr, "lsnif bench-trace: out of host memory for the rays of --rays %u; lower --rays\n",
                 options.rays);
    return 1;
  }
}

}  // namespace lsnif::cli
