// viewer.cpp -- the viewer's frame loop: input -> camera / mode / environment state -> one
// 1-sample pass of the path tracer added to the accumulation -> tone mapping, HUD -> present.
#include "lsnif/renderer/viewer/viewer.h"

#include "lsnif/renderer/render_choice.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "lsnif/renderer/viewer/hud_text.h"
#include "lsnif/image/image_io.h"
#include "lsnif/renderer/viewer/orbit_camera.h"
#include "lsnif/renderer/viewer/presenter.h"
#include "lsnif/renderer/renderer.h"
#include "lsnif/vulkan/context.h"

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

// Opens the window of `presenter` (settings' size) with the callbacks collecting `input`, and
// attaches it to `ctx` (surface and swapchain). Fails without a display or on a device error.
Status open_window(Presenter& presenter, vk::Context& ctx, Input& input, const ViewerSettings& settings) {
  if (Status s = presenter.open_window(settings.width, settings.height, "lsnif view"); !s) return s;
  glfwSetWindowUserPointer(presenter.window(), &input);
  glfwSetKeyCallback(presenter.window(), on_key);
  glfwSetScrollCallback(presenter.window(), on_scroll);
  return presenter.attach(ctx);
}

// The frame loop over an open window: the state the input changes (mode, primary visibility,
// camera, exposure, environment rotation, the selected object and the scene with its moves), one
// 1-sample pass per frame, the display with its HUD, screenshots and the report.
class FrameLoop {
 public:
  FrameLoop(const scene::Scene& scene, const ViewerSettings& settings, Presenter& presenter,
            render::Renderer& renderer, Input& input, ViewerReport& report)
      : settings_(settings),
        presenter_(presenter),
        renderer_(renderer),
        input_(input),
        report_(report),
        reference_(settings.reference),
        edited_(scene),
        exposure_(settings.exposure),
        env_rotation_(settings.env_rotation),
        primary_(settings.primary) {}

  // Sets the scene in both modes, the selected node (settings.select) and the home camera
  // (settings.camera). Fails on a scene the renderer refuses, a node to select that does not exist
  // or a bad camera.
  Status start(const scene::EnvironmentMap* environment) {
    // Both modes on the device, so that the toggle reloads no model and rebuilds no BLAS or TLAS.
    if (Status s = renderer_.set_scene(edited_, reference_, environment, /*both_modes=*/true); !s) return s;
    if (!settings_.select.empty()) {
      for (size_t i = 0; i < edited_.instances.size() && selected_ < 0; ++i)
        if (edited_.instances[i].node_name == settings_.select) selected_ = int64_t(i);
      if (selected_ < 0)
        return Status::error("viewer: the scene has no node named '%s' to select", settings_.select.c_str());
    }
    if (Status s = renderer_.camera_view(settings_.camera, home_); !s) return s;
    renderer_.world_bounds(lo_, hi_);
    home_distance_ = std::max(glm::length(0.5f * (lo_ + hi_) - glm::vec3(home_.camera_to_world[3])), 1e-3f);
    camera_.set(home_.camera_to_world, home_distance_, home_.yfov);
    glfwGetCursorPos(presenter_.window(), &last_x_, &last_y_);
    return Status::ok();
  }

  // Runs frames until the window closes or settings.frames are presented; the report follows every
  // frame. Fails on a failed move, pass or present, or a screenshot that cannot be written.
  Status run() {
    while (!glfwWindowShouldClose(presenter_.window()) && (settings_.frames == 0 || frame_ < settings_.frames)) {
      glfwPollEvents();
      // Input -> state.
      apply_events();
      if (Status s = apply_held_input(); !s) return s;

      // One pass.
      const uint32_t rw = std::max(1u, presenter_.width() / settings_.scale),
                     rh = std::max(1u, presenter_.height() / settings_.scale);
      double ms = 0;
      bool rendered = false;
      if (Status s = render_pass(rw, rh, ms, rendered); !s) return s;
      if (!rendered) continue;

      // Display.
      const std::string status = status_line(ms, rw, rh);
      display(status);
      bool presented = false;
      if (Status s = present(presented); !s) return s;
      if (!presented) continue;  // the swapchain was recreated for a new window size: render again
      end_frame(ms, status);
    }
    report_.mean_frame_ms = report_.frames ? frame_ms_sum_ / report_.frames : 0.0;
    return Status::ok();
  }

