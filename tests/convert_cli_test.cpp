// `lsnif convert` as a user runs it, on the bundled example scene (src/lsnif/renderer/examples): the
// ground quad becomes an LSNIF object with a tiny model, the bunny (already an LSNIF object) keeps
// its model, which now lies in another folder; a second run trains nothing; a dry run writes
// nothing; bad options and a missing input end with the documented exit codes.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "lsnif/import/mesh.h"
#include "lsnif/testing/test_support.h"
#include "flip_cli.h"
#include "gltf_validator/gltf_validator.h"

namespace {

namespace fs = std::filesystem;
using lsnif::test::CommandResult;
using lsnif::test::flip_mean;

const fs::path kExample =
    fs::path(__FILE__).parent_path().parent_path() / "samples/scenes/bunny_on_plane.gltf";
const std::string kTiny = " --convert-when triangles --min-triangles 1 --tiny --eval-rays 1000 --quiet";

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
  r = convert(engine + " -o " + dir.path("out/engine.gltf") + " --convert-when triangles --min-triangles 3000 --tiny --eval-rays 1000 --quiet");
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
                             "--keep-meshes", "--steps", "--voxels", "--convert-when", "--memory-margin",
                             "--blas-size", "--device"})
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
  // The memory rule's options: a margin outside its range, unknown words, --device without a query.
  for (const char* margin : {"0.5", "0", "1e7"}) {
    r = convert(kExample.string() + " -o " + out + " --dry-run --memory-margin " + margin);
    EXPECT_EQ(r.code, 2) << r.out;
    EXPECT_NE(r.out.find("--memory-margin"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("out of range [1, 1e+06]"), std::string::npos) << r.out;
  }
  for (const char* bad : {" --memory-margin two", " --convert-when sometimes", " --blas-size gpu"}) {
    r = convert(kExample.string() + " -o " + out + " --dry-run" + bad);
    EXPECT_EQ(r.code, 2) << bad << ": " << r.out;
    EXPECT_NE(r.out.find(std::string(bad).substr(1, std::string(bad).find(' ', 1) - 1)), std::string::npos) << r.out;
  }
  r = convert(kExample.string() + " -o " + out + " --dry-run --device 0");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--blas-size device"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(out));
}

// Writes `name`.gltf (+ .bin) in `dir`: one node per mesh, each mesh an OFF file of data/meshes
// (positions and triangles, one primitive) or, for "ground", a 2-triangle quad. Returns its path.
std::string write_meshes_scene(const fs::path& dir, const std::string& name, const std::vector<std::string>& meshes) {
  using J = nlohmann::json;
  std::string bin;
  J g = {{"asset", {{"version", "2.0"}}}, {"scene", 0}, {"nodes", J::array()}, {"meshes", J::array()},
         {"accessors", J::array()}, {"bufferViews", J::array()}};
  auto add_view = [&](const void* data, size_t bytes) {
    g["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", bin.size()}, {"byteLength", bytes}});
    bin.append(static_cast<const char*>(data), bytes);
    return g["bufferViews"].size() - 1;
  };
  J roots = J::array();
  for (const std::string& mesh : meshes) {
    lsnif::Mesh m;
    if (mesh == "ground") {
      m.positions = {{-3, 0, -3}, {3, 0, -3}, {3, 0, 3}, {-3, 0, 3}};
      m.triangles = {{0, 2, 1}, {0, 3, 2}};
    } else {
      EXPECT_TRUE(lsnif::load_mesh(std::string(LSNIF_DATA_DIR) + "/meshes/" + mesh + ".off", m)) << mesh;
    }
    const lsnif::Aabb box = m.bounds();
    const size_t positions = add_view(m.positions.data(), m.positions.size() * sizeof(glm::vec3));
    const size_t indices = add_view(m.triangles.data(), m.triangles.size() * sizeof(glm::uvec3));
    g["accessors"].push_back({{"bufferView", positions}, {"componentType", 5126}, {"count", m.positions.size()},
                              {"type", "VEC3"}, {"min", {box.lo.x, box.lo.y, box.lo.z}},
                              {"max", {box.hi.x, box.hi.y, box.hi.z}}});
    g["accessors"].push_back({{"bufferView", indices}, {"componentType", 5125}, {"count", 3 * m.triangles.size()},
                              {"type", "SCALAR"}});
    const size_t a = g["accessors"].size();
    const J primitive = {{"attributes", {{"POSITION", a - 2}}}, {"indices", a - 1}};
    g["meshes"].push_back({{"name", mesh}, {"primitives", J::array({primitive})}});
    roots.push_back(g["nodes"].size());
    g["nodes"].push_back({{"name", mesh}, {"mesh", g["meshes"].size() - 1},
                          {"translation", {3.0 * double(roots.size()), 0, 0}}});
  }
  g["scenes"] = J::array({{{"nodes", roots}}});
  g["buffers"] = J::array({{{"uri", name + ".bin"}, {"byteLength", bin.size()}}});
  std::ofstream(dir / (name + ".bin"), std::ios::binary) << bin;
  std::ofstream(dir / (name + ".gltf")) << g.dump(1);
  return (dir / (name + ".gltf")).string();
}

