// pipeline_option.h -- the --pipeline, --broad-phase and --primary options of render, view, bench
// and demo (render::PathPipeline, render::BroadPhase, render::PrimaryVisibility, docs/renderer.md):
// how the path tracer casts its rays and where its camera rays' hits come from. "auto", the
// default, takes render::choose_render_path's choice for the scene and device (render_choice.h).
#pragma once
#include <cstdio>
#include <string>

#include "lsnif/apps/lsnif/args.h"
#include "lsnif/renderer/render_choice.h"
#include "lsnif/renderer/renderer.h"

namespace lsnif::cli {

// --pipeline and --primary as given ("auto" or a forced choice).
struct PathOptions {
  std::string pipeline = "auto", primary = "auto";
};

void add_pipeline_option(Args& args, std::string* name);
void add_primary_option(Args& args, std::string* name);
void add_broad_phase_option(Args& args, std::string* name);

// True when --pipeline and --primary name a choice; else prints a usage message naming `command`.
bool check_path_options(const char* command, const PathOptions& given);

// The pipeline and primary visibility for `scene` in LSNIF (`reference` false) or reference mode on
// `ctx`'s device for images of `pixels` pixels: what --pipeline and --primary force, the rest chosen
// (its reason in out.why). False (message printed naming `command`) on a bad value or a failed
// device query.
bool resolve_path_options(const char* command, const PathOptions& given, const vk::Context& ctx,
                          const scene::Scene& scene, bool reference, uint64_t pixels, render::RenderChoice& out);

// Parses the option's value; false (after a usage message naming `command`) on anything else.
bool parse_broad_phase_option(const char* command, const std::string& name, render::BroadPhase& out);
// A forced --pipeline (inline / wavefront; "auto" is not one); false after a usage message.
bool parse_pipeline_option(const char* command, const std::string& name, render::PathPipeline& out);

}  // namespace lsnif::cli
