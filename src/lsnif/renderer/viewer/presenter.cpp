// presenter.cpp -- GLFW window + Vulkan swapchain fed by buffer-to-image copies; see presenter.h.
#include "lsnif/renderer/viewer/presenter.h"

#include <algorithm>
#include <cstring>

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>  // after volk.h (presenter.h): declares glfwCreateWindowSurface

namespace lsnif::viewer {

namespace {

std::string glfw_error() {
  const char* what = nullptr;
  const int code = glfwGetError(&what);
  return code == GLFW_NO_ERROR ? std::string("no GLFW error reported") : std::string(what ? what : "unknown");
}

void image_barrier(VkCommandBuffer cmd, VkImage image, VkImageLayout from, VkImageLayout to, VkAccessFlags src_access,
                   VkAccessFlags dst_access) {
  VkImageMemoryBarrier b{};
  b.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
  b.srcAccessMask = src_access;
  b.dstAccessMask = dst_access;
  b.oldLayout = from;
  b.newLayout = to;
  b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.image = image;
  b.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
  vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, nullptr, 0, nullptr,
                       1, &b);
}

}  // namespace

Status init_glfw() {
  static bool initialized = false;
  if (initialized) return Status::ok();
  if (glfwInit() != GLFW_TRUE)
    return Status::error("cannot open a window: %s (is DISPLAY set? headless: run under xvfb-run)", glfw_error().c_str());
  if (glfwVulkanSupported() != GLFW_TRUE)
    return Status::error("GLFW finds no Vulkan loader with window-system support: %s", glfw_error().c_str());
  initialized = true;
  return Status::ok();
}

Status window_instance_extensions(std::vector<std::string>& out) {
  out.clear();
  uint32_t count = 0;
  const char** names = glfwGetRequiredInstanceExtensions(&count);
  if (!names || count == 0)
    return Status::error("no Vulkan surface extensions for this window system: %s", glfw_error().c_str());
  for (uint32_t i = 0; i < count; ++i) out.emplace_back(names[i]);
  return Status::ok();
}

Presenter::~Presenter() {
  if (ctx_ && ctx_->device()) {
    vkDeviceWaitIdle(ctx_->device());
    destroy_swapchain();
    if (acquired_) vkDestroySemaphore(ctx_->device(), acquired_, nullptr);
    if (fence_) vkDestroyFence(ctx_->device(), fence_, nullptr);
    if (pool_) vkDestroyCommandPool(ctx_->device(), pool_, nullptr);
    if (staging_.buffer) ctx_->destroy_buffer(staging_);
    if (readback_.buffer) ctx_->destroy_buffer(readback_);
  }
  if (surface_ && ctx_) vkDestroySurfaceKHR(ctx_->instance(), surface_, nullptr);
  if (window_) glfwDestroyWindow(window_);
}

Status Presenter::open_window(uint32_t width, uint32_t height, const std::string& title) {
  glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
  window_ = glfwCreateWindow(int(width), int(height), title.c_str(), nullptr, nullptr);
  if (!window_) return Status::error("cannot create a %ux%u window: %s", width, height, glfw_error().c_str());
  return Status::ok();
}

Status Presenter::attach(vk::Context& ctx) {
  ctx_ = &ctx;
  if (!window_) return Status::error("presenter: open_window first");
  LSNIF_VK_CHECK(glfwCreateWindowSurface(ctx.instance(), window_, nullptr, &surface_));
  VkBool32 supported = VK_FALSE;
  LSNIF_VK_CHECK(vkGetPhysicalDeviceSurfaceSupportKHR(ctx.physical_device(), ctx.queue_family(), surface_, &supported));
  if (!supported)
    return Status::error("device %s cannot present to this window from its queue family %u",
                         ctx.device_name().c_str(), ctx.queue_family());
  VkCommandPoolCreateInfo pci{};
  pci.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
  pci.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pci.queueFamilyIndex = ctx.queue_family();
  LSNIF_VK_CHECK(vkCreateCommandPool(ctx.device(), &pci, nullptr, &pool_));
  VkCommandBufferAllocateInfo ai{};
  ai.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
  ai.commandPool = pool_;
  ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  ai.commandBufferCount = 1;
  LSNIF_VK_CHECK(vkAllocateCommandBuffers(ctx.device(), &ai, &cmd_));
  VkFenceCreateInfo fci{};
  fci.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
  LSNIF_VK_CHECK(vkCreateFence(ctx.device(), &fci, nullptr, &fence_));
  VkSemaphoreCreateInfo sci{};
  sci.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO;
  LSNIF_VK_CHECK(vkCreateSemaphore(ctx.device(), &sci, nullptr, &acquired_));
  return create_swapchain();
}

void Presenter::destroy_swapchain() {
  for (VkSemaphore s : present_ready_) vkDestroySemaphore(ctx_->device(), s, nullptr);
  present_ready_.clear();
  images_.clear();
  if (swapchain_) vkDestroySwapchainKHR(ctx_->device(), swapchain_, nullptr);
  swapchain_ = VK_NULL_HANDLE;
}

