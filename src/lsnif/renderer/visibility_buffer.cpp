// visibility_buffer.cpp -- the visibility pass of visibility_buffer.h: a render pass with two
// colour targets (RenderVisibility as RGBA32 uint, the distance as R32 float) and a reversed-z
// depth target, one draw per triangle list per sample, each sample's targets copied to its layer
// of the output buffers.
#include "lsnif/renderer/visibility_buffer.h"

#include <cstring>

namespace lsnif::render {

namespace {
#include "render_visibility_frag_spirv.h"
#include "render_visibility_vert_spirv.h"

const VkFormat kFormats[3] = {VK_FORMAT_R32G32B32A32_UINT, VK_FORMAT_R32_SFLOAT, VK_FORMAT_D32_SFLOAT};

// Row-major 3x4 of the affine `m` (RenderRasterPush::object_to_camera).
void rows_3x4(const glm::mat4& m, float out[12]) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) out[r * 4 + c] = m[c][r];
}
}  // namespace

VisibilityBuffer::~VisibilityBuffer() {
  release_targets();
  const VkDevice d = ctx_.device();
  if (pipeline_) vkDestroyPipeline(d, pipeline_, nullptr);
  if (layout_) vkDestroyPipelineLayout(d, layout_, nullptr);
  if (render_pass_) vkDestroyRenderPass(d, render_pass_, nullptr);
}

void VisibilityBuffer::release_targets() {
  const VkDevice d = ctx_.device();
  if (framebuffer_) vkDestroyFramebuffer(d, framebuffer_, nullptr);
  framebuffer_ = VK_NULL_HANDLE;
  for (int i = 0; i < 3; ++i) {
    if (views_[i]) vkDestroyImageView(d, views_[i], nullptr);
    if (images_[i]) vkDestroyImage(d, images_[i], nullptr);
    if (memory_[i]) vkFreeMemory(d, memory_[i], nullptr);
    views_[i] = VK_NULL_HANDLE;
    images_[i] = VK_NULL_HANDLE;
    memory_[i] = VK_NULL_HANDLE;
  }
  ctx_.destroy_buffer(texels_);
  ctx_.destroy_buffer(distances_);
  width_ = height_ = layers_ = 0;
}

