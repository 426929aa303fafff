// convert_hostile_test.cpp -- the converter against hostile scenes and options: user patterns on
// huge node names (RE2, no recursion), model names that would overwrite a model the scene already
// uses, outputs that are inputs, and scenes the renderer would refuse, caught before any training
// (the dry run says so too).
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>

#include "lsnif/testing/convert_test_support.h"

namespace lsnif::convert {
namespace {
namespace fs = std::filesystem;
using namespace test;

std::string read_all(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// A floor and one elephant; the elephant's node has the given name.
struct SmallScene : TestScene {
  explicit SmallScene(const std::string& elephant_name) : TestScene("lsnif_convert_hostile") {
    scene::add_node(g, "floor", floor, glm::mat4(1.0f));
    scene::add_node(g, elephant_name, elephant, placed({0, 0, 0}, 0, 1));
  }
};

// What training would refuse is refused by the dry run, the plan and the real run alike, before any
// training: an emission the surface channels cannot learn (KHR_materials_emissive_strength 1e6).
TEST(ConvertHostile, TheDryRunRefusesWhatTrainingWould) {
  SmallScene s("e1");
  scene::Material bright{"bright"};
  bright.emission = glm::vec3(1.0e6f, 0.0f, 0.0f);
  const int material = scene::add_material(s.g, bright);
  for (tinygltf::Primitive& p : s.g.meshes[size_t(s.elephant)].primitives) p.material = material;
  save_or_fail(s.g, s.path);
  for (const bool dry : {true, false}) {
    SCOPED_TRACE(dry ? "dry run" : "run");
    ConvertSettings settings = tiny_settings(s.path, s.dir.path("out/scene.gltf"));
    settings.train.surface_maps = kSurfaceMapsOn;
    settings.dry_run = dry;
    ConvertResult r;
    std::string log;
    EXPECT_EQ(run_quiet(settings, r, &log), 1) << log;
    EXPECT_NE(log.find("a material's emission 1e+06 exceeds the 65504 an LSNIF model can learn"), std::string::npos)
        << log;
    EXPECT_EQ(r.trained, 0u);
    // The real run writes the scene with the object kept as triangles, as for any model that fails.
    EXPECT_EQ(fs::exists(s.dir.path("out/scene.gltf")), !dry);
    EXPECT_FALSE(fs::exists(s.dir.path("out/scene.e1.lsnif")));
  }
}

// std::regex recursed once per character and overflowed the stack on this name.
TEST(ConvertHostile, PatternsRunInLinearTimeOnHugeNames) {
  SmallScene s(std::string(30000, 'a'));
  save_or_fail(s.g, s.path);
  for (const char* pattern : {"a*", "(a|aa)*b", "^(a+)+$"}) {
    ConvertSettings settings = tiny_settings(s.path, s.dir.path("out/scene.gltf"));
    settings.dry_run = true;
    settings.select = pattern;
    Plan p;
    Status st = make_plan(settings, p);
    ASSERT_TRUE(st) << st.message();
    size_t selected = 0;
    for (const PlannedNode& n : p.nodes) selected += n.decision == Decision::Convert;
    // "a*" and "^(a+)+$" match the long name; "(a|aa)*b" (no b anywhere) matches nothing.
    EXPECT_EQ(selected, std::string(pattern) == "(a|aa)*b" ? 0u : 1u) << pattern;
  }
  ConvertSettings bad = tiny_settings(s.path, s.dir.path("out/scene.gltf"));
  bad.exclude = "a{2,99999}";
  Status st = check_settings(bad);
  ASSERT_FALSE(st);
  EXPECT_NE(st.message().find("--exclude 'a{2,99999}' is not a valid regular expression"), std::string::npos)
      << st.message();
}

// The elephant's model would be OUT.elephant.lsnif; another node already uses that file as its
// pre-trained model (with the output beside the input): the new model gets another name and the
// pre-trained file is not touched.
TEST(ConvertHostile, GeneratedModelNamesNeverOverwriteAReferencedModel) {
  SmallScene s("e1");
  const int other = scene::add_node(s.g, "pretrained", -1, glm::mat4(1.0f));
  scene::set_neural_object(s.g, other, "out.elephant.lsnif", {0});
  save_or_fail(s.g, s.path);
  const std::string pretrained = s.dir.path("out.elephant.lsnif");
  std::ofstream(pretrained, std::ios::binary) << std::string("LSNIF\0\r\n", 8) << "keep me";
  ConvertSettings settings = tiny_settings(s.path, s.dir.path("out.gltf"));
  settings.eval_rays = 0;
  ConvertResult r;
  std::string log;
  ASSERT_EQ(run_quiet(settings, r, &log), 0) << log;
  ASSERT_EQ(r.plan.models.size(), 1u);
  EXPECT_EQ(r.plan.models[0].file, "out.elephant_2.lsnif");
  EXPECT_EQ(read_all(pretrained), std::string("LSNIF\0\r\n", 8) + "keep me");
  EXPECT_TRUE(fs::exists(s.dir.path("out.elephant_2.lsnif")));
}

TEST(ConvertHostile, OutputsThatAreInputsAreRefusedBeforeTraining) {
  SmallScene s("e1");
  save_or_fail(s.g, s.path);  // scene.gltf + scene.bin
  for (const std::string& out : {s.path, s.dir.path("./scene.gltf"), s.dir.path("sub/../scene.gltf")}) {
    ConvertSettings settings = tiny_settings(s.path, out);
    ConvertResult r;
    std::string log;
    EXPECT_EQ(run_quiet(settings, r, &log), 1) << log;
    EXPECT_NE(log.find("which the input scene " + s.path + " uses"), std::string::npos) << log;
    EXPECT_EQ(r.trained, 0u);
  }
  // OUT.bin would be the input's buffer file.
  ConvertSettings settings = tiny_settings(s.path, s.dir.path("scene.gltf.d/../scene.gltf"));
  fs::create_directories(s.dir.path("scene.gltf.d"));
  ConvertResult r;
  EXPECT_EQ(run_quiet(settings, r), 1);
  EXPECT_TRUE(fs::exists(s.path));
}

// Problems of the scene itself, which the renderer refuses: found before training, by the dry run
// as by the real run, and nothing is trained or written.
TEST(ConvertHostile, TheSceneToWriteIsValidatedBeforeTraining) {
  struct Case {
    const char* name;
    std::function<void(tinygltf::Model&)> damage;
    const char* expected;
  };
  const std::vector<Case> cases = {
      {"missing HDR",
       [](tinygltf::Model& g) {
         scene::EnvironmentSpec env;
         env.hdr = "sky.hdr";
         scene::set_environment(g, env);
       },
       "sky.hdr"},
      {"missing referenced model",
       [](tinygltf::Model& g) { scene::set_neural_object(g, scene::add_node(g, "pre", -1, glm::mat4(1.0f)), "gone.lsnif", {0}); },
       "gone.lsnif"},
      {"zero scale", [](tinygltf::Model& g) { g.nodes[0].scale = {0.0, 0.0, 0.0}; }, "non-invertible"},
      {"yfov 0",
       [](tinygltf::Model& g) {
         scene::Camera cam;
         cam.name = "cam";
         cam.yfov = 0.5f;
         scene::add_camera(g, cam, 0.01f, 100.0f);
       },
       "yfov"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    SmallScene s("e1");
    c.damage(s.g);
    save_or_fail(s.g, s.path);
    if (std::string(c.name) == "yfov 0") {  // tinygltf does not write a yfov of 0: edited in the file
      nlohmann::json j = read_json(s.path);
      j["cameras"][0]["perspective"]["yfov"] = 0;
      write_json(s.path, j);
    }
    for (const bool dry : {true, false}) {
      ConvertSettings settings = tiny_settings(s.path, s.dir.path("out/scene.gltf"));
      settings.dry_run = dry;
      ConvertResult r;
      std::string log;
      EXPECT_EQ(run_quiet(settings, r, &log), 1) << log;
      // A broken node graph is refused while reading the input (lsnif/import/gltf_scene.h), the rest
      // when the scene to write is validated; both before any training.
      if (std::string(c.name) != "zero scale") {
        EXPECT_NE(log.find("the converted scene would not load"), std::string::npos) << log;
      }
      EXPECT_NE(log.find(c.expected), std::string::npos) << log;
      EXPECT_EQ(r.trained, 0u);
      EXPECT_FALSE(fs::exists(s.dir.path("out/scene.elephant.lsnif")));
      EXPECT_FALSE(fs::exists(s.dir.path("out/scene.gltf")));
    }
  }
}

}  // namespace
}  // namespace lsnif::convert
