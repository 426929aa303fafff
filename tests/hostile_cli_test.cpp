// hostile_cli_test.cpp -- the `lsnif` program against the hostile cases a new user can produce:
// deeply nested JSON for every command that reads glTF, huge node names under the converter's
// patterns, zero voxels, writes through links and over devices, a full disk (a file size limit),
// outputs that are inputs, outputs checked before the work, a diverging learning rate, references
// outside the scene's folder, extensions of another JSON type, dry runs of scenes the real run
// refuses, models of another object space, bad option values and names with control characters.
// Every run must end with an exit code (never a signal) and, for these inputs, a non-zero one with
// a message naming the problem.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "lsnif/testing/fuzz_support.h"
#include "lsnif/import/mesh.h"
#include "lsnif/testing/test_support.h"

namespace {

namespace fs = std::filesystem;
using lsnif::test::ProcessResult;
using nlohmann::json;

const std::string kElephant = std::string(LSNIF_DATA_DIR) + "/meshes/elephant.off";
// The training options of every run that trains: the tiny preset, no progress bar.
const std::vector<std::string> kTiny = {"--tiny", "--quiet"};

ProcessResult lsnif_run(std::vector<std::string> args, uint64_t file_size_limit = 0) {
  args.insert(args.begin(), LSNIF_CLI);
  return lsnif::test::run_process(args, 120.0, file_size_limit, {"MESA_SHADER_CACHE_DISABLE=true"});
}

std::vector<std::string> with_tiny(std::vector<std::string> args) {
  args.insert(args.end(), kTiny.begin(), kTiny.end());
  return args;
}

std::string read_all(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void put(const std::string& path, const std::string& bytes) {
  fs::create_directories(fs::path(path).parent_path());
  std::ofstream(path, std::ios::binary) << bytes;
}

std::set<std::string> names_in(const fs::path& dir) {
  std::set<std::string> out;
  for (const fs::directory_entry& e : fs::directory_iterator(dir)) out.insert(e.path().filename().string());
  return out;
}

// Expects a clean failure: exit code `code`, no signal, and `message` in the output.
#define EXPECT_FAILS_WITH(result, code, message)                                                      \
  do {                                                                                                \
    const ProcessResult& r_ = (result);                                                               \
    EXPECT_FALSE(r_.crashed()) << "signal " << r_.signal << "\n" << r_.output;                        \
    EXPECT_FALSE(r_.timed_out) << r_.output;                                                          \
    EXPECT_EQ(r_.exit_code, code) << r_.output;                                                       \
    EXPECT_NE(r_.output.find(message), std::string::npos) << "expected '" << (message) << "' in\n" << r_.output; \
  } while (0)

// A quad scene: ground quad (node "ground", mesh 0) and a camera; the buffer at `buffer_uri`.
json quad_scene(const std::string& buffer_uri) {
  json j = json::parse(R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0,1]}],
"nodes":[{"name":"ground","mesh":0},{"name":"cam","camera":0,"translation":[0,1,3]}],
"cameras":[{"type":"perspective","perspective":{"yfov":0.8,"znear":0.01}}],
"meshes":[{"name":"quad","primitives":[{"attributes":{"POSITION":0},"indices":1}]}],
"accessors":[{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[-1,0,-1],"max":[1,0,1]},
 {"bufferView":1,"componentType":5123,"count":6,"type":"SCALAR"}],
"bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":48},{"buffer":0,"byteOffset":48,"byteLength":12}]})");
  j["buffers"] = json::array({{{"uri", buffer_uri}, {"byteLength", 60}}});
  return j;
}

std::string quad_bin() {
  std::string b = lsnif::fuzz::put_floats({-1, 0, -1, 1, 0, -1, 1, 0, 1, -1, 0, 1});
  const uint16_t idx[6] = {0, 2, 1, 0, 3, 2};
  b.append(reinterpret_cast<const char*>(idx), sizeof idx);
  return b;
}

std::string deep(size_t depth) { return std::string(depth, '[') + std::string(depth, ']'); }

