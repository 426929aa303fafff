// pipeline_option.h -- the --pipeline and --primary options of render, view and bench
// (render::PathPipeline, render::PrimaryVisibility, docs/renderer.md): how the path tracer casts
// its rays and where its camera rays' hits come from.
#pragma once
#include <cstdio>
#include <string>

#include "lsnif/apps/lsnif/args.h"
#include "lsnif/renderer/renderer.h"

namespace lsnif::cli {

inline void add_pipeline_option(Args& args, std::string* name) {
  args.option("pipeline",
              "inline (a ray-tracing pipeline, networks in the intersection shader) or wavefront (compute passes, "
              "every ray cast in batches through lsnifCmdQuery; needs VK_KHR_ray_query); the same estimator",
              name);
}

// Parses the option's value; false (after a usage message naming `command`) on anything else.
inline bool parse_pipeline_option(const char* command, const std::string& name, render::PathPipeline& out) {
  if (render::parse_pipeline(name, out)) return true;
  std::fprintf(stderr, "lsnif %s: --pipeline must be inline or wavefront, not '%s'\n", command, name.c_str());
  return false;
}

inline void add_primary_option(Args& args, std::string* name) {
  args.option("primary",
              "traced (camera rays through the TLAS, LSNIF objects answered by their networks) or raster (a graphics "
              "pass draws every object's triangles, LSNIF nodes their kept meshes from lsnif convert --keep-meshes, "
              "into a visibility buffer the paths start from; secondary and shadow rays are traced)",
              name);
}

// Parses the option's value; false (after a usage message naming `command`) on anything else.
inline bool parse_primary_option(const char* command, const std::string& name, render::PrimaryVisibility& out) {
  if (render::parse_primary(name, out)) return true;
  std::fprintf(stderr, "lsnif %s: --primary must be traced or raster, not '%s'\n", command, name.c_str());
  return false;
}

}  // namespace lsnif::cli
