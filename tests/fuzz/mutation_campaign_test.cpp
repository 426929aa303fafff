// mutation_campaign_test.cpp -- a seeded, deterministic mutation campaign over the program's
// inputs: model files, meshes (OFF, OBJ, PLY, glTF, GLB), glTF scenes and option lists, run through
// the real code paths (the parsers in process, the `lsnif` program for options and a bounded
// number of mutated files). Every case must end without a crash (a signal) or a hang (a time
// limit per case), and every case that is invalid by construction must be refused: any change to
// a model's bytes (its CRC-32 covers them), targeted damage to meshes and scenes (nesting past the
// bound, references leaving the folder, indices past the vertices, wrong extension types,
// degenerate cameras and transforms, truncated containers) and option values outside their
// documented ranges. Random mutations of meshes and scenes, whose validity is not known, must give
// either an error naming the input or a result that meets the loaders' guarantees.
//
// LSNIF_FUZZ_SEED changes the seed and LSNIF_FUZZ_SCALE the number of random cases (longer
// explorations by hand); the defaults keep the campaign within a minute on 2 cores (a few under
// AddressSanitizer).
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "lsnif/testing/fuzz_support.h"
#include "lsnif/import/mesh.h"
#include "lsnif/import/mesh_formats.h"
#include "lsnif/core/model.h"
#include "lsnif/format/model_format.h"
#include "lsnif/scene/scene_gltf.h"
#include "lsnif/testing/test_support.h"                       // tests/: run_process, ScopedTestDir
#include "lsnif/testing/scene_test_support.h"  // check_scene

namespace lsnif {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

// A case slower than this is a hang (the in-process parsers take milliseconds).
constexpr double kCaseSeconds = 10.0;

// Under AddressSanitizer every start of the program costs ~0.5 s: the campaigns that run it once
// per case take every kSanitizedStride-th case there, spread over every option (the Release pass
// runs them all).
#if defined(__SANITIZE_ADDRESS__)
constexpr size_t kSanitizedStride = 4;
#else
constexpr size_t kSanitizedStride = 1;
#endif

double scale() {
  const char* s = std::getenv("LSNIF_FUZZ_SCALE");
  return s ? std::max(0.01, std::atof(s)) : 1.0;
}
int scaled(int n) { return std::max(1, int(n * scale())); }

double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// ---- models ----------------------------------------------------------------------------------

// A small valid model (V=4, one level, 2 materials) with parameters drawn from `seed`; even seeds
// store 8-bit grid features (format version 3).
std::string model_bytes(uint64_t seed) {
  Model m = scene::tiny_model(glm::vec3(-1.0f), glm::vec3(1.0f, 2.0f, 1.5f), {"stone", "caf\xc3\xa9"});
  std::mt19937_64 rng(seed);
  for (uint32_t& w : m.voxels.bits) w = uint32_t(rng());
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (float& g : m.grid) g = u(rng);
  for (float& w : m.mlp) w = u(rng);
  if (seed % 2 == 0) {
    m.config.grid_bits = 8;
    m.quantize();
  }
  std::vector<uint8_t> bytes;
  EXPECT_TRUE(save_model_to_memory(m, bytes));
  return std::string(bytes.begin(), bytes.end());
}

Status parse_model(const std::string& bytes) {
  Model m;
  return load_model_from_memory(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), m);
}

template <typename T>
void put_at(std::string& b, size_t at, T v) {
  std::memcpy(&b[at], &v, sizeof v);
}