 private:
  // Moves the selected object by `delta` (world space) through a TLAS refit.
  Status move_selected(glm::vec3 delta) {
    if (selected_ < 0) return Status::ok();
    glm::mat4& m = edited_.instances[size_t(selected_)].object_to_world;
    m[3] += glm::vec4(delta, 0.0f);
    return renderer_.move_instance(size_t(selected_), m);
  }

  // The events the callbacks collected (and the scripted toggle, settings.toggle_at) -> state: the
  // mode and primary visibility toggles, the home camera, the exposure and the scroll's dolly.
  void apply_events() {
    if (settings_.toggle_at != 0 && frame_ == settings_.toggle_at) input_.toggle_mode = true;
    if (input_.toggle_mode) {
      input_.toggle_mode = false;
      // A scene whose LSNIF nodes have no triangle mesh has no reference mode: say so, stay.
      if (Status s = renderer_.set_mode(!reference_); !s) {
        std::fprintf(stderr, "lsnif view: cannot switch to %s mode: %s\n", reference_ ? "LSNIF" : "reference",
                     s.message().c_str());
      } else {
        reference_ = !reference_;
      }
      restart_ = true;
    }
    if (input_.toggle_primary) {  // traced <-> rasterized primary visibility
      input_.toggle_primary = false;
      primary_ = primary_ == render::PrimaryVisibility::raster ? render::PrimaryVisibility::traced
                                                               : render::PrimaryVisibility::raster;
      restart_ = true;
    }
    if (input_.home) {
      input_.home = false;
      camera_.set(home_.camera_to_world, home_distance_, home_.yfov);
      restart_ = true;
    }
    if (input_.exposure_steps != 0) {  // display only: no restart
      exposure_ += 0.5f * float(input_.exposure_steps);
      input_.exposure_steps = 0;
    }
    if (input_.scroll != 0) {
      camera_.dolly(std::pow(0.9f, float(input_.scroll)));
      input_.scroll = 0;
      restart_ = true;
    }
  }