// The line of `out` that starts with `prefix` ("" when none).
std::string line_starting(const std::string& out, const std::string& prefix) {
  std::istringstream in(out);
  for (std::string line; std::getline(in, line);)
    if (line.rfind(prefix, 0) == 0) return line;
  return "";
}

// The "(R.RRx)" of the report's `scene` line: the scene's memory after over before.
double scene_ratio(const std::string& out) {
  const std::string line = line_starting(out, "scene     ");
  const size_t open = line.rfind('(');
  return open == std::string::npos ? -1.0 : std::stod(line.substr(open + 1));
}

// The acceptance: by default `convert --dry-run` converts only the meshes whose triangle
// BLAS is at least twice their model (the bunny, 75,408 triangles, 7.5 MiB, and the armadillo,
// 52,000, 5.2 MiB, against models estimated at 0.82 MiB), keeps the elephant (5,558 triangles,
// 0.55 MiB) and the ground quad, and prints the memory table; the device's size query (lavapipe)
// gives the estimate's numbers. Nothing is written.
TEST(ConvertCli, DryRunConvertsOnlyWhereLsnifSavesMemory) {
  lsnif::test::ScopedTestDir dir("lsnif_convert_memory");
  const std::string scene = write_meshes_scene(dir.path(), "mixed", {"bunny00", "elephant", "armadillo", "ground"});
  const std::string out = dir.path("out/mixed.gltf");
  CommandResult r = convert(scene + " -o " + out + " --dry-run --quiet");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("node 'bunny00' (mesh 'bunny00', 75408 triangles): convert -> model 'bunny00'"),
            std::string::npos) << r.out;
  EXPECT_NE(r.out.find("node 'armadillo' (mesh 'armadillo', 52000 triangles): convert -> model 'armadillo'"),
            std::string::npos) << r.out;
  EXPECT_NE(r.out.find("node 'elephant' (mesh 'elephant', 5558 triangles): stays triangles (frees less BLAS memory "
                       "than --memory-margin x its model)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("node 'ground' (mesh 'ground', 2 triangles): stays triangles (below --min-triangles)"),
            std::string::npos) << r.out;
  EXPECT_NE(r.out.find("models    2 for 2 instances"), std::string::npos) << r.out;
  // The table: a header, one row per mesh with its decision, the scene before and after.
  const std::string header = line_starting(r.out, "  mesh ");
  for (const char* column : {"triangles", "instances", "BLAS MiB", "model MiB", "ratio", "decision"})
    EXPECT_NE(header.find(column), std::string::npos) << column << "\n" << r.out;
  EXPECT_NE(line_starting(r.out, "  bunny00 ").find("convert -> model 'bunny00'"), std::string::npos) << r.out;
  EXPECT_NE(line_starting(r.out, "  armadillo ").find("convert -> model 'armadillo'"), std::string::npos) << r.out;
  EXPECT_NE(line_starting(r.out, "  elephant ").find("stays: frees < margin x model"), std::string::npos) << r.out;
  EXPECT_NE(line_starting(r.out, "  ground ").find("stays: < --min-triangles"), std::string::npos) << r.out;
  EXPECT_NE(line_starting(r.out, "trade     ").find("calibrated estimate"), std::string::npos) << r.out;
  const double ratio = scene_ratio(r.out);
  EXPECT_GT(ratio, 0.0) << r.out;
  EXPECT_LT(ratio, 1.0) << r.out;  // the scene gets smaller
  EXPECT_FALSE(fs::exists(dir.path("out")));

  // The old rule, asked for: every mesh of 1000 triangles and more, the elephant too.
  CommandResult t = convert(scene + " -o " + out + " --dry-run --quiet --convert-when triangles");
  ASSERT_EQ(t.code, 0) << t.out;
  EXPECT_NE(line_starting(t.out, "  elephant ").find("convert -> model 'elephant'"), std::string::npos) << t.out;
  EXPECT_NE(t.out.find("models    3 for 3 instances"), std::string::npos) << t.out;

  // The device's query: on lavapipe (the default test device) every row as estimated.
  CommandResult d = convert(scene + " -o " + out + " --dry-run --quiet --blas-size device --device " +
                            lsnif::test::test_device());
  ASSERT_EQ(d.code, 0) << d.out;
  EXPECT_NE(line_starting(d.out, "trade     ").find("device query"), std::string::npos) << d.out;
  if (lsnif::test::default_test_device()) {
    for (const char* row : {"  bunny00 ", "  elephant ", "  armadillo ", "  ground ", "scene     "})
      EXPECT_EQ(line_starting(d.out, row), line_starting(r.out, row)) << row;
  }
}