TEST(MutationCampaign, ModelFiles) {
  std::mt19937_64 rng = fuzz::fuzz_rng(0x30DE15ull);
  const auto start = Clock::now();
  size_t cases = 0;
  for (uint64_t seed = 1; seed <= 4; ++seed) {
    const std::string good = model_bytes(seed);
    ASSERT_TRUE(parse_model(good));
    // Random damage: the CRC-32 covers every byte, so any change is invalid.
    for (int it = 0; it < scaled(1500); ++it, ++cases) {
      std::string b = good;
      fuzz::mutate(b, rng);
      const auto t = Clock::now();
      const Status s = parse_model(b);
      ASSERT_LT(seconds_since(t), kCaseSeconds);
      if (b != good) ASSERT_FALSE(s) << "model seed " << seed << " mutation " << it << " accepted";
      else ASSERT_TRUE(s) << s.message();
    }
    // Targeted: header fields outside their ranges behind a valid CRC (docs/model-format.md).
    const std::vector<std::function<void(std::string&)>> fields = {
        [](std::string& b) { put_at<uint32_t>(b, 24, 0); },          // V = 0
        [](std::string& b) { put_at<uint32_t>(b, 24, 257); },        // V > 256
        [](std::string& b) { put_at<uint32_t>(b, 28, 0); },          // H = 0
        [](std::string& b) { put_at<uint32_t>(b, 32, 0); },          // L = 0
        [](std::string& b) { put_at<uint32_t>(b, 52, 3); },          // M < 4
        [](std::string& b) { put_at<uint32_t>(b, 56, 0); },          // F = 0
        [](std::string& b) { put_at<uint32_t>(b, 60, 0); },          // W = 0
        [](std::string& b) { put_at<uint32_t>(b, 68, 0); },          // no material
        [](std::string& b) { put_at<uint32_t>(b, 72, 9); },          // hit parametrization
        [](std::string& b) { put_at<float>(b, 76, NAN); },           // leaky slope
        [](std::string& b) { put_at<float>(b, 80, 1e38f); },         // AABB lo beyond the range, lo > hi
        [](std::string& b) { put_at<float>(b, 92, 1e38f); },         // AABB hi beyond +-1e18
        [](std::string& b) { put_at<float>(b, 84, 5.0f); },          // AABB empty on y
        [](std::string& b) { b[b.find("stone")] = char(0xff); },     // name not UTF-8
        [](std::string& b) { b[b.find("stone")] = '\x1b'; },         // control character in a name
    };
    for (size_t f = 0; f < fields.size(); ++f, ++cases) {
      std::string b = good;
      fields[f](b);
      test::fix_model_crc(b);
      ASSERT_FALSE(parse_model(b)) << "field case " << f;
    }
    if (good[8] != 3) continue;
    // Version 3 (8-bit grid): the grid bits, the zero word, a scale, a code.
    uint64_t grid_at = 0, scales_at = 0;
    std::memcpy(&grid_at, &good[136], 8);
    std::memcpy(&scales_at, &good[184], 8);
    const std::vector<std::function<void(std::string&)>> grid_fields = {
        [](std::string& b) { put_at<uint32_t>(b, 200, 16); },               // grid bits 16 in version 3
        [](std::string& b) { put_at<uint32_t>(b, 204, 1); },                // the zero word
        [&](std::string& b) { put_at<float>(b, scales_at, NAN); },          // scale not finite
        [&](std::string& b) { put_at<float>(b, scales_at, -1.0f); },        // negative scale
        [&](std::string& b) { put_at<uint8_t>(b, grid_at + 1, 0x80); },     // code -128
    };
    for (size_t f = 0; f < grid_fields.size(); ++f, ++cases) {
      std::string b = good;
      grid_fields[f](b);
      test::fix_model_crc(b);
      ASSERT_FALSE(parse_model(b)) << "8-bit field case " << f;
    }
  }
  std::printf("[ info ] models: %zu cases, %.2f s\n", cases, seconds_since(start));
}

// ---- meshes ----------------------------------------------------------------------------------

// The guarantees of load_mesh on success.
std::string check_mesh(const Mesh& m) {
  if (m.triangles.empty()) return "no triangles";
  if (m.materials.empty() || m.triangle_material.size() != m.triangles.size()) return "materials";
  if (m.normals.size() != m.positions.size()) return "normals";
  for (const glm::uvec3& t : m.triangles)
    if (t.x >= m.positions.size() || t.y >= m.positions.size() || t.z >= m.positions.size()) return "index";
  for (uint32_t mat : m.triangle_material)
    if (mat >= m.materials.size()) return "material index";
  for (const glm::vec3& p : m.positions)
    if (!std::isfinite(p.x + p.y + p.z) || std::abs(p.x) > 1e18f || std::abs(p.y) > 1e18f || std::abs(p.z) > 1e18f)
      return "position";
  for (const Material& mat : m.materials)
    if (!is_clean_utf8(mat.name) || mat.name.size() >= kModelMaterialNameBytes) return "material name";
  return "";
}

struct MeshSeed {
  std::string name;
  mesh_io::MeshFormat format;
  std::string data;
};

std::string tri_gltf(const std::string& buffer_uri, size_t bytes) {
  return R"({"asset":{"version":"2.0"},"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0,"scale":[2,1,1]}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1,"material":0}]}],
"materials":[{"name":"m","pbrMetallicRoughness":{"baseColorFactor":[1,0.5,0.2,1]}}],
"accessors":[{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3"},
 {"bufferView":1,"componentType":5123,"count":6,"type":"SCALAR"}],
"bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":48},{"buffer":0,"byteOffset":48,"byteLength":12}],
"buffers":[{"byteLength":)" + std::to_string(bytes) + R"(,"uri":")" + buffer_uri + R"("}],"extras":{"note":[1,[2,[3]]]}})";
}

std::string quad_bin() {
  std::string b = fuzz::put_floats({0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0});
  const uint16_t idx[6] = {0, 1, 2, 0, 2, 3};
  b.append(reinterpret_cast<const char*>(idx), sizeof idx);
  return b;
}

std::vector<MeshSeed> mesh_seeds() {
  using F = mesh_io::MeshFormat;
  const std::string bin = quad_bin();
  const std::string embedded = tri_gltf("data:application/octet-stream;base64," + fuzz::base64(bin), bin.size());
  std::string glb_json = tri_gltf("", bin.size());
  glb_json.replace(glb_json.find(R"(,"uri":"")"), 9, "");
  return {
      {"seed.off", F::Off, "OFF\n5 3 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 2 3\n4 0 1 4 3\n"},
      {"seed.obj", F::Obj, "mtllib in.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nusemtl red\n"
                           "f 1//1 2//1 3//1\nf 1 3 4\n"},
      {"seed.ply", F::Ply, "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                           "property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n"
                           "0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n"},
      {"seed.gltf", F::Gltf, embedded},
      {"seed_external.gltf", F::Gltf, tri_gltf("quad.bin", bin.size())},
      {"seed.glb", F::Glb, fuzz::glb(glb_json, bin)},
  };
}