  // The mouse and the keys held -> state: the drag's orbit, flying, the environment's rotation, the
  // selection and its moves (and the scripted move, settings.move_at). Fails on a failed move.
  Status apply_held_input() {
    GLFWwindow* w = presenter_.window();
    double x = 0, y = 0;
    glfwGetCursorPos(w, &x, &y);
    if (glfwGetMouseButton(w, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS && (x != last_x_ || y != last_y_)) {
      camera_.orbit(-float(x - last_x_) * 0.01f, -float(y - last_y_) * 0.01f);
      restart_ = true;
    }
    last_x_ = x;
    last_y_ = y;
    auto key = [&](int k) { return glfwGetKey(w, k) == GLFW_PRESS ? 1.0f : 0.0f; };
    const float fly_r = key(GLFW_KEY_D) - key(GLFW_KEY_A), fly_u = key(GLFW_KEY_R) - key(GLFW_KEY_F),
                fly_f = key(GLFW_KEY_W) - key(GLFW_KEY_S), turn = key(GLFW_KEY_RIGHT) - key(GLFW_KEY_LEFT);
    if (fly_r != 0 || fly_u != 0 || fly_f != 0) {
      camera_.fly(0.05f * fly_r, 0.05f * fly_u, 0.05f * fly_f);
      restart_ = true;
    }
    if (turn != 0) {
      env_rotation_ += 0.1f * turn;
      restart_ = true;
    }
    if (input_.select_next) {
      input_.select_next = false;
      selected_ = (selected_ + 1) % int64_t(edited_.instances.size());
    }
    const glm::vec3 move(key(GLFW_KEY_L) - key(GLFW_KEY_J), key(GLFW_KEY_U) - key(GLFW_KEY_O),
                         key(GLFW_KEY_K) - key(GLFW_KEY_I));
    if (move != glm::vec3(0.0f) && selected_ >= 0) {
      if (Status s = move_selected(0.02f * glm::length(hi_ - lo_) * move); !s) return s;
      restart_ = true;
    }
    if (settings_.move_at != 0 && frame_ == settings_.move_at) {
      if (Status s = move_selected(settings_.move_by); !s) return s;
      restart_ = true;
    }
    return Status::ok();
  }

  // One 1-sample pass of an rw x rh image (the accumulation restarted first where needed), resolved
  // into `linear_`; `ms` its time. `rendered` false: rasterizing failed, the viewer went back to the
  // primary visibility it started with, render again. Fails on a device error, or where the
  // primary visibility it started with fails.
  Status render_pass(uint32_t rw, uint32_t rh, double& ms, bool& rendered) {
    if (restart_ || linear_.width != rw || linear_.height != rh) {
      if (Status s = renderer_.reset_accumulation(rw, rh); !s) return s;
      restart_ = false;
    }
    render::View view;
    view.camera_to_world = camera_.camera_to_world();
    view.yfov = camera_.yfov();
    view.env_rotation = env_rotation_;
    const auto t0 = std::chrono::steady_clock::now();
    if (Status s = renderer_.accumulate(view, renderer_.accumulated_samples(), 1, settings_.max_bounces,
                                        render::RenderSettings().rr_depth, settings_.pipeline, primary_);
        !s) {
      // Rasterizing a scene with an LSNIF node without a mesh: say so and trace instead (when
      // the viewer started traced; a --primary raster start fails).
      if (primary_ == settings_.primary) return s;
      std::fprintf(stderr, "lsnif view: cannot rasterize the primary visibility: %s\n", s.message().c_str());
      primary_ = settings_.primary;
      restart_ = true;
      return Status::ok();
    }
    ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    renderer_.resolve(linear_);
    rendered = true;
    return Status::ok();
  }

  // The HUD's status line: mode, primary visibility, the pass's `ms`, samples, the rw x rh image,
  // exposure, environment rotation and the selected node.
  std::string status_line(double ms, uint32_t rw, uint32_t rh) const {
    char status[256];
    std::snprintf(status, sizeof status, "%s%s  %.0f MS/FRAME  %u SPP  %ux%u  EXPOSURE %+.1f  ENV %.0f DEG  SEL %s",
                  reference_ ? "REFERENCE" : "LSNIF", primary_ == render::PrimaryVisibility::raster ? " RASTER" : "",
                  ms, renderer_.accumulated_samples(), rw, rh, exposure_,
                  double(env_rotation_) * 180.0 / 3.14159265358979,
                  selected_ >= 0 ? edited_.instances[size_t(selected_)].node_name.c_str() : "-");
    return status;
  }

  // The image to show in `rgba_`: the accumulation tone-mapped to the window with the HUD (the
  // status line and the controls); the status line in the window's title too.
  void display(const std::string& status) {
    tone_map(linear_, exposure_, presenter_.width(), presenter_.height(), rgba_);
    const uint32_t hud = presenter_.width() >= 800 ? 2 : 1;
    draw_hud_text(rgba_.data(), presenter_.width(), presenter_.height(), 0, 0, status, hud);
    draw_hud_text(rgba_.data(), presenter_.width(), presenter_.height(), 0, kHudLineHeight * int32_t(hud),
                  "TAB MODE  DRAG ORBIT  WASD/RF FLY  SCROLL ZOOM  LEFT/RIGHT ENV  +/- EXPOSURE  N SELECT  "
                  "IJKLUO MOVE  P SHOT",
                  hud);
    glfwSetWindowTitle(presenter_.window(), (std::string("lsnif view - ") + status).c_str());
  }

  // Presents `rgba_` and, when P was pressed or after the last scripted frame with
  // settings.screenshot, writes what was presented (settings.screenshot, or lsnif_view.png).
  // `presented` false: the swapchain was recreated, nothing shown or written. Fails on a device
  // error or a screenshot that cannot be written.
  Status present(bool& presented) {
    const bool last = settings_.frames != 0 && frame_ + 1 == settings_.frames;
    const bool shoot = input_.screenshot || (last && !settings_.screenshot.empty());
    if (Status s = presenter_.present(rgba_, presented, shoot ? &shot_ : nullptr); !s) return s;
    if (!presented) return Status::ok();
    if (shoot) {
      const std::string path = settings_.screenshot.empty() ? "lsnif_view.png" : settings_.screenshot;
      if (Status s = save_screenshot(path, shot_, presenter_.width(), presenter_.height()); !s) return s;
      if (input_.screenshot) std::printf("screenshot %s\n", path.c_str());
      input_.screenshot = false;
    }
    return Status::ok();
  }

  // Counts a presented frame (its pass took `ms`): its line on stdout (unless quiet) and the report.
  void end_frame(double ms, const std::string& status) {
    frame_ms_sum_ += ms;
    ++frame_;
    if (!settings_.quiet) {
      std::printf("frame %u: %s\n", frame_, status.c_str());
      std::fflush(stdout);  // a line per frame also when stdout is a pipe or a file
    }
    report_.frames = frame_;
    report_.samples = renderer_.accumulated_samples();
    report_.reference = reference_;
    report_.selected = selected_ >= 0 ? edited_.instances[size_t(selected_)].node_name : std::string();
  }

  const ViewerSettings& settings_;
  Presenter& presenter_;
  render::Renderer& renderer_;
  Input& input_;
  ViewerReport& report_;
  bool reference_;
  scene::Scene edited_;  // with the objects' moves
  int64_t selected_ = -1;
  render::View home_;
  float home_distance_ = 0.0f;
  glm::vec3 lo_{0.0f}, hi_{0.0f};  // world bounds
  OrbitCamera camera_;
  float exposure_, env_rotation_;
  bool restart_ = true;
  render::PrimaryVisibility primary_;  // V toggles
  double last_x_ = 0, last_y_ = 0, frame_ms_sum_ = 0;
  image::Image linear_;
  std::vector<uint8_t> rgba_, shot_;
  uint32_t frame_ = 0;  // frames presented
};

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
  vk::ContextOptions options = render::context_options(settings.validation, settings.device);
  options.swapchain = true;
  options.on_validation_message = settings.on_validation_message;
  if (Status s = window_instance_extensions(options.instance_extensions); !s) return s;

