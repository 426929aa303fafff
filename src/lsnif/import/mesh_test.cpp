// mesh_test.cpp -- mesh import: every format on small files written here (checked against the
// values the files were written from), the real test meshes (checked against independent
// brute-force readers), the clean-up step's counters, and the Mesh queries against hand-computed
// values.
#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <unistd.h>
#include <nlohmann/json.hpp>
#include <sstream>

#include "lsnif/import/mesh.h"

namespace lsnif {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

const std::string kDataDir = LSNIF_DATA_DIR;

// A fresh folder under the system temp dir, removed with its contents at the end of the test.
class TempDir {
 public:
  TempDir() {
    static int counter = 0;
    path_ = fs::temp_directory_path() /
            ("lsnif_mesh_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  std::string write(const std::string& name, const std::string& bytes) const {
    std::string p = (path_ / name).string();
    std::ofstream(p, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
    return p;
  }
  std::string path(const std::string& name) const { return (path_ / name).string(); }

 private:
  fs::path path_;
};

struct Loaded {
  Status status;
  Mesh mesh;
  MeshImportReport report;
};

Loaded load(const std::string& path, const MeshImportOptions& options = {}) {
  Loaded l;
  l.status = load_mesh(path, l.mesh, &l.report, options);
  return l;
}

// Options for the tests that count dropped triangles on tiny meshes where most are bad.
MeshImportOptions allow_dropping() {
  MeshImportOptions o;
  o.allow_dropping_most = true;
  return o;
}

bool contains(const std::string& s, const std::string& what) { return s.find(what) != std::string::npos; }

bool any_warning(const MeshImportReport& r, const std::string& what) {
  for (const std::string& w : r.warnings)
    if (contains(w, what)) return true;
  return false;
}

void expect_vec3(const glm::vec3& a, const glm::vec3& b, float tol = 1e-6f) {
  EXPECT_NEAR(a.x, b.x, tol);
  EXPECT_NEAR(a.y, b.y, tol);
  EXPECT_NEAR(a.z, b.z, tol);
}

bool finite_box(const Aabb& b) {
  for (int k = 0; k < 3; ++k)
    if (!std::isfinite(b.lo[k]) || !std::isfinite(b.hi[k]) || b.lo[k] > b.hi[k]) return false;
  return true;
}

// Unit cube: 8 corners (bit 0 -> x, bit 1 -> y, bit 2 -> z), 6 outward quads.
const int kCubeQuads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                              {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
glm::vec3 cube_corner(int i) { return glm::vec3(float(i & 1), float((i >> 1) & 1), float((i >> 2) & 1)); }

// Every triangle's geometric normal points away from `centre` (of a convex mesh).
void expect_outward(const Mesh& m, glm::vec3 centre = glm::vec3(0.5f)) {
  for (const glm::uvec3& t : m.triangles) {
    glm::vec3 a = m.positions[t.x], b = m.positions[t.y], c = m.positions[t.z];
    glm::vec3 n = glm::cross(b - a, c - a);
    EXPECT_GT(glm::dot(n, (a + b + c) / 3.0f - centre), 0.0f);
  }
}

// ---------------------------------------------------------------- OFF

TEST(MeshOff, CubeWithCommentsQuadsAndFaceColors) {
  TempDir dir;
  std::ostringstream off;
  off << "# a cube\nOFF\n\n# counts next\n8 6 12\n";
  for (int i = 0; i < 8; ++i) {
    glm::vec3 p = cube_corner(i);
    off << p.x << " " << p.y << " " << p.z << "  # corner " << i << "\n";
  }
  for (const auto& q : kCubeQuads) off << "4 " << q[0] << " " << q[1] << " " << q[2] << " " << q[3] << " 255 0 0\n";
  Loaded l = load(dir.write("cube.off", off.str()));
  ASSERT_TRUE(l.status) << l.status.message();
  EXPECT_EQ(l.mesh.positions.size(), 8u);
  ASSERT_EQ(l.mesh.triangles.size(), 12u);
  // Fan triangulation of quad (a b c d): (a b c), (a c d).
  EXPECT_EQ(l.mesh.triangles[0], glm::uvec3(0, 2, 3));
  EXPECT_EQ(l.mesh.triangles[1], glm::uvec3(0, 3, 1));
  Aabb b = l.mesh.bounds();
  expect_vec3(b.lo, glm::vec3(0.0f));
  expect_vec3(b.hi, glm::vec3(1.0f));
  expect_outward(l.mesh);
  EXPECT_EQ(l.report.fixed_normals, 8u);  // OFF has no normals: all computed
  ASSERT_EQ(l.mesh.normals.size(), 8u);
  for (const glm::vec3& n : l.mesh.normals) EXPECT_NEAR(glm::length(n), 1.0f, 1e-5f);
  EXPECT_EQ(l.mesh.materials.size(), 1u);
  EXPECT_EQ(l.mesh.triangle_material.size(), 12u);
  EXPECT_EQ(l.report.dropped_degenerate + l.report.dropped_invalid, 0u);
}

TEST(MeshOff, CountsOnKeywordLineAndPentagonFan) {
  TempDir dir;
  // Regular pentagon in z = 0 plus apex-free: one 5-gon -> 3 triangles (0 1 2), (0 2 3), (0 3 4).
  std::ostringstream off;
  off << "OFF 5 1 0\n";
  for (int i = 0; i < 5; ++i) {
    double a = 2.0 * 3.14159265358979323846 * i / 5.0;
    off << std::cos(a) << " " << std::sin(a) << " 0\n";
  }
  off << "5 0 1 2 3 4\n";
  Loaded l = load(dir.write("penta.OFF", off.str()));  // upper-case extension
  ASSERT_TRUE(l.status) << l.status.message();
  ASSERT_EQ(l.mesh.triangles.size(), 3u);
  EXPECT_EQ(l.mesh.triangles[0], glm::uvec3(0, 1, 2));
  EXPECT_EQ(l.mesh.triangles[1], glm::uvec3(0, 2, 3));
  EXPECT_EQ(l.mesh.triangles[2], glm::uvec3(0, 3, 4));
  // Counter-clockwise in the xy plane: every computed normal is +z.
  for (const glm::vec3& n : l.mesh.normals) expect_vec3(n, glm::vec3(0, 0, 1), 1e-5f);
}

TEST(MeshOff, CountsLargerThanDataIsAnError) {
  TempDir dir;
  Loaded l = load(dir.write("short.off", "OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n"));
  EXPECT_FALSE(l.status);
  EXPECT_TRUE(contains(l.status.message(), "short.off")) << l.status.message();
  EXPECT_TRUE(contains(l.status.message(), "3 of 4 vertices")) << l.status.message();
  Loaded f = load(dir.write("short2.off", "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"));
  EXPECT_FALSE(f.status);
  EXPECT_TRUE(contains(f.status.message(), "1 of 2 faces")) << f.status.message();
  EXPECT_TRUE(f.mesh.triangles.empty());
}

TEST(MeshOff, GoodAndBadTrianglesAreCounted) {
  TempDir dir;
  // v0..v3 a good tetra corner set, v4 NaN, v5 collinear with v0 and v1.
  std::string off =
      "OFF\n6 6 0\n"
      "0 0 0\n1 0 0\n0 1 0\n0 0 1\nnan 0 0\n2 0 0\n"
      "3 0 1 2\n"    // good
      "3 0 2 3\n"    // good
      "3 0 0 1\n"    // repeated index -> degenerate
      "3 0 1 5\n"    // collinear -> degenerate
      "3 0 1 4\n"    // NaN corner -> invalid
      "3 0 1 17\n";  // index out of range -> invalid
  Loaded l = load(dir.write("mixed.off", off));
  ASSERT_FALSE(l.status);  // 4 of 6 dropped
  EXPECT_TRUE(contains(l.status.message(), "4 of its 6 triangles would be dropped (2 degenerate, 2 invalid)"))
      << l.status.message();
  EXPECT_TRUE(contains(l.status.message(), "--allow-dropped-triangles")) << l.status.message();
  l = load(dir.write("mixed.off", off), allow_dropping());
  ASSERT_TRUE(l.status) << l.status.message();
  EXPECT_EQ(l.mesh.triangles.size(), 2u);
  EXPECT_EQ(l.report.dropped_degenerate, 2u);
  EXPECT_EQ(l.report.dropped_invalid, 2u);
  EXPECT_TRUE(any_warning(l.report, "degenerate"));
  EXPECT_TRUE(any_warning(l.report, "non-finite"));
  EXPECT_EQ(l.mesh.triangle_material.size(), 2u);
  // The vertices no kept triangle uses (the NaN one, the collinear one) are gone.
  EXPECT_EQ(l.mesh.positions.size(), 4u);
  for (const glm::vec3& p : l.mesh.positions) EXPECT_TRUE(std::isfinite(p.x + p.y + p.z));
  Aabb b = l.mesh.bounds();
  EXPECT_TRUE(finite_box(b));
  expect_vec3(b.hi, glm::vec3(1.0f));
}

TEST(MeshOff, NaNPositionsAndAllDegenerateAreErrors) {
  TempDir dir;
  Loaded nan = load(dir.write("nan.off", "OFF\n3 1 0\n0 0 0\nnan 1 0\n0 1 0\n3 0 1 2\n"));
  EXPECT_FALSE(nan.status);
  EXPECT_TRUE(contains(nan.status.message(), "no valid triangles (0 degenerate, 1 invalid)"))
      << nan.status.message();
  EXPECT_EQ(nan.report.dropped_invalid, 1u);
  Loaded deg = load(dir.write("flat.off", "OFF\n4 2 0\n0 0 0\n1 1 1\n2 2 2\n5 5 5\n3 0 1 2\n3 1 2 3\n"));
  EXPECT_FALSE(deg.status);
  EXPECT_TRUE(contains(deg.status.message(), "flat.off: no valid triangles (2 degenerate, 0 invalid)"))
      << deg.status.message();
}

// ---------------------------------------------------------------- generic errors

TEST(MeshErrors, MissingEmptyUnknownAndGarbage) {
  TempDir dir;
  Loaded missing = load(dir.path("nope.obj"));
  EXPECT_FALSE(missing.status);
  EXPECT_TRUE(contains(missing.status.message(), "nope.obj"));
  Loaded empty = load(dir.write("empty.ply", ""));
  EXPECT_FALSE(empty.status);
  EXPECT_TRUE(contains(empty.status.message(), "empty.ply: empty file")) << empty.status.message();
  Loaded unknown = load(dir.write("mesh.stl", "solid x\n"));
  EXPECT_FALSE(unknown.status);
  EXPECT_TRUE(contains(unknown.status.message(), "unsupported mesh format")) << unknown.status.message();
  Loaded garbage = load(dir.write("garbage.off", "PLY\n1 2 3\n"));
  EXPECT_FALSE(garbage.status);
  EXPECT_FALSE(garbage.status.message().empty());
  fs::create_directories(dir.path("sub.off"));
  Loaded dirpath = load(dir.path("sub.off"));
  EXPECT_FALSE(dirpath.status);
}

// ---------------------------------------------------------------- OBJ

TEST(MeshObj, CubeWithNegativeIndicesMatchesPositiveOnes) {
  TempDir dir;
  std::ostringstream pos, neg;
  for (int i = 0; i < 8; ++i) {
    glm::vec3 p = cube_corner(i);
    pos << "v " << p.x << " " << p.y << " " << p.z << "\n";
  }
  neg << pos.str();
  pos << "g cube\ns off\n";
  for (const auto& q : kCubeQuads) {
    pos << "f";
    neg << "f";
    for (int k = 0; k < 4; ++k) {
      pos << " " << q[k] + 1;
      neg << " " << q[k] - 8;  // relative to the 8 vertices defined so far
    }
    pos << "\n";
    neg << "\n";
  }
  Loaded a = load(dir.write("pos.obj", pos.str()));
  Loaded b = load(dir.write("neg.obj", neg.str()));
  ASSERT_TRUE(a.status) << a.status.message();
  ASSERT_TRUE(b.status) << b.status.message();
  EXPECT_EQ(a.mesh.positions.size(), 8u);
  ASSERT_EQ(a.mesh.triangles.size(), 12u);
  EXPECT_EQ(a.mesh.triangles, b.mesh.triangles);
  EXPECT_EQ(a.mesh.positions, b.mesh.positions);
  EXPECT_EQ(a.mesh.triangles[0], glm::uvec3(0, 2, 3));
  EXPECT_EQ(a.mesh.triangles[1], glm::uvec3(0, 3, 1));
  expect_outward(a.mesh);
  EXPECT_TRUE(a.mesh.uvs.empty());
}

TEST(MeshObj, CornerFormsMaterialsAndMtllib) {
  TempDir dir;
  dir.write("m.mtl", "newmtl red\nKd 1 0 0\nnewmtl blue\nKd 0 0 1\n");
  std::string obj =
      "mtllib m.mtl\n"
      "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
      "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
      "vn 0 0 2\n"  // not normalized on purpose: kept as given
      "usemtl red\n"
      "f 1/1 2/2 3/3\n"          // v/t
      "usemtl blue\n"
      "f 1//1 3//1 4//1\n"       // v//n
      "usemtl red\n"
      "f -4/-4/-1 -3/-3/-1 -1/-1/-1\n"  // v/t/n, negative: vertices 1 2 4
      "l 1 2\n";
  Loaded l = load(dir.write("quad.obj", obj));
  ASSERT_TRUE(l.status) << l.status.message();
  ASSERT_EQ(l.mesh.triangles.size(), 3u);
  ASSERT_EQ(l.mesh.materials.size(), 2u);
  EXPECT_EQ(l.mesh.materials[0].name, "red");
  expect_vec3(l.mesh.materials[0].base_color, glm::vec3(1, 0, 0));
  EXPECT_EQ(l.mesh.materials[1].name, "blue");
  expect_vec3(l.mesh.materials[1].base_color, glm::vec3(0, 0, 1));
  EXPECT_EQ(l.mesh.triangle_material, (std::vector<uint32_t>{0, 1, 0}));
  // Distinct (v, vt, vn) triples: 3 + 3 + 3 corners, none shared.
  EXPECT_EQ(l.mesh.positions.size(), 9u);
  ASSERT_EQ(l.mesh.uvs.size(), 9u);
  ASSERT_EQ(l.mesh.normals.size(), 9u);
  // Triangle 0 carries the uvs of its corners.
  const glm::uvec3 t0 = l.mesh.triangles[0];
  EXPECT_EQ(l.mesh.uvs[t0.y], glm::vec2(1, 0));
  EXPECT_EQ(l.mesh.uvs[t0.z], glm::vec2(1, 1));
  // Triangle 1's corners have the given normal; triangle 0's had none and were recomputed (+z).
  expect_vec3(l.mesh.normals[l.mesh.triangles[1].x], glm::vec3(0, 0, 2));
  expect_vec3(l.mesh.normals[t0.x], glm::vec3(0, 0, 1), 1e-6f);
  EXPECT_EQ(l.report.fixed_normals, 3u);
  // Triangle 2 = OBJ vertices 1 2 4.
  const glm::uvec3 t2 = l.mesh.triangles[2];
  expect_vec3(l.mesh.positions[t2.x], glm::vec3(0, 0, 0));
  expect_vec3(l.mesh.positions[t2.y], glm::vec3(1, 0, 0));
  expect_vec3(l.mesh.positions[t2.z], glm::vec3(0, 1, 0));
  EXPECT_TRUE(any_warning(l.report, "line/point"));
  // Albedo = material base color (no texture, no vertex colors).
  expect_vec3(l.mesh.albedo(1, 0.3f, 0.3f), glm::vec3(0, 0, 1));
}

TEST(MeshObj, VertexColorsBadIndicesAndMissingMtllib) {
  TempDir dir;
  std::string obj =
      "mtllib missing.mtl\n"
      "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nv 0 0 1\n"
      "f 1 2 3\nf 1 2 9\nf 0 1 2\nf 1 2\n";
  Loaded l = load(dir.write("c.obj", obj), allow_dropping());
  ASSERT_TRUE(l.status) << l.status.message();
  EXPECT_EQ(l.mesh.triangles.size(), 1u);
  EXPECT_EQ(l.report.dropped_invalid, 2u);      // index 9 and index 0
  EXPECT_EQ(l.report.dropped_degenerate, 1u);   // the 2-vertex face
  EXPECT_TRUE(any_warning(l.report, "missing.mtl"));
  // Vertex 4 (no color given: white) is used by no kept triangle and removed.
  ASSERT_EQ(l.mesh.colors.size(), 3u);
  // Albedo interpolates the vertex colors with Embree barycentrics.
  expect_vec3(l.mesh.albedo(0, 0.25f, 0.5f), glm::vec3(0.25f, 0.25f, 0.5f));
  Loaded bad = load(dir.write("bad.obj", "v 0 0\n"));
  EXPECT_FALSE(bad.status);
  EXPECT_TRUE(contains(bad.status.message(), "bad.obj: line 1")) << bad.status.message();
}

// ---------------------------------------------------------------- PLY

struct PlyVertex {
  float x, y, z, nx, ny, nz;
  uint8_t r, g, b;
  float s, t;
  double junk;
};

const PlyVertex kTetra[4] = {
    {0, 0, 0, -1, -1, -1, 255, 0, 0, 0.0f, 0.0f, 1.5},
    {1, 0, 0, 1, 0, 0, 0, 255, 0, 1.0f, 0.0f, 2.5},
    {0, 1, 0, 0, 1, 0, 0, 0, 255, 0.0f, 1.0f, 3.5},
    {0, 0, 1, 0, 0, 1, 51, 102, 204, 0.5f, 0.5f, 4.5},
};
// Outward faces; the last one is a quad (0 1 3 + a repeated 3) to check list lengths > 3.
const std::vector<std::vector<int>> kTetraFaces = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3, 3}};

std::string ply_header(const char* fmt) {
  return std::string("ply\nformat ") + fmt + " 1.0\ncomment test\n"
         "element vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
         "property list uchar int vlist\n"  // an unknown list in the vertex element
         "property float nx\nproperty float ny\nproperty float nz\n"
         "property uchar red\nproperty uchar green\nproperty uchar blue\n"
         "property float s\nproperty float t\nproperty double junk\n"
         "element face 4\nproperty uchar flags\nproperty list uchar int vertex_indices\n"
         "property short more\n"
         "element edge 1\nproperty int a\nproperty list int ushort b\n"
         "end_header\n";
}

template <typename T>
void put(std::string& out, T v, bool big) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if (big) std::reverse(b, b + sizeof(T));
  out.append(b, sizeof(T));
}

std::string tetra_ply(const char* fmt) {
  const bool ascii = std::strcmp(fmt, "ascii") == 0, big = std::strcmp(fmt, "binary_big_endian") == 0;
  std::string out = ply_header(fmt);
  std::ostringstream a;
  for (const PlyVertex& v : kTetra) {
    if (ascii) {
      a << v.x << " " << v.y << " " << v.z << " 2 7 8 " << v.nx << " " << v.ny << " " << v.nz << " "
        << int(v.r) << " " << int(v.g) << " " << int(v.b) << " " << v.s << " " << v.t << " " << v.junk << "\n";
    } else {
      put(out, v.x, big), put(out, v.y, big), put(out, v.z, big);
      put(out, uint8_t(2), big), put(out, int32_t(7), big), put(out, int32_t(8), big);
      put(out, v.nx, big), put(out, v.ny, big), put(out, v.nz, big);
      put(out, v.r, big), put(out, v.g, big), put(out, v.b, big);
      put(out, v.s, big), put(out, v.t, big), put(out, v.junk, big);
    }
  }
  for (const auto& f : kTetraFaces) {
    if (ascii) {
      a << "9 " << f.size();
      for (int i : f) a << " " << i;
      a << " -3\n";
    } else {
      put(out, uint8_t(9), big);
      put(out, uint8_t(f.size()), big);
      for (int i : f) put(out, int32_t(i), big);
      put(out, int16_t(-3), big);
    }
  }
  if (ascii) {
    a << "5 3 1 2 3\n";
    out += a.str();
  } else {
    put(out, int32_t(5), big), put(out, int32_t(3), big);
    for (uint16_t i = 1; i <= 3; ++i) put(out, i, big);
  }
  return out;
}

TEST(MeshPly, AsciiAndBinaryAgree) {
  TempDir dir;
  Loaded ascii = load(dir.write("t_ascii.ply", tetra_ply("ascii")));
  ASSERT_TRUE(ascii.status) << ascii.status.message();
  const Mesh& m = ascii.mesh;
  ASSERT_EQ(m.positions.size(), 4u);
  // 3 triangles + the quad fanned into (1 2 3) and the degenerate (1 3 3).
  EXPECT_EQ(m.triangles.size(), 4u);
  EXPECT_EQ(ascii.report.dropped_degenerate, 1u);
  EXPECT_TRUE(any_warning(ascii.report, "edge"));
  for (int i = 0; i < 4; ++i) {
    const PlyVertex& v = kTetra[i];
    expect_vec3(m.positions[size_t(i)], glm::vec3(v.x, v.y, v.z));
    expect_vec3(m.normals[size_t(i)], glm::vec3(v.nx, v.ny, v.nz));
    expect_vec3(m.colors[size_t(i)], glm::vec3(v.r, v.g, v.b) / 255.0f);  // linear value / 255
    EXPECT_EQ(m.uvs[size_t(i)], glm::vec2(v.s, v.t));
  }
  expect_outward(m, glm::vec3(0.25f));
  EXPECT_EQ(ascii.report.fixed_normals, 0u);  // the given normals are all usable
  for (const char* fmt : {"binary_little_endian", "binary_big_endian"}) {
    Loaded bin = load(dir.write(std::string("t_") + fmt + ".ply", tetra_ply(fmt)));
    ASSERT_TRUE(bin.status) << fmt << ": " << bin.status.message();
    EXPECT_EQ(bin.mesh.positions, m.positions) << fmt;
    EXPECT_EQ(bin.mesh.normals, m.normals) << fmt;
    EXPECT_EQ(bin.mesh.colors, m.colors) << fmt;
    EXPECT_EQ(bin.mesh.uvs, m.uvs) << fmt;
    EXPECT_EQ(bin.mesh.triangles, m.triangles) << fmt;
    EXPECT_EQ(bin.report.dropped_degenerate, 1u);
  }
}

TEST(MeshPly, VertexIndexWithIntCountsAndTruncation) {
  TempDir dir;
  std::string hdr =
      "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty double x\nproperty double y\n"
      "property double z\nelement face 1\nproperty list int uint vertex_index\nend_header\n";
  std::string body;
  const double p[4][3] = {{0, 0, 0}, {2, 0, 0}, {2, 2, 0}, {0, 2, 0}};
  for (const auto& v : p)
    for (double c : v) put(body, c, false);
  put(body, int32_t(4), false);
  for (uint32_t i = 0; i < 4; ++i) put(body, i, false);
  Loaded l = load(dir.write("quad.ply", hdr + body));
  ASSERT_TRUE(l.status) << l.status.message();
  ASSERT_EQ(l.mesh.triangles.size(), 2u);
  EXPECT_EQ(l.mesh.triangles[0], glm::uvec3(0, 1, 2));
  EXPECT_EQ(l.mesh.triangles[1], glm::uvec3(0, 2, 3));
  expect_vec3(l.mesh.bounds().hi, glm::vec3(2, 2, 0));
  Loaded cut = load(dir.write("cut.ply", hdr + body.substr(0, body.size() - 3)));
  EXPECT_FALSE(cut.status);
  EXPECT_TRUE(contains(cut.status.message(), "cut.ply")) << cut.status.message();
  Loaded noxyz = load(dir.write("noxyz.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float q\nend_header\n1\n"));
  EXPECT_FALSE(noxyz.status);
}

// ---------------------------------------------------------------- glTF written here

// Builds a glTF asset: JSON plus one binary buffer, written as .gltf + .bin or as .glb.
struct GltfBuilder {
  json j;
  std::string bin;

