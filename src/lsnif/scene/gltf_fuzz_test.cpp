// gltf_fuzz_test.cpp -- deterministic mutation fuzzing of load_scene. Real files from data/gltf
// (BoxTextured as .glb, as .gltf with external buffer and image, with data URIs; Cameras;
// 2CylinderEngine), the example scene and a synthetic file using both LSNIF extensions, sparse
// accessors and every index type are damaged thousands of times with a fixed seed (bit flips, byte
// overwrites, truncations, insertions of random bytes and of troublesome tokens, deletions,
// duplications, numbers replaced) and loaded from memory. Every result must be either an error
// whose message names the input, or a scene meeting all of scene_gltf.h's guarantees. Under
// AddressSanitizer (LSNIF_SANITIZE) this is also the loader's out-of-bounds check.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iterator>
#include <map>
#include <random>
#include <vector>

#include "lsnif/testing/fuzz_support.h"
#include "lsnif/scene/scene_gltf.h"
#include "lsnif/testing/scene_test_support.h"

namespace lsnif::scene {
namespace {

using fuzz::read_bytes;

const std::string kData = std::string(LSNIF_DATA_DIR) + "/gltf/";

std::string folder_of(const std::string& path) { return std::filesystem::path(path).parent_path().string(); }

struct Seed {
  std::string name;
  bool binary;
  std::string data;
  std::string base_dir;
  int iterations;
};

// A small scene using what the real files do not: both LSNIF extensions (the model and the
// environment image beside the scene in `dir`), a mesh shared by two nodes, ubyte / uint indices,
// a sparse accessor, TRS and matrix nodes, emissive strength, a data-URI texture and a camera.
// Buffer (data URI, 116 bytes): 4 positions, 4 uvs, ubyte indices (+2 pad), uint indices, one
// sparse index (ubyte, +3 pad) and its value.
std::string synthetic_seed() {
  return R"({"asset":{"version":"2.0"},"scene":0,
"extensionsUsed":["LSNIF_neural_object","LSNIF_environment","KHR_materials_emissive_strength"],
"extensions":{"LSNIF_environment":{"hdr":"sky.hdr","color":[1,0.5,0.5],"intensity":2,"rotation_degrees":45}},
"scenes":[{"nodes":[0,3,4]}],
"nodes":[{"name":"root","translation":[1,2,3],"rotation":[0,0.3826834,0,0.9238795],"children":[1,2]},
 {"name":"a","mesh":0,"scale":[1,2,1]},
 {"name":"b","mesh":0,"matrix":[1,0,0,0,0,1,0,0,0,0,1,0,0,4,0,1],"extensions":{"LSNIF_neural_object":{"model":"obj.lsnif","materials":[1,0]}}},
 {"name":"c","extensions":{"LSNIF_neural_object":{"model":"obj.lsnif"}},"translation":[0,-1,0]},
 {"name":"cam","camera":0,"translation":[0,0,4]}],
"cameras":[{"type":"perspective","perspective":{"yfov":0.6,"aspectRatio":1.25,"znear":0.01}}],
"meshes":[{"name":"m","primitives":[
 {"attributes":{"POSITION":0,"TEXCOORD_0":1},"indices":2,"material":0},
 {"attributes":{"POSITION":4},"indices":3,"material":1},
 {"attributes":{"POSITION":0},"mode":1}]}],
"materials":[{"name":"lit","emissiveFactor":[1,1,0],"extensions":{"KHR_materials_emissive_strength":{"emissiveStrength":3}},
  "pbrMetallicRoughness":{"baseColorTexture":{"index":0},"metallicFactor":0.5}},
 {"name":"plain","pbrMetallicRoughness":{"baseColorFactor":[0.2,0.4,0.6,1]}}],
"textures":[{"source":0}],
"images":[{"uri":"data:image/png;base64,iVBORw0KGgoAAAANSUhEUgAAAAIAAAACCAYAAABytg0kAAAAFUlEQVR42mP4z8DwHwyB9P+Ghob/AEVRCHrNY6F/AAAAAElFTkSuQmCC"}],
"accessors":[{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3"},
 {"bufferView":1,"componentType":5126,"count":4,"type":"VEC2"},
 {"bufferView":2,"componentType":5121,"count":6,"type":"SCALAR"},
 {"bufferView":3,"componentType":5125,"count":3,"type":"SCALAR"},
 {"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","sparse":{"count":1,"indices":{"bufferView":4,"componentType":5121},"values":{"bufferView":5}}}],
"bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":48},{"buffer":0,"byteOffset":48,"byteLength":32},
 {"buffer":0,"byteOffset":80,"byteLength":6},{"buffer":0,"byteOffset":88,"byteLength":12},
 {"buffer":0,"byteOffset":100,"byteLength":1},{"buffer":0,"byteOffset":104,"byteLength":12}],
"buffers":[{"byteLength":116,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAACAPwAAgD8AAAAAAAAAAAAAgD8AAAAAAAAAAAAAAAAAAIA/AAAAAAAAgD8AAIA/AAAAAAAAgD8AAQIAAgMAAAAAAAACAAAAAwAAAAIAAAAAAEBAAABAQAAAQEA="}]})";
}

std::vector<Seed> seeds(const TempDir& dir) {
  std::vector<Seed> s;
  auto add = [&](const std::string& rel, bool binary, int iterations) {
    const std::string path = kData + rel;
    std::string data = read_bytes(path);
    if (!data.empty()) s.push_back({rel, binary, std::move(data), folder_of(path), iterations});
  };
  add("BoxTextured-glTF-Binary/BoxTextured.glb", true, 8000);
  add("BoxTextured-glTF/BoxTextured.gltf", false, 5000);
  add("BoxTextured-glTF-Embedded/BoxTextured.gltf", false, 4000);
  add("cameras/Cameras.gltf", false, 4000);
  add("2CylinderEngine-glTF-Binary/2CylinderEngine.glb", true, 300);
  s.push_back({"synthetic.gltf", false, synthetic_seed(), dir.str(), 10000});
  const std::string example = std::string(LSNIF_SCENE_EXAMPLES_DIR) + "/bunny_on_plane.gltf";
  s.push_back({"bunny_on_plane.gltf", false, read_bytes(example), dir.str(), 6000});
  return s;
}

// The mutator of src/lsnif/import/mesh_fuzz_test.cpp with three more tokens for JSON structure.
std::vector<const char*> mutation_tokens() {
  std::vector<const char*> t(std::begin(fuzz::kMutationTokens), std::end(fuzz::kMutationTokens));
  t.insert(t.end(), {"\"\"", "[]", "{}"});
  return t;
}

class SceneFuzz : public ::testing::Test {
 protected:
  void SetUp() override {
    write_fake_lsnif(dir_ / "obj.lsnif");
    write_fake_lsnif(dir_ / "bunny.lsnif");
    write_file(dir_ / "sky.hdr", "#?RADIANCE\n");
  }
  TempDir dir_;
};

TEST_F(SceneFuzz, SeedsLoad) {
  for (const Seed& s : seeds(dir_)) {
    SceneLoadOptions o;
    o.quiet = true;
    Scene scene;
    Status st = load_scene_from_memory(s.data, s.binary, s.name, s.base_dir, o, scene);
    ASSERT_TRUE(st) << s.name << ": " << st.message();
    EXPECT_EQ(check_scene(scene), "") << s.name;
    if (s.name == "synthetic.gltf") {
      EXPECT_EQ(scene.instances.size(), 3u);
      EXPECT_EQ(scene.lsnif_objects.size(), 2u);
      EXPECT_EQ(scene.cameras.size(), 1u);
      EXPECT_EQ(scene.textures.size(), 1u);
      EXPECT_EQ(scene.meshes.at(0).primitives.size(), 2u);
      EXPECT_EQ(scene.meshes[0].primitives[1].positions[2], glm::vec3(3.0f));  // sparse
      EXPECT_EQ(scene.environment.path, dir_ / "sky.hdr");
    }
  }
}

TEST_F(SceneFuzz, MutatedInputsNeverBreakTheContract) {
  // Fixed seed; LSNIF_FUZZ_SEED / LSNIF_FUZZ_SCALE allow longer explorations by hand.
  const char* scale_env = std::getenv("LSNIF_FUZZ_SCALE");
  std::mt19937_64 rng = fuzz::fuzz_rng(0x5CE7E5EEDull);
  const std::vector<const char*> tokens = mutation_tokens();
  const double scale = scale_env ? std::max(0.01, std::atof(scale_env)) : 1.0;
  const auto start = std::chrono::steady_clock::now();
  size_t ok = 0, failed = 0;
  for (const Seed& s : seeds(dir_)) {
    size_t seed_ok = 0;
    std::map<std::string, int> reasons;
    const int iterations = std::max(1, int(s.iterations * scale));
    for (int it = 0; it < iterations; ++it) {
      std::string data = s.data;
      fuzz::mutate(data, rng, tokens);
      SceneLoadOptions o;
      o.quiet = true;
      Scene scene;
      Status st = load_scene_from_memory(data, s.binary, s.name, s.base_dir, o, scene);
      if (st) {
        ++ok;
        ++seed_ok;
        ASSERT_EQ(check_scene(scene), "") << s.name << " iteration " << it << "\n" << data.substr(0, 2000);
      } else {
        ++failed;
        ASSERT_FALSE(st.message().empty()) << s.name << " iteration " << it;
        ASSERT_NE(st.message().find(s.name), std::string::npos)
            << s.name << " iteration " << it << ": " << st.message();
        ASSERT_TRUE(scene.instances.empty() && scene.meshes.empty() && scene.materials.empty())
            << "a failed load must leave an empty scene";
        if (std::getenv("LSNIF_FUZZ_VERBOSE")) reasons[st.message().substr(0, 100)]++;
      }
    }
    std::printf("[ info ] %s: %zu of %d mutations loaded\n", s.name.c_str(), seed_ok, iterations);
    for (const auto& [r, c] : reasons)
      if (c > 5) std::printf("   %5d  %s\n", c, r.c_str());
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("[ info ] %zu loads ok, %zu rejected, %.2f s\n", ok, failed, seconds);
  // Both outcomes must occur, or the mutations are too weak (or too strong) to test anything.
  EXPECT_GT(ok, size_t(1000 * scale));
  EXPECT_GT(failed, size_t(1000 * scale));
}

}  // namespace
}  // namespace lsnif::scene
