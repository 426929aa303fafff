// render_choice.cpp -- see render_choice.h.
#include "lsnif/renderer/render_choice.h"

#include <algorithm>
#include <vector>

#include "lsnif/vulkan/device_choice.h"
#include "lsnif/renderer/shaders/render_host_device.h"

namespace lsnif::render {

Status device_paths(const vk::Context& ctx, DevicePaths& out) {
  vk::DeviceInfo info;
  if (Status s = vk::query_device_info(ctx.instance(), ctx.physical_device(), info); !s) return s;
  DevicePaths p;
  p.ray_query = info.ray_query;
  VkPhysicalDeviceProperties props;
  vkGetPhysicalDeviceProperties(ctx.physical_device(), &props);
  p.cpu = props.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU;
  p.query = info.ray_query || info.primitive_culling;
  uint32_t count = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(ctx.physical_device(), &count, nullptr);
  std::vector<VkQueueFamilyProperties> families(count);
  vkGetPhysicalDeviceQueueFamilyProperties(ctx.physical_device(), &count, families.data());
  p.graphics = ctx.queue_family() < count && (families[ctx.queue_family()].queueFlags & VK_QUEUE_GRAPHICS_BIT);
  out = p;
  return Status::ok();
}

std::string raster_obstacle(const scene::Scene& scene) {
  for (const scene::Instance& in : scene.instances) {
    if (in.lsnif < 0) continue;
    if (in.mesh < 0 || size_t(in.mesh) >= scene.meshes.size() || scene.meshes[size_t(in.mesh)].primitives.empty())
      return "LSNIF node '" + in.node_name + "' keeps no triangle mesh (lsnif convert --keep-meshes keeps them)";
    if (scene.meshes[size_t(in.mesh)].primitives.size() > RENDER_VISIBILITY_MAX_PRIMITIVES)
      return "the mesh of LSNIF node '" + in.node_name + "' has more primitives than the visibility pass draws";
  }
  return "";
}

uint64_t raster_triangles(const scene::Scene& scene) {
  uint64_t n = 0;
  for (const scene::Instance& in : scene.instances) {
    if (in.mesh < 0 || size_t(in.mesh) >= scene.meshes.size()) continue;
    for (const scene::Primitive& p : scene.meshes[size_t(in.mesh)].primitives) n += p.indices.size() / 3;
  }
  return n;
}

std::string cutout_material(const scene::Scene& scene, bool reference) {
  for (const scene::Instance& in : scene.instances) {
    if ((in.lsnif >= 0 && !reference) || in.mesh < 0 || size_t(in.mesh) >= scene.meshes.size()) continue;
    for (const scene::Primitive& p : scene.meshes[size_t(in.mesh)].primitives)
      if (p.material < scene.materials.size() && scene.materials[p.material].cutoff() > 0.0f)
        return scene.materials[p.material].name;
  }
  return "";
}

RenderChoice choose_render_path(const scene::Scene& scene, bool reference, const DevicePaths& paths, uint64_t pixels) {
  RenderChoice c;
  bool lsnif_nodes = false;
  for (const scene::Instance& in : scene.instances) lsnif_nodes |= in.lsnif >= 0;
  if (reference || !lsnif_nodes) {
    c.why = reference ? "reference mode: the fastest triangle path (inline, traced)"
                      : "no LSNIF node: the fastest triangle path (inline, traced)";
    return c;
  }
  const std::string cutout = cutout_material(scene, /*reference=*/false);
  if (!cutout.empty()) {
    c.why = "inline: material '" + printable(cutout) +
            "' is an alpha cut-out on triangles, which lsnifCmdQuery does not alpha-test";
  } else if (paths.query) {
    c.pipeline = PathPipeline::wavefront;
    c.why = paths.ray_query ? "wavefront: the device runs lsnifCmdQuery (ray-query broad phase)"
                            : "wavefront: the device runs lsnifCmdQuery (ray-tracing broad phase)";
  } else {
    c.why = "inline: the device runs no broad phase of lsnifCmdQuery (no ray queries, no "
            "rayTraversalPrimitiveCulling)";
  }
  const std::string obstacle = raster_obstacle(scene);
  const double per_pixel = double(raster_triangles(scene)) / double(std::max<uint64_t>(pixels, 1));
  if (!paths.graphics) {
    c.why += "; traced primary: the queue has no graphics";
  } else if (!obstacle.empty()) {
    c.why += "; traced primary: " + obstacle;
  } else if (paths.cpu && per_pixel > kCpuRasterTrianglesPerPixel) {
    c.why += format("; traced primary: %.3g triangles per pixel to rasterize, more than a CPU device rasterizes "
                    "faster than it traces (%.3g)", per_pixel, kCpuRasterTrianglesPerPixel);
  } else {
    c.primary = PrimaryVisibility::raster;
    c.why += "; rasterized primary: every LSNIF node keeps its mesh";
  }
  return c;
}

}  // namespace lsnif::render
