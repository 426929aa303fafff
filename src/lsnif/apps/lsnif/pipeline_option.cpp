// pipeline_option.cpp -- see pipeline_option.h.
#include "lsnif/apps/lsnif/pipeline_option.h"

#include "lsnif/format/status.h"

namespace lsnif::cli {

void add_pipeline_option(Args& args, std::string* name) {
  args.option("pipeline",
              "auto (the fastest correct one for the scene and device, printed: wavefront where the device runs "
              "lsnifCmdQuery, docs/renderer.md), inline (a ray-tracing pipeline, networks in the intersection "
              "shader) or wavefront (compute passes, every ray cast in batches through lsnifCmdQuery); the same "
              "estimator",
              name);
}

void add_primary_option(Args& args, std::string* name) {
  args.option("primary",
              "auto (raster where every LSNIF node keeps its mesh and the queue has graphics, else traced; "
              "reference mode: traced), traced (camera rays through the TLAS, LSNIF objects answered by their "
              "networks) or raster (a graphics pass draws every object's triangles, LSNIF nodes their kept meshes "
              "from lsnif convert --keep-meshes, into a visibility buffer the paths start from; secondary and "
              "shadow rays are traced)",
              name);
}

void add_broad_phase_option(Args& args, std::string* name) {
  args.option("broad-phase",
              "wavefront pipeline: how lsnifCmdQuery finds each ray's triangle hit and LSNIF candidates: auto (the "
              "plugin's choice), trace-rays (a ray-tracing pipeline; needs rayTraversalPrimitiveCulling) or ray-query "
              "(ray queries in a compute shader; needs VK_KHR_ray_query)",
              name);
}

bool parse_broad_phase_option(const char* command, const std::string& name, render::BroadPhase& out) {
  if (render::parse_broad_phase(name, out)) return true;
  std::fprintf(stderr, "lsnif %s: --broad-phase must be auto, trace-rays or ray-query, not '%s'\n", command,
               printable(name).c_str());
  return false;
}

bool parse_pipeline_option(const char* command, const std::string& name, render::PathPipeline& out) {
  if (render::parse_pipeline(name, out)) return true;
  std::fprintf(stderr, "lsnif %s: --pipeline must be auto, inline or wavefront, not '%s'\n", command,
               printable(name).c_str());
  return false;
}

bool check_path_options(const char* command, const PathOptions& given) {
  render::PathPipeline pipeline;
  render::PrimaryVisibility primary;
  if (given.pipeline != "auto" && !parse_pipeline_option(command, given.pipeline, pipeline)) return false;
  if (given.primary != "auto" && !render::parse_primary(given.primary, primary)) {
    std::fprintf(stderr, "lsnif %s: --primary must be auto, traced or raster, not '%s'\n", command,
                 printable(given.primary).c_str());
    return false;
  }
  return true;
}

bool resolve_path_options(const char* command, const PathOptions& given, const vk::Context& ctx,
                          const scene::Scene& scene, bool reference, uint64_t pixels, render::RenderChoice& out) {
  if (!check_path_options(command, given)) return false;
  render::RenderChoice choice;
  if (given.pipeline == "auto" || given.primary == "auto") {
    render::DevicePaths paths;
    if (Status s = render::device_paths(ctx, paths); !s) {
      std::fprintf(stderr, "lsnif %s: asking the device what it runs: %s\n", command, s.message().c_str());
      return false;
    }
    choice = render::choose_render_path(scene, reference, paths, pixels);
  }
  std::string forced;
  if (given.pipeline != "auto") {
    render::parse_pipeline(given.pipeline, choice.pipeline);
    forced = "--pipeline " + given.pipeline;
  }
  if (given.primary != "auto") {
    render::parse_primary(given.primary, choice.primary);
    forced += (forced.empty() ? "--primary " : " and --primary ") + given.primary;
  }
  if (given.pipeline != "auto" && given.primary != "auto") choice.why = "forced by " + forced;
  else if (!forced.empty()) choice.why = "forced by " + forced + "; the rest chosen: " + choice.why;
  out = choice;
  return true;
}

}  // namespace lsnif::cli
