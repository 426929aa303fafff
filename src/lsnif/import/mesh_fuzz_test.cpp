// mesh_fuzz_test.cpp -- deterministic mutation fuzzing of every mesh importer. Small valid OFF,
// OBJ, PLY (ascii and binary) and glTF / GLB inputs are damaged thousands of times with a fixed
// seed (bit flips, byte overwrites, truncations, insertions of random bytes and of troublesome
// tokens, deletions, duplications) and parsed from memory. Every result must be either an error
// whose message names the input, or a mesh that satisfies all of load_mesh's guarantees. Run
// under AddressSanitizer (LSNIF_SANITIZE) this is the importers' out-of-bounds check.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <random>
#include <unistd.h>

#include "lsnif/testing/fuzz_support.h"
#include "lsnif/import/mesh.h"
#include "lsnif/import/mesh_formats.h"

namespace lsnif {
namespace {

using fuzz::base64;
using fuzz::glb;
using fuzz::kPngBase64;
using fuzz::mutate;
using fuzz::png_bytes;
using fuzz::put_floats;
using mesh_io::MeshFormat;

// Binary payload shared by the glTF seeds: 4 vertices (positions, normals, uvs, ubyte colors),
// strip indices, sparse indices/values, and the PNG.
struct GltfPayload {
  std::string bin;
  size_t png_offset = 0;
};

GltfPayload gltf_payload() {
  GltfPayload p;
  p.bin += put_floats({0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0});       // 0: positions, 48 bytes
  p.bin += put_floats({0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1});       // 48: normals
  p.bin += put_floats({0, 0, 1, 0, 0, 1, 1, 1});                   // 96: uvs, 32 bytes
  p.bin += std::string("\xff\x00\x00\xff\x00\xff\x00\xff\x00\x00\xff\xff\x80\x80\x80\xff", 16);  // 128
  p.bin += std::string("\x00\x00\x01\x00\x02\x00\x03\x00", 8);    // 144: ushort strip indices
  p.bin += std::string("\x02\x00\x00\x00", 4);                     // 152: sparse index
  p.bin += put_floats({2, 2, 0});                                  // 156: sparse value
  p.png_offset = p.bin.size();                                     // 168
  p.bin += png_bytes();
  while (p.bin.size() % 4) p.bin += '\0';
  return p;
}

// glTF JSON around the payload; `buffer` is the buffers[0] object, `image` the images[0] one.
std::string gltf_json(const std::string& buffer, const std::string& image, size_t png_offset, size_t png_size) {
  return R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],
"nodes":[{"children":[1],"rotation":[0,0,0.7071068,0.7071068]},{"mesh":0,"scale":[1,-2,1],"translation":[1,2,3]}],
"meshes":[{"name":"m","primitives":[
 {"attributes":{"POSITION":0,"NORMAL":1,"TEXCOORD_0":2,"COLOR_0":3},"indices":4,"mode":5,"material":0},
 {"attributes":{"POSITION":5},"mode":4},
 {"attributes":{"POSITION":0},"mode":0}]}],
"materials":[{"name":"mat","pbrMetallicRoughness":{"baseColorFactor":[0.5,1,1,1],"baseColorTexture":{"index":0}}}],
"textures":[{"source":0}],
"images":[)" + image + R"(],
"accessors":[
 {"bufferView":0,"componentType":5126,"count":4,"type":"VEC3"},
 {"bufferView":1,"componentType":5126,"count":4,"type":"VEC3"},
 {"bufferView":2,"componentType":5126,"count":4,"type":"VEC2"},
 {"bufferView":3,"componentType":5121,"normalized":true,"count":4,"type":"VEC4"},
 {"bufferView":4,"componentType":5123,"count":4,"type":"SCALAR"},
 {"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","sparse":{"count":1,
   "indices":{"bufferView":5,"componentType":5125},"values":{"bufferView":6}}}],
"bufferViews":[
 {"buffer":0,"byteOffset":0,"byteLength":48},{"buffer":0,"byteOffset":48,"byteLength":48},
 {"buffer":0,"byteOffset":96,"byteLength":32},{"buffer":0,"byteOffset":128,"byteLength":16},
 {"buffer":0,"byteOffset":144,"byteLength":8},{"buffer":0,"byteOffset":152,"byteLength":4},
 {"buffer":0,"byteOffset":156,"byteLength":12},
 {"buffer":0,"byteOffset":)" + std::to_string(png_offset) + R"(,"byteLength":)" + std::to_string(png_size) + R"(}],
"buffers":[)" + buffer + "]}";
}

template <typename T>
void put(std::string& s, T v) {
  s.append(reinterpret_cast<const char*>(&v), sizeof(T));
}

struct Seed {
  std::string name;
  MeshFormat format;
  std::string data;
};

