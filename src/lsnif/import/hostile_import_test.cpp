// hostile_import_test.cpp -- the importer against inputs built to hurt it: JSON nested past the
// bound (.gltf and the JSON chunk of a .glb, in a mesh and through the sidecar parser), files
// referenced from outside the mesh's folder (glTF buffers and images, OBJ mtllib; `..`, absolute
// paths, percent-encoded dots, the working folder fallback), and triangle clean-up judged per
// triangle (a stray far triangle, a mesh scaled to 1e-30, most of a mesh degenerate, an unused NaN
// vertex, dirty material names).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "lsnif/testing/fuzz_support.h"
#include "lsnif/import/gltf_access.h"
#include "lsnif/import/json_text.h"
#include "lsnif/import/mesh.h"
#include "lsnif/format/model_format.h"
#include "lsnif/import/resolve_path.h"

#include <nlohmann/json.hpp>

namespace lsnif {
namespace {

namespace fs = std::filesystem;

class TempDir {
 public:
  TempDir() {
    path_ = fs::temp_directory_path() / ("lsnif_hostile_import_" + std::to_string(::getpid()) + "_" +
                                         ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(path_);
    fs::create_directories(path_ / "scene");
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  // Writes `bytes` to `name` (relative to the folder) and returns its path.
  std::string write(const std::string& name, const std::string& bytes) const {
    const fs::path p = path_ / name;
    fs::create_directories(p.parent_path());
    std::ofstream(p, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
    return p.string();
  }
  std::string path(const std::string& name) const { return (path_ / name).string(); }

 private:
  fs::path path_;
};

bool contains(const std::string& s, const std::string& what) { return s.find(what) != std::string::npos; }

std::string nested(size_t depth) { return std::string(depth, '[') + std::string(depth, ']'); }

// A one-triangle glTF whose positions buffer is at `uri`, and the 36 bytes it needs.
std::string triangle_gltf(const std::string& uri, const std::string& extras = "null") {
  return R"({"asset":{"version":"2.0"},"extras":)" + extras +
         R"(,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}],
"bufferViews":[{"buffer":0,"byteLength":36}],"buffers":[{"uri":")" +
         uri + R"(","byteLength":36}]})";
}
std::string triangle_bytes() { return fuzz::put_floats({0, 0, 0, 1, 0, 0, 0, 1, 0}); }

TEST(JsonDepth, BoundCountsBracketsOutsideStringsOnly) {
  EXPECT_TRUE(json::check_depth(nested(json::kMaxDepth), "x"));
  Status s = json::check_depth(nested(json::kMaxDepth + 1), "x.gltf");
  ASSERT_FALSE(s);
  EXPECT_TRUE(contains(s.message(), "x.gltf: JSON nested deeper than 128 levels (at byte 128)")) << s.message();
  // Brackets inside strings, also after escaped quotes, are text.
  const std::string in_string = "{\"a\":\"" + std::string(5000, '[') + "\\\"" + std::string(5000, '{') + "\"}";
  EXPECT_TRUE(json::check_depth(in_string, "x"));
  EXPECT_TRUE(json::check_depth("[]]]]]]" + nested(100), "x"));  // stray closers do not go negative
  nlohmann::json j;
  EXPECT_FALSE(json::parse(nested(20000), "deep.json", j));
  s = json::parse("{\"a\": [1, 2", "broken.json", j);
  ASSERT_FALSE(s);
  EXPECT_TRUE(contains(s.message(), "broken.json: not valid JSON")) << s.message();
  ASSERT_TRUE(json::parse("{\"a\": [1, 2]}", "ok.json", j));
  EXPECT_EQ(j["a"][1], 2);
}

// The crash of the issue: 20,000 levels in "extras" of a .gltf and of a .glb's JSON chunk.
TEST(JsonDepth, DeepGltfAndGlbAreRefusedBeforeParsing) {
  TempDir dir;
  dir.write("scene/tri.bin", triangle_bytes());
  for (size_t depth : {size_t(200), size_t(20000), size_t(100000)}) {
    const std::string text = triangle_gltf("tri.bin", nested(depth));
    for (const bool binary : {false, true}) {
      const std::string path = dir.write(binary ? "scene/deep.glb" : "scene/deep.gltf",
                                         binary ? fuzz::glb(text, "") : text);
      Mesh mesh;
      Status s = load_mesh(path, mesh);
      ASSERT_FALSE(s) << depth;
      EXPECT_TRUE(contains(s.message(), "JSON nested deeper than 128 levels")) << s.message();
    }
  }
  // Just under the bound loads (extras are ignored by the importer).
  Mesh mesh;
  Status s = load_mesh(dir.write("scene/ok.gltf", triangle_gltf("tri.bin", nested(json::kMaxDepth - 2))), mesh);
  ASSERT_TRUE(s) << s.message();
  EXPECT_EQ(mesh.triangles.size(), 1u);
}

TEST(ReferencePolicy, ResolvesInsideRefusesEscapesUnlessAllowed) {
  std::string out;
  ASSERT_TRUE(resolve_reference("scenes/a", "tex/x.png", false, "image", out));
  EXPECT_EQ(out, "scenes/a/tex/x.png");
  ASSERT_TRUE(resolve_reference("scenes/a", "tex/../y.png", false, "image", out));
  EXPECT_EQ(out, "scenes/a/y.png");
  ASSERT_TRUE(resolve_reference("", "m.lsnif", false, "model", out));
  EXPECT_EQ(out, "m.lsnif");
  for (const char* bad : {"../x.bin", "a/../../x.bin", "../../../../etc/passwd", "/etc/passwd", "./../x"}) {
    Status s = resolve_reference("scenes/a", bad, false, "buffer URI", out);
    ASSERT_FALSE(s) << bad;
    EXPECT_TRUE(contains(s.message(), std::string("buffer URI '") + bad + "' refers to a file outside the folder "
                                                                          "'scenes/a'")) << s.message();
    EXPECT_TRUE(contains(s.message(), "--allow-outside-refs")) << s.message();
    EXPECT_TRUE(resolve_reference("scenes/a", bad, true, "buffer URI", out)) << bad;
  }
  ASSERT_TRUE(resolve_reference("scenes/a", "../x.bin", true, "uri", out));
  EXPECT_EQ(out, "scenes/x.bin");
  EXPECT_FALSE(resolve_reference("scenes/a", "", true, "uri", out));
  EXPECT_FALSE(resolve_reference("scenes/a", std::string("a\0b", 3), true, "uri", out));
}

TEST(ReferencePolicy, GltfBuffersAndImagesStayInTheFolder) {
  TempDir dir;
  dir.write("outside.bin", triangle_bytes());
  dir.write("scene/inside.bin", triangle_bytes());
  for (const std::string& uri : {std::string("../outside.bin"), std::string("%2E%2E/outside.bin"),
                                dir.path("outside.bin")}) {
    const std::string path = dir.write("scene/m.gltf", triangle_gltf(uri));
    Mesh mesh;
    Status s = load_mesh(path, mesh);
    ASSERT_FALSE(s) << uri;
    EXPECT_TRUE(contains(s.message(), "outside the folder")) << s.message();
    MeshImportOptions allow;
    allow.allow_outside_refs = true;
    s = load_mesh(path, mesh, nullptr, allow);
    ASSERT_TRUE(s) << uri << ": " << s.message();
    EXPECT_EQ(mesh.triangles.size(), 1u);
  }
  // An image outside is an error too (tinygltf alone would only warn and drop it).
  std::string text = triangle_gltf("inside.bin");
  text.insert(text.size() - 1, R"(,"images":[{"uri":"../tex.png"}])");
  dir.write("tex.png", fuzz::png_bytes());
  Mesh mesh;
  Status s = load_mesh(dir.write("scene/img.gltf", text), mesh);
  ASSERT_FALSE(s);
  EXPECT_TRUE(contains(s.message(), "'../tex.png' refers to a file outside")) << s.message();
  // tinygltf would also look for a missing file in the working folder: never.
  const fs::path cwd = fs::current_path();
  fs::current_path(dir.path(""));
  dir.write("cwd_only.bin", triangle_bytes());
  s = load_mesh(dir.write("scene/cwd.gltf", triangle_gltf("cwd_only.bin")), mesh);
  fs::current_path(cwd);
  ASSERT_FALSE(s);
  EXPECT_TRUE(contains(s.message(), "cwd_only.bin")) << s.message();
}

TEST(ReferencePolicy, ObjMtllibStaysInTheFolder) {
  TempDir dir;
  dir.write("outside.mtl", "newmtl red\nKd 1 0 0\n");
  dir.write("scene/inside.mtl", "newmtl red\nKd 0 1 0\n");
  const std::string obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n";
  Mesh mesh;
  ASSERT_TRUE(load_mesh(dir.write("scene/in.obj", "mtllib inside.mtl\n" + obj), mesh));
  EXPECT_EQ(mesh.materials[0].base_color, glm::vec3(0, 1, 0));
  for (const std::string& lib : {std::string("../outside.mtl"), dir.path("outside.mtl"), std::string("/etc/passwd")}) {
    Status s = load_mesh(dir.write("scene/out.obj", "mtllib " + lib + "\n" + obj), mesh);
    ASSERT_FALSE(s) << lib;
    EXPECT_TRUE(contains(s.message(), "mtllib '" + lib + "' refers to a file outside the folder")) << s.message();
  }
  MeshImportOptions allow;
  allow.allow_outside_refs = true;
  ASSERT_TRUE(load_mesh(dir.write("scene/out.obj", "mtllib ../outside.mtl\n" + obj), mesh, nullptr, allow));
  EXPECT_EQ(mesh.materials[0].base_color, glm::vec3(1, 0, 0));
}

// An OFF grid of n x n quads (2 n^2 triangles) in [0, 1]^2 scaled by `scale`, plus `extra` text
// appended to the vertex and face lists.
std::string off_grid(int n, double scale, const std::string& extra_vertices = "", int extra_vertex_count = 0,
                     const std::string& extra_faces = "", int extra_face_count = 0) {
  std::string v, f;
  for (int y = 0; y <= n; ++y)
    for (int x = 0; x <= n; ++x) v += format("%.17g %.17g 0\n", scale * x / n, scale * y / n);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const int a = y * (n + 1) + x, b = a + 1, c = a + n + 1, d = c + 1;
      f += format("3 %d %d %d\n3 %d %d %d\n", a, b, d, a, d, c);
    }
  const int nv = (n + 1) * (n + 1) + extra_vertex_count, nf = 2 * n * n + extra_face_count;
  return format("OFF\n%d %d 0\n", nv, nf) + v + extra_vertices + f + extra_faces;
}

// A buffer's data URI must decode to its byteLength: a mismatch is named with both sizes (tinygltf
// said "Failed to decode 'uri' : " and quoted the whole URI, megabytes of it), a URI of no base64
// says so, and tinygltf's own long messages come back escaped and shortened.
TEST(DataUri, WrongLengthsAreNamedAndLongMessagesShortened) {
  TempDir dir;
  const std::string prefix = "data:application/octet-stream;base64,";
  Mesh mesh;
  Status s = load_mesh(dir.write("scene/ok.gltf", triangle_gltf(prefix + fuzz::base64(triangle_bytes()))), mesh);
  ASSERT_TRUE(s) << s.message();
  EXPECT_EQ(mesh.triangles.size(), 1u);
  for (const size_t bytes : {size_t(35), size_t(40), size_t(3) << 20}) {
    SCOPED_TRACE(bytes);
    const std::string uri = prefix + fuzz::base64(std::string(bytes, '\x01'));
    s = load_mesh(dir.write("scene/len.gltf", triangle_gltf(uri)), mesh);
    ASSERT_FALSE(s);
    EXPECT_TRUE(contains(s.message(), "buffer 0: data URI holds " + std::to_string(bytes) + " bytes, byteLength says 36"))
        << s.message().substr(0, 300);
    EXPECT_LT(s.message().size(), 300u);
  }
  s = load_mesh(dir.write("scene/none.gltf", triangle_gltf(prefix + "!!!!")), mesh);
  ASSERT_FALSE(s);
  EXPECT_TRUE(contains(s.message(), "buffer 0: data URI holds no base64 data")) << s.message();
  // tinygltf's text, whatever it quotes: one line, escaped, at most about the limit.
  const std::string quoted = "Failed to decode 'uri' : " + prefix + std::string(1 << 20, 'A') + "\x1b[2J in Buffer\n";
  const std::string trimmed = gltf::trim_message(quoted, 600);
  EXPECT_LT(trimmed.size(), 700u);
  EXPECT_TRUE(contains(trimmed, "Failed to decode 'uri' : " + prefix)) << trimmed;
  EXPECT_TRUE(contains(trimmed, "\\x1b[2J in Buffer")) << trimmed;
  EXPECT_EQ(trimmed.find('\x1b'), std::string::npos);
  EXPECT_EQ(gltf::trim_message("two\nlines\n"), "two;lines");
}

// A glTF that uses every kind of index and enum core glTF has (scene, nodes and children, mesh,
// camera, attributes, indices, material, mode, accessor and buffer views, component types, texture,
// image, sampler and its enums, texCoord, KHR_texture_transform's texCoord), on one triangle; the
// image lies in a bufferView, which loading leaves undecoded.
nlohmann::json indexed_gltf() {
  const std::string bytes = fuzz::put_floats({0, 0, 0, 1, 0, 0, 0, 1, 0}) + fuzz::put_floats({0, 0, 1, 0, 0, 1, 0, 0, 1}) +
                            fuzz::put_floats({0, 0, 1, 0, 0, 1}) + std::string("\x00\x00\x01\x00\x02\x00\x00\x00", 8) +
                            std::string(16, '\x00');
  nlohmann::json j = nlohmann::json::parse(R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0,1]}],
"extensionsUsed":["KHR_texture_transform"],
"nodes":[{"mesh":0,"children":[2]},{"camera":0},{"name":"child"}],
"cameras":[{"type":"perspective","perspective":{"yfov":0.8,"znear":0.01}}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0,"NORMAL":1,"TEXCOORD_0":2},"indices":3,"material":0,"mode":4}]}],
"materials":[{"pbrMetallicRoughness":{"baseColorTexture":{"index":0,"texCoord":0,
  "extensions":{"KHR_texture_transform":{"texCoord":0}}}},"normalTexture":{"index":0}}],