Status VisibilityBuffer::create_pipeline() {
  const VkDevice d = ctx_.device();
  uint32_t family_count = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(ctx_.physical_device(), &family_count, nullptr);
  std::vector<VkQueueFamilyProperties> families(family_count);
  vkGetPhysicalDeviceQueueFamilyProperties(ctx_.physical_device(), &family_count, families.data());
  if (ctx_.queue_family() >= family_count || !(families[ctx_.queue_family()].queueFlags & VK_QUEUE_GRAPHICS_BIT))
    return Status::error("rasterized primary visibility: the device's queue family %u (%s) has no graphics",
                         ctx_.queue_family(), ctx_.device_name().c_str());
  VkAttachmentDescription att[3]{};
  for (int i = 0; i < 3; ++i) {
    att[i].format = kFormats[i];
    att[i].samples = VK_SAMPLE_COUNT_1_BIT;
    att[i].loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    att[i].storeOp = i < 2 ? VK_ATTACHMENT_STORE_OP_STORE : VK_ATTACHMENT_STORE_OP_DONT_CARE;
    att[i].stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
    att[i].stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    att[i].initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    att[i].finalLayout = i < 2 ? VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL : VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
  }
  const VkAttachmentReference colors[2] = {{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL},
                                           {1, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL}};
  const VkAttachmentReference depth{2, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL};
  VkSubpassDescription sub{};
  sub.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
  sub.colorAttachmentCount = 2;
  sub.pColorAttachments = colors;
  sub.pDepthStencilAttachment = &depth;
  // In: the previous sample's copies read the targets before this one clears them. Out: the
  // colour writes before the copies.
  VkSubpassDependency deps[2]{};
  deps[0].srcSubpass = VK_SUBPASS_EXTERNAL;
  deps[0].dstSubpass = 0;
  deps[0].srcStageMask = VK_PIPELINE_STAGE_TRANSFER_BIT | VK_PIPELINE_STAGE_LATE_FRAGMENT_TESTS_BIT;
  deps[0].dstStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT | VK_PIPELINE_STAGE_EARLY_FRAGMENT_TESTS_BIT;
  deps[0].srcAccessMask = VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
  deps[0].dstAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT | VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_READ_BIT |
                          VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
  deps[1].srcSubpass = 0;
  deps[1].dstSubpass = VK_SUBPASS_EXTERNAL;
  deps[1].srcStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
  deps[1].dstStageMask = VK_PIPELINE_STAGE_TRANSFER_BIT;
  deps[1].srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
  deps[1].dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
  VkRenderPassCreateInfo rpci{};
  rpci.sType = VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO;
  rpci.attachmentCount = 3;
  rpci.pAttachments = att;
  rpci.subpassCount = 1;
  rpci.pSubpasses = &sub;
  rpci.dependencyCount = 2;
  rpci.pDependencies = deps;
  LSNIF_VK_CHECK(vkCreateRenderPass(d, &rpci, nullptr, &render_pass_));

  VkPushConstantRange range{VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(RenderRasterPush)};
  VkPipelineLayoutCreateInfo lci{};
  lci.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
  lci.pushConstantRangeCount = 1;
  lci.pPushConstantRanges = &range;
  LSNIF_VK_CHECK(vkCreatePipelineLayout(d, &lci, nullptr, &layout_));

  VkShaderModule modules[2] = {};
  vk::Spirv code[2];
  code[0].code = render_visibility_vert_spirv;
  code[0].bytes = sizeof render_visibility_vert_spirv;
  code[1].code = render_visibility_frag_spirv;
  code[1].bytes = sizeof render_visibility_frag_spirv;
  for (int i = 0; i < 2; ++i)
    if (Status s = ctx_.create_shader_module(code[i], modules[i]); !s) {
      if (modules[0]) vkDestroyShaderModule(d, modules[0], nullptr);
      return s.context("visibility pass");
    }
  VkPipelineShaderStageCreateInfo stages[2]{};
  for (int i = 0; i < 2; ++i) {
    stages[i].sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    stages[i].stage = i == 0 ? VK_SHADER_STAGE_VERTEX_BIT : VK_SHADER_STAGE_FRAGMENT_BIT;
    stages[i].module = modules[i];
    stages[i].pName = "main";
  }
  VkPipelineVertexInputStateCreateInfo vertex{};
  vertex.sType = VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO;
  VkPipelineInputAssemblyStateCreateInfo assembly{};
  assembly.sType = VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO;
  assembly.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
  VkPipelineViewportStateCreateInfo viewport{};
  viewport.sType = VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO;
  viewport.viewportCount = 1;
  viewport.scissorCount = 1;
  VkPipelineRasterizationStateCreateInfo raster{};
  raster.sType = VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO;
  raster.polygonMode = VK_POLYGON_MODE_FILL;
  raster.cullMode = VK_CULL_MODE_NONE;  // camera rays hit both sides
  raster.frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE;
  raster.lineWidth = 1.0f;
  VkPipelineMultisampleStateCreateInfo ms{};
  ms.sType = VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO;
  ms.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
  VkPipelineDepthStencilStateCreateInfo ds{};
  ds.sType = VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO;
  ds.depthTestEnable = VK_TRUE;
  ds.depthWriteEnable = VK_TRUE;
  ds.depthCompareOp = VK_COMPARE_OP_GREATER;  // reversed z: nearer is larger
  VkPipelineColorBlendAttachmentState blend[2]{};
  blend[0].colorWriteMask = VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT | VK_COLOR_COMPONENT_B_BIT |
                            VK_COLOR_COMPONENT_A_BIT;
  blend[1].colorWriteMask = blend[0].colorWriteMask;  // identical (no independentBlend)
  VkPipelineColorBlendStateCreateInfo cb{};
  cb.sType = VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO;
  cb.attachmentCount = 2;
  cb.pAttachments = blend;
  const VkDynamicState dyn[2] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
  VkPipelineDynamicStateCreateInfo dynamic{};
  dynamic.sType = VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO;
  dynamic.dynamicStateCount = 2;
  dynamic.pDynamicStates = dyn;
  VkGraphicsPipelineCreateInfo gci{};
  gci.sType = VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO;
  gci.stageCount = 2;
  gci.pStages = stages;
  gci.pVertexInputState = &vertex;
  gci.pInputAssemblyState = &assembly;
  gci.pViewportState = &viewport;
  gci.pRasterizationState = &raster;
  gci.pMultisampleState = &ms;
  gci.pDepthStencilState = &ds;
  gci.pColorBlendState = &cb;
  gci.pDynamicState = &dynamic;
  gci.layout = layout_;
  gci.renderPass = render_pass_;
  const VkResult r = vkCreateGraphicsPipelines(d, VK_NULL_HANDLE, 1, &gci, nullptr, &pipeline_);
  for (VkShaderModule m : modules) vkDestroyShaderModule(d, m, nullptr);
  if (r != VK_SUCCESS) return Status::error("visibility pass: vkCreateGraphicsPipelines failed (VkResult %d)", int(r));
  return Status::ok();
}