TEST(MutationCampaign, Meshes) {
  test::ScopedTestDir dir("lsnif_campaign_meshes");
  fs::create_directories(dir.path() / "mesh");
  const std::string base = dir.path("mesh");
  std::ofstream(dir.path("mesh/quad.bin"), std::ios::binary) << quad_bin();
  std::ofstream(dir.path("mesh/in.mtl")) << "newmtl red\nKd 1 0 0\n";
  std::ofstream(dir.path("outside.bin"), std::ios::binary) << quad_bin();
  std::ofstream(dir.path("outside.mtl")) << "newmtl red\nKd 0 1 0\n";
  std::mt19937_64 rng = fuzz::fuzz_rng(0x3E5E5ull);
  const auto start = Clock::now();
  size_t loaded = 0, refused = 0, targeted = 0;
  auto run = [&](const MeshSeed& s, const std::string& data, Mesh& mesh) {
    MeshImportReport report;
    const auto t = Clock::now();
    Status st = mesh_io::parse_mesh(data, s.format, s.name, base, mesh, &report);
    EXPECT_LT(seconds_since(t), kCaseSeconds) << s.name;
    return st;
  };
  for (const MeshSeed& s : mesh_seeds()) {
    Mesh mesh;
    Status st = run(s, s.data, mesh);
    ASSERT_TRUE(st) << s.name << ": " << st.message();
    ASSERT_EQ(check_mesh(mesh), "") << s.name;
    for (int it = 0; it < scaled(1500); ++it) {
      std::string data = s.data;
      fuzz::mutate(data, rng);
      st = run(s, data, mesh);
      if (st) {
        ++loaded;
        ASSERT_EQ(check_mesh(mesh), "") << s.name << " mutation " << it << "\n" << data.substr(0, 500);
      } else {
        ++refused;
        ASSERT_NE(st.message().find(s.name), std::string::npos) << st.message();
      }
    }
    // Invalid by construction.
    const bool is_json = s.format == mesh_io::MeshFormat::Gltf;
    std::vector<std::string> bad;
    if (is_json) {
      const size_t note = s.data.find("[1,[2,[3]]]");
      for (size_t depth : {size_t(129), size_t(5000), size_t(30000)})
        bad.push_back(std::string(s.data).replace(note, 11, std::string(depth, '[') + std::string(depth, ']')));
      if (s.name == "seed_external.gltf") {
        for (const std::string& uri :
             std::vector<std::string>{"../outside.bin", "%2e%2e/outside.bin", dir.path("outside.bin"), "./../outside.bin"})
          bad.push_back(std::string(s.data).replace(s.data.find("quad.bin"), 8, uri));
      }
      std::string count = s.data;  // more vertices than the buffer holds
      bad.push_back(count.replace(count.find("\"count\":4"), 9, "\"count\":400"));
      std::string index = s.data;  // indices past the vertices: every triangle invalid
      bad.push_back(index.replace(index.find("\"count\":4"), 9, "\"count\":2"));
    }
    if (s.format == mesh_io::MeshFormat::Glb)
      for (int k = 0; k < 40; ++k) bad.push_back(s.data.substr(0, size_t(rng() % s.data.size())));  // truncated
    if (s.format == mesh_io::MeshFormat::Off) {
      bad.push_back("OFF\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 7\n3 0 9 3\n");  // indices past the vertices
      bad.push_back("OFF\n3 1 0\n0 0 0\n1e-31 0 0\n0 1e-31 0\n3 0 1 2\n");          // too small for float ray math
      bad.push_back("OFF\n3 1 0\n0 0 0\n1 1 1\n2 2 2\n3 0 1 2\n");                  // collinear
      bad.push_back("OFF\n3 1 0\n0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n");                // NaN corner
    }
    if (s.format == mesh_io::MeshFormat::Obj)
      for (const std::string& lib : std::vector<std::string>{"../outside.mtl", "/etc/passwd", dir.path("outside.mtl")})
        bad.push_back(std::string(s.data).replace(s.data.find("in.mtl"), 6, lib));
    for (size_t k = 0; k < bad.size(); ++k, ++targeted) {
      st = run(s, bad[k], mesh);
      ASSERT_FALSE(st) << s.name << " invalid case " << k << " accepted:\n" << bad[k].substr(0, 300);
      ASSERT_NE(st.message().find(s.name), std::string::npos) << st.message();
    }
  }
  std::printf("[ info ] meshes: %zu random mutations loaded, %zu refused; %zu invalid by construction refused; %.2f s\n",
              loaded, refused, targeted, seconds_since(start));
  EXPECT_GT(loaded, size_t(scaled(400)));
  EXPECT_GT(refused, size_t(scaled(400)));
}

// ---- scenes ----------------------------------------------------------------------------------

json scene_doc() {
  const std::string bin = quad_bin();
  json d = json::parse(R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0,1,2,3]}],
