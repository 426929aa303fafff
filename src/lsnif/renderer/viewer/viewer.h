// viewer.h -- the sample IBL viewer: a window showing the path tracer's progressive
// accumulation of a scene, with an orbit/fly camera, a toggle between LSNIF and reference mode,
// environment rotation and exposure, and the frame time on screen.
//
// Controls: left drag orbits, scroll dollies, W/A/S/D + R/F fly, Tab (or M) toggles LSNIF /
// reference, Left/Right rotate the environment, +/- change the exposure, Home restores the
// camera, N selects the next object and J/L, I/K, U/O move it along x, z, y (the TLAS is refit,
// nothing re-uploaded), P writes a screenshot, Esc quits. Any change but the exposure restarts
// the accumulation.
#pragma once
#include <cstdint>
#include <functional>
#include <string>

#include <glm/glm.hpp>

#include "lsnif/scene/environment.h"
#include "lsnif/renderer/renderer.h"
#include "lsnif/scene/scene.h"
#include "lsnif/format/status.h"

namespace lsnif::viewer {

struct ViewerSettings {
  uint32_t width = 800, height = 600;  // window size
  uint32_t scale = 2;                  // render at window / scale (nearest upscaled): lavapipe is slow
  uint32_t max_bounces = 4;
  render::PathPipeline pipeline = render::PathPipeline::inline_rt;  // how the renderer casts rays
  render::PrimaryVisibility primary = render::PrimaryVisibility::traced;  // camera rays traced or rasterized
  // Take the pipeline / the primary visibility from render::choose_render_path (render_choice.h)
  // for the scene's LSNIF mode on the viewer's device instead of the fields above.
  bool choose_pipeline = false, choose_primary = false;
  int32_t camera = 0;                  // the scene's camera; -1: frame the scene
  bool reference = false;              // start in reference mode
  float exposure = 0.0f;               // stops
  float env_rotation = 0.0f;           // radians added to the environment's
  bool validation = false;             // Khronos validation layer (messages fail the run at exit)
  // Each validation message as it arrives (vk::ContextOptions::on_validation_message); may be empty.
  std::function<void(bool error, const char* message)> on_validation_message;
  std::string device;                  // vk::ContextOptions::device ("": automatic choice)
  // Scripted runs (tests, screenshots): stop after `frames` frames (0: when the window closes),
  // toggle the mode before frame `toggle_at` (0: never), and write `screenshot` (.png) of the
  // last presented frame read back from the swapchain.
  uint32_t frames = 0, toggle_at = 0;
  std::string select;                  // node selected at the start ("": none)
  uint32_t move_at = 0;                // move the selected node by `move_by` (world) before this frame
  glm::vec3 move_by{0.0f};
  std::string screenshot;
  bool quiet = false;                  // no per-frame line on stdout
};

struct ViewerReport {
  uint32_t frames = 0;          // frames presented
  uint32_t samples = 0;         // samples per pixel in the last image
  double mean_frame_ms = 0;     // mean time of a frame's render pass
  bool reference = false;       // mode of the last frame
  std::string selected;         // the node selected at the end ("": none)
  uint32_t validation_errors = 0, validation_warnings = 0;
  std::string device;
  // The pipeline and primary visibility the viewer ran with, and what chose them.
  render::PathPipeline pipeline = render::PathPipeline::inline_rt;
  render::PrimaryVisibility primary = render::PrimaryVisibility::traced;
  std::string path_choice;
};

// Opens the window on the Vulkan device (with window-system support) and runs until the window
// is closed or settings.frames are done. Fails, naming the problem, without a display, without a
// device that can ray trace and present, on a scene the renderer refuses, or on a device error.
Status run_viewer(const scene::Scene& scene, const scene::EnvironmentMap* environment, const ViewerSettings& settings,
                  ViewerReport& report);

}  // namespace lsnif::viewer