"textures":[{"source":0,"sampler":0}],"images":[{"bufferView":4,"mimeType":"image/png"}],
"samplers":[{"magFilter":9729,"minFilter":9987,"wrapS":10497,"wrapT":33071}],
"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
 {"bufferView":1,"componentType":5126,"count":3,"type":"VEC3"},
 {"bufferView":2,"componentType":5126,"count":3,"type":"VEC2"},
 {"bufferView":3,"componentType":5123,"count":3,"type":"SCALAR"}],
"bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":36},
 {"buffer":0,"byteOffset":72,"byteLength":24},{"buffer":0,"byteOffset":96,"byteLength":6},
 {"buffer":0,"byteOffset":104,"byteLength":16}]})");
  j["buffers"] = nlohmann::json::array({{{"uri", "data:application/octet-stream;base64," + fuzz::base64(bytes)},
                                         {"byteLength", bytes.size()}}});
  return j;
}

// The JSON pointers of every integer of `j` that is an index or an enum (not a size, not a bound).
void integer_paths(const nlohmann::json& j, const std::string& path, std::vector<std::string>& out) {
  if (j.is_number_integer()) out.push_back(path);
  if (j.is_array())
    for (size_t i = 0; i < j.size(); ++i) integer_paths(j[i], path + "/" + std::to_string(i), out);
  if (j.is_object())
    for (const auto& [key, value] : j.items())
      if (key != "byteLength" && key != "byteOffset" && key != "count" && key != "min" && key != "max")
        integer_paths(value, path + "/" + key, out);
}

