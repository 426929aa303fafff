// `lsnif convert` as a user runs it, on the bundled example scene (src/lsnif/renderer/examples): the
// ground quad becomes an LSNIF object with a tiny model, the bunny (already an LSNIF object) keeps
// its model, which now lies in another folder; a second run trains nothing; a dry run writes
// nothing; bad options and a missing input end with the documented exit codes.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "lsnif/import/mesh.h"
#include "lsnif/testing/test_support.h"
#include "gltf_validator/gltf_validator.h"

namespace {

namespace fs = std::filesystem;
using lsnif::test::CommandResult;

const fs::path kExample =
    fs::path(__FILE__).parent_path().parent_path() / "samples/scenes/bunny_on_plane.gltf";
const std::string kTiny = " --min-triangles 1 --tiny --eval-rays 1000 --quiet";

CommandResult convert(const std::string& args) {
  return lsnif::test::run_command(std::string(LSNIF_CLI) + " convert " + args + " 2>&1");
}

nlohmann::json node_named(const nlohmann::json& scene, const std::string& name) {
  for (const nlohmann::json& n : scene["nodes"])
    if (n.value("name", "") == name) return n;
  return nlohmann::json();
}

TEST(ConvertCli, ConvertsRerunsAndDryRuns) {
  lsnif::test::ScopedTestDir dir("lsnif_convert_cli");
  fs::create_directories(dir.path() / "in");
  fs::copy_file(kExample, dir.path() / "in/scene.gltf");
  // The bunny's model only has to exist with the right magic for the scene to load.
  std::ofstream(dir.path("in/bunny.lsnif"), std::ios::binary) << std::string("LSNIF\0\r\n", 8) << "rest";
  const std::string in = dir.path("in/scene.gltf"), out = dir.path("out/scene.gltf");

  // The written scene would refer to ../in/bunny.lsnif, outside its folder: refused before any
  // training unless allowed (the renderer would refuse it too).
  CommandResult r = convert(in + " -o " + out + kTiny);
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("model '../in/bunny.lsnif' refers to a file outside the folder"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("trained "), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(dir.path("out/scene.ground_quad.lsnif")));
  EXPECT_FALSE(fs::exists(out));

  r = convert(in + " -o " + out + kTiny + " --allow-outside-refs");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("node 'ground' (mesh 'ground_quad', 2 triangles): convert"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("trained   1, up to date 0, failed 0"), std::string::npos) << r.out;
  const std::string model = dir.path("out/scene.ground_quad.lsnif");
  ASSERT_TRUE(fs::exists(model));
  EXPECT_TRUE(fs::exists(model + ".json"));
  EXPECT_EQ(lsnif::test::run_command(std::string(LSNIF_CLI) + " info " + model).code, 0);

  std::ifstream f(out);
  const nlohmann::json scene = nlohmann::json::parse(f, nullptr, false);
  ASSERT_FALSE(scene.is_discarded());
  const nlohmann::json ground = node_named(scene, "ground");
  EXPECT_FALSE(ground.contains("mesh"));  // the triangles are gone without --keep-meshes
  EXPECT_EQ(ground["extensions"]["LSNIF_neural_object"]["model"], "scene.ground_quad.lsnif");
  EXPECT_EQ(ground["extensions"]["LSNIF_neural_object"]["materials"], nlohmann::json::array({0}));
  // The bunny's model path is now relative to the output's folder.
  EXPECT_EQ(node_named(scene, "bunny")["extensions"]["LSNIF_neural_object"]["model"], "../in/bunny.lsnif");
  EXPECT_TRUE(scene["extensions"].contains("LSNIF_environment"));
  r = lsnif::test::validate_gltf({out});  // the Khronos glTF validator: no error
  EXPECT_EQ(r.code, 0) << r.out;

  const auto time = fs::last_write_time(model);
  r = convert(in + " -o " + out + kTiny + " --allow-outside-refs");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("trained   0, up to date 1, failed 0"), std::string::npos) << r.out;
  EXPECT_EQ(fs::last_write_time(model), time);

  r = convert(in + " -o " + dir.path("dry/scene.gltf") + " --dry-run --allow-outside-refs" + kTiny);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("would be trained"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(dir.path("dry")));
}