class HostileCli : public ::testing::Test {
 protected:
  // One tiny elephant model for the suite, in a folder of its own (each test has another).
  static void SetUpTestSuite() {
    suite_dir_ = fs::temp_directory_path() / ("lsnif_hostile_cli_" + std::to_string(::getpid()));
    fs::create_directories(suite_dir_);
    model_ = (suite_dir_ / "elephant.lsnif").string();
    if (!fs::exists(kElephant)) return;
    const ProcessResult r = lsnif_run(with_tiny({"train", kElephant, "-o", model_}));
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  static void TearDownTestSuite() {
    std::error_code ec;
    fs::remove_all(suite_dir_, ec);
  }
  void SetUp() override {
    if (!fs::exists(kElephant)) GTEST_SKIP() << kElephant << " missing: run scripts/setup.sh";
    dir_ = std::make_unique<lsnif::test::ScopedTestDir>("lsnif_hostile_cli");
    work_ = dir_->path();
  }
  std::string path(const std::string& name) const { return (work_ / name).string(); }

  static fs::path suite_dir_;
  static std::string model_;
  std::unique_ptr<lsnif::test::ScopedTestDir> dir_;
  fs::path work_;
};
fs::path HostileCli::suite_dir_;
std::string HostileCli::model_;

// JSON nested 20,000 deep crashed every command that reads glTF (stack overflow in the parser).
TEST_F(HostileCli, DeepJsonIsAnErrorForEveryCommand) {
  put(path("scene/quad.bin"), quad_bin());
  json j = quad_scene("quad.bin");
  std::string text = j.dump();
  text.insert(text.size() - 1, ",\"extras\":" + deep(20000));
  put(path("scene/deep.gltf"), text);
  put(path("scene/deep.glb"), lsnif::fuzz::glb(text, ""));
  for (const std::string& file : {path("scene/deep.gltf"), path("scene/deep.glb")}) {
    const std::vector<std::vector<std::string>> runs = {
        {"render", file, "-o", path("r.png"), "--width", "8", "--height", "8", "--spp", "1"},
        with_tiny({"train", file, "-o", path("t.lsnif")}),
        {"eval", model_, file, "--rays", "100"},
        with_tiny({"convert", file, "-o", path("c/out.gltf")}),
        {"bench-memory", file, model_},
    };
    for (const std::vector<std::string>& run : runs) {
      SCOPED_TRACE(run[0] + " " + file);
      EXPECT_FAILS_WITH(lsnif_run(run), 1, "JSON nested deeper than 128 levels");
    }
  }
}

// The node graph is read by one reader (lsnif/import/gltf_scene.h) for every command: train, eval,
// render and convert give a file the same verdict. `file` is a scene in the work folder's scene/
// with quad.bin beside it; each command must fail with `message`.
void expect_every_command_refuses(const std::string& file, const std::string& work, const std::string& model,
                                  const std::string& message) {
  const std::vector<std::vector<std::string>> runs = {
      with_tiny({"train", file, "-o", work + "/t.lsnif"}),
      {"eval", model, file, "--rays", "100"},
      {"render", file, "-o", work + "/r.png", "--width", "8", "--height", "8", "--spp", "1"},
      with_tiny({"convert", file, "-o", work + "/c/out.gltf", "--convert-when", "triangles", "--min-triangles", "1"}),
  };
  for (const std::vector<std::string>& run : runs) {
    SCOPED_TRACE(run[0]);
    EXPECT_FAILS_WITH(lsnif_run(run), 1, message);
  }
  EXPECT_FALSE(fs::exists(work + "/t.lsnif"));
  EXPECT_FALSE(fs::exists(work + "/r.png"));
  EXPECT_FALSE(fs::exists(work + "/c/out.gltf"));
}

// The quad scene as every command accepts it: the control of the node-graph cases below.
TEST_F(HostileCli, NodeGraphControlPassesEveryCommand) {
  put(path("scene/quad.bin"), quad_bin());
  put(path("scene/quad.gltf"), quad_scene("quad.bin").dump());
  const std::string file = path("scene/quad.gltf");
  const std::vector<std::vector<std::string>> runs = {
      with_tiny({"train", file, "-o", path("t.lsnif")}),
      {"eval", path("t.lsnif"), file, "--rays", "100"},
      {"render", file, "-o", path("r.png"), "--width", "8", "--height", "8", "--spp", "1"},
      with_tiny({"convert", file, "-o", path("c/out.gltf"), "--convert-when", "triangles", "--min-triangles", "1", "--dry-run"}),
  };
  for (const std::vector<std::string>& run : runs) {
    SCOPED_TRACE(run[0]);
    const ProcessResult r = lsnif_run(run);
    EXPECT_EQ(r.exit_code, 0) << r.output;
  }
}

// Nodes sharing children 40 levels deep (2^40 paths from 80 nodes in a small file): the training
// importer used to walk every path and allocate gigabytes while the renderer refused the file. A
// node is reached at most once now, by every command.
TEST_F(HostileCli, SharedChildrenAreRefusedByEveryCommand) {
  put(path("scene/quad.bin"), quad_bin());
  json j = quad_scene("quad.bin");
  constexpr int kLevels = 40;
  json nodes = json::array({j["nodes"][0], j["nodes"][1]});
  for (int level = 0; level < kLevels; ++level)
    for (int k = 0; k < 2; ++k) {
      json n = {{"name", "level" + std::to_string(level) + (k ? "b" : "a")}, {"mesh", 0}};
      if (level + 1 < kLevels) n["children"] = {2 + 2 * (level + 1), 3 + 2 * (level + 1)};
      nodes.push_back(n);
    }
  j["nodes"] = nodes;
  j["scenes"][0]["nodes"] = {0, 1, 2, 3};
  put(path("scene/shared.gltf"), j.dump());
  EXPECT_LT(fs::file_size(path("scene/shared.gltf")), 32u * 1024u);
  expect_every_command_refuses(path("scene/shared.gltf"), work_.string(), model_,
                               "node 80 ('level39a') is reached a second time");
}

TEST_F(HostileCli, NonAffineMatrixIsRefusedByEveryCommand) {
  put(path("scene/quad.bin"), quad_bin());
  json j = quad_scene("quad.bin");
  j["nodes"][0]["matrix"] = {1, 0, 0, 0.5, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  put(path("scene/projective.gltf"), j.dump());
  expect_every_command_refuses(path("scene/projective.gltf"), work_.string(), model_,
                               "node 0 ('ground'): matrix is not affine");
}

TEST_F(HostileCli, ZeroQuaternionIsRefusedByEveryCommand) {
  put(path("scene/quad.bin"), quad_bin());
  json j = quad_scene("quad.bin");
  j["nodes"][0]["rotation"] = {0, 0, 0, 0};
  put(path("scene/zero_rotation.gltf"), j.dump());
  expect_every_command_refuses(path("scene/zero_rotation.gltf"), work_.string(), model_,
                               "node 0 ('ground'): rotation quaternion has zero length");
}

// JSON has no NaN or infinity. A number past the double range is refused by the JSON reader itself;
// one past the float range makes a world transform that is infinite once converted to float.
TEST_F(HostileCli, NonFiniteTransformIsRefusedByEveryCommand) {
  put(path("scene/quad.bin"), quad_bin());
  const std::string text = quad_scene("quad.bin").dump();
  const std::string ground = R"({"mesh":0,"name":"ground"})";
  ASSERT_NE(text.find(ground), std::string::npos) << text;
  const auto with_matrix = [&](const std::string& first) {
    std::string t = text;
    return t.replace(t.find(ground), ground.size(),
                     R"({"mesh":0,"name":"ground","matrix":[)" + first + R"(,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1]})");
  };
  put(path("scene/overflow.gltf"), with_matrix("1e999"));
  expect_every_command_refuses(path("scene/overflow.gltf"), work_.string(), model_,
                               "number overflow parsing '1e999'");
  put(path("scene/infinite.gltf"), with_matrix("1e300"));
  expect_every_command_refuses(path("scene/infinite.gltf"), work_.string(), model_,
                               "node 0 ('ground'): NaN or infinite value in its world transform");
}

// Materials are read by one reader too (lsnif/import/gltf_material.h): a factor the renderer
// refuses is refused by training, evaluation and conversion as well.
TEST_F(HostileCli, BadMaterialIsRefusedByEveryCommand) {
  put(path("scene/quad.bin"), quad_bin());
  json j = quad_scene("quad.bin");
  j["materials"] = json::array({{{"name", "paint"}, {"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 5}}}}}}});
  j["meshes"][0]["primitives"][0]["material"] = 0;
  put(path("scene/material.gltf"), j.dump());
  expect_every_command_refuses(path("scene/material.gltf"), work_.string(), model_,
                               "material 0 ('paint'): baseColorTexture references missing texture 5 (0 textures)");
  json k = quad_scene("quad.bin");  // a factor tinygltf keeps: a negative emissive strength
  k["materials"] = json::array({{{"name", "paint"},
                                 {"emissiveFactor", {1, 1, 1}},
                                 {"extensions", {{"KHR_materials_emissive_strength", {{"emissiveStrength", -2}}}}}}});
  k["meshes"][0]["primitives"][0]["material"] = 0;
  put(path("scene/strength.gltf"), k.dump());
  expect_every_command_refuses(path("scene/strength.gltf"), work_.string(), model_,
                               "material 0 ('paint'): emissiveStrength must be a finite number >= 0");
}

TEST_F(HostileCli, PatternsOnHugeNamesAndZeroVoxels) {
  put(path("scene/quad.bin"), quad_bin());
  json j = quad_scene("quad.bin");
  j["nodes"][0]["name"] = std::string(30000, 'a');
  put(path("scene/long.gltf"), j.dump());
  for (const char* option : {"--select", "--exclude"}) {
    const ProcessResult r = lsnif_run({"convert", path("scene/long.gltf"), "-o", path("c/out.gltf"), "--dry-run",
                                       "--convert-when", "triangles", "--min-triangles", "1", option, "a*"});
    EXPECT_FALSE(r.crashed()) << r.signal << r.output;
    EXPECT_EQ(r.exit_code, 0) << r.output;
  }
  ProcessResult r = lsnif_run({"convert", path("scene/long.gltf"), "-o", path("c/out.gltf"), "--dry-run",
                               "--convert-when", "triangles", "--min-triangles", "1", "--group", "g=(a|a)*"});
  EXPECT_FALSE(r.crashed()) << r.output;
  EXPECT_FAILS_WITH(lsnif_run({"train", kElephant, "-o", path("v.lsnif"), "--voxels", "0"}), 2,
                    "--voxels 0 out of range [1, 256]");
  EXPECT_FAILS_WITH(lsnif_run({"convert", path("scene/long.gltf"), "-o", path("c/out.gltf"), "--dry-run",
                               "--voxels", "0"}),
                    2, "--voxels 0 out of range");
}

TEST_F(HostileCli, NoWriteThroughALinkOrOverADevice) {
  put(path("outside/precious.txt"), "precious");
  fs::create_directories(path("out"));
  fs::create_symlink(path("outside/precious.txt"), path("out/x.lsnif.tmp"));
  ProcessResult r = lsnif_run(with_tiny({"train", kElephant, "-o", path("out/x.lsnif")}));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(read_all(path("outside/precious.txt")), "precious");
  EXPECT_TRUE(fs::is_regular_file(fs::symlink_status(path("out/x.lsnif"))));
  EXPECT_TRUE(fs::is_symlink(path("out/x.lsnif.tmp")));
  // A link at the output itself, a device and a folder are refused before the training.
  fs::create_symlink(path("outside/precious.txt"), path("out/link.lsnif"));
  EXPECT_FAILS_WITH(lsnif_run(with_tiny({"train", kElephant, "-o", path("out/link.lsnif")})), 1, "symbolic link");
  EXPECT_EQ(read_all(path("outside/precious.txt")), "precious");
  r = lsnif_run(with_tiny({"train", kElephant, "-o", "/dev/null"}));
  EXPECT_FAILS_WITH(r, 1, "'/dev/null' is a device; refusing to replace it");
  EXPECT_EQ(r.output.find("trained "), std::string::npos) << r.output;
  EXPECT_TRUE(fs::is_character_file("/dev/null"));
  EXPECT_FAILS_WITH(lsnif_run(with_tiny({"train", kElephant, "-o", path("out")})), 1, "is a folder");
}

// A full disk (RLIMIT_FSIZE): a clear error, a non-zero exit, and the previous file intact.
TEST_F(HostileCli, FullDiskFailsLoudlyAndKeepsThePreviousFiles) {
  put(path("m.lsnif"), "old model");
  put(path("m.lsnif.csv"), "old curve");
  ProcessResult r = lsnif_run(with_tiny({"train", kElephant, "-o", path("m.lsnif")}), 20000);
  EXPECT_FAILS_WITH(r, 1, "File too large");
  EXPECT_EQ(read_all(path("m.lsnif")), "old model");
  EXPECT_EQ(read_all(path("m.lsnif.csv")), "old curve");  // the curve goes only after the model
  EXPECT_EQ(names_in(work_), (std::set<std::string>{"m.lsnif", "m.lsnif.csv"}));

  // Images (the writer `render` uses too; lavapipe's own memory files cannot run under a file size
  // limit, so `flip` stands in for it): a FLIP heatmap.
  const std::string scene = path("scene/quad.gltf");
  put(path("scene/quad.bin"), quad_bin());
  put(scene, quad_scene("quad.bin").dump());
  for (const char* spp : {"1", "2"}) {
    r = lsnif_run({"render", scene, "-o", path(std::string("spp") + spp + ".png"), "--width", "32", "--height", "24",
                   "--spp", spp});
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  put(path("heat.png"), "old heatmap");
  r = lsnif_run({"flip", path("spp1.png"), path("spp2.png"), "--heatmap", path("heat.png")}, 100);
  EXPECT_FAILS_WITH(r, 1, "File too large");
  EXPECT_EQ(read_all(path("heat.png")), "old heatmap");
  for (const std::string& name : names_in(work_)) EXPECT_EQ(name.find(".tmp-"), std::string::npos) << name;
}

TEST_F(HostileCli, OutputsThatAreInputsAreRefused) {
  fs::copy_file(kElephant, path("a.off"));
  const std::string mesh = read_all(path("a.off"));
  EXPECT_FAILS_WITH(lsnif_run(with_tiny({"train", path("a.off"), "-o", path("a.off")})), 1,
                    "is the input file");
  EXPECT_FAILS_WITH(lsnif_run(with_tiny({"train", path("a.off"), "-o", path("x.lsnif"), "--csv", path("a.off")})),
                    1, "--csv '" + path("a.off") + "' is the input file");
  fs::create_hard_link(path("a.off"), path("hard.off"));
  EXPECT_FAILS_WITH(lsnif_run(with_tiny({"train", path("a.off"), "-o", path("hard.off")})), 1, "is the input file");
  EXPECT_EQ(read_all(path("a.off")), mesh);

  put(path("scene/quad.bin"), quad_bin());
  put(path("scene/in.gltf"), quad_scene("quad.bin").dump());
  fs::copy_file(model_, path("v.png"));
  EXPECT_FAILS_WITH(lsnif_run({"render", path("scene/in.gltf"), "--lsnif", "ground=" + path("v.png"), "-o",
                               path("v.png")}),
                    1, "is the input file");
  EXPECT_EQ(read_all(path("v.png")), read_all(model_));
  const std::string scene_text = read_all(path("scene/in.gltf"));
  EXPECT_FAILS_WITH(lsnif_run(with_tiny({"convert", path("scene/in.gltf"), "-o", path("scene/in.gltf"),
                                         "--convert-when", "triangles", "--min-triangles", "1"})),
                    1, "which the input scene");
  EXPECT_EQ(read_all(path("scene/in.gltf")), scene_text);
}

TEST_F(HostileCli, OutputsAreCheckedBeforeTheWork) {
  ProcessResult r = lsnif_run(with_tiny({"train", kElephant, "-o", path("missing/x.lsnif")}));
  EXPECT_FAILS_WITH(r, 1, "-o: cannot write '" + path("missing/x.lsnif") + "': the folder '" + path("missing") +
                              "' does not exist");
  EXPECT_EQ(r.output.find("trained "), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("csv"), std::string::npos) << r.output;  // not reported as a CSV problem
  r = lsnif_run(with_tiny({"train", kElephant, "-o", path("x.lsnif"), "--csv", path("missing/x.csv")}));
  EXPECT_FAILS_WITH(r, 1, "--csv: cannot write");
  EXPECT_FALSE(fs::exists(path("x.lsnif")));
  put(path("scene/quad.bin"), quad_bin());
  put(path("scene/quad.gltf"), quad_scene("quad.bin").dump());
  r = lsnif_run({"render", path("scene/quad.gltf"), "-o", path("missing/r.png")});
  EXPECT_FAILS_WITH(r, 1, "the folder '" + path("missing") + "' does not exist");
  // A diverging run stops early with a clear error and writes nothing.
  r = lsnif_run(with_tiny({"train", kElephant, "-o", path("lr.lsnif"), "--lr", "1e30"}));
  EXPECT_FAILS_WITH(r, 1, "training diverged");
  EXPECT_FALSE(fs::exists(path("lr.lsnif")));
  EXPECT_FALSE(fs::exists(path("lr.lsnif.csv")));
}

TEST_F(HostileCli, ReferencesStayInTheSceneFolderUnlessAllowed) {
  put(path("quad.bin"), quad_bin());
  put(path("scene/s.gltf"), quad_scene("../quad.bin").dump());
  const std::vector<std::vector<std::string>> runs = {
      {"render", path("scene/s.gltf"), "-o", path("r.png"), "--width", "8", "--height", "8", "--spp", "1"},
      with_tiny({"train", path("scene/s.gltf"), "-o", path("t.lsnif")}),
      {"eval", model_, path("scene/s.gltf"), "--rays", "100"},
      with_tiny({"convert", path("scene/s.gltf"), "-o", path("c/out.gltf"), "--convert-when", "triangles", "--min-triangles", "1"}),
      {"bench-memory", path("scene/s.gltf"), model_},
  };
  for (const std::vector<std::string>& run : runs) {
    SCOPED_TRACE(run[0]);
    EXPECT_FAILS_WITH(lsnif_run(run), 1, "'../quad.bin' refers to a file outside the folder");
  }
  ProcessResult r = lsnif_run(with_tiny({"train", path("scene/s.gltf"), "-o", path("t.lsnif"),
                                         "--allow-outside-refs", "--allow-dropped-triangles"}));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  r = lsnif_run({"render", path("scene/s.gltf"), "-o", path("r.png"), "--width", "8", "--height", "8", "--spp", "1",
                 "--allow-outside-refs"});
  EXPECT_EQ(r.exit_code, 0) << r.output;
  // OBJ mtllib: /etc/passwd is never read.
  put(path("m/m.obj"), "mtllib /etc/passwd\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  EXPECT_FAILS_WITH(lsnif_run(with_tiny({"train", path("m/m.obj"), "-o", path("m.lsnif")})), 1,
                    "mtllib '/etc/passwd' refers to a file outside the folder");
}

TEST_F(HostileCli, SceneErrorsAreFoundByRenderAndByTheDryRun) {
  put(path("scene/quad.bin"), quad_bin());
  fs::copy_file(model_, path("scene/bunny.lsnif"));
  json j = quad_scene("quad.bin");
  j["nodes"].push_back({{"name", "bunny"}, {"extensions", {{"LSNIF_neural_object", "bunny.lsnif"}}}});
  j["scenes"][0]["nodes"].push_back(2);
  put(path("scene/string.gltf"), j.dump());
  EXPECT_FAILS_WITH(lsnif_run({"render", path("scene/string.gltf"), "-o", path("r.png")}), 1,
                    "node 2 ('bunny'): LSNIF_neural_object must be a JSON object, not a string");
  json e = quad_scene("quad.bin");
  e["extensions"] = {{"LSNIF_environment", 5}};
  put(path("scene/env.gltf"), e.dump());
  EXPECT_FAILS_WITH(lsnif_run({"render", path("scene/env.gltf"), "-o", path("r.png")}), 1,
                    "LSNIF_environment must be a JSON object, not a number");
  // A missing HDR: the dry run says so, as the real run does before training.
  json h = quad_scene("quad.bin");
  h["extensions"] = {{"LSNIF_environment", {{"hdr", "sky.hdr"}}}};
  put(path("scene/hdr.gltf"), h.dump());
  for (const char* dry : {"--dry-run", "--quiet"}) {
    ProcessResult r = lsnif_run(with_tiny({"convert", path("scene/hdr.gltf"), "-o", path("c/out.gltf"),
                                           "--convert-when", "triangles", "--min-triangles", "1", dry}));
    EXPECT_FAILS_WITH(r, 1, "the converted scene would not load");
    EXPECT_EQ(r.output.find("trained "), std::string::npos) << r.output;
  }
  EXPECT_FALSE(fs::exists(path("c/out.quad.lsnif")));
  // A model trained in another object space than the node's mesh: refused with both boxes.
  put(path("scene/plain.gltf"), quad_scene("quad.bin").dump());
  const ProcessResult r = lsnif_run({"render", path("scene/plain.gltf"), "--lsnif", "ground=" + model_, "-o", path("r.png")});
  EXPECT_FAILS_WITH(r, 1, "node 'ground': model " + model_ + " was trained in another object space");
  EXPECT_NE(r.output.find("a model of the mesh would have (-1.02"), std::string::npos) << r.output;
}

TEST_F(HostileCli, OptionValuesAndNamesAreChecked) {
  EXPECT_FAILS_WITH(lsnif_run({"train", kElephant, "-o", path("x.lsnif"), "--batch", "0"}), 2,
                    "--batch 0 out of range [1, 262144]");
  for (const char* lr : {"0", "-0.01"})
    EXPECT_FAILS_WITH(lsnif_run({"train", kElephant, "-o", path("x.lsnif"), "--lr", lr}), 2,
                      "must be a positive, finite learning rate");
  EXPECT_FAILS_WITH(lsnif_run({"train", kElephant, "-o", path("x.lsnif"), "--w-distance", "-1"}), 2,
                    "--w-distance -1 must be a finite weight >= 0");
  // Node names with control characters are printed escaped.
  put(path("scene/quad.bin"), quad_bin());
  json j = quad_scene("quad.bin");
  j["nodes"][0]["name"] = "evil\x1b[2J\x07name";
  put(path("scene/names.gltf"), j.dump());
  ProcessResult r = lsnif_run({"convert", path("scene/names.gltf"), "-o", path("c/out.gltf"), "--dry-run",
                               "--convert-when", "triangles", "--min-triangles", "1"});
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("node 'evil\\x1b[2J\\x07name'"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find('\x1b'), std::string::npos);
  // `info` refuses a model with bounds of 1e38 or a material name that is not UTF-8 (the bytes
  // patched, the CRC-32 recomputed).
  const std::string bytes = read_all(model_);
  std::string huge = bytes;
  const float lo = -1e38f, hi = 1e38f;
  std::memcpy(&huge[80], &lo, 4);
  std::memcpy(&huge[92], &hi, 4);
  lsnif::test::fix_model_crc(huge);
  put(path("huge.lsnif"), huge);
  EXPECT_FAILS_WITH(lsnif_run({"info", path("huge.lsnif")}), 1, "exceeds +-1e+18");
  std::string name = bytes;
  const size_t at = name.find("default");
  ASSERT_NE(at, std::string::npos);
  name[at] = char(0xff);
  lsnif::test::fix_model_crc(name);
  put(path("name.lsnif"), name);
  EXPECT_FAILS_WITH(lsnif_run({"info", path("name.lsnif")}), 1, "\\xffefault\" is not valid UTF-8");
}

// The elephant written as OFF with `scale` applied and `extra` vertex / face lines appended.
std::string elephant_off(double scale, const std::string& extra_vertices, int extra_vertex_count,
                         const std::string& extra_faces, int extra_face_count) {
  lsnif::Mesh e;
  EXPECT_TRUE(lsnif::load_mesh(kElephant, e));
  std::string off = "OFF\n" + std::to_string(e.positions.size() + size_t(extra_vertex_count)) + " " +
                    std::to_string(e.triangles.size() + size_t(extra_face_count)) + " 0\n";
  char line[128];
  for (const glm::vec3& p : e.positions) {
    std::snprintf(line, sizeof line, "%.9g %.9g %.9g\n", scale * p.x, scale * p.y, scale * p.z);
    off += line;
  }
  off += extra_vertices;
  for (const glm::uvec3& t : e.triangles) off += "3 " + std::to_string(t.x) + " " + std::to_string(t.y) + " " +
                                                 std::to_string(t.z) + "\n";
  return off + extra_faces;
}

// Degeneracy is judged per triangle: a stray triangle far away no longer drops the rest of the mesh
// (which then fills too little of its box to train on: a clear error, not a model of a remnant),
// an unused NaN vertex is harmless, and a mesh too small for float ray math is an error rather than
// a model of nothing.
TEST_F(HostileCli, MeshCleanupIsJudgedPerTriangle) {
  lsnif::Mesh e;
  ASSERT_TRUE(lsnif::load_mesh(kElephant, e));
  const std::string n = std::to_string(e.positions.size());
  put(path("stray.off"), elephant_off(1.0, "10000 0 0\n10001 0 0\n10000 1 0\n", 3,
                                      "3 " + n + " " + std::to_string(e.positions.size() + 1) + " " +
                                          std::to_string(e.positions.size() + 2) + "\n",
                                      1));
  ProcessResult r = lsnif_run(with_tiny({"train", path("stray.off"), "-o", path("stray.lsnif")}));
  EXPECT_NE(r.output.find(": " + std::to_string(e.triangles.size() + 1) + " triangles"), std::string::npos)
      << r.output;
  EXPECT_EQ(r.output.find("dropped"), std::string::npos) << r.output;
  EXPECT_FAILS_WITH(r, 1, "far-away stray triangles");
  put(path("nan.off"), elephant_off(1.0, "nan nan nan\n", 1, "", 0));
  r = lsnif_run(with_tiny({"train", path("nan.off"), "-o", path("nan.lsnif")}));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  put(path("tiny.off"), elephant_off(1e-30, "", 0, "", 0));
  r = lsnif_run(with_tiny({"train", path("tiny.off"), "-o", path("tiny.lsnif")}));
  EXPECT_FAILS_WITH(r, 1, "no valid triangles");
  EXPECT_FALSE(fs::exists(path("tiny.lsnif")));
}

}  // namespace

// Numbers on the command line are decimal and every one has a range, checked before any work:
// huge thread counts crashed or hung, "010" trained V=8 (octal) and "0x20" V=32, a batch of 2^32 - 1
// aborted in the allocator, a camera index past 2^31 was silently ignored, an environment intensity
// of 1e10 wrote infinities, and --eval-rays 2^32 - 1 failed only after every model had trained.
TEST_F(HostileCli, NumbersAreDecimalAndBounded) {
  const std::string out = path("x.lsnif");
  EXPECT_FAILS_WITH(lsnif_run(with_tiny({"train", kElephant, "-o", out, "--threads", "100000"})), 2,
                    "invalid value '100000' for --threads: out of range [0, 256]");
  EXPECT_FAILS_WITH(lsnif_run({"eval", model_, kElephant, "--threads", "20000"}), 2, "out of range [0, 256]");
  EXPECT_FAILS_WITH(lsnif_run(with_tiny({"train", kElephant, "-o", out, "--voxels", "010"})), 2,
                    "for --voxels: leading zeros are not allowed");
  EXPECT_FAILS_WITH(lsnif_run(with_tiny({"train", kElephant, "-o", out, "--voxels", "0x20"})), 2,
                    "for --voxels: a decimal whole number expected (hexadecimal is not read)");
  EXPECT_FAILS_WITH(lsnif_run(with_tiny({"train", kElephant, "-o", out, "--lr", "0x1p-7"})), 2,
                    "for --lr: a decimal number expected");
  EXPECT_FAILS_WITH(lsnif_run({"train", kElephant, "-o", out, "--batch", "4294967295"}), 2,
                    "--batch 4294967295 out of range [1, 262144]");
  EXPECT_FALSE(fs::exists(out));
  // Render: the camera, the environment, the image size.
  put(path("scene/quad.bin"), quad_bin());
  put(path("scene/quad.gltf"), quad_scene("quad.bin").dump());
  const std::vector<std::string> render = {"render", path("scene/quad.gltf"), "-o", path("r.png"), "--width", "8",
                                           "--height", "8", "--spp", "1"};
  const auto with = [&render](std::vector<std::string> more) {
    more.insert(more.begin(), render.begin(), render.end());
    return more;
  };
  EXPECT_FAILS_WITH(lsnif_run(with({"--camera", "4000000000"})), 2, "for --camera: out of range [0, 2147483647]");
  for (const char* intensity : {"1e10", "1e38", "-1"})
    EXPECT_FAILS_WITH(lsnif_run(with({"--env-intensity", intensity})), 2,
                      "for --env-intensity: out of range [0, 1e+06]");
  EXPECT_FAILS_WITH(lsnif_run(with({"--width", "16385"})), 2, "for --width: out of range [1, 16384]");
  EXPECT_FALSE(fs::exists(path("r.png")));
  // Convert refuses an eval-ray count before it trains anything.
  const ProcessResult r = lsnif_run(with_tiny({"convert", path("scene/quad.gltf"), "-o", path("c/out.gltf"),
                                               "--eval-rays", "4294967295"}));
  EXPECT_FAILS_WITH(r, 2, "for --eval-rays: out of range [0, 1048576]");
  EXPECT_FALSE(fs::exists(path("c")));
}

// --camera names one of the scene's cameras or is an error: past the last one, on a scene without
// cameras, or beside an option that replaces the scene's cameras.
TEST_F(HostileCli, CameraIndexNamesACamera) {
  put(path("scene/quad.bin"), quad_bin());
  put(path("scene/quad.gltf"), quad_scene("quad.bin").dump());
  json no_camera = quad_scene("quad.bin");
  no_camera["scenes"][0]["nodes"] = json::array({0});
  put(path("scene/none.gltf"), no_camera.dump());
  const auto render = [this](const std::string& scene, std::vector<std::string> more) {
    std::vector<std::string> args = {"render", path("scene/" + scene), "-o", path("r.png"), "--width", "8",
                                     "--height", "8", "--spp", "1"};
    args.insert(args.end(), more.begin(), more.end());
    return lsnif_run(args);
  };
  EXPECT_FAILS_WITH(render("quad.gltf", {"--camera", "1"}), 2, "--camera 1: the scene has 1 camera (0 to 0)");
  EXPECT_FAILS_WITH(render("none.gltf", {"--camera", "0"}), 2, "--camera 0: the scene has no camera");
  EXPECT_FAILS_WITH(render("quad.gltf", {"--camera", "0", "--frame-scene"}), 2, "--frame-scene replaces them");
  EXPECT_FALSE(fs::exists(path("r.png")));
  const ProcessResult ok = render("quad.gltf", {"--camera", "0"});
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_TRUE(fs::exists(path("r.png")));
}

// The format of an image output is checked with the other output checks, before the work: `render
// -o r.txt` rendered to 100% and only then refused the extension.
TEST_F(HostileCli, ImageFormatsAreCheckedBeforeTheWork) {
  put(path("scene/quad.bin"), quad_bin());
  put(path("scene/quad.gltf"), quad_scene("quad.bin").dump());
  ProcessResult r = lsnif_run({"render", path("scene/quad.gltf"), "-o", path("r.txt"), "--width", "8", "--height",
                               "8", "--spp", "1"});
  EXPECT_FAILS_WITH(r, 2, "unknown image extension 'txt' (expected .exr, .hdr, .png, .jpg or .jpeg)");
  EXPECT_EQ(r.output.find("render (LSNIF)"), std::string::npos) << "the render started:\n" << r.output;
  // flip: the heatmap's format is refused before the images are read (these do not exist).
  r = lsnif_run({"flip", path("a.png"), path("b.png"), "--heatmap", path("h.bmp")});
  EXPECT_FAILS_WITH(r, 1, "--heatmap: cannot write");
  EXPECT_NE(r.output.find("'bmp'"), std::string::npos) << r.output;
  // demo: the picture's format before the training.
  r = lsnif_run(with_tiny({"demo", "--mesh", kElephant, "-o", path("d.lsnif"), "--picture", path("p.gif")}));
  EXPECT_FAILS_WITH(r, 2, "--picture: cannot write");
  EXPECT_FALSE(fs::exists(path("d.lsnif")));
}

// A settings file with a key given twice is refused, naming the key (the last value silently won).
TEST_F(HostileCli, SettingsFileKeysAreUnique) {
  put(path("dup.json"), R"({"steps": 2, "voxels": 16, "steps": 3})");
  const ProcessResult r = lsnif_run(with_tiny({"train", kElephant, "-o", path("x.lsnif"), "--config", path("dup.json")}));
  EXPECT_FAILS_WITH(r, 2, "the key \"steps\" appears twice in one object");
  EXPECT_FALSE(fs::exists(path("x.lsnif")));
}