// Every index and enum a glTF gives is range-checked as the 64-bit value the JSON holds, before
// tinygltf narrows it to an int (where 2^32 would read as index 0 and 2^64-1 as -1, "none"): each
// of them, set in turn to 2^32, 2^32 + 2, 2^64 - 1 and -2^31 - 1, is refused naming its JSON path.
TEST(GltfIndices, EveryIndexIsCheckedBeforeItIsNarrowed) {
  TempDir dir;
  const nlohmann::json base = indexed_gltf();
  tinygltf::Model model;
  std::vector<std::string> warnings;
  const Status ok = gltf::load_model(base.dump(), false, "indexed.gltf", dir.path("scene"), gltf::LoadOptions(), model,
                                     warnings);
  ASSERT_TRUE(ok) << ok.message();
  ASSERT_EQ(model.materials.size(), 1u);
  EXPECT_EQ(model.materials[0].normalTexture.index, 0);
  std::vector<std::string> paths;
  integer_paths(base, "", paths);
  ASSERT_GE(paths.size(), 30u);
  for (const std::string& path : paths) {
    for (const nlohmann::json& value : {nlohmann::json(uint64_t(1) << 32), nlohmann::json((uint64_t(1) << 32) + 2),
                                        nlohmann::json(~uint64_t(0)), nlohmann::json(-int64_t(2147483649))}) {
      SCOPED_TRACE(path + " = " + value.dump());
      nlohmann::json j = base;
      j[nlohmann::json::json_pointer(path)] = value;
      tinygltf::Model m;
      const Status s = gltf::load_model(j.dump(), false, "indexed.gltf", dir.path("scene"), gltf::LoadOptions(), m,
                                        warnings);
      ASSERT_FALSE(s);
      EXPECT_TRUE(contains(s.message(), "indexed.gltf: invalid glTF: " + path + " is " + value.dump() + ", beyond any glTF "
                                        "index or enum"))
          << s.message();
    }
  }
  // The mesh importer reads through the same check.
  nlohmann::json j = base;
  j["materials"][0]["normalTexture"]["index"] = uint64_t(1) << 32;
  Mesh mesh;
  const Status s = load_mesh(dir.write("scene/wrapped.gltf", j.dump()), mesh);
  ASSERT_FALSE(s);
  EXPECT_TRUE(contains(s.message(), "/materials/0/normalTexture/index is 4294967296")) << s.message();
}

