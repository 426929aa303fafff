// viewer.cpp -- the viewer's frame loop: input -> camera / mode / environment state -> one
// 1-sample pass of the path tracer added to the accumulation -> tone mapping, HUD -> present.
#include "lsnif/renderer/viewer/viewer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "lsnif/renderer/viewer/hud_text.h"
#include "lsnif/image/image_io.h"
#include "lsnif/renderer/viewer/orbit_camera.h"
#include "lsnif/renderer/viewer/presenter.h"
#include "lsnif/renderer/renderer.h"
#include "lsnif/harness/vk_compute.h"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

namespace lsnif::viewer {

namespace {

// What the window's callbacks collect between frames.
struct Input {
  bool toggle_mode = false, toggle_primary = false, screenshot = false, home = false, select_next = false;
  int exposure_steps = 0;
  double scroll = 0;
};

void on_key(GLFWwindow* window, int key, int /*scancode*/, int action, int /*mods*/) {
  if (action != GLFW_PRESS && action != GLFW_REPEAT) return;
  Input& in = *static_cast<Input*>(glfwGetWindowUserPointer(window));
  switch (key) {
    case GLFW_KEY_TAB:
    case GLFW_KEY_M: in.toggle_mode = true; break;
    case GLFW_KEY_P: in.screenshot = true; break;
    case GLFW_KEY_V: in.toggle_primary = true; break;
    case GLFW_KEY_HOME: in.home = true; break;
    case GLFW_KEY_N: in.select_next = true; break;
    case GLFW_KEY_EQUAL:
    case GLFW_KEY_KP_ADD: ++in.exposure_steps; break;
    case GLFW_KEY_MINUS:
    case GLFW_KEY_KP_SUBTRACT: --in.exposure_steps; break;
    case GLFW_KEY_ESCAPE: glfwSetWindowShouldClose(window, GLFW_TRUE); break;
    default: break;
  }
}

void on_scroll(GLFWwindow* window, double /*dx*/, double dy) {
  static_cast<Input*>(glfwGetWindowUserPointer(window))->scroll += dy;
}

// The accumulated image (linear), exposed, sRGB-encoded and nearest-upscaled to the window.
void tone_map(const image::Image& img, float exposure, uint32_t width, uint32_t height, std::vector<uint8_t>& rgba) {
  rgba.assign(size_t(width) * height * 4, 255);
  if (img.width == 0 || img.height == 0) return;
  const float gain = std::exp2(exposure);
  for (uint32_t y = 0; y < height; ++y) {
    const uint32_t sy = std::min(img.height - 1, uint32_t(uint64_t(y) * img.height / height));
    for (uint32_t x = 0; x < width; ++x) {
      const uint32_t sx = std::min(img.width - 1, uint32_t(uint64_t(x) * img.width / width));
      const float* p = img.at(sx, sy);
      uint8_t* o = rgba.data() + (size_t(y) * width + x) * 4;
      for (int k = 0; k < 3; ++k) o[k] = image::encode_srgb8(p[k] * gain);
    }
  }
}

Status save_screenshot(const std::string& path, const std::vector<uint8_t>& rgb, uint32_t width, uint32_t height) {
  image::Image img;
  img.width = width;
  img.height = height;
  img.rgb.resize(rgb.size());
  // Decode to linear so that save_image's encoding gives back the same bytes.
  for (size_t i = 0; i < rgb.size(); ++i) img.rgb[i] = image::srgb_to_linear(float(rgb[i]) / 255.0f);
  return image::save_image(path, img);
}

}  // namespace

Status run_viewer(const scene::Scene& scene, const scene::EnvironmentMap* environment, const ViewerSettings& settings,
                  ViewerReport& report) {
  report = ViewerReport();
  if (settings.width == 0 || settings.height == 0 || settings.scale == 0)
    return Status::error("viewer: width, height and scale must be positive");
  if (!settings.screenshot.empty() && image::is_hdr_path(settings.screenshot))
    return Status::error("viewer: the screenshot is what the window shows: write it as .png, not %s",
                         settings.screenshot.c_str());
  if (Status s = init_glfw(); !s) return s;
  vk::ContextOptions options = render::context_options(settings.pipeline, settings.validation, settings.device);
  options.swapchain = true;
  if (Status s = window_instance_extensions(options.instance_extensions); !s) return s;

  Input input;
  vk::ComputeContext ctx;
  if (Status s = ctx.init(options); !s) return s.context("viewer device");
  report.device = ctx.device_name();
  Status result = Status::ok();
  {
    Presenter presenter;
    render::Renderer renderer(ctx);
    result = [&]() -> Status {
      if (Status s = presenter.open_window(settings.width, settings.height, "lsnif view"); !s) return s;
      glfwSetWindowUserPointer(presenter.window(), &input);
      glfwSetKeyCallback(presenter.window(), on_key);
      glfwSetScrollCallback(presenter.window(), on_scroll);
      if (Status s = presenter.attach(ctx); !s) return s;

      bool reference = settings.reference;
      scene::Scene edited = scene;  // with the objects' moves
      // Both modes on the device, so that the toggle reloads no model and rebuilds no BLAS or TLAS.
      if (Status s = renderer.set_scene(edited, reference, environment, /*both_modes=*/true); !s) return s;
      int64_t selected = -1;
      if (!settings.select.empty()) {
        for (size_t i = 0; i < edited.instances.size() && selected < 0; ++i)
          if (edited.instances[i].node_name == settings.select) selected = int64_t(i);
        if (selected < 0) return Status::error("viewer: the scene has no node named '%s' to select", settings.select.c_str());
      }
      // Moves the selected object by `delta` (world space) through a TLAS refit.
      auto move_selected = [&](glm::vec3 delta) -> Status {
        if (selected < 0) return Status::ok();
        glm::mat4& m = edited.instances[size_t(selected)].object_to_world;
        m[3] += glm::vec4(delta, 0.0f);
        return renderer.move_instance(size_t(selected), m);
      };
      render::View home;
      if (Status s = renderer.camera_view(settings.camera, home); !s) return s;
      glm::vec3 lo, hi;
      renderer.world_bounds(lo, hi);
      const float home_distance = std::max(glm::length(0.5f * (lo + hi) - glm::vec3(home.camera_to_world[3])), 1e-3f);
      OrbitCamera camera;
      camera.set(home.camera_to_world, home_distance, home.yfov);
      float exposure = settings.exposure, env_rotation = settings.env_rotation;
      bool restart = true;
      render::PrimaryVisibility primary = settings.primary;  // V toggles
      double last_x = 0, last_y = 0, frame_ms_sum = 0;
      glfwGetCursorPos(presenter.window(), &last_x, &last_y);
      image::Image linear;
      std::vector<uint8_t> rgba, shot;
      uint32_t frame = 0;

      while (!glfwWindowShouldClose(presenter.window()) && (settings.frames == 0 || frame < settings.frames)) {
        glfwPollEvents();
        GLFWwindow* w = presenter.window();
        // Input -> state.
        if (settings.toggle_at != 0 && frame == settings.toggle_at) input.toggle_mode = true;
        if (input.toggle_mode) {
          input.toggle_mode = false;
          // A scene whose LSNIF nodes have no triangle mesh has no reference mode: say so, stay.
          if (Status s = renderer.set_mode(!reference); !s) {
            std::fprintf(stderr, "lsnif view: cannot switch to %s mode: %s\n", reference ? "LSNIF" : "reference",
                         s.message().c_str());
          } else {
            reference = !reference;
          }
          restart = true;
        }
        if (input.toggle_primary) {  // traced <-> rasterized primary visibility
          input.toggle_primary = false;
          primary = primary == render::PrimaryVisibility::raster ? render::PrimaryVisibility::traced
                                                                 : render::PrimaryVisibility::raster;
          restart = true;
        }
        if (input.home) {
          input.home = false;
          camera.set(home.camera_to_world, home_distance, home.yfov);
          restart = true;
        }
        if (input.exposure_steps != 0) {  // display only: no restart
          exposure += 0.5f * float(input.exposure_steps);
          input.exposure_steps = 0;
        }
        if (input.scroll != 0) {
          camera.dolly(std::pow(0.9f, float(input.scroll)));
          input.scroll = 0;
          restart = true;
        }
        double x = 0, y = 0;
        glfwGetCursorPos(w, &x, &y);
        if (glfwGetMouseButton(w, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS && (x != last_x || y != last_y)) {
          camera.orbit(-float(x - last_x) * 0.01f, -float(y - last_y) * 0.01f);
          restart = true;
        }
        last_x = x;
        last_y = y;
        auto key = [&](int k) { return glfwGetKey(w, k) == GLFW_PRESS ? 1.0f : 0.0f; };
        const float fly_r = key(GLFW_KEY_D) - key(GLFW_KEY_A), fly_u = key(GLFW_KEY_R) - key(GLFW_KEY_F),
                    fly_f = key(GLFW_KEY_W) - key(GLFW_KEY_S), turn = key(GLFW_KEY_RIGHT) - key(GLFW_KEY_LEFT);
        if (fly_r != 0 || fly_u != 0 || fly_f != 0) {
          camera.fly(0.05f * fly_r, 0.05f * fly_u, 0.05f * fly_f);
          restart = true;
        }
        if (turn != 0) {
          env_rotation += 0.1f * turn;
          restart = true;
        }
        if (input.select_next) {
          input.select_next = false;
          selected = (selected + 1) % int64_t(edited.instances.size());
        }
        const glm::vec3 move(key(GLFW_KEY_L) - key(GLFW_KEY_J), key(GLFW_KEY_U) - key(GLFW_KEY_O),
                             key(GLFW_KEY_K) - key(GLFW_KEY_I));
        if (move != glm::vec3(0.0f) && selected >= 0) {
          if (Status s = move_selected(0.02f * glm::length(hi - lo) * move); !s) return s;
          restart = true;
        }
        if (settings.move_at != 0 && frame == settings.move_at) {
          if (Status s = move_selected(settings.move_by); !s) return s;
          restart = true;
        }

        // One pass.
        const uint32_t rw = std::max(1u, presenter.width() / settings.scale),
                       rh = std::max(1u, presenter.height() / settings.scale);
        if (restart || linear.width != rw || linear.height != rh) {
          if (Status s = renderer.reset_accumulation(rw, rh); !s) return s;
          restart = false;
        }
        render::View view;
        view.camera_to_world = camera.camera_to_world();
        view.yfov = camera.yfov();
        view.env_rotation = env_rotation;
        const auto t0 = std::chrono::steady_clock::now();
        if (Status s = renderer.accumulate(view, renderer.accumulated_samples(), 1, settings.max_bounces,
                                           render::RenderSettings().rr_depth, settings.pipeline, primary);
            !s) {
          // Rasterizing a scene with an LSNIF node without a mesh: say so and trace instead (when
          // the viewer started traced; a --primary raster start fails).
          if (primary == settings.primary) return s;
          std::fprintf(stderr, "lsnif view: cannot rasterize the primary visibility: %s\n", s.message().c_str());
          primary = settings.primary;
          restart = true;
          continue;
        }
        const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
        renderer.resolve(linear);

        // Display.
        tone_map(linear, exposure, presenter.width(), presenter.height(), rgba);
        const uint32_t hud = presenter.width() >= 800 ? 2 : 1;
        char status[256];
        std::snprintf(status, sizeof status, "%s%s  %.0f MS/FRAME  %u SPP  %ux%u  EXPOSURE %+.1f  ENV %.0f DEG  SEL %s",
                      reference ? "REFERENCE" : "LSNIF", primary == render::PrimaryVisibility::raster ? " RASTER" : "", ms, renderer.accumulated_samples(), rw, rh, exposure,
                      double(env_rotation) * 180.0 / 3.14159265358979,
                      selected >= 0 ? edited.instances[size_t(selected)].node_name.c_str() : "-");
        draw_hud_text(rgba.data(), presenter.width(), presenter.height(), 0, 0, status, hud);
        draw_hud_text(rgba.data(), presenter.width(), presenter.height(), 0, kHudLineHeight * int32_t(hud),
                      "TAB MODE  DRAG ORBIT  WASD/RF FLY  SCROLL ZOOM  LEFT/RIGHT ENV  +/- EXPOSURE  N SELECT  IJKLUO MOVE  P SHOT", hud);
        glfwSetWindowTitle(w, (std::string("lsnif view - ") + status).c_str());
        const bool last = settings.frames != 0 && frame + 1 == settings.frames;
        const bool shoot = input.screenshot || (last && !settings.screenshot.empty());
        bool presented = false;
        if (Status s = presenter.present(rgba, presented, shoot ? &shot : nullptr); !s) return s;
        if (!presented) continue;  // the swapchain was recreated for a new window size: render again
        if (shoot) {
          const std::string path = settings.screenshot.empty() ? "lsnif_view.png" : settings.screenshot;
          if (Status s = save_screenshot(path, shot, presenter.width(), presenter.height()); !s) return s;
          if (input.screenshot) std::printf("screenshot %s\n", path.c_str());
          input.screenshot = false;
        }
        frame_ms_sum += ms;
        ++frame;
        if (!settings.quiet) {
          std::printf("frame %u: %s\n", frame, status);
          std::fflush(stdout);  // a line per frame also when stdout is a pipe or a file
        }
        report.frames = frame;
        report.samples = renderer.accumulated_samples();
        report.reference = reference;
        report.selected = selected >= 0 ? edited.instances[size_t(selected)].node_name : std::string();
      }
      report.mean_frame_ms = report.frames ? frame_ms_sum / report.frames : 0.0;
      return Status::ok();
    }();
    vkDeviceWaitIdle(ctx.device());
  }
  ctx.destroy_device();  // validation reports leaked objects here
  report.validation_errors = ctx.validation_errors();
  report.validation_warnings = ctx.validation_warnings();
  return result;
}

}  // namespace lsnif::viewer
