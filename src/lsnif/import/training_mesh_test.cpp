// The training mesh file (training_mesh.h): load_mesh reads back bit for bit what save_training_mesh
// wrote, for meshes of every importer (an OFF scan, a textured GLB, KHR_texture_transform materials,
// a CAD sample with many materials, a mesh with vertex colours); damaged files are errors naming the
// file, never a mesh.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>

#include "lsnif/format/crc32.h"
#include "lsnif/import/mesh.h"
#include "lsnif/import/mesh_formats.h"
#include "lsnif/import/training_mesh.h"
#include "lsnif/testing/scoped_test_dir.h"

namespace lsnif {
namespace {

namespace fs = std::filesystem;

template <class T>
bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

// Every field of the two meshes, bit for bit (floats compared as bytes: -0 and NaN payloads count).
void expect_identical(const Mesh& a, const Mesh& b) {
  EXPECT_TRUE(same_bits(a.positions, b.positions));
  EXPECT_TRUE(same_bits(a.normals, b.normals));
  EXPECT_TRUE(same_bits(a.uvs, b.uvs));
  EXPECT_TRUE(same_bits(a.colors, b.colors));
  EXPECT_TRUE(same_bits(a.triangles, b.triangles));
  EXPECT_TRUE(same_bits(a.triangle_material, b.triangle_material));
  ASSERT_EQ(a.materials.size(), b.materials.size());
  for (size_t i = 0; i < a.materials.size(); ++i) {
    const Material &x = a.materials[i], &y = b.materials[i];
    EXPECT_EQ(x.name, y.name);
    // The material's fields after the name are plain numbers: compare them as bytes.
    const auto tail = [](const Material& m) {
      std::vector<float> v = {m.base_color.x, m.base_color.y, m.base_color.z, m.metallic, m.roughness,
                              m.emission.x, m.emission.y, m.emission.z, m.occlusion_strength, m.normal_scale,
                              float(m.base_color_texture), float(m.metallic_roughness_texture), float(m.emission_texture),
                              float(m.occlusion_texture), float(m.normal_texture), float(m.alpha_mode), m.alpha,
                              m.alpha_cutoff};
      for (const UvTransform& u : m.uv_transform)
        for (int c = 0; c < 3; ++c) v.insert(v.end(), {u[c].x, u[c].y});
      return v;
    };
    EXPECT_TRUE(same_bits(tail(x), tail(y))) << "material " << i;
  }
  ASSERT_EQ(a.textures.size(), b.textures.size());
  for (size_t i = 0; i < a.textures.size(); ++i) {
    EXPECT_EQ(a.textures[i].width, b.textures[i].width);
    EXPECT_EQ(a.textures[i].height, b.textures[i].height);
    EXPECT_TRUE(same_bits(a.textures[i].rgba, b.textures[i].rgba)) << "texture " << i;
  }
}

std::string data(const std::string& relative) { return std::string(LSNIF_DATA_DIR) + "/" + relative; }

TEST(TrainingMesh, RealMeshesReadBackBitForBit) {
  test::ScopedTestDir dir("lsnif_training_mesh");
  const std::vector<std::string> sources = {
      data("meshes/bunny00.off"), data("gltf/BoxTextured-glTF-Binary/BoxTextured.glb"),
      data("gltf/textureTransform/TextureTransformTest.gltf"),
      data("gltf/2CylinderEngine-glTF-Binary/2CylinderEngine.glb")};
  bool transformed = false;
  for (const std::string& source : sources) {
    if (!fs::exists(source)) GTEST_SKIP() << source << " missing: run scripts/setup.sh";
    SCOPED_TRACE(source);
    Mesh original, back;
    MeshImportOptions options;
    options.allow_dropping_most = true;  // the CAD sample repeats indices: dropped either way
    ASSERT_TRUE(load_mesh(source, original, nullptr, options));
    for (const Material& m : original.materials)
      for (const UvTransform& u : m.uv_transform) transformed |= u != kIdentityUvTransform;
    const std::string path = (dir.path() / (fs::path(source).stem().string() + ".lsmesh")).string();
    ASSERT_TRUE(save_training_mesh(original, path));
    MeshImportReport report;
    const Status s = load_mesh(path, back, &report);
    ASSERT_TRUE(s) << s.message();
    EXPECT_EQ(report.dropped_degenerate + report.dropped_invalid + report.fixed_normals, 0u);
    expect_identical(original, back);
  }
  EXPECT_TRUE(transformed) << "no source exercised a texture transform";
}

// A mesh with every optional array and a texture per slot, values that text formats would round.
Mesh synthetic_mesh() {
  Mesh m;
  m.positions = {{0.1f, 0.2f, 0.3f}, {1.0f / 3.0f, 0.0f, 0.0f}, {0.0f, 1e-3f, 7.0f}};
  m.normals = {{0, 0, 1}, {0, 0.6f, 0.8f}, {0.6f, 0, 0.8f}};
  m.uvs = {{0, 0}, {1.0f / 7.0f, 2}, {-1, 0.5f}};
  m.colors = {{1, 0, 0}, {0, 1, 0}, {0.1f, 0.2f, 0.3f}};
  m.triangles = {{0, 1, 2}};
  m.triangle_material = {0};
  Material mat;
  mat.name = "m\xc3\xa4t";
  mat.base_color = {0.5f, 0.25f, 1.0f / 3.0f};
  mat.base_color_texture = 0;
  mat.metallic_roughness_texture = 1;
  mat.emission = {2.5f, 0, 0};
  mat.uv_transform[kSlotEmission] = UvTransform(0.7f, 0.1f, -0.1f, 0.7f, 0.25f, 1.0f / 3.0f);
  mat.alpha_mode = AlphaMode::Mask;
  mat.alpha = 0.9f;
  mat.alpha_cutoff = 1.0f / 3.0f;
  m.materials = {mat};
  for (uint32_t k = 0; k < 2; ++k) {
    Texture t;
    t.width = 2 + k;
    t.height = 1;
    for (uint32_t i = 0; i < t.width * 4; ++i) t.rgba.push_back(uint8_t(17 * i + k));
    m.textures.push_back(t);
  }
  return m;
}

TEST(TrainingMesh, EveryFieldSurvives) {
  const Mesh original = synthetic_mesh();
  std::string bytes;
  ASSERT_TRUE(training_mesh_bytes(original, bytes));
  Mesh back;
  const Status s = mesh_io::parse_mesh(bytes, mesh_io::MeshFormat::TrainingMesh, "x.lsmesh", "", back, nullptr);
  ASSERT_TRUE(s) << s.message();
  expect_identical(original, back);
}

TEST(TrainingMesh, AMeshThatIsNotFinalizedIsRefused) {
  Mesh m = synthetic_mesh();
  m.normals.clear();
  std::string bytes;
  const Status s = training_mesh_bytes(m, bytes);
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find("not finalized"), std::string::npos) << s.message();
}

Status parse(const std::string& bytes) {
  Mesh m;
  return mesh_io::parse_mesh(bytes, mesh_io::MeshFormat::TrainingMesh, "bad.lsmesh", "", m, nullptr);
}

// The checksum closes the file: damaged or cut bytes are errors naming the file.
TEST(TrainingMesh, DamagedFilesAreErrors) {
  std::string good;
  ASSERT_TRUE(training_mesh_bytes(synthetic_mesh(), good));
  std::mt19937 rng(7);
  for (int i = 0; i < 400; ++i) {
    std::string bad = good;
    if (i % 2) {
      bad[rng() % bad.size()] ^= char(1 + rng() % 255);
    } else {
      bad.resize(rng() % bad.size());
    }
    const Status s = parse(bad);
    ASSERT_FALSE(s) << "case " << i;
    EXPECT_NE(s.message().find("bad.lsmesh"), std::string::npos) << s.message();
  }
  EXPECT_NE(parse(std::string("LSNIFMSH") + std::string(8, 'x')).message().find("checksum"), std::string::npos);
  EXPECT_NE(parse("not a mesh").message().find("no LSNIFMSH signature"), std::string::npos);
}

// Files with a valid checksum but contents out of range (a writer of another program, a careful
// attacker) are refused by the reader's checks, not trusted for the checksum.
TEST(TrainingMesh, ConsistentChecksumsDoNotMakeBadContentsValid) {
  std::string good;
  ASSERT_TRUE(training_mesh_bytes(synthetic_mesh(), good));
  const auto reseal = [](std::string b) {
    b.resize(b.size() - 4);
    const uint32_t crc = crc32(reinterpret_cast<const uint8_t*>(b.data()), b.size());
    b.append(reinterpret_cast<const char*>(&crc), 4);
    return b;
  };
  const auto with_u64 = [&](size_t offset, uint64_t v) {
    std::string b = good;
    std::memcpy(b.data() + offset, &v, 8);
    return reseal(b);
  };
  const auto with_u32 = [&](size_t offset, uint32_t v) {
    std::string b = good;
    std::memcpy(b.data() + offset, &v, 4);
    return reseal(b);
  };
  const size_t counts = 16;  // after the magic, version and flags
  // The first triangle's corners: after the counts, 3 positions, normals, uvs and colours.
  const size_t corners = counts + 7 * 8 + 3 * 12 + 3 * 12 + 3 * 8 + 3 * 12;
  EXPECT_NE(parse(with_u32(8, 2)).message().find("version 2"), std::string::npos);
  EXPECT_NE(parse(with_u32(12, 1)).message().find("flags"), std::string::npos);
  EXPECT_NE(parse(with_u64(counts, uint64_t(1) << 40)).message().find("counts out of range"), std::string::npos);
  EXPECT_NE(parse(with_u64(counts + 4 * 8, 1000)).message().find("ends inside"), std::string::npos);
  EXPECT_NE(parse(with_u32(corners, 3)).message().find("triangle 0 refers to a vertex"), std::string::npos);
  EXPECT_NE(parse(good + "x").message().find("checksum"), std::string::npos);
}

}  // namespace
}  // namespace lsnif