// Scenes made elsewhere convert into valid glTF (the Khronos validator): a CAD assembly (assimp's
// test files) and a scene with a perspective camera without zfar (an infinite projection, which
// tinygltf reads as zfar 0 and must not write back) and an empty node `{}` (which tinygltf writes
// as null). Its unnamed node and mesh have the one name every command uses (node_0, mesh_0).
TEST(ConvertCli, OutputsOfRealScenesPassTheKhronosValidator) {
  const std::string engine = std::string(LSNIF_DATA_DIR) + "/gltf/2CylinderEngine-glTF-Binary/2CylinderEngine.glb";
  const std::string cameras = std::string(LSNIF_DATA_DIR) + "/gltf/cameras/Cameras.gltf";
  if (!fs::exists(engine) || !fs::exists(cameras)) GTEST_SKIP() << "assimp's glTF files missing: run scripts/setup.sh";
  lsnif::test::ScopedTestDir dir("lsnif_convert_cli");
  std::ifstream f(cameras);
  nlohmann::json scene = nlohmann::json::parse(f);
  ASSERT_TRUE(scene["cameras"][0]["perspective"].contains("zfar"));
  scene["cameras"][0]["perspective"].erase("zfar");
  scene["nodes"].push_back(nlohmann::json::object());
  scene["scenes"][0]["nodes"].push_back(scene["nodes"].size() - 1);
  ASSERT_FALSE(scene["nodes"][0].contains("name"));
  ASSERT_FALSE(scene["meshes"][0].contains("name"));
  fs::create_directories(dir.path() / "in");
  fs::copy_file(fs::path(cameras).parent_path() / "simpleSquare.bin", dir.path() / "in/simpleSquare.bin");
  std::ofstream(dir.path("in/cameras.gltf")) << scene.dump();
  CommandResult r = lsnif::test::validate_gltf({dir.path("in/cameras.gltf"), engine});
  ASSERT_EQ(r.code, 0) << "the inputs themselves:\n" << r.out;

  r = lsnif::test::run_command(std::string(LSNIF_CLI) + " render " + dir.path("in/cameras.gltf") +
                               " --width 16 --height 12 --spp 1 --node-transform node_0=0,0,0 -o " +
                               dir.path("in.png") + " 2>&1");
  ASSERT_EQ(r.code, 0) << r.out;
  r = convert(dir.path("in/cameras.gltf") + " -o " + dir.path("out/cameras.gltf") + kTiny + " --select node_0");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("node 'node_0' (mesh 'mesh_0', 2 triangles): convert"), std::string::npos) << r.out;
  r = convert(engine + " -o " + dir.path("out/engine.gltf") + " --min-triangles 3000 --tiny --eval-rays 1000 --quiet");
  ASSERT_EQ(r.code, 0) << r.out;
  r = lsnif::test::validate_gltf({dir.path("out/cameras.gltf"), dir.path("out/engine.gltf")});
  EXPECT_EQ(r.code, 0) << r.out;
  std::ifstream g(dir.path("out/cameras.gltf"));
  const nlohmann::json written = nlohmann::json::parse(g);
  EXPECT_FALSE(written["cameras"][0]["perspective"].contains("zfar")) << written["cameras"].dump();
  EXPECT_EQ(written["cameras"][1]["orthographic"]["zfar"], 100.0) << written["cameras"].dump();
}

// A .gltf with an external texture converted into another folder: the image is embedded into the
// output's buffer (the output folder stands alone and validates), unless --allow-outside-refs asks
// for a reference to where it lies.
TEST(ConvertCli, ExternalImagesAreEmbeddedWhenTheOutputGoesElsewhere) {
  const std::string box = std::string(LSNIF_DATA_DIR) + "/gltf/BoxTextured-glTF/BoxTextured.gltf";
  if (!fs::exists(box)) GTEST_SKIP() << box << " missing: run scripts/setup.sh";
  lsnif::test::ScopedTestDir dir("lsnif_convert_cli");
  const std::string out = dir.path("out/box.gltf"), ref = dir.path("ref/box.gltf");
  CommandResult r = convert(box + " -o " + out + kTiny);
  ASSERT_EQ(r.code, 0) << r.out;
  std::ifstream f(out);
  const nlohmann::json scene = nlohmann::json::parse(f);
  ASSERT_EQ(scene["images"].size(), 1u);
  EXPECT_FALSE(scene["images"][0].contains("uri")) << scene["images"].dump();
  EXPECT_EQ(scene["images"][0]["mimeType"], "image/png");
  const nlohmann::json& view = scene["bufferViews"][scene["images"][0]["bufferView"].get<size_t>()];
  EXPECT_EQ(view["byteLength"].get<uint64_t>(),
            fs::file_size(fs::path(box).parent_path() / "CesiumLogoFlat.png"));
  r = lsnif::test::validate_gltf({out});
  EXPECT_EQ(r.code, 0) << r.out;
  // The output folder alone, moved elsewhere, still renders.
  fs::rename(dir.path("out"), dir.path("moved"));
  r = lsnif::test::run_command(std::string(LSNIF_CLI) + " render " + dir.path("moved/box.gltf") +
                               " --width 16 --height 12 --spp 1 -o " + dir.path("moved.png") + " 2>&1");
  EXPECT_EQ(r.code, 0) << r.out;

  r = convert(box + " -o " + ref + kTiny + " --allow-outside-refs");
  ASSERT_EQ(r.code, 0) << r.out;
  std::ifstream g(ref);
  const nlohmann::json referenced = nlohmann::json::parse(g);
  const std::string uri = referenced["images"][0]["uri"];
  EXPECT_TRUE(fs::equivalent(fs::path(ref).parent_path() / uri, fs::path(box).parent_path() / "CesiumLogoFlat.png")) << uri;
}

