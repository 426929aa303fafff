// hostile_resources_cli_test.cpp -- the `lsnif` program against small inputs that ask for more
// memory than a machine has, and against untrusted text that would flood or garble a terminal: a
// valid 3 MB model whose grid usage covers every voxel, a 40 KB glTF placing one large accessor
// thousands of times, more rays than the address space takes, a data URI of a megabyte with a wrong
// byteLength, devices given as files, names with bidirectional overrides. The memory cases run
// under a 4 GiB address-space limit (RLIMIT_AS, as `prlimit --as`): each must end in seconds with
// an exit code (never a signal) and a message naming the budget or the limit and the count.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "lsnif/core/model.h"
#include "lsnif/testing/scoped_test_dir.h"
#include "lsnif/testing/test_support.h"

namespace {

namespace fs = std::filesystem;
using lsnif::test::ProcessResult;
using nlohmann::json;

constexpr uint64_t kFourGiB = uint64_t(4) << 30;
const std::string kBunny = std::string(LSNIF_DATA_DIR) + "/meshes/bunny00.off";

// `lsnif ARGS`, under an address-space limit of `address_space` bytes (0: none).
ProcessResult lsnif_run(std::vector<std::string> args, uint64_t address_space = 0) {
  args.insert(args.begin(), LSNIF_CLI);
  return lsnif::test::run_process(args, 180.0, 0, {"MESA_SHADER_CACHE_DISABLE=true"}, address_space);
}

void write_file(const std::string& path, const std::string& bytes) {
  fs::create_directories(fs::path(path).parent_path());
  std::ofstream(path, std::ios::binary) << bytes;
}

// A refusal: an exit code other than 0 (no signal, no time-out) within `seconds`, with `message`
// in the output.
void expect_refused(const ProcessResult& r, const std::string& message, double seconds = 30.0) {
  EXPECT_FALSE(r.crashed()) << "signal " << r.signal << "\n" << r.output;
  EXPECT_FALSE(r.timed_out) << r.output;
  EXPECT_GT(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find(message), std::string::npos) << "expected '" << message << "' in\n" << r.output;
  EXPECT_LT(r.seconds, seconds) << r.output;
}

// A valid model of V = 256 with every voxel occupied, grid levels of R = 256 and 512 (2^17 entries
// each, all zero), material 0 named `material`: 3 MB.
void write_full_model(const std::string& path, const std::string& material) {
  lsnif::Model m;
  lsnif::Config& c = m.config;
  c.voxel_resolution = 256;
  c.grid_levels = 2;
  c.grid_resolution[0] = 256;
  c.grid_resolution[1] = 512;
  c.table_log2[0] = c.table_log2[1] = 17;
  c.material_count = 1;
  m.voxels.resolution = 256;
  m.voxels.bounds = lsnif::Aabb{glm::vec3(-1.0f), glm::vec3(1.0f)};
  m.voxels.bits.assign(256u * 256u * 256u / 32u, ~0u);
  m.materials = {lsnif::ModelMaterial{material, glm::vec3(0.5f)}};
  m.grid.assign(size_t(c.grid_parameter_count()), 0.0f);
  m.mlp.assign(size_t(c.mlp_parameter_count()), 0.0f);
  m.quantize();
  ASSERT_TRUE(m.validate()) << m.validate().message();
  const lsnif::Status s = lsnif::save_model(m, path);
  ASSERT_TRUE(s) << s.message();
}

// The base64 of `bytes` zero bytes: "AAAA" per 3 bytes ("AA==" / "AAA=" for a last 1 / 2).
std::string zero_base64(size_t bytes) {
  std::string out(bytes / 3 * 4, 'A');
  if (bytes % 3) out += std::string(bytes % 3 + 1, 'A') + std::string(3 - bytes % 3, '=');
  return out;
}

// A glTF scene of `nodes` nodes placing meshes: all mesh 0 (`distinct` false) or each its own mesh
// (true); every mesh one primitive of 2^20 positions (a sparse accessor without a bufferView: zeros
// but for the one position its 16 bytes of sparse data set) drawn as 2^20 / 3 triangles. A few
// dozen bytes a node.
// With `primitives` > 1, one node places one mesh of that many such primitives.
std::string many_placements(size_t nodes, bool distinct, size_t primitives = 1) {
  json j = {{"asset", {{"version", "2.0"}}}, {"scene", 0}};
  json scene_nodes = json::array(), node_list = json::array(), meshes = json::array();
  const json primitive = {{"attributes", {{"POSITION", 0}}}};
  for (size_t i = 0; i < nodes; ++i) {
    scene_nodes.push_back(i);
    node_list.push_back({{"mesh", distinct ? i : 0}});
    if (distinct || i == 0) meshes.push_back({{"primitives", json(std::vector<json>(primitives, primitive))}});
  }
  j["scenes"] = {{{"nodes", scene_nodes}}};
  j["nodes"] = node_list;
  j["meshes"] = meshes;
  j["accessors"] = {{{"componentType", 5126},
                     {"count", 1 << 20},
                     {"type", "VEC3"},
                     {"min", {0, 0, 0}},
                     {"max", {0, 0, 0}},
                     {"sparse",
                      {{"count", 1},
                       {"indices", {{"bufferView", 0}, {"componentType", 5125}}},
                       {"values", {{"bufferView", 1}}}}}}};
  j["bufferViews"] = {{{"buffer", 0}, {"byteLength", 4}}, {{"buffer", 0}, {"byteOffset", 4}, {"byteLength", 12}}};
  j["buffers"] = {{{"uri", "data:application/octet-stream;base64," + zero_base64(16)}, {"byteLength", 16}}};
  return j.dump();
}

// A one-triangle scene whose buffer 0 is a data URI of `bytes` zero bytes while its byteLength
// says `byte_length`.
std::string data_uri_scene(size_t bytes, size_t byte_length) {
  json j = json::parse(R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[0,0,0]}],
"bufferViews":[{"buffer":0,"byteLength":36}]})");
  j["buffers"] = {{{"uri", "data:application/octet-stream;base64," + zero_base64(bytes)}, {"byteLength", byte_length}}};
  return j.dump();
}

class HostileResourcesCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::make_unique<lsnif::test::ScopedTestDir>("lsnif_hostile_resources");
  }
  std::string path(const std::string& name) const { return dir_->path(name); }
  std::unique_ptr<lsnif::test::ScopedTestDir> dir_;
};

// `info --grid-usage` of every voxel of V = 256 set listed 6 faces x (n + 1)^2 vertices per voxel
// with repeats (gigabytes) before removing them: now counted and hashed without a list. The truth:
// every lattice point but the (n - 1)^3 inside each voxel, (R + 1)^3 - (V (n - 1))^3.
TEST_F(HostileResourcesCli, GridUsageOfAFullGridRunsInBoundedMemory) {
  write_full_model(path("full.lsnif"), "default");
  const ProcessResult r = lsnif_run({"info", path("full.lsnif"), "--grid-usage", "--json"}, kFourGiB);
  ASSERT_FALSE(r.crashed()) << r.output;
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_LT(r.seconds, 60.0);
  const json j = json::parse(r.output);
  const json& levels = j["grid_usage"];
  ASSERT_EQ(levels.size(), 2u);
  const uint64_t truth[2] = {257ull * 257 * 257, 513ull * 513 * 513 - 256ull * 256 * 256};
  for (size_t l = 0; l < 2; ++l) {
    SCOPED_TRACE(l);
    const uint64_t vertices = levels[l]["vertices"], used = levels[l]["entries_used"],
                   shared = levels[l]["entries_shared"], in_shared = levels[l]["vertices_in_shared"];
    EXPECT_EQ(vertices, truth[l]);
    EXPECT_EQ(levels[l]["table_entries"], 1u << 17);
    EXPECT_LE(used, 1u << 17);
    EXPECT_EQ(vertices, used - shared + in_shared);
    EXPECT_EQ(levels[l]["indexed_slots"], 0u) << "more vertices than an indexed level takes";
  }
  const ProcessResult text = lsnif_run({"info", path("full.lsnif"), "--grid-usage"}, kFourGiB);
  EXPECT_EQ(text.exit_code, 0) << text.output;
  EXPECT_NE(text.output.find("collision-free (indexed): not possible (more than the"), std::string::npos)
      << text.output;
}

// One mesh of 2^20 positions placed by 2000 nodes: 2000 x 349525 triangles flattened, from a 40 KB
// file. Every command that flattens a glTF refuses it before reading a vertex, naming the count and
// the budget (convert: a node whose mesh has 400 such primitives); the renderer, which reads each
// mesh once, refuses 400 distinct such meshes.
TEST_F(HostileResourcesCli, GltfPlacingMoreGeometryThanTheBudgetIsRefusedAtOnce) {
  write_file(path("placed.gltf"), many_placements(2000, false));
  write_file(path("primitives.gltf"), many_placements(1, false, 400));
  write_file(path("distinct.gltf"), many_placements(400, true));
  EXPECT_LT(fs::file_size(path("placed.gltf")), 50000u);
  write_full_model(path("model.lsnif"), "default");
  const uint64_t per_primitive = (1 << 20) / 3;
  const std::string placed = "the scene's 2000 mesh placements hold " + std::to_string(2000 * per_primitive) +
                             " triangles, more than the 134217728 (2^27)";
  const std::vector<std::vector<std::string>> flattening = {
      {"train", path("placed.gltf"), "-o", path("t.lsnif"), "--tiny", "--quiet"},
      {"eval", path("model.lsnif"), path("placed.gltf"), "--rays", "100"},
      {"bench-memory", path("placed.gltf"), path("model.lsnif")}};
  for (const std::vector<std::string>& run : flattening) {
    SCOPED_TRACE(run[0]);
    expect_refused(lsnif_run(run, kFourGiB), placed);
  }
  expect_refused(lsnif_run({"convert", path("primitives.gltf"), "-o", path("c/out.gltf"), "--tiny", "--quiet",
                            "--convert-when", "triangles"},
                           kFourGiB),
                 "the scene's 1 mesh placement holds " + std::to_string(400 * per_primitive) + " triangles");
  expect_refused(lsnif_run({"render", path("distinct.gltf"), "-o", path("r.png"), "--width", "8", "--height", "8",
                            "--spp", "1"},
                           kFourGiB),
                 "the scene's 400 meshes hold " + std::to_string(400 * per_primitive) + " triangles");
}

