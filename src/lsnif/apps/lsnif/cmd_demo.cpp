// lsnif demo: the README's main job on the bundled default: train the CGAL bunny (or reuse the
// model), save it, evaluate it on held-out rays against exact ray casting and the voxel-only
// baseline, then render it on a ground quad under an HDR sky in reference mode (the fastest triangle
// path) and in LSNIF mode with the pipeline chosen for the scene and device (pipeline_option.h),
// and again with the inline pipeline, and print the FLIP, memory and time rows with side-by-side
// pictures (render_compare.h) and a summary of the three.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>

#include "lsnif/apps/lsnif/args.h"
#include "lsnif/apps/lsnif/commands.h"
#include "lsnif/format/atomic_file.h"
#include "lsnif/apps/lsnif/data_dir.h"
#include "lsnif/apps/lsnif/device_option.h"
#include "lsnif/apps/lsnif/pipeline_option.h"
#include "lsnif/train/evaluate.h"
#include "lsnif/import/mesh.h"
#include "lsnif/core/model.h"
#include "lsnif/apps/lsnif/render_compare.h"
#include "lsnif/vulkan/context.h"
#include "lsnif/apps/lsnif/train_options.h"
#include "lsnif/image/image_io.h"

namespace lsnif::cli {

namespace {

// "out/bunny_compare.png" -> "out/bunny_compare_inline.png".
std::string with_suffix(const std::string& path, const std::string& suffix) {
  const std::filesystem::path p(path);
  return (p.parent_path() / (p.stem().string() + suffix + p.extension().string())).string();
}

// One line of the summary: a render's path, time and geometry memory against the reference's.
void print_summary_row(const char* label, const render::RenderSettings& rs, const render::RenderStats& st,
                       const render::RenderStats& ref, const double* flip) {
  const uint64_t bytes = st.lsnif_bytes + st.triangle_blas_bytes;
  std::printf("  %-24s %-20s %10.2f %9.2fx %12.3f %9.2fx %8s\n", label,
              (std::string(render::pipeline_name(rs.pipeline)) + ", " + render::primary_name(rs.primary)).c_str(),
              st.ms_per_sample, st.ms_per_sample / std::max(1e-9, ref.ms_per_sample), double(bytes) / 1048576.0,
              double(ref.triangle_blas_bytes) / double(std::max<uint64_t>(1, bytes)),
              flip ? format("%.4f", *flip).c_str() : "-");
}

}  // namespace

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
  PathOptions path;
  Args args("demo", "Trains an LSNIF model of the bundled bunny (from scripts/setup.sh), writes it to\n"
                    "out/bunny.lsnif, evaluates it on held-out rays against exact ray casting, and renders it\n"
                    "in LSNIF and reference mode (FLIP, memory, time; out/bunny_compare.png).");
  args.option("data", "folder with meshes/ and hdr/ from scripts/setup.sh", &data_dir);
  args.option("mesh", "mesh to train, in --data unless given", &mesh_path);
  args.option("eval-rays", "held-out rays for the evaluation", &rays, 1, kMaxEvalRays);
  args.flag("reuse", "load the model from --output if it exists instead of training", &reuse);
  args.flag("no-render", "skip the rendering comparison", &no_render);
  args.option("image-width", "render width (--width is the network's hidden width)", &rs.width, 1, kMaxImageSide);
  args.option("image-height", "render height", &rs.height, 1, kMaxImageSide);
  args.option("spp", "render samples per pixel", &rs.spp, 1, kMaxSpp);
  args.option("hdr", "environment image for the render (empty: constant sky), in --data unless given", &hdr);
  args.option("picture", "side-by-side image (reference | LSNIF | FLIP)", &picture);
  add_device_option(args, &device);
  add_pipeline_option(args, &path.pipeline);
  add_primary_option(args, &path.primary);
  opts.add_to(args);
  if (int r = args.parse(argc, argv)) return r == 1 ? 0 : 2;
  if (!check_path_options("demo", path)) return 2;
  if (!no_render)
    if (Status s = image::check_image_extension(picture); !s) {
      std::fprintf(stderr, "lsnif demo: --picture: %s\n", s.message().c_str());
      return 2;
    }
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
  // The pictures are checked before the work too (their folder made as the model's is).
  if (!no_render) {
    const std::filesystem::path picture_parent = std::filesystem::path(picture).parent_path();
    if (!picture_parent.empty()) std::filesystem::create_directories(picture_parent, ec);
    for (const std::string& p : {picture, with_suffix(picture, "_inline")})
      if (Status s = check_output_path(p); !s) {
        std::fprintf(stderr, "lsnif demo: --picture: %s\n", s.message().c_str());
        return 1;
      }
  }
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
  vk::Context ctx;
  if (Status s = ctx.init(/*ray_tracing=*/true, /*validation=*/false, device); !s) {
    std::fprintf(stderr, "lsnif demo: no usable Vulkan ray-tracing device for the render (`lsnif devices` tells "
                         "what is missing): %s\n", s.message().c_str());
    return 1;
  }
  const scene::Scene scene = object_on_ground(mesh, opts.output, hdr);
  // The reference always takes the fastest triangle path; the LSNIF mode the choice for the scene
  // and device (or what --pipeline / --primary force), then the inline path for comparison.
  render::RenderChoice lsnif_path, reference_path;
  const uint64_t pixels = uint64_t(rs.width) * rs.height;
  if (!resolve_path_options("demo", path, ctx, scene, /*reference=*/false, pixels, lsnif_path) ||
      !resolve_path_options("demo", PathOptions(), ctx, scene, /*reference=*/true, pixels, reference_path))
    return 1;
  std::printf("\npipeline choice  LSNIF: %s\n                 reference: %s\n", lsnif_path.why.c_str(),
              reference_path.why.c_str());
  rs.pipeline = lsnif_path.pipeline;
  rs.primary = lsnif_path.primary;
  ReferenceRender reference;
  CompareReport cmp, inline_cmp;
  if (Status s = render_compare(ctx, scene, rs, picture, cmp, &reference, &reference_path); !s) {
    std::fprintf(stderr, "lsnif demo: %s\n", s.message().c_str());
    return 1;
  }
  render::RenderSettings inline_rs = rs;
  inline_rs.pipeline = render::PathPipeline::inline_rt;
  inline_rs.primary = render::PrimaryVisibility::traced;
  const bool second = inline_rs.pipeline != rs.pipeline || inline_rs.primary != rs.primary;
  if (second) {
    std::printf("\nthe inline path (networks in the intersection shader, traced camera rays), for comparison\n");
    if (Status s = render_compare(ctx, scene, inline_rs, with_suffix(picture, "_inline"), inline_cmp, &reference,
                                  &reference_path);
        !s) {
      std::fprintf(stderr, "lsnif demo: %s\n", s.message().c_str());
      return 1;
    }
  }
  std::error_code size_ec;
  const uint64_t file_bytes = std::filesystem::file_size(opts.output, size_ec);
  std::printf("\nsummary: %s, model %s (%.3f MiB file), %ux%u, %u spp on %s\n", mesh_path.c_str(),
              opts.output.c_str(), size_ec ? 0.0 : double(file_bytes) / 1048576.0, rs.width, rs.height, rs.spp,
              ctx.device_name().c_str());
  std::printf("  %-24s %-20s %10s %10s %12s %10s %8s\n", "", "pipeline, primary", "ms/sample", "time",
              "memory (MiB)", "smaller", "FLIP");
  render::RenderSettings ref_rs = rs;
  ref_rs.pipeline = reference_path.pipeline;
  ref_rs.primary = reference_path.primary;
  print_summary_row("reference (triangles)", ref_rs, cmp.reference, cmp.reference, nullptr);
  print_summary_row("LSNIF (default)", rs, cmp.lsnif, cmp.reference, &cmp.flip_mean);
  if (second) print_summary_row("LSNIF (inline path)", inline_rs, inline_cmp.lsnif, cmp.reference, &inline_cmp.flip_mean);
  std::printf("  (time: against the reference; smaller: the reference's triangle BLAS over the LSNIF render's "
              "geometry; FLIP: mean LDR-FLIP against the reference)\n");
  return 0;
}

}  // namespace lsnif::cli