"extensionsUsed":["LSNIF_neural_object","LSNIF_environment"],
"extensions":{"LSNIF_environment":{"color":[0.5,0.6,0.7],"intensity":1.5}},
"nodes":[{"name":"ground","mesh":0},{"name":"obj","mesh":0,"translation":[0,1,0],
  "extensions":{"LSNIF_neural_object":{"model":"m.lsnif","materials":[0]}}},
 {"name":"only","translation":[1,0,0],"extensions":{"LSNIF_neural_object":{"model":"m.lsnif"}}},
 {"name":"cam","camera":0,"translation":[0,1,4]}],
"cameras":[{"type":"perspective","perspective":{"yfov":0.7,"znear":0.01}}],
"materials":[{"name":"grey"}],
"meshes":[{"name":"quad","primitives":[{"attributes":{"POSITION":0},"indices":1,"material":0}]}],
"accessors":[{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3"},
 {"bufferView":1,"componentType":5123,"count":6,"type":"SCALAR"}],
"bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":48},{"buffer":0,"byteOffset":48,"byteLength":12}]})");
  d["buffers"] = json::array({{{"byteLength", bin.size()}, {"uri", "data:application/octet-stream;base64," + fuzz::base64(bin)}}});
  return d;
}

// The scene as text; the string "DEEP" becomes 20,000 levels of nested arrays.
std::string as_text(const json& d) {
  std::string bytes = d.dump();
  if (const size_t at = bytes.find("\"DEEP\""); at != std::string::npos)
    bytes.replace(at, 6, std::string(20000, '[') + std::string(20000, ']'));
  return bytes;
}

// The scene as a GLB: buffer 0's bytes in the BIN chunk.
std::string as_glb(json d) {
  d["buffers"][0].erase("uri");
  return fuzz::glb(as_text(d), quad_bin());
}

TEST(MutationCampaign, Scenes) {
  test::ScopedTestDir dir("lsnif_campaign_scenes");
  fs::create_directories(dir.path() / "scene");
  const std::string base = dir.path("scene");
  const std::string model = model_bytes(7);
  std::ofstream(dir.path("scene/m.lsnif"), std::ios::binary) << model;
  std::ofstream(dir.path("m.lsnif"), std::ios::binary) << model;
  std::mt19937_64 rng = fuzz::fuzz_rng(0x5CE4Eull);
  scene::SceneLoadOptions quiet;
  quiet.quiet = true;
  const auto start = Clock::now();
  size_t loaded = 0, refused = 0, targeted = 0;
  auto run = [&](const std::string& data, bool binary, scene::Scene& s) {
    const auto t = Clock::now();
    Status st = scene::load_scene_from_memory(data, binary, "campaign.gltf", base, quiet, s);
    EXPECT_LT(seconds_since(t), kCaseSeconds);
    return st;
  };
  const json doc = scene_doc();
  const std::string text = doc.dump();
  scene::Scene s;
  Status seed = run(text, false, s);
  ASSERT_TRUE(seed) << seed.message();
  ASSERT_EQ(scene::check_scene(s), "");
  const std::string glb = as_glb(doc);
  seed = run(glb, true, s);
  ASSERT_TRUE(seed) << seed.message();
  std::vector<const char*> tokens(std::begin(fuzz::kMutationTokens), std::end(fuzz::kMutationTokens));
  tokens.insert(tokens.end(), {"\"\"", "[]", "{}"});
  for (const bool binary : {false, true}) {
    for (int it = 0; it < scaled(3000); ++it) {
      std::string data = binary ? glb : text;
      fuzz::mutate(data, rng, tokens);
      const Status st = run(data, binary, s);
      if (st) {
        ++loaded;
        ASSERT_EQ(scene::check_scene(s), "") << "mutation " << it << "\n" << data.substr(0, 800);
      } else {
        ++refused;
        ASSERT_NE(st.message().find("campaign.gltf"), std::string::npos) << st.message();
      }
    }
  }
  // Invalid by construction: each edit must make the scene fail to load.
  std::vector<std::function<void(json&)>> edits;
  for (const json& v : {json("m.lsnif"), json(5), json::array({1}), json(true), json(nullptr)}) {
    edits.push_back([v](json& d) { d["nodes"][2]["extensions"]["LSNIF_neural_object"] = v; });
    edits.push_back([v](json& d) { d["extensions"]["LSNIF_environment"] = v; });
  }
  for (const char* ref : {"../m.lsnif", "sub/../../m.lsnif", "/etc/passwd"})
    edits.push_back([ref](json& d) { d["nodes"][1]["extensions"]["LSNIF_neural_object"]["model"] = ref; });
  edits.push_back([](json& d) { d["extensions"]["LSNIF_environment"]["hdr"] = "missing.hdr"; });
  edits.push_back([](json& d) { d["extensions"]["LSNIF_environment"]["hdr"] = "../m.lsnif"; });
  for (double yfov : {0.0, -1.0, 3.2, 1e-9})
    edits.push_back([yfov](json& d) { d["cameras"][0]["perspective"]["yfov"] = yfov; });
  edits.push_back([](json& d) { d["nodes"][0]["scale"] = {0, 0, 0}; });
  edits.push_back([](json& d) { d["nodes"][1]["scale"] = {1, 0, 1}; });
  edits.push_back([](json& d) { d["nodes"][0]["matrix"] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 2, 3, 1}; });
  edits.push_back([](json& d) { d["accessors"][0]["count"] = 400; });
  edits.push_back([](json& d) { d["accessors"][1]["count"] = 7; });
  edits.push_back([](json& d) { d["nodes"][1]["extensions"]["LSNIF_neural_object"]["materials"] = {5}; });
  edits.push_back([](json& d) { d["extras"] = "DEEP"; });  // replaced by 20,000 levels below
  for (size_t k = 0; k < edits.size(); ++k) {
    json d = doc;
    edits[k](d);
    for (const bool binary : {false, true}) {
      ++targeted;
      const Status st = run(binary ? as_glb(d) : as_text(d), binary, s);
      ASSERT_FALSE(st) << "scene edit " << k << (binary ? " (GLB)" : "") << " accepted";
      ASSERT_NE(st.message().find("campaign.gltf"), std::string::npos) << st.message();
    }
  }
  for (int k = 0; k < 50; ++k, ++targeted) {  // truncated GLB containers
    const std::string cut = glb.substr(0, size_t(rng() % glb.size()));
    ASSERT_FALSE(run(cut, true, s)) << "GLB cut at " << cut.size() << " accepted";
  }
  std::printf("[ info ] scenes: %zu random mutations loaded, %zu refused; %zu invalid by construction refused; %.2f s\n",
              loaded, refused, targeted, seconds_since(start));
  EXPECT_GT(loaded, size_t(scaled(400)));
  EXPECT_GT(refused, size_t(scaled(400)));
}