Status Presenter::create_swapchain() {
  const VkDevice dev = ctx_->device();
  vkDeviceWaitIdle(dev);
  destroy_swapchain();
  VkSurfaceCapabilitiesKHR caps;
  LSNIF_VK_CHECK(vkGetPhysicalDeviceSurfaceCapabilitiesKHR(ctx_->physical_device(), surface_, &caps));
  if (!(caps.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_DST_BIT))
    return Status::error("the window surface's images cannot be transfer destinations on %s", ctx_->device_name().c_str());
  can_read_back_ = (caps.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_SRC_BIT) != 0;
  uint32_t count = 0;
  vkGetPhysicalDeviceSurfaceFormatsKHR(ctx_->physical_device(), surface_, &count, nullptr);
  std::vector<VkSurfaceFormatKHR> formats(count);
  vkGetPhysicalDeviceSurfaceFormatsKHR(ctx_->physical_device(), surface_, &count, formats.data());
  // 8-bit formats only: present() writes sRGB-encoded bytes as they are.
  const VkSurfaceFormatKHR* chosen = nullptr;
  for (const VkSurfaceFormatKHR& f : formats)
    if (f.format == VK_FORMAT_B8G8R8A8_UNORM || f.format == VK_FORMAT_R8G8B8A8_UNORM ||
        f.format == VK_FORMAT_B8G8R8A8_SRGB || f.format == VK_FORMAT_R8G8B8A8_SRGB) {
      chosen = &f;
      break;
    }
  if (!chosen) return Status::error("the window surface offers no 8-bit RGBA/BGRA format (%u formats)", count);
  format_ = chosen->format;
  bgra_ = format_ == VK_FORMAT_B8G8R8A8_UNORM || format_ == VK_FORMAT_B8G8R8A8_SRGB;
  int fw = 0, fh = 0;
  glfwGetFramebufferSize(window_, &fw, &fh);
  extent_ = caps.currentExtent;
  if (extent_.width == 0xFFFFFFFFu) extent_ = {uint32_t(std::max(fw, 1)), uint32_t(std::max(fh, 1))};
  extent_.width = std::clamp(extent_.width, caps.minImageExtent.width, caps.maxImageExtent.width);
  extent_.height = std::clamp(extent_.height, caps.minImageExtent.height, caps.maxImageExtent.height);
  if (extent_.width == 0 || extent_.height == 0) return Status::error("the window has no area (minimized?)");

  VkSwapchainCreateInfoKHR sci{};
  sci.sType = VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR;
  sci.surface = surface_;
  sci.minImageCount = std::max(caps.minImageCount, 2u);
  if (caps.maxImageCount) sci.minImageCount = std::min(sci.minImageCount, caps.maxImageCount);
  sci.imageFormat = format_;
  sci.imageColorSpace = chosen->colorSpace;
  sci.imageExtent = extent_;
  sci.imageArrayLayers = 1;
  sci.imageUsage = VK_IMAGE_USAGE_TRANSFER_DST_BIT | (can_read_back_ ? VK_IMAGE_USAGE_TRANSFER_SRC_BIT : 0);
  sci.imageSharingMode = VK_SHARING_MODE_EXCLUSIVE;
  sci.preTransform = caps.currentTransform;
  sci.compositeAlpha = (caps.supportedCompositeAlpha & VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR)
                           ? VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR
                           : VkCompositeAlphaFlagBitsKHR(caps.supportedCompositeAlpha & -caps.supportedCompositeAlpha);
  sci.presentMode = VK_PRESENT_MODE_FIFO_KHR;  // always supported
  sci.clipped = VK_TRUE;
  LSNIF_VK_CHECK(vkCreateSwapchainKHR(dev, &sci, nullptr, &swapchain_));
  count = 0;
  vkGetSwapchainImagesKHR(dev, swapchain_, &count, nullptr);
  images_.resize(count);
  vkGetSwapchainImagesKHR(dev, swapchain_, &count, images_.data());
  present_ready_.assign(count, VK_NULL_HANDLE);
  VkSemaphoreCreateInfo semi{};
  semi.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO;
  for (VkSemaphore& s : present_ready_) LSNIF_VK_CHECK(vkCreateSemaphore(dev, &semi, nullptr, &s));

  const size_t bytes = size_t(extent_.width) * extent_.height * 4;
  if (staging_.buffer) ctx_->destroy_buffer(staging_);
  if (readback_.buffer) ctx_->destroy_buffer(readback_);
  if (Status s = ctx_->create_buffer(bytes, staging_, VK_BUFFER_USAGE_TRANSFER_SRC_BIT); !s) return s;
  if (Status s = ctx_->create_buffer(bytes, readback_, VK_BUFFER_USAGE_TRANSFER_DST_BIT); !s) return s;
  return Status::ok();
}

