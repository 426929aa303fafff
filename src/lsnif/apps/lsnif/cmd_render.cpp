// lsnif render SCENE: headless path tracing of a glTF scene with LSNIF objects (or, with
// --reference, their triangle meshes) on the Vulkan device; writes an EXR or PNG.
#include <cstdio>
#include <string>

#include "lsnif/apps/lsnif/args.h"
#include "lsnif/apps/lsnif/commands.h"
#include "lsnif/apps/lsnif/device_option.h"
#include "lsnif/scene/environment.h"
#include "lsnif/image/image_io.h"
#include "lsnif/apps/lsnif/pipeline_option.h"
#include "lsnif/apps/common/progress.h"
#include "lsnif/renderer/renderer.h"
#include "lsnif/apps/lsnif/scene_args.h"
#include "lsnif/vulkan/context.h"

namespace lsnif::cli {

int cmd_render(int argc, char** argv) {
  std::string output = "render.png", device, broad_phase_name = "auto";
  PathOptions path;
  bool validation = false;
  // The options bind to the render's settings; `lsnif render` makes a larger, cleaner image than
  // the renderer's default (render_defaults.h: the image of `lsnif demo` and the benchmarks).
  render::RenderSettings settings;
  settings.width = 640;
  settings.height = 480;
  settings.spp = 64;
  SceneArgs sa;
  Args args("render",
            "Path traces a glTF scene on the Vulkan device: nodes with an LSNIF object (the scene's "
            "LSNIF_neural_object extension or --lsnif) are traced through the LSNIF plugin, all others as "
            "triangles; --reference traces every node as triangles with the same random sequences. Image-based "
            "lighting from the scene's LSNIF_environment or --env; Lambert + GGX materials. Writes .exr (linear) "
            "or .png (sRGB). Reports time per sample and the device memory of the geometry.");
  sa.add_to(args);
  args.option("output", "output image (.exr, .hdr, .png)", &output);
  args.alias("-o", "output");
  args.flag("reference", "trace LSNIF nodes as their triangle meshes", &settings.reference);
  args.option("width", "image width", &settings.width, 1, kMaxImageSide);
  args.option("height", "image height", &settings.height, 1, kMaxImageSide);
  args.option("spp", "samples per pixel", &settings.spp, 1, kMaxSpp);
  args.option("bounces", "bounces after the camera ray (the paper's 4)", &settings.max_bounces, 0, kMaxBounces);
  add_pipeline_option(args, &path.pipeline);
  add_broad_phase_option(args, &broad_phase_name);
  args.flag("stage-times", "with --pipeline wavefront: time its stages on the device (timestamps) and report them",
            &settings.stage_times);
  add_primary_option(args, &path.primary);
  args.flag("validation", "enable the Khronos validation layer (slow; exit 1 on any message)", &validation);
  add_device_option(args, &device);
  if (int r = args.parse(argc, argv)) return r == 1 ? 0 : 2;
  if (!check_path_options("render", path)) return 2;
  if (settings.stage_times && path.pipeline == "inline") {
    std::fprintf(stderr, "lsnif render: --stage-times needs the wavefront pipeline (the inline pipeline is one launch)\n");
    return 2;
  }
  if (!parse_broad_phase_option("render", broad_phase_name, settings.broad_phase)) return 2;

  // The image's place and format are checked before the render, not after it.
  if (int r = sa.check_output("render", "-o", output)) return r;
  if (Status s = image::check_image_extension(output); !s) {
    std::fprintf(stderr, "lsnif render: -o: %s\n", s.message().c_str());
    return 2;
  }
  scene::Scene scene;
  scene::EnvironmentMap environment;
  if (int r = sa.load("render", scene, environment)) return r;

  vk::Context ctx;
  vk::ContextOptions context_options = render::context_options(validation, device);
  context_options.on_validation_message = print_validation_message;
  if (Status s = ctx.init(context_options); !s) {
    std::fprintf(stderr, "lsnif render: no usable Vulkan ray-tracing device (`lsnif devices` tells what is missing): %s\n",
                 s.message().c_str());
    return 1;
  }
  render::RenderChoice choice;
  if (!resolve_path_options("render", path, ctx, scene, settings.reference,
                            uint64_t(settings.width) * settings.height, choice))
    return 1;
  if (settings.stage_times && choice.pipeline != render::PathPipeline::wavefront) {
    std::fprintf(stderr, "lsnif render: --stage-times needs the wavefront pipeline, and the choice is %s (%s)\n",
                 render::pipeline_name(choice.pipeline), choice.why.c_str());
    return 2;
  }
  settings.pipeline = choice.pipeline;
  settings.primary = choice.primary;
  settings.camera = sa.camera_index();
  settings.environment = environment.width ? &environment : nullptr;
  render::Renderer renderer(ctx);
  image::Image out;
  render::RenderStats stats;
  ProgressBar bar(settings.reference ? "render (reference)" : "render (LSNIF)", settings.spp);
  const Status s = renderer.render(scene, settings, out, stats, [&](uint32_t done) { bar.update(done); });
  if (!s) {
    std::fprintf(stderr, "\nlsnif render: %s\n", s.message().c_str());
    return 1;
  }
  bar.finish();
  if (Status w = image::save_image(output, out); !w) {
    std::fprintf(stderr, "lsnif render: %s\n", w.message().c_str());
    return 1;
  }
  std::printf("scene            %s (%s mode, %s pipeline, %s primary)\n", sa.scene_path.c_str(),
              settings.reference ? "reference" : "LSNIF", render::pipeline_name(settings.pipeline),
              render::primary_name(settings.primary));
  std::printf("pipeline choice  %s\n", choice.why.c_str());
  std::printf("device           %s\n", ctx.device_name().c_str());
  if (settings.pipeline == render::PathPipeline::wavefront)
    std::printf("broad phase      %s (lsnifCmdQuery)\n", render::broad_phase_name(stats.broad_phase));
  std::printf("image            %s, %ux%u, %u spp, %u bounces\n", output.c_str(), settings.width, settings.height,
              settings.spp, settings.max_bounces);
  std::printf("time             %.2f s, %.2f ms per sample (%.3g s per frame of 1 spp)\n", stats.seconds,
              stats.ms_per_sample, stats.ms_per_sample / 1000.0);
  if (stats.has_stages)
    std::printf("stages (device)  ms per sample: %s\n", render::describe(stats.stages).c_str());
  std::printf("instances        %u triangle (BLAS records), %u LSNIF (%u models)\n", stats.triangle_instances,
              stats.lsnif_instances, stats.lsnif_models);
  std::printf("device memory    triangle BLAS %.3f MiB (%llu triangles), LSNIF models %.3f MiB, TLAS %.3f MiB\n",
              double(stats.triangle_blas_bytes) / 1048576.0, (unsigned long long)stats.triangles,
              double(stats.lsnif_bytes) / 1048576.0, double(stats.tlas_bytes) / 1048576.0);
  if (validation && (ctx.validation_errors() || ctx.validation_warnings())) {
    std::fprintf(stderr, "lsnif render: validation reported %u errors and %u warnings\n", ctx.validation_errors(),
                 ctx.validation_warnings());
    return 1;
  }
  return 0;
}

}  // namespace lsnif::cli