// ---- the program: option lists and mutated files ----------------------------------------------

// `env`: entries added to the child's environment ("NAME=value").
test::ProcessResult lsnif_run(std::vector<std::string> args, double timeout = 120.0,
                              std::vector<std::string> env = {}) {
  args.insert(args.begin(), LSNIF_CLI);
  env.push_back("MESA_SHADER_CACHE_DISABLE=true");
  return test::run_process(args, timeout, 0, env);
}

std::string describe(const std::vector<std::string>& args) {
  std::string s = "lsnif";
  for (const std::string& a : args) s += " '" + a.substr(0, 80) + "'";
  return s;
}

TEST(MutationCampaign, OptionLists) {
  const std::string elephant = std::string(LSNIF_DATA_DIR) + "/meshes/elephant.off";
  if (!fs::exists(elephant)) GTEST_SKIP() << elephant << " missing: run scripts/setup.sh";
  test::ScopedTestDir dir("lsnif_campaign_options");
  // The --tiny preset's model in 2 steps of 256 rays, given as values, not as --tiny: every option
  // below is added to these, and --tiny would refuse one it sets before its value is checked.
  const std::vector<std::string> tiny = {"--voxels", "16", "--res-min", "32", "--res-max", "64", "--table-log2", "12",
                                         "--width", "32", "--steps", "2", "--batch", "256", "--quiet"};
  // Values outside each option's documented range (README, --help): every one must be refused.
  struct Bad {
    std::string option;
    std::vector<std::string> values;
  };
  const std::vector<Bad> train_bad = {
      {"--voxels", {"0", "257", "-1", "7", "abc", "", "4294967296", "1.5"}},
      {"--points", {"0", "99999"}},
      {"--levels", {"0", "9"}},
      {"--res-min", {"0", "24"}},
      {"--res-max", {"16", "8192"}},
      {"--table-log2", {"3", "25"}},
      {"--features", {"0", "99"}},
      {"--width", {"0", "100000"}},
      {"--layers", {"0", "99"}},
      {"--steps", {"0", "-5"}},
      {"--batch", {"0", "x"}},
      {"--ray-reuse", {"0", "999999"}},
      {"--lr", {"0", "-0.01", "nan", "inf", "1e39", "abc"}},
      {"--w-occlusion", {"-1", "nan", "inf"}},
      {"--w-distance", {"-0.5"}},
      {"--w-normal", {"-1e-9"}},
      {"--hit", {"bogus", ""}},
      {"--normal-loss", {"cos"}},
      {"--grid-bits", {"12", "0", "4", "x"}},
      {"--threads", {"-1"}},
      {"--seed", {"-1", "1e3"}},
  };
  const auto start = Clock::now();
  size_t runs = 0;
  auto expect_refused = [&](const std::vector<std::string>& args) {
    const test::ProcessResult r = lsnif_run(args);
    ++runs;
    EXPECT_FALSE(r.crashed()) << describe(args) << ": signal " << r.signal << "\n" << r.output;
    EXPECT_FALSE(r.timed_out) << describe(args);
    EXPECT_NE(r.exit_code, 0) << describe(args) << " accepted\n" << r.output;
    EXPECT_FALSE(r.output.empty()) << describe(args) << ": no message";
  };
  for (const Bad& b : train_bad)
    for (const std::string& v : b.values) {
      std::vector<std::string> args = {"train", elephant, "-o", dir.path("t.lsnif")};
      args.insert(args.end(), tiny.begin(), tiny.end());
      args.insert(args.end(), {b.option, v});
      expect_refused(args);
    }
  // All weights zero together.
  {
    std::vector<std::string> args = {"train", elephant, "-o", dir.path("t.lsnif")};
    args.insert(args.end(), tiny.begin(), tiny.end());
    for (const char* w : {"--w-occlusion", "--w-distance", "--w-normal", "--w-albedo", "--w-material"})
      args.insert(args.end(), {w, "0"});
    expect_refused(args);
  }
  // Other commands' options, options without a value, unknown options.
  const std::string scene = std::string(LSNIF_SCENE_EXAMPLE);
  const std::vector<std::vector<std::string>> others = {
      {"render", scene, "--width", "0"}, {"render", scene, "--height", "99999"}, {"render", scene, "--spp", "0"},
      {"render", scene, "--lsnif", "=x"}, {"render", scene, "--lsnif", "nonode=" + dir.path("none.lsnif")},
      {"render", scene, "--fov", "nan"}, {"render", scene, "--node-transform", "ground=1,2,3,0"},
      {"render", scene, "--sun", "0,0,0,1"}, {"render", scene, "--add", "x.lsnif"},
      {"eval", dir.path("none.lsnif"), elephant}, {"eval", elephant, elephant, "--rays", "abc"},
      {"info", elephant}, {"info", "/dev/null"}, {"info", dir.path("")},
      {"convert", scene, "-o", dir.path("c/out.gltf"), "--select", "("},
      {"convert", scene, "-o", dir.path("c/out.gltf"), "--group", "nameonly"},
      {"convert", scene, "-o", dir.path("c/out.glb")},
      {"convert", scene, "-o", dir.path("c/out.gltf"), "--voxels", "0", "--dry-run"},
      {"convert", scene, "-o", dir.path("c/out.gltf"), "--min-triangles", "-3"},
      {"flip", elephant, elephant}, {"flip", "a.png", "b.exr"},
      {"train", elephant}, {"train", elephant, "-o"}, {"train", "-o", dir.path("x.lsnif")},
      {"train", elephant, "-o", dir.path("x.lsnif"), "--bogus", "1"},
      {"train", elephant + ".missing", "-o", dir.path("x.lsnif")},
      {"bench-memory", elephant, dir.path("none.lsnif")}, {"bench-trace", elephant, elephant, "--rays", "0"},
      {"nonsense"},
  };
  for (const std::vector<std::string>& args : others) expect_refused(args);

  // Mutated mesh files through `lsnif train` (validity unknown: no crash, no hang; a mutation
  // that loads may train).
  std::mt19937_64 rng = fuzz::fuzz_rng(0xC11ull);
  size_t trained = 0;
  for (const MeshSeed& s : mesh_seeds()) {
    if (s.name == "seed_external.gltf") continue;
    for (int it = 0; it < scaled(4); ++it) {
      std::string data = s.data;
      fuzz::mutate(data, rng);
      const std::string file = dir.path("mutated_" + std::to_string(it) + "_" + s.name);
      std::ofstream(file, std::ios::binary) << data;
      std::vector<std::string> args = {"train", file, "-o", dir.path("m.lsnif")};
      args.insert(args.end(), tiny.begin(), tiny.end());
      const test::ProcessResult r = lsnif_run(args);
      ++runs;
      EXPECT_FALSE(r.crashed()) << describe(args) << ": signal " << r.signal << "\n" << r.output;
      EXPECT_FALSE(r.timed_out) << describe(args);
      EXPECT_TRUE(r.exit_code == 0 || r.exit_code == 1) << describe(args) << "\n" << r.output;
      trained += r.exit_code == 0;
    }
  }
  std::printf("[ info ] program: %zu runs (%zu trainings of mutated meshes succeeded), %.2f s\n", runs, trained,
              seconds_since(start));
}