// Values tinygltf would drop for its default without a word are errors naming the path: properties
// of the wrong JSON type, a sampler that does not exist, wrap and filter modes outside glTF's enums.
TEST(GltfIndices, ValuesTinygltfWouldDropAreRefused) {
  TempDir dir;
  const struct {
    const char* pointer;
    nlohmann::json value;
    const char* words;
  } cases[] = {
      {"/materials/0/alphaCutoff", "0.9", "/materials/0/alphaCutoff must be a number, not \"0.9\""},
      {"/materials/0/alphaMode", 1, "/materials/0/alphaMode must be a string, not 1"},
      {"/materials/0/doubleSided", "yes", "/materials/0/doubleSided must be true or false"},
      {"/samplers/0/wrapT", 12345, "/samplers/0/wrapT is 12345, none of glTF's values for it (33071, 33648, 10497)"},
      {"/samplers/0/wrapS", 0, "/samplers/0/wrapS is 0, none of glTF's values"},
      {"/samplers/0/magFilter", 9987, "/samplers/0/magFilter is 9987, none of glTF's values for it (9728, 9729)"},
      {"/samplers/0/minFilter", -1, "/samplers/0/minFilter is -1"},
      {"/textures/0/sampler", 3, "/textures/0/sampler is 3, but the file has 1 samplers"},
      {"/textures/0/sampler", -1, "/textures/0/sampler is -1, but the file has 1 samplers"},
      {"/textures/0/sampler", 0.5, "/textures/0/sampler must be an integer, not 0.5"},
      {"/nodes/0/mesh", 1.5, "/nodes/0/mesh must be an integer, not 1.5"},
  };
  std::vector<std::string> warnings;
  for (const auto& c : cases) {
    SCOPED_TRACE(c.pointer);
    nlohmann::json j = indexed_gltf();
    j[nlohmann::json::json_pointer(c.pointer)] = c.value;
    tinygltf::Model m;
    const Status s = gltf::load_model(j.dump(), false, "dropped.gltf", dir.path("scene"), gltf::LoadOptions(), m,
                                      warnings);
    ASSERT_FALSE(s);
    EXPECT_TRUE(contains(s.message(), std::string("dropped.gltf: invalid glTF: ") + c.words)) << s.message();
  }
  // Every value glTF allows still loads (samplers are then not read: docs/scene-format.md).
  for (const int wrap : {33071, 33648, 10497}) {
    nlohmann::json j = indexed_gltf();
    j["samplers"][0]["wrapS"] = wrap;
    tinygltf::Model m;
    const Status s = gltf::load_model(j.dump(), false, "ok.gltf", dir.path("scene"), gltf::LoadOptions(), m, warnings);
    EXPECT_TRUE(s) << s.message();
  }
}