TEST(ConvertCli, HelpAndErrors) {
  CommandResult r = convert("--help");
  EXPECT_EQ(r.code, 0);
  for (const char* option : {"--min-triangles", "--select", "--exclude", "--group", "--jobs", "--dry-run",
                             "--keep-meshes", "--steps", "--voxels"})
    EXPECT_NE(r.out.find(option), std::string::npos) << option;
  lsnif::test::ScopedTestDir dir("lsnif_convert_cli");
  const std::string out = dir.path("out.gltf");
  r = convert(kExample.string() + " -o " + out + " --group nameonly");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("NAME=REGEX"), std::string::npos) << r.out;
  r = convert(kExample.string() + " -o " + out + " --select '('");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--select"), std::string::npos) << r.out;
  r = convert(kExample.string() + " -o " + dir.path("out.glb"));
  EXPECT_EQ(r.code, 2) << r.out;
  r = convert(dir.path("missing.gltf") + " -o " + out);
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("missing.gltf"), std::string::npos) << r.out;
}

// A scene with repeated meshes, written by hand: a 6 x 6 ground quad and three instances of the
// elephant (scaled to unit size, standing on the ground) under a constant sky, a camera looking at
// them. `with_elephants` false leaves the elephant nodes out of the scene (the "object removed"
// render). Returns the .gltf path.
std::string write_herd_scene(const fs::path& dir, const std::string& name, bool with_elephants) {
  lsnif::Mesh e;
  EXPECT_TRUE(lsnif::load_mesh(std::string(LSNIF_DATA_DIR) + "/meshes/elephant.off", e));
  const lsnif::Aabb box = e.bounds();
  const float scale = 1.0f / std::max({box.extent().x, box.extent().y, box.extent().z});
  std::vector<float> floats = {-3, 0, -3, 3, 0, -3, 3, 0, 3, -3, 0, 3};
  glm::vec3 lo(1e30f), hi(-1e30f);
  for (glm::vec3 p : e.positions) {
    const glm::vec3 q = (p - glm::vec3(box.center().x, box.lo.y, box.center().z)) * scale;
    lo = glm::min(lo, q);
    hi = glm::max(hi, q);
    floats.insert(floats.end(), {q.x, q.y, q.z});
  }
  std::vector<uint32_t> indices = {0, 2, 1, 0, 3, 2};
  for (glm::uvec3 t : e.triangles) indices.insert(indices.end(), {t.x, t.y, t.z});
  std::ofstream bin(dir / (name + ".bin"), std::ios::binary);
  bin.write(reinterpret_cast<const char*>(floats.data()), std::streamsize(floats.size() * 4));
  bin.write(reinterpret_cast<const char*>(indices.data()), std::streamsize(indices.size() * 4));
  bin.close();
  const size_t nv = e.positions.size(), pos_bytes = floats.size() * 4;
  using J = nlohmann::json;
  J g = {{"asset", {{"version", "2.0"}}},
         {"extensionsUsed", {"LSNIF_environment"}},
         {"extensions", {{"LSNIF_environment", {{"color", {0.8, 0.9, 1.0}}}}}},
         {"scene", 0},
         {"nodes", J::array({{{"name", "ground"}, {"mesh", 0}},
                             {{"name", "camera"}, {"camera", 0}, {"translation", {0, 1.2, 3.2}},
                              {"rotation", {-0.17, 0, 0, 0.985}}},
                             {{"name", "elephant_a"}, {"mesh", 1}, {"translation", {-1.0, 0, 0}},
                              {"rotation", {0, 0.26, 0, 0.966}}},
                             {{"name", "elephant_b"}, {"mesh", 1}, {"translation", {0.4, 0, -0.6}},
                              {"rotation", {0, -0.5, 0, 0.866}}, {"scale", {0.8, 0.8, 0.8}}},
                             {{"name", "elephant_c"}, {"mesh", 1}, {"translation", {1.1, 0, 0.6}},
                              {"scale", {0.6, 0.6, 0.6}}}})},
         {"scenes", J::array({{{"nodes", with_elephants ? J({0, 1, 2, 3, 4}) : J({0, 1})}}})},
         {"cameras", J::array({{{"type", "perspective"}, {"perspective", {{"yfov", 0.8}, {"znear", 0.01}, {"zfar", 100}}}}})},
         {"materials", J::array({{{"name", "ground"}, {"pbrMetallicRoughness", {{"baseColorFactor", {0.8, 0.8, 0.8, 1}}, {"metallicFactor", 0}}}},
                                 {{"name", "elephant"}, {"pbrMetallicRoughness", {{"baseColorFactor", {0.6, 0.6, 0.65, 1}}, {"metallicFactor", 0}}}}})},
         {"meshes", J::array({{{"name", "ground"}, {"primitives", J::array({{{"attributes", {{"POSITION", 0}}}, {"indices", 2}, {"material", 0}}})}},
                              {{"name", "elephant"}, {"primitives", J::array({{{"attributes", {{"POSITION", 1}}}, {"indices", 3}, {"material", 1}}})}}})},
         {"accessors", J::array({{{"bufferView", 0}, {"componentType", 5126}, {"count", 4}, {"type", "VEC3"},
                                  {"min", {-3, 0, -3}}, {"max", {3, 0, 3}}},
                                 {{"bufferView", 0}, {"byteOffset", 48}, {"componentType", 5126}, {"count", nv}, {"type", "VEC3"},
                                  {"min", {lo.x, lo.y, lo.z}}, {"max", {hi.x, hi.y, hi.z}}},
                                 {{"bufferView", 1}, {"componentType", 5125}, {"count", 6}, {"type", "SCALAR"}},
                                 {{"bufferView", 1}, {"byteOffset", 24}, {"componentType", 5125}, {"count", e.triangles.size() * 3},
                                  {"type", "SCALAR"}}})},
         {"bufferViews", J::array({{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", pos_bytes}},
                                   {{"buffer", 0}, {"byteOffset", pos_bytes}, {"byteLength", indices.size() * 4}}})},
         {"buffers", J::array({{{"uri", name + ".bin"}, {"byteLength", pos_bytes + indices.size() * 4}}})}};
  std::ofstream(dir / (name + ".gltf")) << g.dump(1);
  return (dir / (name + ".gltf")).string();
}

double flip_mean(const std::string& reference, const std::string& test) {
  CommandResult r = lsnif::test::run_command(std::string(LSNIF_CLI) + " flip " + reference + " " + test + " 2>&1");
  EXPECT_EQ(r.code, 0) << r.out;
  const size_t at = r.out.find("mean");
  return at == std::string::npos ? 1.0 : std::stod(r.out.substr(r.out.find_first_not_of(' ', at + 4)));
}

// The acceptance on a small scale: three instances of one mesh convert into one model
// (trained once), the converted scene's reference mode renders bit for bit like the original scene,
// and its LSNIF render is closer to the original than half the error of removing the objects
// (the renderer test's bound). Vulkan on lavapipe.
TEST(ConvertCli, ConvertedSceneRendersLikeTheOriginal) {
  lsnif::test::ScopedTestDir dir("lsnif_convert_render");
  const std::string scene = write_herd_scene(dir.path(), "herd", true);
  const std::string empty = write_herd_scene(dir.path(), "empty", false);
  const std::string out = dir.path("out/herd.gltf");
  // Not --tiny: the in-process tests' larger model (test_support.h tiny_train_settings) at 600 steps,
  // which the image bound below was set for.
  CommandResult r = convert(scene + " -o " + out + " --keep-meshes --voxels 16 --points 12 --res-min 32 --res-max 64"
                            " --table-log2 14 --width 64 --batch 2048 --steps 600 --eval-rays 0 --quiet");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("models    1 for 3 instances"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("3 instances sharing it"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("trained   1,"), std::string::npos) << r.out;

  const std::string render = std::string(LSNIF_CLI) + " render --width 64 --height 48 --spp 8 ";
  for (const auto& [args, image] : {std::pair{scene, "original.png"}, std::pair{out + " --reference", "reference.png"},
                                    std::pair{out, "lsnif.png"}, std::pair{empty, "removed.png"}}) {
    CommandResult rr = lsnif::test::run_command(render + args + " -o " + dir.path(image) + " 2>&1");
    ASSERT_EQ(rr.code, 0) << args << "\n" << rr.out;
  }
  std::ifstream a(dir.path("original.png"), std::ios::binary), b(dir.path("reference.png"), std::ios::binary);
  const std::string original((std::istreambuf_iterator<char>(a)), {}), reference((std::istreambuf_iterator<char>(b)), {});
  EXPECT_TRUE(!original.empty() && original == reference);
  const double lsnif = flip_mean(dir.path("original.png"), dir.path("lsnif.png"));
  const double removed = flip_mean(dir.path("original.png"), dir.path("removed.png"));
  std::printf("mean LDR-FLIP against the original: LSNIF %.4f, objects removed %.4f\n", lsnif, removed);
  EXPECT_LT(lsnif, 0.5 * removed);
}

}  // namespace