// Numeric option values in every form the C library reads besides decimal, and past every range:
// each must be refused (exit 2) naming the option, before any work. Random mutations of valid
// values must end cleanly too; the commands' inputs do not exist, so a value that parses ends in
// "not found" (exit 1) instead of starting work.
TEST(MutationCampaign, OptionValueForms) {
  test::ScopedTestDir dir("lsnif_campaign_values");
  const std::string none = dir.path("missing");
  struct Numeric {
    std::vector<std::string> command;  // the command and its (missing) inputs
    std::string option;
    std::string valid;  // a value in the option's range (with a point for a real number)
  };
  const std::vector<std::string> train = {"train", none + ".off", "-o", dir.path("t.lsnif")};
  const std::vector<std::string> render = {"render", none + ".gltf", "-o", dir.path("r.png")};
  const std::vector<std::string> eval = {"eval", none + ".lsnif", none + ".off"};
  const std::vector<std::string> convert = {"convert", none + ".gltf", "-o", dir.path("c/out.gltf")};
  const std::vector<std::string> trace = {"bench-trace", none + ".off", none + ".lsnif"};
  const std::vector<std::string> flip = {"flip", none + ".exr", none + "2.exr"};
  const std::vector<Numeric> numerics = {
      {train, "--voxels", "16"},        {train, "--steps", "2"},           {train, "--batch", "256"},
      {train, "--seed", "7"},           {train, "--table-log2", "12"},     {train, "--threads", "2"},
      {train, "--lr", "0.01"},          {train, "--w-normal", "1.0"},        {train, "--sphere-scale", "1.5"},
      {train, "--indexed", "1,0"},      {render, "--width", "8"},          {render, "--spp", "1"},
      {render, "--camera", "0"},        {render, "--env-intensity", "2.0"},  {render, "--fov", "45.0"},
      {render, "--bounces", "4"},       {eval, "--rays", "100"},           {eval, "--threads", "1"},
      {convert, "--eval-rays", "100"},  {convert, "--jobs", "2"},          {convert, "--memory-margin", "2.0"},
      {convert, "--min-triangles", "5"}, {trace, "--rays", "1000"},        {trace, "--gemm-seconds", "0.5"},
      {flip, "--ppd", "67.0"},            {flip, "--num-exposures", "3"},
  };
  // Forms that are never a value: other bases, signs and spaces, non-finite numbers, and for whole
  // numbers leading zeros (octal to strtoul), a plus sign, a fraction and numbers past 64 bits.
  const auto bad_forms = [](const std::string& v) {
    std::vector<std::string> forms = {"0x" + v, "-" + v + "0", " " + v, v + " ", v + "x", "",
                                      "nan",    "inf",         "1e400", "0x1p3",
                                      "\xef\xbc\x91"};  // a full-width digit
    if (v.find_first_not_of("0123456789,") == std::string::npos)
      forms.insert(forms.end(), {"0" + v, "+" + v, v + ".5", "18446744073709551616", "99999999999999999999999999"});
    return forms;
  };
  const auto start = Clock::now();
  size_t runs = 0;
  // Runs the command of `n` with `value`: it must end with an exit code, in time.
  const auto run_value = [&runs](const Numeric& n, const std::string& value, std::vector<std::string>& args) {
    args = n.command;
    args.insert(args.end(), {n.option, value});
    const test::ProcessResult r = lsnif_run(args, 30.0);
    ++runs;
    EXPECT_FALSE(r.crashed()) << describe(args) << ": signal " << r.signal << "\n" << r.output;
    EXPECT_FALSE(r.timed_out) << describe(args);
    return r;
  };
  std::vector<std::string> args;
  size_t case_index = 0;
  for (const Numeric& n : numerics)
    for (const std::string& v : bad_forms(n.valid)) {
      if (case_index++ % kSanitizedStride) continue;
      const test::ProcessResult r = run_value(n, v, args);
      EXPECT_EQ(r.exit_code, 2) << describe(args) << "\n" << r.output;
      EXPECT_NE(r.output.find(n.option), std::string::npos) << describe(args) << ": the option is not named\n"
                                                           << r.output;
    }
  std::mt19937_64 rng = fuzz::fuzz_rng(0xA11ull);
  for (int it = 0; it < scaled(60 / int(kSanitizedStride)); ++it) {
    const Numeric& n = numerics[rng() % numerics.size()];
    std::string v = n.valid;
    fuzz::mutate(v, rng);
    const test::ProcessResult r = run_value(n, v, args);
    EXPECT_TRUE(r.exit_code == 1 || r.exit_code == 2) << describe(args) << "\n" << r.output;
  }
  std::printf("[ info ] option values: %zu runs, %.2f s\n", runs, seconds_since(start));
}