Status Presenter::present(const std::vector<uint8_t>& rgba, bool& presented, std::vector<uint8_t>* screenshot) {
  presented = false;
  if (!swapchain_) return Status::error("presenter: attach first");
  int fw = 0, fh = 0;
  glfwGetFramebufferSize(window_, &fw, &fh);
  if (fw == 0 || fh == 0) return Status::ok();  // minimized: nothing to show
  if (uint32_t(fw) != extent_.width || uint32_t(fh) != extent_.height) return create_swapchain();
  const size_t bytes = size_t(extent_.width) * extent_.height * 4;
  if (rgba.size() != bytes)
    return Status::error("presenter: %zu bytes for a %ux%u swapchain image", rgba.size(), extent_.width, extent_.height);
  if (screenshot && !can_read_back_)
    return Status::error("the window surface's images cannot be read back (no TRANSFER_SRC usage): no screenshot");

  const VkDevice dev = ctx_->device();
  uint32_t index = 0;
  VkResult r = vkAcquireNextImageKHR(dev, swapchain_, UINT64_MAX, acquired_, VK_NULL_HANDLE, &index);
  if (r == VK_ERROR_OUT_OF_DATE_KHR) return create_swapchain();
  if (r != VK_SUCCESS && r != VK_SUBOPTIMAL_KHR)
    return Status::error("vkAcquireNextImageKHR failed (VkResult %d)", int(r));

  uint8_t* dst = static_cast<uint8_t*>(staging_.mapped);
  if (bgra_) {
    for (size_t i = 0; i < bytes; i += 4) {
      dst[i] = rgba[i + 2];
      dst[i + 1] = rgba[i + 1];
      dst[i + 2] = rgba[i];
      dst[i + 3] = 255;
    }
  } else {
    std::memcpy(dst, rgba.data(), bytes);
  }

  LSNIF_VK_CHECK(vkResetCommandBuffer(cmd_, 0));
  VkCommandBufferBeginInfo bi{};
  bi.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  LSNIF_VK_CHECK(vkBeginCommandBuffer(cmd_, &bi));
  const VkImage image = images_[index];
  image_barrier(cmd_, image, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 0,
                VK_ACCESS_TRANSFER_WRITE_BIT);
  VkBufferImageCopy region{};
  region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  region.imageExtent = {extent_.width, extent_.height, 1};
  vkCmdCopyBufferToImage(cmd_, staging_.buffer, image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
  VkImageLayout layout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
  VkAccessFlags access = VK_ACCESS_TRANSFER_WRITE_BIT;
  if (screenshot) {
    image_barrier(cmd_, image, layout, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, access, VK_ACCESS_TRANSFER_READ_BIT);
    vkCmdCopyImageToBuffer(cmd_, image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, readback_.buffer, 1, &region);
    layout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    access = VK_ACCESS_TRANSFER_READ_BIT;
    VkBufferMemoryBarrier host{};
    host.sType = VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER;
    host.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    host.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
    host.srcQueueFamilyIndex = host.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    host.buffer = readback_.buffer;
    host.size = VK_WHOLE_SIZE;
    vkCmdPipelineBarrier(cmd_, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 0, nullptr, 1, &host, 0,
                         nullptr);
  }
  image_barrier(cmd_, image, layout, VK_IMAGE_LAYOUT_PRESENT_SRC_KHR, access, 0);
  LSNIF_VK_CHECK(vkEndCommandBuffer(cmd_));

  const VkPipelineStageFlags wait_stage = VK_PIPELINE_STAGE_TRANSFER_BIT;
  VkSubmitInfo si{};
  si.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
  si.waitSemaphoreCount = 1;
  si.pWaitSemaphores = &acquired_;
  si.pWaitDstStageMask = &wait_stage;
  si.commandBufferCount = 1;
  si.pCommandBuffers = &cmd_;
  si.signalSemaphoreCount = 1;
  si.pSignalSemaphores = &present_ready_[index];
  LSNIF_VK_CHECK(vkResetFences(dev, 1, &fence_));
  LSNIF_VK_CHECK(vkQueueSubmit(ctx_->queue(), 1, &si, fence_));
  LSNIF_VK_CHECK(vkWaitForFences(dev, 1, &fence_, VK_TRUE, UINT64_MAX));

  if (screenshot) {
    const uint8_t* src = static_cast<const uint8_t*>(readback_.mapped);
    screenshot->resize(size_t(extent_.width) * extent_.height * 3);
    for (size_t i = 0, n = size_t(extent_.width) * extent_.height; i < n; ++i)
      for (int k = 0; k < 3; ++k) (*screenshot)[i * 3 + size_t(k)] = src[i * 4 + size_t(bgra_ ? 2 - k : k)];
  }

  VkPresentInfoKHR pi{};
  pi.sType = VK_STRUCTURE_TYPE_PRESENT_INFO_KHR;
  pi.waitSemaphoreCount = 1;
  pi.pWaitSemaphores = &present_ready_[index];
  pi.swapchainCount = 1;
  pi.pSwapchains = &swapchain_;
  pi.pImageIndices = &index;
  r = vkQueuePresentKHR(ctx_->queue(), &pi);
  if (r == VK_ERROR_OUT_OF_DATE_KHR || r == VK_SUBOPTIMAL_KHR) {
    presented = true;
    return create_swapchain();
  }
  if (r != VK_SUCCESS) return Status::error("vkQueuePresentKHR failed (VkResult %d)", int(r));
  presented = true;
  return Status::ok();
}

}  // namespace lsnif::viewer