// The CAD sample of the issue (assimp's 2CylinderEngine): 34 primitives, 75,730 triangles, 7.51 MiB
// of triangle BLASes. No part's BLAS (1.1 MiB at most) is twice its model's (0.82 MiB estimated):
// by default nothing converts; the old rule (--convert-when triangles) makes the scene larger
// (1.58x), which the scene line shows; a margin of 1 converts the two parts that save memory.
TEST(ConvertCli, TheCadSampleStaysTrianglesByDefault) {
  const std::string engine = std::string(LSNIF_DATA_DIR) + "/gltf/2CylinderEngine-glTF-Binary/2CylinderEngine.glb";
  if (!fs::exists(engine)) GTEST_SKIP() << "assimp's glTF files missing: run scripts/setup.sh";
  lsnif::test::ScopedTestDir dir("lsnif_convert_memory");
  CommandResult r = convert(engine + " -o " + dir.path("out/engine.gltf") + " --dry-run --quiet");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("models    0 for 0 instances"), std::string::npos) << r.out;
  EXPECT_NE(line_starting(r.out, "scene     ").find("7.511 MiB of triangle BLASes before"), std::string::npos) << r.out;
  EXPECT_DOUBLE_EQ(scene_ratio(r.out), 1.0) << r.out;
  r = convert(engine + " -o " + dir.path("out/engine.gltf") + " --dry-run --quiet --convert-when triangles");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("models    16 for 37 instances"), std::string::npos) << r.out;
  EXPECT_GT(scene_ratio(r.out), 1.0) << r.out;
  r = convert(engine + " -o " + dir.path("out/engine.gltf") + " --dry-run --quiet --memory-margin 1");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("models    2 for 2 instances"), std::string::npos) << r.out;
  EXPECT_GT(scene_ratio(r.out), 0.0) << r.out;
  EXPECT_LT(scene_ratio(r.out), 1.0) << r.out;
  EXPECT_FALSE(fs::exists(dir.path("out")));
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
  CommandResult r = convert(scene + " -o " + out + " --convert-when triangles --keep-meshes --voxels 16 --points 12 --res-min 32 --res-max 64"
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