// Settings files (--config): a valid one with one key's value or the document's shape broken in
// a way no reading can accept (duplicate keys, wrong types, signs, huge and fractional counts,
// strings for numbers) is refused, naming the file; random byte mutations end cleanly.
TEST(MutationCampaign, SettingsFiles) {
  test::ScopedTestDir dir("lsnif_campaign_settings");
  const std::string config = dir.path("c.json");
  const std::vector<std::string> train = {"train", dir.path("missing.off"), "-o", dir.path("t.lsnif"), "--config",
                                          config};
  const std::string valid = R"({"voxels": 16, "steps": 2, "batch": 256, "lr": 0.01, "seed": 3, "indexed": [1, 0]})";
  const std::vector<std::pair<std::string, std::string>> replacements = {
      {"\"voxels\": 16", "\"voxels\": 16, \"voxels\": 32"}, {"\"steps\": 2", "\"steps\": \"2\""},
      {"\"steps\": 2", "\"steps\": -2"},                   {"\"steps\": 2", "\"steps\": 2.5"},
      {"\"steps\": 2", "\"steps\": 18446744073709551616"},  {"\"steps\": 2", "\"steps\": 1e400"},
      {"\"batch\": 256", "\"batch\": 4294967295"},           {"\"batch\": 256", "\"batch\": \"0x100\""},
      {"\"lr\": 0.01", "\"lr\": -1"},                        {"\"lr\": 0.01", "\"lr\": null"},
      {"\"lr\": 0.01", "\"lr\": [0.01]"},                    {"\"seed\": 3", "\"seed\": true"},
      {"\"indexed\": [1, 0]", "\"indexed\": [1, 0, 1, 0, 1, 0, 1, 0, 1]"},
      {"\"indexed\": [1, 0]", "\"indexed\": {\"a\": 1, \"a\": 2}"},
      {"\"voxels\": 16", "\"voxles\": 16"},
  };
  const auto write = [&config](const std::string& text) { std::ofstream(config, std::ios::binary) << text; };
  size_t runs = 0;
  for (const auto& [from, to] : replacements) {
    std::string text = valid;
    ASSERT_NE(text.find(from), std::string::npos) << from;
    text.replace(text.find(from), from.size(), to);
    write(text);
    const test::ProcessResult r = lsnif_run(train, 30.0);
    ++runs;
    EXPECT_FALSE(r.crashed()) << text << ": signal " << r.signal << "\n" << r.output;
    EXPECT_EQ(r.exit_code, 2) << text << "\n" << r.output;
    EXPECT_NE(r.output.find(config), std::string::npos) << text << ": the file is not named\n" << r.output;
  }
  write(valid);  // the control: it parses, and the missing mesh ends the run
  test::ProcessResult control = lsnif_run(train, 30.0);
  EXPECT_EQ(control.exit_code, 1) << control.output;
  EXPECT_NE(control.output.find("missing.off"), std::string::npos) << control.output;
  std::mt19937_64 rng = fuzz::fuzz_rng(0xC0Full);
  for (int it = 0; it < scaled(60 / int(kSanitizedStride)); ++it) {
    std::string text = valid;
    fuzz::mutate(text, rng);
    write(text);
    const test::ProcessResult r = lsnif_run(train, 30.0);
    ++runs;
    EXPECT_FALSE(r.crashed()) << text << ": signal " << r.signal << "\n" << r.output;
    EXPECT_FALSE(r.timed_out) << text;
    EXPECT_TRUE(r.exit_code == 1 || r.exit_code == 2) << text << "\n" << r.output;
  }
  std::printf("[ info ] settings files: %zu runs\n", runs);
}