Status VisibilityBuffer::resize(uint32_t width, uint32_t height, uint32_t layers) {
  if (width == width_ && height == height_ && layers <= layers_) return Status::ok();
  release_targets();
  const VkDevice d = ctx_.device();
  VkPhysicalDeviceMemoryProperties mem;
  vkGetPhysicalDeviceMemoryProperties(ctx_.physical_device(), &mem);
  for (int i = 0; i < 3; ++i) {
    VkImageCreateInfo ici{};
    ici.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
    ici.imageType = VK_IMAGE_TYPE_2D;
    ici.format = kFormats[i];
    ici.extent = {width, height, 1};
    ici.mipLevels = 1;
    ici.arrayLayers = 1;
    ici.samples = VK_SAMPLE_COUNT_1_BIT;
    ici.tiling = VK_IMAGE_TILING_OPTIMAL;
    ici.usage = i < 2 ? VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT
                      : VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT;
    ici.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    LSNIF_VK_CHECK(vkCreateImage(d, &ici, nullptr, &images_[i]));
    VkMemoryRequirements req;
    vkGetImageMemoryRequirements(d, images_[i], &req);
    uint32_t type = UINT32_MAX;  // device-local first, else any the image accepts
    for (uint32_t pass = 0; pass < 2 && type == UINT32_MAX; ++pass)
      for (uint32_t t = 0; t < mem.memoryTypeCount && type == UINT32_MAX; ++t)
        if ((req.memoryTypeBits & (1u << t)) &&
            (pass == 1 || (mem.memoryTypes[t].propertyFlags & VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT)))
          type = t;
    if (type == UINT32_MAX) return Status::error("visibility pass: no memory type for a %ux%u target", width, height);
    VkMemoryAllocateInfo mai{};
    mai.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    mai.allocationSize = req.size;
    mai.memoryTypeIndex = type;
    LSNIF_VK_CHECK(vkAllocateMemory(d, &mai, nullptr, &memory_[i]));
    LSNIF_VK_CHECK(vkBindImageMemory(d, images_[i], memory_[i], 0));
    VkImageViewCreateInfo vci{};
    vci.sType = VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO;
    vci.image = images_[i];
    vci.viewType = VK_IMAGE_VIEW_TYPE_2D;
    vci.format = kFormats[i];
    vci.subresourceRange = {VkImageAspectFlags(i < 2 ? VK_IMAGE_ASPECT_COLOR_BIT : VK_IMAGE_ASPECT_DEPTH_BIT), 0, 1, 0, 1};
    LSNIF_VK_CHECK(vkCreateImageView(d, &vci, nullptr, &views_[i]));
  }
  VkFramebufferCreateInfo fci{};
  fci.sType = VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO;
  fci.renderPass = render_pass_;
  fci.attachmentCount = 3;
  fci.pAttachments = views_;
  fci.width = width;
  fci.height = height;
  fci.layers = 1;
  LSNIF_VK_CHECK(vkCreateFramebuffer(d, &fci, nullptr, &framebuffer_));
  const size_t pixels = size_t(width) * height;
  Status s = ctx_.create_buffer(pixels * layers * sizeof(RenderVisibility), texels_, VK_BUFFER_USAGE_TRANSFER_DST_BIT);
  if (s) s = ctx_.create_buffer(pixels * layers * sizeof(float), distances_, VK_BUFFER_USAGE_TRANSFER_DST_BIT);
  if (!s) return s.context(format("the visibility buffers of a %ux%u image (%u layers)", width, height, layers));
  width_ = width;
  height_ = height;
  layers_ = layers;
  return Status::ok();
}