// A PNG whose header claims more pixels a side than can be decoded is named as such (stb_image
// calls it an "unknown image type"); a file that is no PNG at all keeps stb's words.
TEST(Images, AnOversizedPngHeaderIsNamed) {
  TempDir dir;
  std::string png("\x89PNG\r\n\x1a\n\x00\x00\x00\x0dIHDR", 16);
  for (uint32_t v : {40000u, 16u})
    for (int i = 3; i >= 0; --i) png += char((v >> (8 * i)) & 0xff);
  png += std::string("\x08\x06\x00\x00\x00", 5) + std::string(4, '\0');
  tinygltf::Image image;
  Status s = gltf::decode_image_file(dir.write("big.png", png), uint64_t(1) << 27, image);
  ASSERT_FALSE(s);
  EXPECT_TRUE(contains(s.message(), "a PNG of 40000x16 pixels, more than the 32768 a side that can be decoded"))
      << s.message();
  s = gltf::decode_image_file(dir.write("text.png", "not an image at all"), uint64_t(1) << 27, image);
  ASSERT_FALSE(s);
  EXPECT_TRUE(contains(s.message(), "not a decodable PNG/JPEG")) << s.message();
}

// A buffer that is a link to a device: "not a regular file", not tinygltf's "File not found".
TEST(DataUri, ADeviceAsABufferIsNotARegularFile) {
  TempDir dir;
  fs::create_symlink("/dev/zero", dir.path("scene/zero.bin"));
  Mesh mesh;
  const Status s = load_mesh(dir.write("scene/dev.gltf", triangle_gltf("zero.bin")), mesh);
  ASSERT_FALSE(s);
  EXPECT_TRUE(contains(s.message(), "not a regular file")) << s.message();
  EXPECT_FALSE(contains(s.message(), "not found")) << s.message();
}

