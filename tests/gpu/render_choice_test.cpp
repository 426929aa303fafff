// The automatic choice of pipeline and primary visibility (src/lsnif/renderer/render_choice.h) on
// scenes built here (no device: the choice is a rule over the scene and what the device offers):
// the triangles the visibility pass would draw, counted per instance, against the image's pixels on
// a CPU device, and what a GPU, a missing queue capability or a node without a mesh change.
#include "lsnif/renderer/render_choice.h"

#include <gtest/gtest.h>

namespace lsnif::render {
namespace {

// `instances` LSNIF nodes sharing one kept mesh of `triangles` triangles (a fan; the choice never
// reads positions).
scene::Scene scene_of(uint32_t instances, uint32_t triangles) {
  scene::Scene s;
  scene::Mesh mesh;
  scene::Primitive p;
  p.positions.resize(triangles + 2);
  for (uint32_t t = 0; t < triangles; ++t) p.indices.insert(p.indices.end(), {0, t + 1, t + 2});
  mesh.primitives.push_back(std::move(p));
  s.meshes.push_back(std::move(mesh));
  s.materials.emplace_back();
  for (uint32_t i = 0; i < instances; ++i) {
    scene::Instance in;
    in.node_name = "object_" + std::to_string(i);
    in.mesh = 0;
    in.lsnif = 0;
    s.instances.push_back(in);
  }
  return s;
}

DevicePaths lavapipe_like() {
  DevicePaths p;
  p.query = p.ray_query = p.graphics = p.cpu = true;
  return p;
}

TEST(RenderChoice, RasterTrianglesCountEveryInstance) {
  EXPECT_EQ(raster_triangles(scene_of(1, 1000)), 1000u);
  EXPECT_EQ(raster_triangles(scene_of(7, 1000)), 7000u);
  scene::Scene s = scene_of(2, 10);
  s.instances[1].mesh = -1;  // an LSNIF node without a kept mesh draws nothing
  EXPECT_EQ(raster_triangles(s), 10u);
}

TEST(RenderChoice, ACpuDeviceTracesTheCameraRaysAboveTenTrianglesPerPixel) {
  const uint64_t pixels = 320 * 240;
  // Just above and just below kCpuRasterTrianglesPerPixel per pixel, in four instances.
  const uint32_t above = uint32_t(kCpuRasterTrianglesPerPixel * double(pixels) / 4.0) + 1;
  const uint32_t below = uint32_t(kCpuRasterTrianglesPerPixel * double(pixels) / 4.0) - 1;
  RenderChoice c = choose_render_path(scene_of(4, above), /*reference=*/false, lavapipe_like(), pixels);
  EXPECT_EQ(c.pipeline, PathPipeline::wavefront);
  EXPECT_EQ(c.primary, PrimaryVisibility::traced) << c.why;
  EXPECT_NE(c.why.find("triangles per pixel to rasterize"), std::string::npos) << c.why;
  c = choose_render_path(scene_of(4, below), false, lavapipe_like(), pixels);
  EXPECT_EQ(c.primary, PrimaryVisibility::raster) << c.why;
  // The same scene on a larger image has fewer triangles per pixel.
  c = choose_render_path(scene_of(4, above), false, lavapipe_like(), 2 * pixels);
  EXPECT_EQ(c.primary, PrimaryVisibility::raster) << c.why;
}

TEST(RenderChoice, OtherDevicesAndScenesKeepTheirRules) {
  DevicePaths gpu = lavapipe_like();
  gpu.cpu = false;
  RenderChoice c = choose_render_path(scene_of(1, 1000000), false, gpu, 100);
  EXPECT_EQ(c.primary, PrimaryVisibility::raster) << "a GPU rasterizes: " << c.why;
  DevicePaths no_graphics = lavapipe_like();
  no_graphics.graphics = false;
  c = choose_render_path(scene_of(1, 10), false, no_graphics, 1000);
  EXPECT_EQ(c.primary, PrimaryVisibility::traced);
  EXPECT_NE(c.why.find("no graphics"), std::string::npos) << c.why;
  scene::Scene no_mesh = scene_of(1, 10);
  no_mesh.instances[0].mesh = -1;
  c = choose_render_path(no_mesh, false, lavapipe_like(), 1000);
  EXPECT_EQ(c.primary, PrimaryVisibility::traced);
  EXPECT_NE(c.why.find("keeps no triangle mesh"), std::string::npos) << c.why;
  c = choose_render_path(scene_of(1, 10), /*reference=*/true, lavapipe_like(), 1000);
  EXPECT_EQ(c.pipeline, PathPipeline::inline_rt);
  EXPECT_EQ(c.primary, PrimaryVisibility::traced);
}

}  // namespace
}  // namespace lsnif::render
