// visibility_buffer.h -- rasterized primary visibility (the paper's section 4): a headless graphics
// pass (src/lsnif/renderer/shaders/render_visibility.vert/.frag, an offscreen render pass, no swapchain) that draws
// triangle lists into a visibility buffer -- per pixel the TLAS record (and mesh primitive of it),
// the triangle, its barycentrics and the distance from the camera, the closest surface kept by a
// depth attachment -- once per sample with that sample's camera jitter folded into the projection,
// and copies it to host-visible buffers the path tracer's camera stage reads
// (src/lsnif/renderer/shaders/render_visibility.glsl).
#pragma once
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "lsnif/renderer/shaders/render_host_device.h"
#include "lsnif/format/status.h"
#include "lsnif/vulkan/context.h"

namespace lsnif::render {

// One triangle list to draw: RenderVisibility::instance it writes, its object-space vertex data
// (float3 positions, uint32 indices, 3 per triangle) and where it stands. `alpha_test`: its
// material is an alpha cut-out; the fragments in holes are discarded (RenderRasterPush::alpha_test).
struct VisibilityDraw {
  uint32_t instance = 0;
  uint64_t positions = 0, indices = 0;
  uint32_t triangles = 0;
  glm::mat4 object_to_world{1.0f};
  bool alpha_test = false;
};

// The pinhole camera of the traced camera rays (render_path_start).
struct VisibilityCamera {
  glm::mat4 camera_to_world{1.0f};  // looks down -z
  float tan_half_fov_y = 0.4f, aspect = 1.0f;
  float near_plane = 1e-4f;         // closer surfaces are clipped
};

class VisibilityBuffer {
 public:
  explicit VisibilityBuffer(vk::Context& ctx) : ctx_(ctx) {}
  ~VisibilityBuffer();
  VisibilityBuffer(const VisibilityBuffer&) = delete;
  VisibilityBuffer& operator=(const VisibilityBuffer&) = delete;

  // Rasterizes `draws` for samples first_sample .. first_sample + samples - 1 into layers 0 ..
  // samples - 1 of a width x height visibility buffer (texels(), distances()), and waits. `frame`
  // is the device address of the RenderFrame whose tables the alpha test of the draws with
  // alpha_test reads (its instance table indexed by the draws' instance). Fails on a zero size, a
  // device whose queue cannot do graphics, an alpha-tested draw without a frame, or a device error.
  Status rasterize(const std::vector<VisibilityDraw>& draws, const VisibilityCamera& camera, uint64_t frame,
                   uint32_t width, uint32_t height, uint32_t first_sample, uint32_t samples);
  // RenderVisibility per (layer, pixel) and its distance (float), layer-major; device addresses.
  uint64_t texels_address() const { return texels_.address; }
  uint64_t distances_address() const { return distances_.address; }
  const RenderVisibility* texels() const { return static_cast<const RenderVisibility*>(texels_.mapped); }
  const float* distances() const { return static_cast<const float*>(distances_.mapped); }

 private:
  Status create_pipeline();
  Status resize(uint32_t width, uint32_t height, uint32_t layers);
  void release_targets();
  vk::Context& ctx_;
  VkRenderPass render_pass_ = VK_NULL_HANDLE;
  VkPipelineLayout layout_ = VK_NULL_HANDLE;
  VkPipeline pipeline_ = VK_NULL_HANDLE;
  // The targets: visibility (RGBA32 uint), distance (R32 float), depth (D32 float).
  VkImage images_[3] = {};
  VkDeviceMemory memory_[3] = {};
  VkImageView views_[3] = {};
  VkFramebuffer framebuffer_ = VK_NULL_HANDLE;
  vk::Buffer texels_{}, distances_{};
  uint32_t width_ = 0, height_ = 0, layers_ = 0;
};

}  // namespace lsnif::render