TEST(MeshCleanup, DegeneracyIsJudgedPerTriangle) {
  TempDir dir;
  // 800 small triangles and one stray triangle 10,000 units away: every one is kept (the old
  // bounding-box-relative threshold dropped almost all of them).
  const int n = 20, base = (n + 1) * (n + 1);
  const std::string stray = off_grid(n, 0.01, "10000 0 0\n10001 0 0\n10000 1 0\n", 3,
                                     format("3 %d %d %d\n", base, base + 1, base + 2), 1);
  Mesh mesh;
  MeshImportReport report;
  ASSERT_TRUE(load_mesh(dir.write("stray.off", stray), mesh, &report));
  EXPECT_EQ(mesh.triangles.size(), size_t(2 * n * n + 1));
  EXPECT_EQ(report.dropped_degenerate, 0u);

  // Scaled by 1e-30 the triangles are too small for float ray math: an error, not an empty model.
  Status s = load_mesh(dir.write("tiny.off", off_grid(n, 1e-30)), mesh);
  ASSERT_FALSE(s);
  EXPECT_TRUE(contains(s.message(), "no valid triangles (800 degenerate, 0 invalid)")) << s.message();
  // Scaled by 1e-6 (small but fine) it loads whole.
  ASSERT_TRUE(load_mesh(dir.write("small.off", off_grid(n, 1e-6)), mesh));
  EXPECT_EQ(mesh.triangles.size(), size_t(2 * n * n));

  // Collinear corners are degenerate whatever the size.
  s = load_mesh(dir.write("line.off", "OFF\n3 1 0\n0 0 0\n1e6 0 0\n2e6 1e-6 0\n3 0 1 2\n"), mesh);
  ASSERT_FALSE(s);
  EXPECT_TRUE(contains(s.message(), "1 degenerate")) << s.message();
}

