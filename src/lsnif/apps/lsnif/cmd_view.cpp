// lsnif view SCENE: the sample IBL viewer (src/lsnif/renderer/viewer/viewer.h) on a glTF scene with LSNIF
// objects: progressive path tracing in a window, LSNIF / reference toggle, orbit / fly camera,
// environment rotation and exposure. Scripted runs (--frames, --toggle-at, --screenshot) serve the
// Xvfb smoke test and screenshots.
#include <cstdio>
#include <string>

#include "lsnif/apps/common/progress.h"
#include "lsnif/apps/lsnif/args.h"
#include "lsnif/apps/lsnif/commands.h"
#include "lsnif/apps/lsnif/device_option.h"
#include "lsnif/apps/lsnif/pipeline_option.h"
#include "lsnif/apps/lsnif/scene_args.h"
#include "lsnif/scene/scene_edit.h"
#include "lsnif/renderer/viewer/viewer.h"

namespace lsnif::cli {

int cmd_view(int argc, char** argv) {
  viewer::ViewerSettings vs;
  SceneArgs sa;
  float exposure = 0.0f;
  Args args("view",
            "Opens a window that path traces a glTF scene progressively on the Vulkan device (LSNIF objects\n"
            "through the plugin). Left drag orbits, scroll zooms, W/A/S/D + R/F fly, Tab toggles LSNIF /\n"
            "reference, Left/Right rotate the environment, +/- set the exposure, Home resets the camera,\n"
            "P saves a screenshot, Esc quits. Needs a display (headless: xvfb-run -a lsnif view ...).");
  sa.add_to(args);
  args.option("width", "window width", &vs.width, 1, kMaxImageSide);
  args.option("height", "window height", &vs.height, 1, kMaxImageSide);
  args.option("scale", "render at window size / scale (lavapipe is slow: 2 or more)", &vs.scale, 1, 64);
  args.option("bounces", "bounces after the camera ray", &vs.max_bounces, 0, kMaxBounces);
  args.flag("reference", "start in reference mode (LSNIF objects as their triangle meshes)", &vs.reference);
  args.option("exposure", "display exposure in stops", &exposure, -64.0f, 64.0f);
  args.option("frames", "quit after this many frames (0: when the window is closed)", &vs.frames, 0, UINT32_MAX);
  args.option("toggle-at", "toggle LSNIF / reference before this frame (scripted runs; 0: never)", &vs.toggle_at, 0, UINT32_MAX);
  std::string move_by;
  args.option("select", "node selected at the start (N selects the next; J/L, I/K, U/O move it)", &vs.select);
  args.option("move-at", "move the selected node by --move-by before this frame (scripted runs; 0: never)",
              &vs.move_at, 0, UINT32_MAX);
  args.option("move-by", "X,Y,Z: the scripted move, in world units", &move_by);
  args.option("screenshot", "write the last frame, read back from the window, to this .png", &vs.screenshot);
  args.flag("quiet", "no line per frame", &vs.quiet);
  args.flag("validation", "enable the Khronos validation layer (exit 1 on any message)", &vs.validation);
  vs.on_validation_message = print_validation_message;
  add_device_option(args, &vs.device);
  PathOptions path;
  add_pipeline_option(args, &path.pipeline);
  add_primary_option(args, &path.primary);
  if (int r = args.parse(argc, argv)) return r == 1 ? 0 : 2;
  if (!check_path_options("view", path)) return 2;
  vs.choose_pipeline = path.pipeline == "auto";
  vs.choose_primary = path.primary == "auto";
  if (!vs.choose_pipeline) render::parse_pipeline(path.pipeline, vs.pipeline);
  if (!vs.choose_primary) render::parse_primary(path.primary, vs.primary);
  if (!move_by.empty()) {
    if (Status st = scene::parse_point(move_by, "--move-by", vs.move_by); !st) {
      std::fprintf(stderr, "lsnif view: %s\n", st.message().c_str());
      return 2;
    }
  }
  if (vs.move_at != 0 && vs.select.empty()) {
    std::fprintf(stderr, "lsnif view: --move-at needs --select NODE\n");
    return 2;
  }
  vs.exposure = exposure;
  vs.camera = sa.camera_index();
  if (!vs.screenshot.empty())
    if (int r = sa.check_output("view", "--screenshot", vs.screenshot)) return r;
  scene::Scene scene;
  scene::EnvironmentMap environment;
  if (int r = sa.load("view", scene, environment)) return r;
  viewer::ViewerReport report;
  const Status s = viewer::run_viewer(scene, environment.width ? &environment : nullptr, vs, report);
  if (!s) {
    std::fprintf(stderr, "lsnif view: %s\n", s.message().c_str());
    return 1;
  }
  std::printf("viewer: %u frames on %s, last image %u spp in %s mode, %.1f ms per frame (render pass)\n",
              report.frames, report.device.c_str(), report.samples, report.reference ? "reference" : "LSNIF",
              report.mean_frame_ms);
  std::printf("viewer: %s pipeline, %s primary (%s)\n", render::pipeline_name(report.pipeline),
              render::primary_name(report.primary), report.path_choice.c_str());
  if (!vs.screenshot.empty()) std::printf("screenshot %s\n", vs.screenshot.c_str());
  if (vs.validation && (report.validation_errors || report.validation_warnings)) {
    std::fprintf(stderr, "lsnif view: validation reported %u errors and %u warnings\n", report.validation_errors,
                 report.validation_warnings);
    return 1;
  }
  return 0;
}

}  // namespace lsnif::cli