// 2^24 rays need 4 GB of ray, hit and result buffers beside the host's copies: past a 4 GiB address
// space, lavapipe's mapping failed and create_buffer's memset crashed. Now a buffer the process
// cannot map is an error naming its bytes and --rays.
TEST_F(HostileResourcesCli, BenchTraceRaysPastTheAddressSpaceAreAnError) {
  if (!fs::exists(kBunny)) GTEST_SKIP() << kBunny << " missing: run scripts/setup.sh";
  ProcessResult r = lsnif_run({"train", kBunny, "-o", path("bunny.lsnif"), "--tiny", "--quiet"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = lsnif_run({"bench-trace", kBunny, path("bunny.lsnif"), "--rays", "16777216", "--repeat", "1", "--device",
                 lsnif::test::test_device()},
                kFourGiB);
  expect_refused(r, "lower --rays", 120.0);
  EXPECT_NE(r.output.find("bytes"), std::string::npos) << r.output;
}

// A data URI of 1 MB whose byteLength is wrong: tinygltf's message quoted the whole URI ("Failed to
// decode 'uri' : data:...") as if it were undecodable. Now the sizes, in a line.
TEST_F(HostileResourcesCli, DataUriOfTheWrongLengthIsNamedInALine) {
  write_file(path("uri.gltf"), data_uri_scene(1 << 20, 36));
  const std::string message = "buffer 0: data URI holds 1048576 bytes, byteLength says 36";
  for (const std::vector<std::string>& run :
       {std::vector<std::string>{"train", path("uri.gltf"), "-o", path("t.lsnif"), "--tiny", "--quiet"},
        std::vector<std::string>{"render", path("uri.gltf"), "-o", path("r.png"), "--width", "8", "--height", "8"}}) {
    SCOPED_TRACE(run[0]);
    const ProcessResult r = lsnif_run(run);
    expect_refused(r, message);
    EXPECT_LT(r.output.size(), 2000u) << r.output.substr(0, 2000);
    EXPECT_EQ(r.output.find("AAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAA"),
              std::string::npos);
  }
}

// A link to /dev/zero given as a mesh, a model or a scene's buffer: "not a regular file", not
// "File not found".
TEST_F(HostileResourcesCli, DevicesGivenAsFilesAreNotRegularFiles) {
  fs::create_directories(path("s"));
  for (const char* name : {"zero.off", "zero.lsnif", "s/zero.bin"}) fs::create_symlink("/dev/zero", path(name));
  json j = json::parse(data_uri_scene(36, 36));
  j["buffers"][0]["uri"] = "zero.bin";
  write_file(path("s/linked.gltf"), j.dump());
  const std::vector<std::vector<std::string>> runs = {
      {"train", path("zero.off"), "-o", path("t.lsnif"), "--tiny", "--quiet"},
      {"info", path("zero.lsnif")},
      {"train", path("s/linked.gltf"), "-o", path("t.lsnif"), "--tiny", "--quiet"},
      {"render", path("s/linked.gltf"), "-o", path("r.png"), "--width", "8", "--height", "8"}};
  for (const std::vector<std::string>& run : runs) {
    SCOPED_TRACE(run[0] + " " + run[1]);
    const ProcessResult r = lsnif_run(run);
    expect_refused(r, "not a regular file");
    EXPECT_EQ(r.output.find("not found"), std::string::npos) << r.output;
  }
}

// A material and a node named with a right-to-left override (U+202E, which makes "evil\u202Etxt.exe"
// show as "evilexe.txt") are printed as \u{202e}, never as the character.
TEST_F(HostileResourcesCli, BidiOverridesInNamesArePrintedEscaped) {
  const std::string rlo = "\xe2\x80\xae";
  write_full_model(path("named.lsnif"), "evil" + rlo + "txt.exe");
  ProcessResult r = lsnif_run({"info", path("named.lsnif")});
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("material   0: evil\\u{202e}txt.exe"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find(rlo), std::string::npos) << r.output;
  // A missing file whose name has one: the path in the message is escaped too.
  r = lsnif_run({"info", path("gone" + rlo + ".lsnif")});
  expect_refused(r, "gone\\u{202e}.lsnif");
  EXPECT_EQ(r.output.find(rlo), std::string::npos) << r.output;
}

}  // namespace