  GltfBuilder() {
    j["asset"] = {{"version", "2.0"}};
    j["buffers"] = json::array();
    j["bufferViews"] = json::array();
    j["accessors"] = json::array();
  }
  int view(const void* data, size_t bytes) {
    while (bin.size() % 4) bin.push_back('\0');
    j["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", bin.size()}, {"byteLength", bytes}});
    bin.append(static_cast<const char*>(data), bytes);
    return int(j["bufferViews"].size()) - 1;
  }
  template <typename T>
  int accessor(const std::vector<T>& data, int components, int component_type, const char* type,
               bool normalized = false) {
    json a = {{"bufferView", view(data.data(), data.size() * sizeof(T))},
              {"componentType", component_type},
              {"count", data.size() / size_t(components)},
              {"type", type}};
    if (normalized) a["normalized"] = true;
    j["accessors"].push_back(a);
    return int(j["accessors"].size()) - 1;
  }
  std::string gltf(const std::string& bin_uri) {
    json out = j;
    out["buffers"] = json::array({{{"byteLength", bin.size()}, {"uri", bin_uri}}});
    return out.dump();
  }
  std::string glb() {
    json out = j;
    out["buffers"] = json::array({{{"byteLength", bin.size()}}});
    std::string js = out.dump();
    while (js.size() % 4) js.push_back(' ');
    std::string b = bin;
    while (b.size() % 4) b.push_back('\0');
    std::string g;
    auto u32 = [&](uint32_t v) { g.append(reinterpret_cast<const char*>(&v), 4); };
    g = "glTF";
    u32(2);
    u32(uint32_t(12 + 8 + js.size() + 8 + b.size()));
    u32(uint32_t(js.size()));
    u32(0x4E4F534A);
    g += js;
    u32(uint32_t(b.size()));
    u32(0x004E4942);
    g += b;
    return g;
  }
};