Status VisibilityBuffer::rasterize(const std::vector<VisibilityDraw>& draws, const VisibilityCamera& camera,
                                   uint64_t frame, uint32_t width, uint32_t height, uint32_t first_sample,
                                   uint32_t samples) {
  if (width == 0 || height == 0 || samples == 0)
    return Status::error("visibility pass: width, height and samples must be positive");
  for (const VisibilityDraw& d : draws)
    if (d.alpha_test && frame == 0) return Status::error("visibility pass: an alpha-tested draw needs the frame's tables");
  if (!pipeline_)
    if (Status s = create_pipeline(); !s) return s;
  if (Status s = resize(width, height, samples); !s) return s;
  const glm::mat4 world_to_camera = glm::inverse(camera.camera_to_world);
  const size_t pixels = size_t(width) * height;
  return ctx_.submit("visibility pass", [&](VkCommandBuffer cmd) {
    for (uint32_t s = 0; s < samples; ++s) {
      VkClearValue clear[3]{};
      for (uint32_t k = 0; k < 4; ++k) clear[0].color.uint32[k] = RENDER_VISIBILITY_NONE;
      clear[1].color.float32[0] = 0.0f;
      clear[2].depthStencil = {0.0f, 0};  // reversed z: 0 is infinitely far
      VkRenderPassBeginInfo rbi{};
      rbi.sType = VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO;
      rbi.renderPass = render_pass_;
      rbi.framebuffer = framebuffer_;
      rbi.renderArea = {{0, 0}, {width, height}};
      rbi.clearValueCount = 3;
      rbi.pClearValues = clear;
      vkCmdBeginRenderPass(cmd, &rbi, VK_SUBPASS_CONTENTS_INLINE);
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_);
      const VkViewport vp{0.0f, 0.0f, float(width), float(height), 0.0f, 1.0f};
      const VkRect2D sc{{0, 0}, {width, height}};
      vkCmdSetViewport(cmd, 0, 1, &vp);
      vkCmdSetScissor(cmd, 0, 1, &sc);
      for (const VisibilityDraw& draw : draws) {
        RenderRasterPush push{};
        rows_3x4(world_to_camera * draw.object_to_world, push.object_to_camera);
        push.positions = draw.positions;
        push.indices = draw.indices;
        push.instance = draw.instance;
        push.sample_index = first_sample + s;
        push.width = width;
        push.height = height;
        push.tan_half_fov_y = camera.tan_half_fov_y;
        push.aspect = camera.aspect;
        push.near_plane = camera.near_plane;
        push.alpha_test = draw.alpha_test ? 1u : 0u;
        push.frame = draw.alpha_test ? frame : 0;
        vkCmdPushConstants(cmd, layout_, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof push,
                           &push);
        vkCmdDraw(cmd, 3 * draw.triangles, 1, 0, 0);
      }
      vkCmdEndRenderPass(cmd);
      VkBufferImageCopy copy{};
      copy.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
      copy.imageExtent = {width, height, 1};
      copy.bufferOffset = VkDeviceSize(s) * pixels * sizeof(RenderVisibility);
      vkCmdCopyImageToBuffer(cmd, images_[0], VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, texels_.buffer, 1, &copy);
      copy.bufferOffset = VkDeviceSize(s) * pixels * sizeof(float);
      vkCmdCopyImageToBuffer(cmd, images_[1], VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, distances_.buffer, 1, &copy);
    }
    VkMemoryBarrier b{};
    b.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
    b.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    b.dstAccessMask = VK_ACCESS_HOST_READ_BIT | VK_ACCESS_SHADER_READ_BIT;
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_HOST_BIT | VK_PIPELINE_STAGE_ALL_COMMANDS_BIT,
                         0, 1, &b, 0, nullptr, 0, nullptr);
  });
}

}  // namespace lsnif::render