  Input input;
  vk::Context ctx;
  if (Status s = ctx.init(options); !s) return s.context("viewer device");
  report.device = ctx.device_name();
  ViewerSettings chosen = settings;
  report.path_choice = "forced by --pipeline and --primary";
  if (settings.choose_pipeline || settings.choose_primary) {
    render::DevicePaths paths;
    if (Status s = render::device_paths(ctx, paths); !s) return s.context("viewer device");
    // For the LSNIF mode, also in a reference start: the toggle keeps the pipeline.
    const render::RenderChoice c =
        render::choose_render_path(scene, /*reference=*/false, paths, uint64_t(settings.width) * settings.height);
    if (settings.choose_pipeline) chosen.pipeline = c.pipeline;
    if (settings.choose_primary) chosen.primary = c.primary;
    report.path_choice = settings.choose_pipeline && settings.choose_primary ? c.why : "partly forced; chosen: " + c.why;
  }
  report.pipeline = chosen.pipeline;
  report.primary = chosen.primary;
  Status result = Status::ok();
  {
    Presenter presenter;
    render::Renderer renderer(ctx);
    result = [&]() -> Status {
      if (Status s = open_window(presenter, ctx, input, chosen); !s) return s;
      FrameLoop loop(scene, chosen, presenter, renderer, input, report);
      if (Status s = loop.start(environment); !s) return s;
      return loop.run();
    }();
    vkDeviceWaitIdle(ctx.device());
  }
  ctx.destroy_device();  // validation reports leaked objects here
  report.validation_errors = ctx.validation_errors();
  report.validation_warnings = ctx.validation_warnings();
  return result;
}

}  // namespace lsnif::viewer