TEST(MeshCleanup, DroppingMostOfAMeshIsAnErrorUnlessAllowed) {
  TempDir dir;
  // 8 good triangles and 9 with a NaN corner: more than half would go.
  const int n = 2, base = (n + 1) * (n + 1);
  std::string faces;
  for (int i = 0; i < 9; ++i) faces += format("3 0 1 %d\n", base);
  const std::string path = dir.write("half.off", off_grid(n, 1.0, "nan 0 0\n", 1, faces, 9));
  Mesh mesh;
  Status s = load_mesh(path, mesh);
  ASSERT_FALSE(s);
  EXPECT_TRUE(contains(s.message(), "9 of its 17 triangles would be dropped (0 degenerate, 9 invalid)"))
      << s.message();
  MeshImportOptions allow;
  allow.allow_dropping_most = true;
  MeshImportReport report;
  ASSERT_TRUE(load_mesh(path, mesh, &report, allow));
  EXPECT_EQ(mesh.triangles.size(), 8u);
  EXPECT_EQ(report.dropped_invalid, 9u);
  // Exactly half dropped is still accepted.
  faces.clear();
  for (int i = 0; i < 8; ++i) faces += format("3 0 1 %d\n", base);
  ASSERT_TRUE(load_mesh(dir.write("exactly_half.off", off_grid(n, 1.0, "nan 0 0\n", 1, faces, 8)), mesh));
}

TEST(MeshCleanup, UnusedBrokenVerticesAndDirtyNamesAreCleaned) {
  TempDir dir;
  // An unreferenced NaN vertex and a vertex beyond the float ray-math range: both removed; the
  // triangle using the far one is invalid.
  const std::string off = off_grid(2, 1.0, "nan nan nan\n1e30 0 0\n", 2, "3 0 1 10\n", 1);
  Mesh mesh;
  MeshImportReport report;
  ASSERT_TRUE(load_mesh(dir.write("nan.off", off), mesh, &report));
  EXPECT_EQ(mesh.positions.size(), 9u);
  EXPECT_EQ(mesh.normals.size(), 9u);
  EXPECT_EQ(report.dropped_invalid, 1u);
  for (const glm::vec3& p : mesh.positions) EXPECT_TRUE(std::isfinite(p.x + p.y + p.z) && std::abs(p.x) <= 1.0f);
  for (const glm::uvec3& t : mesh.triangles) EXPECT_TRUE(t.x < 9 && t.y < 9 && t.z < 9);

  // Material names become clean UTF-8 of at most 63 bytes, which the model file can store.
  const std::string obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl bad\x01\xff" "name\nf 1 2 3\nusemtl " +
                          std::string(100, 'm') + "\nf 1 3 2\n";
  ASSERT_TRUE(load_mesh(dir.write("names.obj", obj), mesh, &report));
  ASSERT_EQ(mesh.materials.size(), 2u);
  EXPECT_EQ(mesh.materials[0].name, "bad??name");
  EXPECT_EQ(mesh.materials[1].name, std::string(kModelMaterialNameBytes - 1, 'm'));
  EXPECT_TRUE(is_clean_utf8(mesh.materials[0].name));
}

}  // namespace
}  // namespace lsnif
