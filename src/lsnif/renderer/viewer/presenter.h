// presenter.h -- the viewer's window: a GLFW window without a client API, a Vulkan surface and
// swapchain on the renderer's device, and present(): an RGBA8 image copied into the next
// swapchain image (vkCmdCopyBufferToImage; no graphics pipeline), optionally read back as a
// screenshot of exactly what was presented.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <volk.h>

#include "lsnif/format/status.h"
#include "lsnif/vulkan/context.h"

struct GLFWwindow;

namespace lsnif::viewer {

// glfwInit, once per process; fails, with GLFW's own words, without a display or Vulkan support.
Status init_glfw();
// The instance extensions a Vulkan window surface needs (glfwGetRequiredInstanceExtensions).
Status window_instance_extensions(std::vector<std::string>& out);

class Presenter {
 public:
  Presenter() = default;
  ~Presenter();
  Presenter(const Presenter&) = delete;
  Presenter& operator=(const Presenter&) = delete;

  // Opens a width x height window (init_glfw first).
  Status open_window(uint32_t width, uint32_t height, const std::string& title);
  // Creates the surface and swapchain on `ctx` (initialized with window_instance_extensions and
  // ContextOptions::swapchain; must outlive this). Fails if the device's queue cannot present to
  // the surface or the surface cannot be a transfer destination.
  Status attach(vk::Context& ctx);

  // The swapchain's size: the image present() expects.
  uint32_t width() const { return extent_.width; }
  uint32_t height() const { return extent_.height; }
  // Presents `rgba` (width() x height(), 4 bytes per pixel, row 0 at the top, sRGB-encoded).
  // When `screenshot` is not null it receives the presented swapchain image read back as RGB8.
  // When the window's size changed, the swapchain is recreated first and `presented` is false
  // (ask width()/height() again). Device errors fail.
  Status present(const std::vector<uint8_t>& rgba, bool& presented, std::vector<uint8_t>* screenshot = nullptr);

  GLFWwindow* window() const { return window_; }
  // Whether the swapchain format stores B, G, R, A (else R, G, B, A).
  bool bgra() const { return bgra_; }

 private:
  Status create_swapchain();
  void destroy_swapchain();
  vk::Context* ctx_ = nullptr;
  GLFWwindow* window_ = nullptr;
  VkSurfaceKHR surface_ = VK_NULL_HANDLE;
  VkSwapchainKHR swapchain_ = VK_NULL_HANDLE;
  VkFormat format_ = VK_FORMAT_UNDEFINED;
  bool bgra_ = false, can_read_back_ = false;
  VkExtent2D extent_{0, 0};
  std::vector<VkImage> images_;
  std::vector<VkSemaphore> present_ready_;  // one per swapchain image
  VkSemaphore acquired_ = VK_NULL_HANDLE;
  VkCommandPool pool_ = VK_NULL_HANDLE;
  VkCommandBuffer cmd_ = VK_NULL_HANDLE;
  VkFence fence_ = VK_NULL_HANDLE;
  vk::Buffer staging_{}, readback_{};
};

}  // namespace lsnif::viewer
