// render_choice.h -- the renderer's automatic choice of pipeline and primary visibility for a scene
// on a device (`--pipeline auto`, `--primary auto` of lsnif render, view, bench and demo): the
// fastest correct way measured (docs/renderer.md, "Choosing the pipeline").
//
// - LSNIF mode with LSNIF nodes: the wavefront pipeline (the networks in batches through
//   lsnifCmdQuery: 1.2-3.3x the inline pipeline's speed in docs/bench-scenes.md) where the device
//   runs a broad phase of lsnifCmdQuery (ray queries, or rayTraversalPrimitiveCulling), else inline.
//   Primary visibility rasterized where every LSNIF node keeps a triangle mesh the visibility pass
//   can draw and the queue has graphics (the paper's section 4: camera rays never meet a network),
//   else traced.
// - A scene whose instanced meshes use an alpha cut-out material: inline and traced (the only path
//   that alpha-tests triangles).
// - Reference mode, or no LSNIF node: the inline pipeline, traced (the fastest triangle path: a
//   ray-tracing pipeline traverses triangles ~2x faster than ray queries on lavapipe).
#pragma once
#include <string>

#include "lsnif/format/status.h"
#include "lsnif/harness/vk_compute.h"
#include "lsnif/renderer/renderer.h"
#include "lsnif/renderer/scene.h"

namespace lsnif::render {

struct RenderChoice {
  PathPipeline pipeline = PathPipeline::inline_rt;
  PrimaryVisibility primary = PrimaryVisibility::traced;
  std::string why;  // what decided, one line ("wavefront: the device runs lsnifCmdQuery (ray queries); ...")
};

// What the device offers that the choice depends on (device_paths).
struct DevicePaths {
  bool query = false;     // lsnifCmdQuery can run: ray queries or rayTraversalPrimitiveCulling
  bool ray_query = false;
  bool graphics = false;  // the context's queue family has graphics (the visibility pass)
};
// What `ctx` (initialized with ray tracing) offers. Fails when the plugin's device query does.
Status device_paths(const vk::ComputeContext& ctx, DevicePaths& out);

// The choice for `scene` in LSNIF mode (`reference` false) or reference mode on a device offering
// `paths` (rules above).
RenderChoice choose_render_path(const scene::Scene& scene, bool reference, const DevicePaths& paths);

// Why a node keeps no mesh the visibility pass can draw ("" when every LSNIF node keeps one).
std::string raster_obstacle(const scene::Scene& scene);

// The name of the first alpha cut-out material (scene::Material::alpha_cutoff > 0) a primitive of an
// instanced mesh uses, "" when none. Only the inline pipeline's traced rays alpha-test triangles
// (render_triangle.rahit): such a scene is rendered inline and traced.
std::string cutout_material(const scene::Scene& scene);

}  // namespace lsnif::render
