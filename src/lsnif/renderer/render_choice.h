// render_choice.h -- the renderer's automatic choice of pipeline and primary visibility for a scene
// on a device (`--pipeline auto`, `--primary auto` of lsnif render, view, bench and demo): the
// fastest correct way measured (docs/renderer.md, "Choosing the pipeline").
//
// - LSNIF mode with LSNIF nodes: the wavefront pipeline (the networks in batches through
//   lsnifCmdQuery: 1.2-3.3x the inline pipeline's speed in docs/bench-scenes.md) where the device
//   runs a broad phase of lsnifCmdQuery (ray queries, or rayTraversalPrimitiveCulling), else inline.
//   Primary visibility rasterized where every LSNIF node keeps a triangle mesh the visibility pass
//   can draw and the queue has graphics (the paper's section 4: camera rays never meet a network),
//   except on a CPU device when the pass would draw more than kCpuRasterTrianglesPerPixel triangles
//   per pixel (there rasterizing costs more than tracing the camera rays: measured below); else
//   traced.
// - LSNIF mode where a node traced as triangles (not an LSNIF node) uses an alpha cut-out material:
//   the inline pipeline (its any-hit shaders alpha-test triangles; lsnifCmdQuery does not), primary
//   visibility as above (the visibility pass alpha-tests too). An LSNIF node's cut-outs are
//   geometry in its model and change nothing.
// - Reference mode, or no LSNIF node: the inline pipeline, traced (the fastest triangle path: a
//   ray-tracing pipeline traverses triangles ~2x faster than ray queries on lavapipe).
#pragma once
#include <string>

#include "lsnif/format/status.h"
#include "lsnif/vulkan/context.h"
#include "lsnif/renderer/renderer.h"
#include "lsnif/scene/scene.h"

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
  bool cpu = false;       // a CPU device (VK_PHYSICAL_DEVICE_TYPE_CPU: lavapipe)
};

// Above this many triangles per pixel, a CPU device traces the camera rays rather than rasterize
// them. Measured on lavapipe (docs/renderer.md, "Choosing the pipeline"): the visibility pass costs
// ~0.12 us per triangle drawn (388 ms for the heavy bench scene's 3.32M at 320 x 240) and traced
// camera rays ~1.3 us per pixel, so they break even near 11 triangles per pixel. A GPU's
// rasterizer is not bound by it (no GPU has measured it yet).
inline constexpr double kCpuRasterTrianglesPerPixel = 10.0;

// Triangles the visibility pass draws for `scene` (every node's mesh, LSNIF nodes their kept ones).
uint64_t raster_triangles(const scene::Scene& scene);
// What `ctx` (initialized with ray tracing) offers. Fails when the plugin's device query does.
Status device_paths(const vk::Context& ctx, DevicePaths& out);

// The choice for `scene` in LSNIF mode (`reference` false) or reference mode on a device offering
// `paths` (rules above), for images of `pixels` pixels.
RenderChoice choose_render_path(const scene::Scene& scene, bool reference, const DevicePaths& paths, uint64_t pixels);

// Why a node keeps no mesh the visibility pass can draw ("" when every LSNIF node keeps one).
std::string raster_obstacle(const scene::Scene& scene);

// The name of the first alpha cut-out material (scene::Material::cutoff() > 0) a primitive of the
// mesh of a node traced as triangles uses, "" when none: in reference mode (`reference`) every node
// with a mesh, in LSNIF mode the nodes without an LSNIF object. The wavefront pipeline's
// lsnifCmdQuery does not alpha-test triangles: the renderer refuses it for such a mode.
std::string cutout_material(const scene::Scene& scene, bool reference);

}  // namespace lsnif::render