constexpr int kFloat = 5126, kUByte = 5121, kUShort = 5123;

// One triangle (0,0,0) (1,0,0) (0,1,0) with +z normals, under one node with `node` properties.
GltfBuilder triangle_asset(const json& node) {
  GltfBuilder g;
  int pos = g.accessor(std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0}, 3, kFloat, "VEC3");
  int nrm = g.accessor(std::vector<float>{0, 0, 1, 0, 0, 1, 0, 0, 1}, 3, kFloat, "VEC3");
  int idx = g.accessor(std::vector<uint16_t>{0, 1, 2}, 1, kUShort, "SCALAR");
  g.j["meshes"] = {{{"name", "tri"},
                    {"primitives", {{{"attributes", {{"POSITION", pos}, {"NORMAL", nrm}}}, {"indices", idx}}}}}};
  json n = node;
  n["mesh"] = 0;
  g.j["nodes"] = {{{"children", {1}}}, n};
  g.j["scenes"] = {{{"nodes", {0}}}};
  g.j["scene"] = 0;
  return g;
}

TEST(MeshGltf, TrsTransformAndGlbEquivalence) {
  TempDir dir;
  // scale 2, then 90 degrees about z, then translate (1, 2, 3).
  const double s = std::sqrt(0.5);
  GltfBuilder g = triangle_asset({{"translation", {1, 2, 3}}, {"rotation", {0, 0, s, s}}, {"scale", {2, 2, 2}}});
  dir.write("tri.bin", g.bin);
  Loaded l = load(dir.write("tri.gltf", g.gltf("tri.bin")));
  ASSERT_TRUE(l.status) << l.status.message();
  ASSERT_EQ(l.mesh.triangles.size(), 1u);
  // Hand-computed: R(x, y) = (-y, x).
  expect_vec3(l.mesh.positions[0], glm::vec3(1, 2, 3), 1e-5f);
  expect_vec3(l.mesh.positions[1], glm::vec3(1, 4, 3), 1e-5f);
  expect_vec3(l.mesh.positions[2], glm::vec3(-1, 2, 3), 1e-5f);
  EXPECT_EQ(l.mesh.triangles[0], glm::uvec3(0, 1, 2));
  expect_vec3(l.mesh.normals[0], glm::vec3(0, 0, 1), 1e-6f);
  Loaded b = load(dir.write("tri.glb", g.glb()));
  ASSERT_TRUE(b.status) << b.status.message();
  EXPECT_EQ(b.mesh.positions, l.mesh.positions);
  EXPECT_EQ(b.mesh.triangles, l.mesh.triangles);
}

