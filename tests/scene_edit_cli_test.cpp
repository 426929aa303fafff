// Render-time scene edits through `lsnif render` (src/lsnif/scene/scene_edit.h via --node-transform,
// --add, --at, --look-from, --sun) on lavapipe with a tiny model: added copies of a model share one model on the
// device, and bad edits give clear errors with the right exit codes (2: malformed option, 1: the
// scene cannot take it).
#include <gtest/gtest.h>

#include <string>

#include "lsnif/import/mesh.h"
#include "lsnif/core/model.h"
#include "lsnif/testing/test_support.h"

namespace lsnif {
namespace {

TEST(SceneEditCli, AddedModelsAndMovedNodesRender) {
  const std::string bunny = std::string(LSNIF_DATA_DIR) + "/meshes/bunny00.off";
  Mesh mesh;
  ASSERT_TRUE(load_mesh(bunny, mesh)) << bunny << " missing: run scripts/setup.sh";
  test::ScopedTestDir dir("lsnif_scene_edit_cli");
  TrainSettings settings = test::tiny_train_settings();
  settings.steps = 20;
  Model model;
  ASSERT_TRUE(train_model(mesh, settings, model));
  const std::string m = dir.path("bunny.lsnif");
  ASSERT_TRUE(save_model(model, m));
  const std::string render = std::string(LSNIF_CLI) + " render " + std::string(LSNIF_SCENE_EXAMPLE) +
                             " --lsnif bunny=" + m +
                             " --width 24 --height 16 --spp 1 -o " + dir.path("out.png");

  test::CommandResult r = test::run_command(render + " --add '" + m + ";" + m +
                                            "' --at '0.9,0.35,-0.3,0.6,90;-0.9,0.35,-0.3,0.6,-45' "
                                            "--node-transform 'bunny=0,0.5,0.4' 2>&1");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("3 LSNIF (1 models)"), std::string::npos) << r.out;  // one file, one model on the device

  r = test::run_command(render + " --add " + m + " --at '1,2;3,4,5' 2>&1");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--add names 1 models but --at gives 2"), std::string::npos) << r.out;
  r = test::run_command(render + " --add " + m + " --at 1,x,3 2>&1");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("'x': a decimal number expected"), std::string::npos) << r.out;
  r = test::run_command(render + " --add /nonexistent/y.lsnif --at 0,0,0 2>&1");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("y.lsnif"), std::string::npos) << r.out;
  r = test::run_command(render + " --node-transform nobody=0,0,0 2>&1");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("nobody"), std::string::npos) << r.out;
  r = test::run_command(render + " --look-from 2,1.5,3 --look-at 0,0.5,0 --fov 40 --sun 1,2,1,3 2>&1");
  EXPECT_EQ(r.code, 0) << r.out;
  r = test::run_command(render + " --look-from 1,1,1 --look-at 1,1,1 2>&1");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("same point"), std::string::npos) << r.out;
  r = test::run_command(render + " --sun 0,1,0 2>&1");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--sun"), std::string::npos) << r.out;
  r = test::run_command(render + " --node-transform bunny=0,0,0,0 2>&1");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("scale must be positive"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace lsnif