std::vector<Seed> seeds(const std::string& external_bin_name) {
  std::vector<Seed> s;
  s.push_back({"seed.off", MeshFormat::Off,
               "OFF\n# cube\n8 7 0\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n0 0 1\n1 0 1\n0 1 1\n1 1 1\n"
               "4 0 2 3 1\n4 4 5 7 6\n4 0 1 5 4\n4 2 6 7 3\n4 0 4 6 2\n4 1 3 7 5 255 0 0\n3 0 0 1\n"});
  s.push_back({"seed.obj", MeshFormat::Obj,
               "mtllib none.mtl\nv 0 0 0\nv 1 0 0 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\n"
               "vn 0 0 1\nusemtl a\nf 1/1/1 2/2/1 3/3/1 4/1/1\nusemtl b\nf -4//-1 -2//-1 -1//-1\n"
               "f 1 2 4\nf 1/1 3/3 4/2\nl 1 2\n"});
  const std::string ply_hdr =
      "element vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
      "property uchar red\nproperty uchar green\nproperty uchar blue\nproperty float s\nproperty float t\n"
      "property list uchar short junk\n"
      "element face 2\nproperty list uchar int vertex_indices\nproperty double w\nend_header\n";
  s.push_back({"seed_ascii.ply", MeshFormat::Ply,
               "ply\nformat ascii 1.0\n" + ply_hdr +
                   "0 0 0 255 0 0 0 0 1 7\n1 0 0 0 255 0 1 0 0\n1 1 0 0 0 255 1 1 2 1 2\n0 1 0 9 9 9 0 1 0\n"
                   "3 0 1 2 0.5\n4 0 2 3 1 1.5\n"});
  std::string bin = "ply\nformat binary_little_endian 1.0\n" + ply_hdr;
  const float v[4][5] = {{0, 0, 0, 0, 0}, {1, 0, 0, 1, 0}, {1, 1, 0, 1, 1}, {0, 1, 0, 0, 1}};
  for (int i = 0; i < 4; ++i) {
    for (int k = 0; k < 3; ++k) put(bin, v[i][k]);
    put(bin, uint8_t(200)), put(bin, uint8_t(i * 50)), put(bin, uint8_t(9));
    put(bin, v[i][3]), put(bin, v[i][4]);
    put(bin, uint8_t(1)), put(bin, int16_t(-5));
  }
  put(bin, uint8_t(3)), put(bin, int32_t(0)), put(bin, int32_t(1)), put(bin, int32_t(2)), put(bin, 0.5);
  put(bin, uint8_t(4));
  for (int32_t i : {0, 2, 3, 1}) put(bin, i);
  put(bin, 1.5);
  s.push_back({"seed_binary.ply", MeshFormat::Ply, bin});

  GltfPayload p = gltf_payload();
  const size_t png_size = png_bytes().size();
  const std::string data_uri_image = std::string(R"({"uri":"data:image/png;base64,)") + kPngBase64 + "\"}";
  s.push_back({"seed_embedded.gltf", MeshFormat::Gltf,
               gltf_json(R"({"byteLength":)" + std::to_string(p.bin.size()) +
                             R"(,"uri":"data:application/octet-stream;base64,)" + base64(p.bin) + "\"}",
                         data_uri_image, p.png_offset, png_size)});
  s.push_back({"seed_external.gltf", MeshFormat::Gltf,
               gltf_json(R"({"byteLength":)" + std::to_string(p.bin.size()) + R"(,"uri":")" +
                             external_bin_name + "\"}",
                         data_uri_image, p.png_offset, png_size)});
  s.push_back({"seed.glb", MeshFormat::Glb,
               glb(gltf_json(R"({"byteLength":)" + std::to_string(p.bin.size()) + "}",
                             R"({"bufferView":7,"mimeType":"image/png"})", p.png_offset, png_size),
                   p.bin)});
  // A real asset with a real PNG inside, when the test data is there: corrupts the image decoder's
  // input too.
  std::string real =
      fuzz::read_bytes(std::string(LSNIF_DATA_DIR) + "/gltf/BoxTextured-glTF-Binary/BoxTextured.glb");
  if (!real.empty()) s.push_back({"BoxTextured.glb", MeshFormat::Glb, std::move(real)});
  return s;
}