// An exception cannot leave an OpenMP parallel region: a failed allocation inside one would end the
// program in std::terminate on a machine short of memory (as MemoryCappedRuns below found on one
// host) instead of in "out of memory". parallel_allocation_guard, preloaded, fails every allocation
// the program makes inside a region, on every host: training, evaluation and FLIP, whose loops run
// in regions, must not notice. The probe shows the guard at work: refused in a region, not outside.
TEST(MutationCampaign, NothingIsAllocatedInsideParallelRegions) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer replaces the allocator the guard stands in front of";
#else
  const std::vector<std::string> env = {"LD_PRELOAD=" LSNIF_PARALLEL_ALLOCATION_GUARD, "OMP_NUM_THREADS=2"};
  const test::ProcessResult control = test::run_process({LSNIF_PARALLEL_ALLOCATION_PROBE}, 30.0, 0, env);
  ASSERT_EQ(control.exit_code, 0) << control.output;
  EXPECT_NE(control.output.find("threads 2 refused 2 outside ok"), std::string::npos) << control.output;
  EXPECT_NE(control.output.find("parallel_allocation_guard: "), std::string::npos) << control.output;
  const test::ProcessResult unguarded = test::run_process({LSNIF_PARALLEL_ALLOCATION_PROBE}, 30.0);
  EXPECT_NE(unguarded.output.find("threads 2 refused 0 outside ok"), std::string::npos) << unguarded.output;

  const std::string data = LSNIF_DATA_DIR;
  test::ScopedTestDir dir("lsnif_campaign_regions");
  const std::string model = dir.path("bunny.lsnif");
  const std::vector<std::vector<std::string>> runs = {
      {"train", data + "/meshes/bunny00.off", "-o", model, "--steps", "40", "--quiet"},  // default network
      {"eval", model, data + "/meshes/bunny00.off", "--rays", "20000"},
      {"flip", data + "/hdr/city.exr", data + "/hdr/courtyard.exr", "--num-exposures", "2"},
  };
  for (const std::vector<std::string>& args : runs) {
    const test::ProcessResult r = lsnif_run(args, 120.0, env);
    EXPECT_EQ(r.exit_code, 0) << describe(args) << "\n" << r.output;
    EXPECT_EQ(r.output.find("parallel_allocation_guard: "), std::string::npos) << describe(args) << "\n" << r.output;
  }
#endif
}

// Runs under an address-space limit (`prlimit --as`, util-linux): sizes in range that do not fit
// the memory the process may have end with "out of memory" and exit 1, never an abort. (Not under
// AddressSanitizer: it reserves terabytes of address space for its shadow memory.)
TEST(MutationCampaign, MemoryCappedRuns) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer cannot run under an address-space limit";
#else
  const std::string elephant = std::string(LSNIF_DATA_DIR) + "/meshes/elephant.off";
  if (!fs::exists(elephant)) GTEST_SKIP() << elephant << " missing: run scripts/setup.sh";
  if (!fs::exists("/usr/bin/prlimit")) GTEST_SKIP() << "prlimit (util-linux) missing";
  test::ScopedTestDir dir("lsnif_campaign_capped");
  const std::string model = dir.path("e.lsnif");
  const test::ProcessResult trained = lsnif_run({"train", elephant, "-o", model, "--tiny", "--quiet"});
  ASSERT_EQ(trained.exit_code, 0) << trained.output;
  // 2^20 held-out rays take ~1.8 GB; 1 GB of address space is not enough.
  const std::vector<std::string> capped = {"/usr/bin/prlimit", "--as=1000000000", LSNIF_CLI, "eval", model,
                                           elephant,           "--rays",          "1048576"};
  const test::ProcessResult r = test::run_process(capped, 120.0);
  EXPECT_FALSE(r.crashed()) << "signal " << r.signal << "\n" << r.output;
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("lsnif eval: out of memory"), std::string::npos) << r.output;
#endif
}

}  // namespace
}  // namespace lsnif