TEST(MeshGltf, MirrorFlipsWindingAndNormalsUseInverseTranspose) {
  TempDir dir;
  // Matrix (column-major): x -> -2x. Normals: inverse transpose diag(-1/2, 1, 1).
  GltfBuilder g = triangle_asset({{"matrix", {-2, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}}});
  g.j["accessors"][1]["bufferView"] = g.view(std::vector<float>{1, 1, 0, 1, 1, 0, 1, 1, 0}.data(), 36);
  Loaded l = load(dir.write("m.glb", g.glb()));
  ASSERT_TRUE(l.status) << l.status.message();
  ASSERT_EQ(l.mesh.triangles.size(), 1u);
  EXPECT_EQ(l.mesh.triangles[0], glm::uvec3(0, 2, 1));
  const Mesh& m = l.mesh;
  glm::vec3 face = glm::cross(m.positions[m.triangles[0].y] - m.positions[m.triangles[0].x],
                              m.positions[m.triangles[0].z] - m.positions[m.triangles[0].x]);
  EXPECT_GT(face.z, 0.0f);  // still facing +z like the source triangle
  expect_vec3(m.normals[0], glm::normalize(glm::vec3(-0.5f, 1.0f, 0.0f)), 1e-6f);
}

TEST(MeshGltf, StripFanColorsSparseAndPoints) {
  TempDir dir;
  GltfBuilder g;
  // Unit square corners 0 (0,0) 1 (1,0) 2 (0,1) 3 (1,1).
  int pos = g.accessor(std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0}, 3, kFloat, "VEC3");
  int col = g.accessor(std::vector<uint8_t>{255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 51, 51, 51, 255},
                       4, kUByte, "VEC4", true);
  int strip = g.accessor(std::vector<uint8_t>{0, 1, 2, 3}, 1, kUByte, "SCALAR");
  int fan = g.accessor(std::vector<uint16_t>{0, 1, 3, 2}, 1, kUShort, "SCALAR");
  // Sparse copy of the positions: vertex 3 moved to (2, 2, 0).
  json sparse_pos = g.j["accessors"][pos];
  sparse_pos["sparse"] = {{"count", 1},
                          {"indices", {{"bufferView", g.view(std::vector<uint8_t>{3, 0, 0, 0}.data(), 4)},
                                       {"componentType", kUByte}}},
                          {"values", {{"bufferView", g.view(std::vector<float>{2, 2, 0}.data(), 12)}}}};
  g.j["accessors"].push_back(sparse_pos);
  const int sparse = int(g.j["accessors"].size()) - 1;
  g.j["meshes"] = {{{"name", "m"},
                    {"primitives",
                     {{{"attributes", {{"POSITION", pos}, {"COLOR_0", col}}}, {"indices", strip}, {"mode", 5}},
                      {{"attributes", {{"POSITION", sparse}}}, {"indices", fan}, {"mode", 6}},
                      {{"attributes", {{"POSITION", pos}}}, {"mode", 0}}}}}};
  g.j["nodes"] = {{{"mesh", 0}}};  // no scene: the root nodes are used
  dir.write("s.bin", g.bin);
  Loaded l = load(dir.write("s.gltf", g.gltf("s.bin")));
  ASSERT_TRUE(l.status) << l.status.message();
  ASSERT_EQ(l.mesh.triangles.size(), 4u);
  // Strip (0 1 2 3): (0 1 2), (1 3 2). Fan (0 1 3 2): (1 3 0), (3 2 0). Without NORMAL both are
  // flat (glTF), so every triangle has three vertices of its own carrying the face normal +z.
  const glm::vec3 p0(0, 0, 0), p1(1, 0, 0), p2(0, 1, 0), p3(1, 1, 0), q3(2, 2, 0);  // q3: sparse substitution
  const std::vector<std::array<glm::vec3, 3>> want = {{p0, p1, p2}, {p1, p3, p2}, {p1, q3, p0}, {q3, p2, p0}};
  for (size_t t = 0; t < 4; ++t) {
    EXPECT_EQ(l.mesh.triangles[t], glm::uvec3(uint32_t(3 * t), uint32_t(3 * t + 1), uint32_t(3 * t + 2)));
    for (int k = 0; k < 3; ++k) {
      expect_vec3(l.mesh.positions[l.mesh.triangles[t][k]], want[t][size_t(k)]);
      expect_vec3(l.mesh.normals[l.mesh.triangles[t][k]], glm::vec3(0, 0, 1));  // consistent winding
    }
  }
  ASSERT_EQ(l.mesh.colors.size(), 12u);
  expect_vec3(l.mesh.colors[0], glm::vec3(1, 0, 0));        // corner 0
  expect_vec3(l.mesh.colors[4], glm::vec3(0.2f), 1e-6f);    // corner 3 of the strip: 51 / 255
  expect_vec3(l.mesh.colors[7], glm::vec3(1.0f));           // the fan primitive has no colors: white
  EXPECT_TRUE(any_warning(l.report, "POINTS"));
  EXPECT_TRUE(any_warning(l.report, "mesh 0 ('m') primitive 2"));
}