bool finite3(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// All of load_mesh's guarantees on a successful import. Returns a description of the first
// violation, or an empty string.
std::string check_mesh(const Mesh& m) {
  const size_t n = m.positions.size();
  if (m.triangles.empty()) return "no triangles";
  if (m.materials.empty()) return "no materials";
  if (m.triangle_material.size() != m.triangles.size()) return "triangle_material size";
  if (m.normals.size() != n) return "normals size";
  if (!m.uvs.empty() && m.uvs.size() != n) return "uvs size";
  if (!m.colors.empty() && m.colors.size() != n) return "colors size";
  for (size_t t = 0; t < m.triangles.size(); ++t) {
    const glm::uvec3& tri = m.triangles[t];
    if (tri.x >= n || tri.y >= n || tri.z >= n) return "index out of range";
    if (tri.x == tri.y || tri.y == tri.z || tri.x == tri.z) return "repeated index";
    for (int k = 0; k < 3; ++k) {
      if (!finite3(m.positions[tri[k]])) return "non-finite position";
      if (!finite3(m.normals[tri[k]])) return "non-finite normal";
    }
    if (m.triangle_material[t] >= m.materials.size()) return "material out of range";
  }
  for (const Material& mat : m.materials)
    if (mat.base_color_texture >= int(m.textures.size())) return "texture out of range";
  for (const Texture& tex : m.textures)
    if (tex.width == 0 || tex.height == 0 || tex.rgba.size() != size_t(tex.width) * tex.height * 4)
      return "texture size";
  Aabb b = m.bounds();
  if (!finite3(b.lo) || !finite3(b.hi) || !b.valid()) return "bounds";
  for (uint32_t t = 0; t < m.triangles.size() && t < 4; ++t) {
    glm::vec3 nrm = m.shading_normal(t, 0.25f, 0.25f);
    if (!finite3(nrm) || std::abs(glm::length(nrm) - 1.0f) > 1e-3f) return "shading normal";
    if (!finite3(m.albedo(t, 0.25f, 0.25f))) return "albedo";
  }
  return "";
}

class TempDir {
 public:
  TempDir() : path_(std::filesystem::temp_directory_path() / ("lsnif_mesh_fuzz_" + std::to_string(::getpid()))) {
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  std::string str() const { return path_.string(); }

 private:
  std::filesystem::path path_;
};

TEST(MeshFuzz, SeedsAreValid) {
  TempDir dir;
  GltfPayload p = gltf_payload();
  std::ofstream(dir.str() + "/fuzz.bin", std::ios::binary).write(p.bin.data(), std::streamsize(p.bin.size()));
  for (const Seed& s : seeds("fuzz.bin")) {
    Mesh mesh;
    MeshImportReport report;
    Status st = mesh_io::parse_mesh(s.data, s.format, s.name, dir.str(), mesh, &report);
    ASSERT_TRUE(st) << s.name << ": " << st.message();
    EXPECT_EQ(check_mesh(mesh), "") << s.name;
    if (s.name.rfind("seed", 0) == 0 && (s.format == MeshFormat::Gltf || s.format == MeshFormat::Glb)) {
      // strip (2) + sparse triangle (1); the POINTS primitive is reported, textures decoded.
      EXPECT_EQ(mesh.triangles.size(), 3u) << s.name;
      EXPECT_EQ(mesh.textures.size(), 1u) << s.name;
      EXPECT_FALSE(report.warnings.empty()) << s.name;
    }
  }
}

TEST(MeshFuzz, MutatedInputsNeverBreakTheContract) {
  TempDir dir;
  GltfPayload p = gltf_payload();
  std::ofstream(dir.str() + "/fuzz.bin", std::ios::binary).write(p.bin.data(), std::streamsize(p.bin.size()));
  // Fixed seed; LSNIF_FUZZ_SEED / LSNIF_FUZZ_SCALE allow longer explorations by hand.
  const char* scale_env = std::getenv("LSNIF_FUZZ_SCALE");
  std::mt19937_64 rng = fuzz::fuzz_rng(0x15A1F5EEDull);
  const int scale = scale_env ? std::max(1, std::atoi(scale_env)) : 1;
  const auto start = std::chrono::steady_clock::now();
  size_t ok = 0, failed = 0;
  for (const Seed& s : seeds("fuzz.bin")) {
    size_t seed_ok = 0;
    std::map<std::string, int> reasons;
    const int iterations = scale * (s.format == MeshFormat::Gltf || s.format == MeshFormat::Glb ? 4000 : 5000);
    for (int it = 0; it < iterations; ++it) {
      std::string data = s.data;
      mutate(data, rng);
      Mesh mesh;
      MeshImportReport report;
      Status st = mesh_io::parse_mesh(data, s.format, s.name, dir.str(), mesh, &report);
      if (st) {
        ++ok;
        ++seed_ok;
        std::string why = check_mesh(mesh);
        ASSERT_EQ(why, "") << s.name << " iteration " << it;
      } else {
        ++failed;
        ASSERT_FALSE(st.message().empty()) << s.name << " iteration " << it;
        ASSERT_NE(st.message().find(s.name), std::string::npos)
            << s.name << " iteration " << it << ": " << st.message();
        ASSERT_TRUE(mesh.triangles.empty()) << "failed import must leave an empty mesh";
        if (std::getenv("LSNIF_FUZZ_VERBOSE")) reasons[st.message().substr(0, 90)]++;
      }
    }
    std::printf("[ info ] %s: %zu of %d mutations imported\n", s.name.c_str(), seed_ok, iterations);
    for (const auto& [r, c] : reasons)
      if (c > (std::getenv("LSNIF_FUZZ_ALL") ? 0 : 20)) std::printf("   %5d  %s\n", c, r.c_str());
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("[ info ] %zu imports ok, %zu rejected, %.2f s\n", ok, failed, seconds);
  // Both outcomes must occur, or the mutations are too weak (or too strong) to test anything.
  EXPECT_GT(ok, 1000u);
  EXPECT_GT(failed, 1000u);
}

}  // namespace
}  // namespace lsnif
