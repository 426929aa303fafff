// lsnif demo: the README's main job on the bundled default: train the CGAL bunny (or reuse the
// model), save it, evaluate it on held-out rays against exact ray casting and the voxel-only
// baseline, then render it on a ground quad under an HDR sky in LSNIF and reference mode and print
// the FLIP, memory and time rows with a side-by-side picture (render_compare.h).
#include <cstdio>
#include <filesystem>
#include <string>

#include "lsnif/apps/lsnif/args.h"
#include "lsnif/apps/lsnif/commands.h"
#include "lsnif/apps/lsnif/data_dir.h"
#include "lsnif/apps/lsnif/device_option.h"
#include "lsnif/train/evaluate.h"
#include "lsnif/import/mesh.h"
#include "lsnif/core/model.h"
#include "lsnif/apps/lsnif/render_compare.h"
#include "lsnif/harness/vk_compute.h"
#include "lsnif/apps/lsnif/train_options.h"

namespace lsnif::cli {

int cmd_demo(int argc, char** argv) {
  TrainOptions opts;
  std::string data_dir = default_data_dir();
  const auto in_data = [&data_dir](const char* file) { return data_dir + "/" + file; };
  std::string mesh_path = in_data("meshes/bunny00.off");
  opts.output = "out/bunny.lsnif";
  uint32_t rays = 100000;
  bool reuse = false, no_render = false;
  render::RenderSettings rs;  // the default image (render_defaults.h) unless given
  std::string hdr = in_data("hdr/forest.exr"), picture = "out/bunny_compare.png";
  const std::string default_mesh = mesh_path, default_hdr = hdr;
  std::string device;
  Args args("demo", "Trains an LSNIF model of the bundled bunny (from scripts/setup.sh), writes it to\n"
                    "out/bunny.lsnif, evaluates it on held-out rays against exact ray casting, and renders it\n"
                    "in LSNIF and reference mode (FLIP, memory, time; out/bunny_compare.png).");
  args.option("data", "folder with meshes/ and hdr/ from scripts/setup.sh", &data_dir);
  args.option("mesh", "mesh to train, in --data unless given", &mesh_path);
  args.option("eval-rays", "held-out rays for the evaluation", &rays);
  args.flag("reuse", "load the model from --output if it exists instead of training", &reuse);
  args.flag("no-render", "skip the rendering comparison", &no_render);
  args.option("image-width", "render width (--width is the network's hidden width)", &rs.width);
  args.option("image-height", "render height", &rs.height);
  args.option("spp", "render samples per pixel", &rs.spp);
  args.option("hdr", "environment image for the render (empty: constant sky), in --data unless given", &hdr);
  args.option("picture", "side-by-side image (reference | LSNIF | FLIP)", &picture);
  add_device_option(args, &device);
  opts.add_to(args);
  if (int r = args.parse(argc, argv)) return r == 1 ? 0 : 2;
  // --mesh and --hdr not given: the files of --data.
  const bool mesh_from_data = mesh_path == default_mesh, hdr_from_data = hdr == default_hdr;
  if (mesh_from_data) mesh_path = in_data("meshes/bunny00.off");
  if (hdr_from_data) hdr = in_data("hdr/forest.exr");
  if ((mesh_from_data || (hdr_from_data && !no_render)) && !check_data_dir("demo", data_dir)) return 1;
  if (!std::filesystem::exists(mesh_path)) {
    std::fprintf(stderr, "lsnif demo: %s not found: run scripts/setup.sh first (it fetches the test meshes)\n",
                 mesh_path.c_str());
    return 1;
  }
  std::error_code ec;
  std::filesystem::path parent = std::filesystem::path(opts.output).parent_path();
  if (!parent.empty()) std::filesystem::create_directories(parent, ec);
  Model model;
  if (reuse && std::filesystem::exists(opts.output)) {
    if (Status s = load_model(opts.output, model); !s) {
      std::fprintf(stderr, "lsnif demo: %s\n", s.message().c_str());
      return 1;
    }
    std::printf("reusing %s\n", opts.output.c_str());
  } else if (int r = run_training(mesh_path, opts, &model)) {
    return r;
  }
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
  if (no_render) return 0;
  if (!hdr.empty() && !std::filesystem::exists(hdr)) {
    std::fprintf(stderr, "lsnif demo: %s not found: run scripts/setup.sh (it fetches the HDR environments)\n",
                 hdr.c_str());
    return 1;
  }
  vk::ComputeContext ctx;
  if (Status s = ctx.init(/*ray_tracing=*/true, /*validation=*/false, device); !s) {
    std::fprintf(stderr, "lsnif demo: no usable Vulkan ray-tracing device for the render (`lsnif devices` tells "
                         "what is missing): %s\n", s.message().c_str());
    return 1;
  }
  CompareReport cmp;
  if (Status s = render_compare(ctx, object_on_ground(mesh, opts.output, hdr), rs, picture, cmp); !s) {
    std::fprintf(stderr, "lsnif demo: %s\n", s.message().c_str());
    return 1;
  }
  return 0;
}

}  // namespace lsnif::cli
