// pipeline_option.h -- the --pipeline, --broad-phase and --primary options of render, view and bench
// (render::PathPipeline, render::BroadPhase, render::PrimaryVisibility, docs/renderer.md): how the path tracer casts
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
              "every ray cast in batches through lsnifCmdQuery); the same estimator",
              name);
}

inline void add_broad_phase_option(Args& args, std::string* name) {
  args.option("broad-phase",
              "wavefront pipeline: how lsnifCmdQuery finds each ray's triangle hit and LSNIF candidates: auto (the "
              "plugin's choice), trace-rays (a ray-tracing pipeline; needs rayTraversalPrimitiveCulling) or ray-query "
              "(ray queries in a compute shader; needs VK_KHR_ray_query)",
              name);
}

// Parses the option's value; false (after a usage message naming `command`) on anything else.
inline bool parse_broad_phase_option(const char* command, const std::string& name, render::BroadPhase& out) {
  if (render::parse_broad_phase(name, out)) return true;
  std::fprintf(stderr, "lsnif %s: --broad-phase must be auto, trace-rays or ray-query, not '%s'\n", command,
               name.c_str());
  return false;
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