TEST(MeshGltf, EmbeddedTextureDecodesAndDrivesAlbedo) {
  TempDir dir;
  GltfBuilder g = triangle_asset(json::object());
  int uv = g.accessor(std::vector<float>{0.25f, 0.25f, 0.75f, 0.25f, 0.25f, 0.75f}, 2, kFloat, "VEC2");
  g.j["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = uv;
  g.j["meshes"][0]["primitives"][0]["material"] = 0;
  g.j["materials"] = {{{"name", "logo"},
                       {"pbrMetallicRoughness",
                        {{"baseColorFactor", {0.5, 1.0, 1.0, 1.0}}, {"baseColorTexture", {{"index", 0}}}}}}};
  g.j["textures"] = {{{"source", 0}}};
  // 2x2 RGBA PNG: red, green / blue, gray 128.
  g.j["images"] = {{{"uri", "data:image/png;base64,iVBORw0KGgoAAAANSUhEUgAAAAIAAAACCAYAAABytg0kAAAAFUlEQVR42mP4z8"
                            "DwHwyB9P+Ghob/AEVRCHrNY6F/AAAAAElFTkSuQmCC"}}};
  dir.write("t.bin", g.bin);
  Loaded l = load(dir.write("t.gltf", g.gltf("t.bin")));
  ASSERT_TRUE(l.status) << l.status.message();
  ASSERT_EQ(l.mesh.textures.size(), 1u);
  const Texture& t = l.mesh.textures[0];
  ASSERT_EQ(t.width, 2u);
  ASSERT_EQ(t.height, 2u);
  EXPECT_EQ(t.rgba, (std::vector<uint8_t>{255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 128, 128, 128, 255}));
  ASSERT_EQ(l.mesh.materials.size(), 1u);
  EXPECT_EQ(l.mesh.materials[0].base_color_texture, 0);
  expect_vec3(l.mesh.materials[0].base_color, glm::vec3(0.5f, 1.0f, 1.0f));
  // Corner 0 sits on the red texel's centre, corner 1 on green's (top row first).
  expect_vec3(l.mesh.albedo(0, 0, 0), glm::vec3(0.5f, 0, 0), 1e-6f);
  expect_vec3(l.mesh.albedo(0, 1, 0), glm::vec3(0, 1, 0), 1e-6f);
  expect_vec3(l.mesh.albedo(0, 0, 1), glm::vec3(0, 0, 1), 1e-6f);
}

TEST(MeshGltf, MalformedAssetsNameTheProblem) {
  TempDir dir;
  {  // .bin missing next to the .gltf
    GltfBuilder g = triangle_asset(json::object());
    Loaded l = load(dir.write("nobin.gltf", g.gltf("missing_buffer.bin")));
    EXPECT_FALSE(l.status);
    EXPECT_TRUE(contains(l.status.message(), "nobin.gltf")) << l.status.message();
    EXPECT_TRUE(contains(l.status.message(), "missing_buffer.bin")) << l.status.message();
  }
  {  // index out of range
    GltfBuilder g = triangle_asset(json::object());
    g.j["accessors"][2]["bufferView"] = g.view(std::vector<uint16_t>{0, 1, 3}.data(), 6);
    Loaded l = load(dir.write("idx.glb", g.glb()));
    EXPECT_FALSE(l.status);
    EXPECT_TRUE(contains(l.status.message(), "idx.glb: mesh 0 ('tri') primitive 0")) << l.status.message();
    EXPECT_TRUE(contains(l.status.message(), "out of range")) << l.status.message();
  }
  {  // accessor count beyond its bufferView
    GltfBuilder g = triangle_asset(json::object());
    g.j["accessors"][0]["count"] = 4;
    Loaded l = load(dir.write("count.glb", g.glb()));
    EXPECT_FALSE(l.status);
    EXPECT_TRUE(contains(l.status.message(), "POSITION")) << l.status.message();
    EXPECT_TRUE(contains(l.status.message(), "exceed")) << l.status.message();
  }
  {  // bufferView beyond its buffer, via a huge byteOffset
    GltfBuilder g = triangle_asset(json::object());
    g.j["bufferViews"][1]["byteOffset"] = 1u << 30;
    Loaded l = load(dir.write("view.glb", g.glb()));
    EXPECT_FALSE(l.status);
    EXPECT_TRUE(contains(l.status.message(), "NORMAL")) << l.status.message();
  }
  {  // cyclic node hierarchy
    GltfBuilder g = triangle_asset(json::object());
    g.j["nodes"][1]["children"] = {0};
    Loaded l = load(dir.write("cycle.glb", g.glb()));
    EXPECT_FALSE(l.status);
    EXPECT_TRUE(contains(l.status.message(), "cyclic")) << l.status.message();
  }
  {  // truncated GLB
    GltfBuilder g = triangle_asset(json::object());
    std::string glb = g.glb();
    Loaded l = load(dir.write("cut.glb", glb.substr(0, glb.size() - 8)));
    EXPECT_FALSE(l.status);
    EXPECT_TRUE(contains(l.status.message(), "cut.glb")) << l.status.message();
  }
}

// ---------------------------------------------------------------- Mesh queries, hand-computed

Mesh tiny_triangle() {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  m.triangles = {{0, 1, 2}};
  m.triangle_material = {0};
  m.materials = {Material{"m", glm::vec3(0.5f, 1.0f, 1.0f), -1}};
  return m;
}

TEST(MeshQueries, ShadingNormalInterpolatesWithEmbreeBarycentrics) {
  Mesh m = tiny_triangle();
  m.normals = {{0, 0, 1}, {1, 0, 0}, {0, 1, 0}};
  // u = 0.5, v = 0.25: 0.25 n0 + 0.5 n1 + 0.25 n2 = (0.5, 0.25, 0.25).
  expect_vec3(m.shading_normal(0, 0.5f, 0.25f), glm::vec3(0.5f, 0.25f, 0.25f) / std::sqrt(0.375f));
  // Opposite normals cancel at the edge midpoint: falls back to the face normal.
  m.normals = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}};
  expect_vec3(m.shading_normal(0, 0.5f, 0.0f), glm::vec3(0, 0, 1));
  m.normals.clear();
  expect_vec3(m.shading_normal(0, 0.2f, 0.2f), glm::vec3(0, 0, 1));
}

TEST(MeshQueries, AlbedoMultipliesBaseTextureAndVertexColor) {
  Mesh m = tiny_triangle();
  m.colors = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  // (u, v) = (0.2, 0.3): color = 0.5 c0 + 0.2 c1 + 0.3 c2, times base (0.5, 1, 1).
  expect_vec3(m.albedo(0, 0.2f, 0.3f), glm::vec3(0.25f, 0.2f, 0.3f));
  // 1x1 texture of sRGB 128: decoded ((128/255 + 0.055) / 1.055)^2.4.
  const float t128 = static_cast<float>(std::pow((128.0 / 255.0 + 0.055) / 1.055, 2.4));
  m.textures = {Texture{1, 1, {128, 128, 128, 255}, "t"}};
  m.materials[0].base_color_texture = 0;
  m.uvs = {{0, 0}, {1, 0}, {0, 1}};
  expect_vec3(m.albedo(0, 0.2f, 0.3f), glm::vec3(0.25f, 0.2f, 0.3f) * t128);
  m.uvs.clear();  // a texture without uvs is not applied
  expect_vec3(m.albedo(0, 0.2f, 0.3f), glm::vec3(0.25f, 0.2f, 0.3f));
}

