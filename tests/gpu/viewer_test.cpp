// The viewer (`lsnif view`, src/lsnif/renderer/viewer/) under Xvfb on lavapipe with validation on: it opens a
// window, renders frames, and what it presented (read back from the swapchain) is the path
// tracer's image of the same scene and samples, computed here in-process (the independent truth),
// in LSNIF mode and after a toggle in reference mode; the screenshot is not blank. Without a
// display it fails with a clear message. Moving the selected object (a TLAS refit in the viewer)
// shows the scene rendered with the object placed there.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include "lsnif/scene/gltf_build.h"
#include "lsnif/testing/gpu_test_support.h"
#include "lsnif/image/image_io.h"
#include "lsnif/import/mesh.h"
#include "lsnif/core/model.h"
#include "lsnif/testing/render_test_scene.h"
#include "lsnif/renderer/renderer.h"
#include "lsnif/scene/scene_gltf.h"
#include "lsnif/train/trainer.h"

namespace lsnif {
namespace {

namespace fs = std::filesystem;
using namespace gputest;
using test::CommandResult;
using test::run_command;

const std::string kElephant = std::string(LSNIF_DATA_DIR) + "/meshes/elephant.off";
constexpr uint32_t kWidth = 96, kHeight = 72;
constexpr uint32_t kHudRows = 18;  // two HUD lines at scale 1 (hud_text.h: 9 pixels each)

// The scene of render_test written as a glTF file with the model beside it (relative URI), so the
// viewer loads it like a user's scene.
Status write_scene(const fs::path& dir, std::string& gltf_path) {
  Mesh mesh;
  if (!fs::exists(kElephant)) return Status::error("%s missing: run scripts/setup.sh", kElephant.c_str());
  if (Status s = load_mesh(kElephant, mesh); !s) return s;
  const glm::vec3 color(0.6f, 0.3f, 0.15f);
  for (Material& m : mesh.materials) m.base_color = color;
  TrainSettings settings = tiny_settings(HitParam::VoxelSegments);
  settings.steps = 300;
  Model model;
  if (Status s = train_model(mesh, settings, model); !s) return s;
  if (Status s = save_model(model, (dir / "elephant.lsnif").string()); !s) return s;
  const scene::Scene scene = elephant_on_ground(mesh, "elephant.lsnif", color);
  tinygltf::Model gltf = scene::new_gltf_model("viewer_test");
  for (const scene::Material& m : scene.materials) scene::add_material(gltf, m);
  for (const scene::Instance& in : scene.instances) {
    int mesh_index = -1;
    if (Status s = scene::add_mesh(gltf, scene.meshes[size_t(in.mesh)], mesh_index); !s) return s;
    const int node = scene::add_node(gltf, in.node_name, mesh_index, in.object_to_world);
    if (in.lsnif >= 0) scene::set_neural_object(gltf, node, "elephant.lsnif", {0});
  }
  scene::add_camera(gltf, scene.cameras[0], 0.01f, 100.0f);
  scene::EnvironmentSpec env;
  env.color = scene.environment.color;
  scene::set_environment(gltf, env);
  gltf_path = (dir / "elephant_scene.gltf").string();
  return scene::save_gltf(gltf, gltf_path);
}

// Fraction of pixels below the HUD whose displayed bytes differ by more than 2 in some channel;
// also the screenshot's luminance mean and standard deviation.
struct Comparison {
  double differing = 1.0, mean = 0, stddev = 0;
};
Comparison compare(const image::Image& shot, const image::Image& rendered) {
  Comparison c;
  size_t differing = 0, pixels = 0;
  double sum = 0, sum2 = 0;
  for (uint32_t y = kHudRows; y < kHeight; ++y)
    for (uint32_t x = 0; x < kWidth; ++x) {
      const float* s = shot.at(x, y);
      const float* r = rendered.at(x, y);
      int worst = 0;
      for (int k = 0; k < 3; ++k)
        worst = std::max(worst, std::abs(int(std::lround(s[k] * 255.0f)) - int(image::encode_srgb8(r[k]))));
      differing += worst > 2 ? 1 : 0;
      const double l = (s[0] + s[1] + s[2]) / 3.0;
      sum += l;
      sum2 += l * l;
      ++pixels;
    }
  c.differing = double(differing) / double(pixels);
  c.mean = sum / double(pixels);
  c.stddev = std::sqrt(std::max(0.0, sum2 / double(pixels) - c.mean * c.mean));
  return c;
}

TEST(Viewer, UnderXvfbShowsTheRenderersImageAndTogglesModes) {
  ASSERT_EQ(run_command("command -v xvfb-run").code, 0) << "xvfb-run missing: scripts/setup.sh installs package xvfb";
  const test::ScopedTestDir scoped("lsnif_viewer_test");
  const fs::path& dir = scoped.path();
  std::string gltf;
  const Status written = write_scene(dir, gltf);
  ASSERT_TRUE(written) << written.message();

  std::string view = "xvfb-run -a -s '-screen 0 320x240x24' " + std::string(LSNIF_CLI) + " view " + gltf +
                           " --width " + std::to_string(kWidth) + " --height " + std::to_string(kHeight) +
                           " --scale 1 --validation --quiet --device " + test::test_device();
  // By default the viewer chooses (render_choice.h): on lavapipe the wavefront pipeline.
  CommandResult chosen = run_command(view + " --frames 1 2>&1");
  ASSERT_EQ(chosen.code, 0) << chosen.out;
  EXPECT_NE(chosen.out.find("viewer: wavefront pipeline"), std::string::npos) << chosen.out;
  EXPECT_NE(chosen.out.find("the device runs lsnifCmdQuery"), std::string::npos) << chosen.out;
  // The comparisons below render in-process with the inline pipeline and traced camera rays.
  view += " --pipeline inline --primary traced";
  const std::string shot_lsnif = (dir / "lsnif.png").string(), shot_toggled = (dir / "toggled.png").string();
  CommandResult a = run_command(view + " --frames 4 --screenshot " + shot_lsnif + " 2>&1");
  ASSERT_EQ(a.code, 0) << a.out;
  EXPECT_NE(a.out.find("4 frames"), std::string::npos) << a.out;
  EXPECT_NE(a.out.find("4 spp in LSNIF mode"), std::string::npos) << a.out;
  // Frame 0 in LSNIF mode, then the toggle: two reference frames accumulate.
  CommandResult b = run_command(view + " --frames 3 --toggle-at 1 --screenshot " + shot_toggled + " 2>&1");
  ASSERT_EQ(b.code, 0) << b.out;
  EXPECT_NE(b.out.find("2 spp in reference mode"), std::string::npos) << b.out;
  // Frame 0 as loaded, then the elephant moves (TLAS refit): two frames of the moved scene.
  const std::string shot_moved = (dir / "moved.png").string();
  CommandResult m = run_command(view + " --frames 3 --select elephant --move-at 1 --move-by 0.15,0,-0.1 --screenshot " +
                                shot_moved + " 2>&1");
  ASSERT_EQ(m.code, 0) << m.out;
  EXPECT_NE(m.out.find("2 spp in LSNIF mode"), std::string::npos) << m.out;

  // The same scene and samples rendered in-process.
  scene::Scene scene;
  scene::SceneLoadOptions options;
  options.quiet = true;
  ASSERT_TRUE(scene::load_scene(gltf, options, scene));
  vk::Context ctx;
  const Status vk_status = ctx.init(/*ray_tracing=*/true, /*validation=*/true, test::test_device());
  ASSERT_TRUE(vk_status) << vk_status.message();
  {
    render::Renderer renderer(ctx);
    render::RenderSettings settings;
    settings.width = kWidth;
    settings.height = kHeight;
    settings.camera = 0;
    settings.warm_up = false;
    settings.spp = 4;
    image::Image lsnif, reference, shot;
    render::RenderStats stats;
    ASSERT_TRUE(renderer.render(scene, settings, lsnif, stats));
    settings.spp = 2;
    settings.reference = true;
    ASSERT_TRUE(renderer.render(scene, settings, reference, stats));
    scene::Scene moved_scene = scene;
    for (scene::Instance& in : moved_scene.instances)
      if (in.node_name == "elephant") in.object_to_world[3] += glm::vec4(0.15f, 0.0f, -0.1f, 0.0f);
    settings.reference = false;
    image::Image moved;
    ASSERT_TRUE(renderer.render(moved_scene, settings, moved, stats));

    ASSERT_TRUE(image::load_image(shot_lsnif, shot, /*raw=*/true));
    ASSERT_EQ(shot.width, kWidth);
    ASSERT_EQ(shot.height, kHeight);
    const Comparison c = compare(shot, lsnif);
    std::printf("LSNIF screenshot: %.2f%% of pixels differ by > 2/255; mean %.3f, stddev %.3f\n",
                100.0 * c.differing, c.mean, c.stddev);
    EXPECT_LT(c.differing, 0.01);
    EXPECT_GT(c.stddev, 0.03);  // not blank: the elephant and the ground show
    EXPECT_GT(c.mean, 0.05);
    EXPECT_LT(c.mean, 0.95);
    ASSERT_TRUE(image::load_image(shot_toggled, shot, /*raw=*/true));
    const Comparison t = compare(shot, reference);
    std::printf("toggled screenshot vs reference: %.2f%% of pixels differ by > 2/255\n", 100.0 * t.differing);
    EXPECT_LT(t.differing, 0.01);
    // And the toggle changed something: the LSNIF image is not the reference's.
    EXPECT_GT(compare(shot, lsnif).differing, t.differing);
    ASSERT_TRUE(image::load_image(shot_moved, shot, /*raw=*/true));
    const Comparison mv = compare(shot, moved);
    std::printf("moved-object screenshot vs the scene rendered with it moved: %.2f%% of pixels differ by > 2/255\n",
                100.0 * mv.differing);
    EXPECT_LT(mv.differing, 0.01);
  }
  EXPECT_EQ(ctx.validation_errors(), 0u);
  EXPECT_EQ(ctx.validation_warnings(), 0u);

  // No display: a clear error, exit 1.
  CommandResult c = run_command("env -u DISPLAY -u WAYLAND_DISPLAY " + std::string(LSNIF_CLI) + " view " +
                                gltf + " --frames 1 --device " + test::test_device() + " 2>&1");
  EXPECT_EQ(c.code, 1) << c.out;
  EXPECT_NE(c.out.find("xvfb-run"), std::string::npos) << c.out;
}

}  // namespace
}  // namespace lsnif
