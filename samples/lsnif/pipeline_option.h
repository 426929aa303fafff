// pipeline_option.h -- the --pipeline option of render, view and bench (render::PathPipeline,
// docs/renderer.md): how the path tracer casts its rays.
#pragma once
#include <cstdio>
#include <string>

#include "args.h"
#include "renderer.h"

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

}  // namespace lsnif::cli