TEST(MeshQueries, SurfaceMultipliesFactorsWithTheirTextures) {
  Mesh m = tiny_triangle();
  m.uvs = {{0, 0}, {1, 0}, {0, 1}};
  // Data textures (metallic-roughness, occlusion) are linear; the emission texture is sRGB.
  const float s200 = static_cast<float>(std::pow((200.0 / 255.0 + 0.055) / 1.055, 2.4));
  m.textures = {Texture{1, 1, {0, 51, 204, 255}, "t"},     // roughness G = 0.2, metallic B = 0.8
                Texture{1, 1, {200, 200, 0, 255}, "t"},    // emission (sRGB)
                Texture{1, 1, {102, 0, 0, 255}, "t"}};     // occlusion R = 0.4
  Material& mat = m.materials[0];
  mat.metallic = 0.5f;
  mat.roughness = 0.75f;
  mat.emission = glm::vec3(2.0f, 4.0f, 1.0f);
  mat.occlusion_strength = 0.5f;
  SurfaceSample f = m.surface(0, 0.2f, 0.3f);  // factors only
  EXPECT_FLOAT_EQ(f.metallic, 0.5f);
  EXPECT_FLOAT_EQ(f.roughness, 0.75f);
  EXPECT_FLOAT_EQ(f.ambient_occlusion, 1.0f);
  expect_vec3(f.emission, glm::vec3(2.0f, 4.0f, 1.0f));
  expect_vec3(f.albedo, m.albedo(0, 0.2f, 0.3f));
  EXPECT_FALSE(mat.has_surface_textures());
  mat.metallic_roughness_texture = 0;
  mat.emission_texture = 1;
  mat.occlusion_texture = 2;
  EXPECT_TRUE(mat.has_surface_textures());
  SurfaceSample t = m.surface(0, 0.2f, 0.3f);
  EXPECT_NEAR(t.metallic, 0.5f * 0.8f, 1e-6f);
  EXPECT_NEAR(t.roughness, 0.75f * 0.2f, 1e-6f);
  EXPECT_NEAR(t.ambient_occlusion, 1.0f + 0.5f * (0.4f - 1.0f), 1e-6f);  // 1 + strength (R - 1)
  expect_vec3(t.emission, glm::vec3(2.0f * s200, 4.0f * s200, 0.0f), 1e-6f);
  EXPECT_FLOAT_EQ(m.max_emission(), 4.0f);
  m.uvs.clear();  // textures without uvs are not applied
  EXPECT_FLOAT_EQ(m.surface(0, 0.2f, 0.3f).metallic, 0.5f);
}

TEST(MeshQueries, NormalMapTiltsTheNormalInTheUvTangentFrame) {
  // A triangle in the xy plane facing +z, u along +x and v along +y: tangent +x, bitangent +y.
  const glm::vec3 p[3] = {{0, 0, 0}, {2, 0, 0}, {0, 2, 0}};
  const glm::vec2 uv[3] = {{0, 0}, {1, 0}, {0, 1}};
  const glm::vec3 n(0, 0, 1);
  const glm::vec3 tilt_u(0.75f, 0.5f, 0.5f + 0.5f * std::sqrt(0.75f));  // (0.5, 0, 0.866) in tangent space
  expect_vec3(normal_mapped_shading_normal(n, p, uv, tilt_u, 1.0f), glm::vec3(0.5f, 0.0f, std::sqrt(0.75f)), 1e-5f);
  // The scale multiplies the tangent-space x and y (glTF normalTexture.scale).
  const glm::vec3 scaled = glm::normalize(glm::vec3(0.25f, 0.0f, std::sqrt(0.75f)));
  expect_vec3(normal_mapped_shading_normal(n, p, uv, tilt_u, 0.5f), scaled, 1e-5f);
  // Tilt along v goes to +y; u running along -x flips the tangent; a flat texel keeps the normal.
  const glm::vec3 tilt_v(0.5f, 0.75f, 0.5f + 0.5f * std::sqrt(0.75f));
  expect_vec3(normal_mapped_shading_normal(n, p, uv, tilt_v, 1.0f), glm::vec3(0.0f, 0.5f, std::sqrt(0.75f)), 1e-5f);
  const glm::vec2 mirrored[3] = {{1, 0}, {0, 0}, {1, 1}};
  expect_vec3(normal_mapped_shading_normal(n, p, mirrored, tilt_u, 1.0f), glm::vec3(-0.5f, 0.0f, std::sqrt(0.75f)), 1e-5f);
  expect_vec3(normal_mapped_shading_normal(n, p, uv, glm::vec3(0.5f, 0.5f, 1.0f), 1.0f), n, 1e-6f);
  // A degenerate uv map, or a texel pointing below the surface, keeps n.
  const glm::vec2 degenerate[3] = {{0, 0}, {1, 1}, {2, 2}};
  expect_vec3(normal_mapped_shading_normal(n, p, degenerate, tilt_u, 1.0f), n);
  expect_vec3(normal_mapped_shading_normal(n, p, uv, glm::vec3(0.5f, 0.5f, 0.0f), 1.0f), n);
  // Through Mesh::surface: the material's normal texture at the hit's uv.
  Mesh m = tiny_triangle();
  m.uvs = {{0, 0}, {1, 0}, {0, 1}};
  m.textures = {Texture{1, 1, {191, 128, 238, 255}, "t"}};
  m.materials[0].normal_texture = 0;
  const glm::vec3 texel(191 / 255.0f, 128 / 255.0f, 238 / 255.0f);
  const glm::vec3 q[3] = {m.positions[0], m.positions[1], m.positions[2]};
  expect_vec3(m.surface(0, 0.2f, 0.3f).normal, normal_mapped_shading_normal(m.shading_normal(0, 0.2f, 0.3f), q, uv, texel, 1.0f),
              1e-6f);
  EXPECT_GT(m.surface(0, 0.2f, 0.3f).normal.x, 0.4f);
}

TEST(MeshQueries, TextureSampleIsBilinearRepeatAndSrgbDecoded) {
  Texture t{2, 1, {0, 0, 0, 255, 255, 255, 255, 255}, "t"};  // black, white
  expect_vec3(t.sample({0.25f, 0.5f}), glm::vec3(0.0f));    // centre of texel 0
  expect_vec3(t.sample({0.75f, 0.5f}), glm::vec3(1.0f));    // centre of texel 1
  expect_vec3(t.sample({0.5f, 0.5f}), glm::vec3(0.5f));     // halfway in linear space
  expect_vec3(t.sample({0.0f, 0.5f}), glm::vec3(0.5f));     // wraps to texel 1 on the left
  expect_vec3(t.sample({1.25f, -3.5f}), glm::vec3(0.0f));   // repeat in u and v
  expect_vec3(t.sample({0.375f, 0.5f}), glm::vec3(0.25f));  // a quarter of the way
  Texture g{1, 1, {188, 188, 188, 255}, "g"};
  expect_vec3(g.sample({0.3f, 0.9f}), glm::vec3(std::pow((188.0f / 255.0f + 0.055f) / 1.055f, 2.4f)), 1e-6f);
  expect_vec3(g.sample({0.3f, 0.9f}, false), glm::vec3(188.0f / 255.0f), 1e-6f);  // data: not decoded
  Texture empty;
  expect_vec3(empty.sample({0.5f, 0.5f}), glm::vec3(1.0f));
}

