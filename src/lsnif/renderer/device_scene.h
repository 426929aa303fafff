// device_scene.h -- the scene on the device (DeviceScene, built by build_device_scene in
// device_scene.cpp) and what the Renderer's passes share: renderer.cpp (inline pipeline,
// accumulation), renderer_wavefront.cpp (the wavefront pipeline). Internal to lsnif_render, not
// installed.
#pragma once
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

#include "lsnif/vulkan/plugin_device.h"  // volk first: lsnif.h then uses its Vulkan declarations
#include "lsnif/lsnif.hpp"
#include "lsnif/renderer/renderer.h"
#include "lsnif/renderer/shaders/render_host_device.h"

namespace lsnif::render {

// A vk::Spirv of `bytes` of `code` (a shader compiled at build time, cmake/LsnifShaders.cmake).
inline vk::Spirv spirv(const uint32_t* code, size_t bytes) {
  vk::Spirv s;
  s.code = code;
  s.bytes = bytes;
  return s;
}

// The plugin's last error as a Status (after a failed call of the C API).
inline Status plugin_error(const char* what) { return Status::error("%s: %s", what, lsnifGetLastErrorMessage()); }

// True when every element of `m` is finite.
inline bool finite(const glm::mat4& m) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(m[c][r])) return false;
  return true;
}

// Row-major 3x4 of an affine glm matrix (a TLAS record's transform).
inline VkTransformMatrixKHR to_3x4(const glm::mat4& m) {
  VkTransformMatrixKHR xf;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) xf.matrix[r][c] = m[c][r];
  return xf;
}

// Everything set_scene allocates on the device, and what a pass needs of the scene; released by
// the destructor.
struct DeviceScene {
  vk::Context& ctx;
  vk::RayTracer& tracer;
  plugin::Context plugin;
  std::vector<plugin::Model> models;     // per LSNIF object of the scene: its device model (or empty)
  std::vector<vk::Buffer> buffers;
  std::vector<vk::AccelerationStructure> blases;
  // What one mode (LSNIF: 0, reference: 1) traces: its TLAS over the shared BLASes and models, and
  // the tables its shaders read. set_mode switches between prepared modes without uploads.
  struct Mode {
    bool ready = false;
    std::string why_not;                  // set_scene's error for a mode it could not prepare
    vk::AccelerationStructure tlas;
    std::vector<VkAccelerationStructureInstanceKHR> records;  // TLAS records; record i has custom index i
    std::vector<int64_t> record_model;     // per record: index into `models` (LSNIF) or -1 (triangles)
    std::vector<std::pair<size_t, size_t>> instance_records;  // per scene instance: first record, count
    uint64_t instances = 0, material_maps = 0;  // RenderFrame::instances, material_maps of the mode
    uint64_t table_address = 0;
    uint32_t table_count = 0;              // entries of the model table
    std::vector<LsnifModel> table_models;  // per table entry: its model, null for triangle instances
    uint64_t world_to_object = 0;          // RenderFrame::world_to_object of the mode (per custom index)
    glm::mat3* world_to_object_mapped = nullptr;
    RenderStats stats;                     // what the mode uses (times 0)
    // Rasterized primary visibility: every record's triangle lists (an LSNIF record: its node's
    // mesh), or why the mode cannot be rasterized (an LSNIF node without a mesh).
    std::vector<VisibilityDraw> raster_draws;
    std::string raster_why_not;
    // The first alpha cut-out material (scene::Material::cutoff() > 0) among the mode's triangle
    // records, "" when none: the inline pipeline's rays alpha-test them (render_triangle.rahit) and
    // the visibility pass does, but lsnifCmdQuery, which the wavefront pipeline casts its rays
    // through, treats every triangle as opaque. (An LSNIF record's cut-outs are in its model.)
    std::string cutout_material;
  };
  Mode modes[2];
  int active = 0;
  RenderFrame frame{};                    // the scene's part filled in; view and image set per pass
  RenderFrame* frame_on_device = nullptr;  // mapped RenderFrame buffer
  uint64_t frame_address = 0;
  LsnifQueryPipeline query = nullptr;      // the wavefront pipeline's lsnifCmdQuery, made on first use
  glm::vec3 lo{0.0f}, hi{0.0f};           // world bounds (for a framing camera)
  std::vector<scene::Camera> cameras;
  float env_rotation = 0.0f;
  Mode& mode() { return modes[active]; }
  DeviceScene(vk::Context& c, vk::RayTracer& t) : ctx(c), tracer(t) {}
  ~DeviceScene() {
    if (query) lsnifDestroyQueryPipeline(plugin.get(), query);
    for (Mode& m : modes) tracer.destroy(m.tlas);
    for (vk::AccelerationStructure& b : blases) tracer.destroy(b);
    for (vk::Buffer& b : buffers) ctx.destroy_buffer(b);
    models.clear();  // before their context
    plugin.reset();
  }
  // A host-visible buffer holding `bytes` of `data` (zeroed when data is null); its device address.
  Status upload(const void* data, size_t bytes, uint64_t& address, VkBufferUsageFlags extra = 0) {
    vk::Buffer b;
    if (Status s = ctx.create_buffer(bytes, b, extra); !s) return s;
    if (data && bytes) std::memcpy(b.mapped, data, bytes);
    address = b.address;
    buffers.push_back(b);
    return Status::ok();
  }
  template <class T>
  Status upload(const std::vector<T>& v, uint64_t& address) {
    return upload(v.empty() ? nullptr : v.data(), v.size() * sizeof(T), address);
  }
};

// The Renderer's counters of device work (renderer.h: models loaded, BLASes and TLASes built).
struct SceneBuildCounts {
  uint32_t& models_loaded;
  uint32_t& blases_built;
  uint32_t& tlases_built;
};

// `scene` on the device for mode `reference` (and, with both_modes, the other one where the scene
// has its geometry; its error is kept for set_mode) into `out`: the scene's checks (every node's
// transform, indices, meshes and material maps, naming what is wrong), the models, materials,
// textures, triangle BLASes and each mode's TLAS and tables, the frame's scene part and world
// bounds. Triangle hit groups start at `triangle_sbt_offset` of the inline pipeline's table.
Status build_device_scene(vk::Context& ctx, vk::RayTracer& tracer, const scene::Scene& scene, bool reference,
                          const scene::EnvironmentMap* environment, bool both_modes, uint32_t triangle_sbt_offset,
                          SceneBuildCounts counts, std::unique_ptr<DeviceScene>& out);

}  // namespace lsnif::render