TEST(MeshQueries, VertexNormalsAreAreaWeighted) {
  Mesh m;
  // Shared vertex 0: triangle A (area 2, +z), triangle B (area 0.5, +x). Sum (1, 0, 4).
  m.positions = {{0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {0, 1, 0}, {0, 0, 1}};
  m.triangles = {{0, 1, 2}, {0, 3, 4}};
  compute_vertex_normals(m);
  expect_vec3(m.normals[0], glm::vec3(1, 0, 4) / std::sqrt(17.0f));
  expect_vec3(m.normals[1], glm::vec3(0, 0, 1));
  expect_vec3(m.normals[4], glm::vec3(1, 0, 0));
}

TEST(MeshQueries, FinalizeFixesOnlyBadNormalsAndPadsMaterials) {
  Mesh m = tiny_triangle();
  m.materials.clear();
  m.triangle_material.clear();
  m.normals = {{0, 0, 1}, {NAN, 0, 0}, {0, 0, 0}};
  m.uvs = {{0, 0}};  // wrong size: dropped
  MeshImportReport r;
  ASSERT_TRUE(finalize_mesh(m, &r, "tiny"));
  EXPECT_EQ(r.fixed_normals, 2u);
  expect_vec3(m.normals[1], glm::vec3(0, 0, 1));
  expect_vec3(m.normals[2], glm::vec3(0, 0, 1));
  ASSERT_EQ(m.materials.size(), 1u);
  EXPECT_EQ(m.materials[0].name, "default");
  expect_vec3(m.materials[0].base_color, glm::vec3(1.0f));
  EXPECT_EQ(m.triangle_material, std::vector<uint32_t>{0});
  EXPECT_TRUE(m.uvs.empty());
  EXPECT_TRUE(any_warning(r, "texture coordinates"));
  EXPECT_TRUE(any_warning(r, "normals"));
}

// A vertex no triangle uses is removed with its normal; the given normals of the others stay (not
// recomputed as if their count were wrong).
TEST(MeshQueries, FinalizeKeepsGivenNormalsWhenAnUnusedVertexGoes) {
  Mesh m = tiny_triangle();
  m.positions.push_back({5, 5, 5});  // used by no triangle
  const glm::vec3 tilted = glm::normalize(glm::vec3(0.3f, 0.0f, 1.0f));
  m.normals = {tilted, tilted, tilted, {0, 1, 0}};
  MeshImportReport r;
  ASSERT_TRUE(finalize_mesh(m, &r, "tiny"));
  ASSERT_EQ(m.positions.size(), 3u);
  ASSERT_EQ(m.normals.size(), 3u);
  for (const glm::vec3& n : m.normals) expect_vec3(n, tilted);  // the face normal would be (0, 0, 1)
  EXPECT_EQ(r.fixed_normals, 0u);
  EXPECT_FALSE(any_warning(r, "normals"));
  // A normal array of the wrong length is still replaced as a whole.
  Mesh w = tiny_triangle();
  w.positions.push_back({5, 5, 5});
  w.normals = {tilted, tilted, tilted};
  ASSERT_TRUE(finalize_mesh(w, &r, "tiny"));
  EXPECT_TRUE(any_warning(r, "3 normals for 4 vertices; recomputed all"));
  expect_vec3(w.normals[0], glm::vec3(0, 0, 1));
}

// ---------------------------------------------------------------- real meshes

struct OffTruth {
  Aabb box;
  size_t vertices = 0, triangles = 0;
};

// Independent reader: stream extraction over the plain OFF layout of the test meshes.
OffTruth read_off_truth(const std::string& path) {
  std::ifstream in(path);
  std::string magic;
  size_t nv = 0, nf = 0, ne = 0;
  in >> magic >> nv >> nf >> ne;
  OffTruth t;
  t.vertices = nv;
  for (size_t i = 0; i < nv; ++i) {
    glm::vec3 p;
    in >> p.x >> p.y >> p.z;
    t.box.grow(p);
  }
  for (size_t f = 0; f < nf; ++f) {
    size_t n = 0;
    in >> n;
    for (size_t k = 0; k < n; ++k) {
      size_t idx;
      in >> idx;
    }
    t.triangles += n >= 3 ? n - 2 : 0;
  }
  return t;
}

TEST(MeshReal, OffMeshesMatchBruteForce) {
  const std::string dir = kDataDir + "/meshes";
  if (!fs::exists(dir + "/bunny00.off")) GTEST_SKIP() << "test meshes not found in " << dir;
  const std::map<std::string, size_t> expected = {
      {"bunny00.off", 75408}, {"armadillo.off", 52000}, {"ChineseDragon-10kv.off", 19994}};
  for (const auto& [file, faces] : expected) {
    const std::string path = dir + "/" + file;
    if (!fs::exists(path)) continue;
    auto t0 = std::chrono::steady_clock::now();
    Loaded l = load(path);
    double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    ASSERT_TRUE(l.status) << l.status.message();
    OffTruth truth = read_off_truth(path);
    EXPECT_EQ(truth.triangles, faces) << file;
    EXPECT_EQ(l.mesh.triangles.size(), faces) << file;
    EXPECT_EQ(l.mesh.positions.size(), truth.vertices) << file;
    EXPECT_EQ(l.report.dropped_degenerate + l.report.dropped_invalid, 0u) << file;
    Aabb b = l.mesh.bounds();
    EXPECT_TRUE(finite_box(b)) << file;
    const float tol = 1e-6f * truth.box.diagonal();
    expect_vec3(b.lo, truth.box.lo, tol);
    expect_vec3(b.hi, truth.box.hi, tol);
    EXPECT_EQ(l.mesh.normals.size(), l.mesh.positions.size());
    std::printf("[ info ] %s: %zu triangles in %.3f s\n", file.c_str(), l.mesh.triangles.size(), seconds);
#if defined(NDEBUG) && !defined(__SANITIZE_ADDRESS__)
    if (file == "bunny00.off") {
      EXPECT_LT(seconds, 0.3) << "bunny import too slow";
    }
#endif
  }
}

std::string gltf_dir() { return kDataDir + "/gltf"; }

TEST(MeshReal, BoxTexturedGltfAndGlb) {
  const std::string a = gltf_dir() + "/BoxTextured-glTF/BoxTextured.gltf";
  const std::string b = gltf_dir() + "/BoxTextured-glTF-Binary/BoxTextured.glb";
  if (!fs::exists(a) || !fs::exists(b)) GTEST_SKIP() << "BoxTextured not found in " << gltf_dir();
  Loaded ga = load(a), gb = load(b);
  ASSERT_TRUE(ga.status) << ga.status.message();
  ASSERT_TRUE(gb.status) << gb.status.message();
  for (const Loaded* l : {&ga, &gb}) {
    const Mesh& m = l->mesh;
    EXPECT_EQ(m.triangles.size(), 12u);
    ASSERT_EQ(m.textures.size(), 1u);
    EXPECT_GT(m.textures[0].width, 0u);
    EXPECT_EQ(m.textures[0].rgba.size(), size_t(m.textures[0].width) * m.textures[0].height * 4);
    EXPECT_EQ(m.uvs.size(), m.positions.size());
    ASSERT_EQ(m.materials.size(), 1u);
    EXPECT_EQ(m.materials[0].base_color_texture, 0);
    Aabb box = m.bounds();
    expect_vec3(box.lo, glm::vec3(-0.5f), 1e-6f);
    expect_vec3(box.hi, glm::vec3(0.5f), 1e-6f);
    // The albedo follows the texture: at each corner of every triangle it equals the decoded
    // texel under that corner's uv (computed here from the raw bytes), and it is not constant.
    std::set<std::vector<float>> seen;
    for (uint32_t t = 0; t < m.triangles.size(); ++t) {
      for (int c = 0; c < 3; ++c) {
        float u = c == 1 ? 1.0f : 0.0f, v = c == 2 ? 1.0f : 0.0f;
        glm::vec3 al = m.albedo(t, u, v);
        seen.insert({al.x, al.y, al.z});
      }
      glm::vec3 mid = m.albedo(t, 0.3f, 0.3f);
      seen.insert({mid.x, mid.y, mid.z});
    }
    EXPECT_GT(seen.size(), 3u) << "albedo should vary with the texture coordinates";
  }
  EXPECT_EQ(ga.mesh.positions, gb.mesh.positions);
  EXPECT_EQ(ga.mesh.textures[0].rgba, gb.mesh.textures[0].rgba);
}

TEST(MeshReal, BoxTexturedAlbedoMatchesTexelAtUv) {
  const std::string a = gltf_dir() + "/BoxTextured-glTF/BoxTextured.gltf";
  if (!fs::exists(a)) GTEST_SKIP() << "BoxTextured not found in " << gltf_dir();
  Loaded l = load(a);
  ASSERT_TRUE(l.status) << l.status.message();
  const Mesh& m = l.mesh;
  const Texture& tex = m.textures[0];
  auto decode = [](uint8_t c) { double x = c / 255.0; return float(x <= 0.04045 ? x / 12.92 : std::pow((x + 0.055) / 1.055, 2.4)); };
  // Find a hit point whose interpolated uv lands on a texel centre, by construction: take each
  // triangle's centroid uv, snap to the nearest texel centre, and solve for the barycentrics.
  int checked = 0;
  for (uint32_t t = 0; t < m.triangles.size() && checked < 6; ++t) {
    const glm::uvec3 tri = m.triangles[t];
    glm::vec2 a0 = m.uvs[tri.x], a1 = m.uvs[tri.y], a2 = m.uvs[tri.z];
    glm::vec2 c = (a0 + a1 + a2) / 3.0f;
    glm::vec2 texel = glm::floor(c * glm::vec2(tex.width, tex.height));
    glm::vec2 target = (texel + 0.5f) / glm::vec2(tex.width, tex.height);
    // target = a0 + u (a1 - a0) + v (a2 - a0)
    glm::mat2 e(a1 - a0, a2 - a0);
    if (std::abs(glm::determinant(e)) < 1e-8f) continue;
    glm::vec2 uv = glm::inverse(e) * (target - a0);
    if (uv.x < 0 || uv.y < 0 || uv.x + uv.y > 1) continue;
    uint32_t tx = uint32_t(texel.x) % tex.width, ty = uint32_t(texel.y) % tex.height;
    size_t o = (size_t(ty) * tex.width + tx) * 4;
    glm::vec3 expected = m.materials[0].base_color *
                         glm::vec3(decode(tex.rgba[o]), decode(tex.rgba[o + 1]), decode(tex.rgba[o + 2]));
    expect_vec3(m.albedo(t, uv.x, uv.y), expected, 2e-3f);
    ++checked;
  }
  EXPECT_GT(checked, 0);
}

// Independent flattening of a GLB: own chunk parsing, own node recursion with plain 4x4 double
// matrices (column-major as stored), own float reads of POSITION.
struct GlbTruth {
  Aabb box;
  size_t triangles = 0;
};

GlbTruth brute_force_glb(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  uint32_t json_len;
  std::memcpy(&json_len, data.data() + 12, 4);
  json j = json::parse(data.substr(20, json_len));
  const char* bin = data.data() + 20 + json_len + 8;
  using M = std::array<double, 16>;
  auto mul = [](const M& a, const M& b) {
    M r{};
    for (int c = 0; c < 4; ++c)
      for (int rr = 0; rr < 4; ++rr)
        for (int k = 0; k < 4; ++k) r[size_t(c * 4 + rr)] += a[size_t(k * 4 + rr)] * b[size_t(c * 4 + k)];
    return r;
  };
  GlbTruth truth;
  std::function<void(int, const M&)> visit = [&](int n, const M& parent) {
    const json& node = j["nodes"][size_t(n)];
    M local{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    if (node.contains("matrix"))
      for (size_t i = 0; i < 16; ++i) local[i] = node["matrix"][i].get<double>();
    EXPECT_FALSE(node.contains("rotation") || node.contains("scale") || node.contains("translation"));
    M world = mul(parent, local);
    if (node.contains("mesh")) {
      for (const json& prim : j["meshes"][node["mesh"].get<size_t>()]["primitives"]) {
        const json& acc = j["accessors"][prim["attributes"]["POSITION"].get<size_t>()];
        const json& view = j["bufferViews"][acc["bufferView"].get<size_t>()];
        EXPECT_EQ(acc["componentType"].get<int>(), 5126);
        size_t stride = view.value("byteStride", size_t(12));
        size_t base = view.value("byteOffset", size_t(0)) + acc.value("byteOffset", size_t(0));
        for (size_t i = 0; i < acc["count"].get<size_t>(); ++i) {
          float p[3];
          std::memcpy(p, bin + base + i * stride, 12);
          glm::vec3 q;
          for (int r = 0; r < 3; ++r)
            q[r] = float(world[size_t(r)] * p[0] + world[size_t(4 + r)] * p[1] + world[size_t(8 + r)] * p[2] +
                         world[size_t(12 + r)]);
          truth.box.grow(q);
        }
        truth.triangles += j["accessors"][prim["indices"].get<size_t>()]["count"].get<size_t>() / 3;
      }
    }
    if (node.contains("children"))
      for (const json& c : node["children"]) visit(c.get<int>(), world);
  };
  const M identity{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  for (const json& r : j["scenes"][j.value("scene", 0)]["nodes"]) visit(r.get<int>(), identity);
  return truth;
}

TEST(MeshReal, CylinderEngineFlattensNodeTransforms) {
  const std::string path = gltf_dir() + "/2CylinderEngine-glTF-Binary/2CylinderEngine.glb";
  if (!fs::exists(path)) GTEST_SKIP() << "2CylinderEngine not found in " << gltf_dir();
  Loaded l = load(path);
  ASSERT_TRUE(l.status) << l.status.message();
  GlbTruth truth = brute_force_glb(path);
  EXPECT_EQ(l.mesh.triangles.size() + l.report.dropped_degenerate + l.report.dropped_invalid, truth.triangles);
  Aabb b = l.mesh.bounds();
  ASSERT_TRUE(finite_box(b));
  const float tol = 1e-5f * truth.box.diagonal();
  expect_vec3(b.lo, truth.box.lo, tol);
  expect_vec3(b.hi, truth.box.hi, tol);
}

TEST(MeshReal, PrimitiveModesAndBrokenAssets) {
  const std::string dir = gltf_dir() + "/glTF-Asset-Generator/Mesh_PrimitiveMode";
  if (!fs::exists(dir)) GTEST_SKIP() << "Mesh_PrimitiveMode not found in " << gltf_dir();
  // Triangle modes: the same unit square as two triangles, all facing the same way.
  for (int i : {4, 5, 6, 11, 12, 13, 14, 15}) {
    char name[64];
    std::snprintf(name, sizeof(name), "/Mesh_PrimitiveMode_%02d.gltf", i);
    Loaded l = load(dir + name);
    ASSERT_TRUE(l.status) << name << ": " << l.status.message();
    ASSERT_EQ(l.mesh.triangles.size(), 2u) << name;
    float area = 0.0f;
    glm::vec3 first(0.0f);
    for (const glm::uvec3& t : l.mesh.triangles) {
      glm::vec3 n = glm::cross(l.mesh.positions[t.y] - l.mesh.positions[t.x],
                               l.mesh.positions[t.z] - l.mesh.positions[t.x]);
      area += 0.5f * glm::length(n);
      if (first == glm::vec3(0.0f)) first = n;
      EXPECT_GT(glm::dot(n, first), 0.0f) << name;
    }
    EXPECT_NEAR(area, 1.0f, 1e-5f) << name;
  }
  // Point and line modes: an error that says why, after a warning per primitive.
  for (int i : {0, 1, 2, 3, 7, 8, 9, 10}) {
    char name[64];
    std::snprintf(name, sizeof(name), "/Mesh_PrimitiveMode_%02d.gltf", i);
    Loaded l = load(dir + name);
    EXPECT_FALSE(l.status) << name;
    EXPECT_TRUE(contains(l.status.message(), "no triangle primitives")) << l.status.message();
    EXPECT_TRUE(any_warning(l.report, "not triangles")) << name;
  }
  const std::map<std::string, std::string> broken = {
      {"/MissingBin/BoxTextured.gltf", "BoxTextured0.bin"},
      {"/IndexOutOfRange/IndexOutOfRange.gltf", "out of range"},
      {"/IndexOutOfRange/AllIndicesOutOfRange.gltf", "out of range"},
      {"/RecursiveNodes/RecursiveNodes.gltf", "cyclic"},
      {"/draco/2CylinderEngine.gltf", "KHR_draco_mesh_compression"},
  };
  for (const auto& [file, why] : broken) {
    if (!fs::exists(gltf_dir() + file)) continue;
    Loaded l = load(gltf_dir() + file);
    EXPECT_FALSE(l.status) << file;
    EXPECT_TRUE(contains(l.status.message(), why)) << file << ": " << l.status.message();
  }
  // Infinite positions in every vertex: all 12 triangles invalid, which is an error.
  const std::string inf = gltf_dir() + "/BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb";
  if (fs::exists(inf)) {
    Loaded l = load(inf);
    EXPECT_FALSE(l.status);
    EXPECT_TRUE(contains(l.status.message(), "no valid triangles (0 degenerate, 12 invalid)"))
        << l.status.message();
    EXPECT_EQ(l.report.dropped_invalid, 12u);
  }
}

}  // namespace
}  // namespace lsnif
