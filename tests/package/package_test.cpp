// package_test.cpp -- LSNIF as a renderer adopts it (label `package`). A tiny bunny model is trained
// in process; this build is installed (`cmake --install`) into a temporary prefix and packaged
// (`cpack -G DEB`); the hello_lsnif example, a separate C11 project, is configured and built from the
// copy the package installs (share/lsnif/examples/hello_lsnif) against the installed package only,
// three ways (find_package, pkg-config, the .deb files extracted into a temporary root), and from
// samples/hello_lsnif inside a parent project that add_subdirectory()s this source tree (with find_package
// also hello_lsnif_engine, the same scene as an engine with its own push-constant layout, custom
// indices and feature chain adopts LSNIF, its intersection shader built from the installed source,
// and its Vulkan 1.1 instance refused with a message naming the version); every build runs
// on lavapipe with the validation layer and its picture is compared per pixel with a CPU reference:
// the ground by exact ray/triangle tests, the LSNIF instance by core's intersect(), closest hit, the
// shading of hello_lsnif.c's header restated here. Also checked: what the exported lsnif::vk and the
// installed liblsnif_vk.so carry (link interface, shared-library dependencies, exported symbols).
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "lsnif/core/intersector.h"
#include "lsnif/core/model.h"
#include "lsnif/import/mesh.h"
#include "lsnif/host_device.h"
#include "lsnif/testing/test_support.h"
#include "lsnif/train/evaluate.h"
#include "lsnif/train/trainer.h"

namespace lsnif {
namespace {

namespace fs = std::filesystem;

const std::string kSourceDir = LSNIF_SOURCE_DIR;
const std::string kBuildDir = LSNIF_BINARY_DIR;
const std::string kCmake = LSNIF_CMAKE_COMMAND;
const std::string kCpack = LSNIF_CPACK_COMMAND;
const std::string kGenerator = LSNIF_CMAKE_GENERATOR;
// Where a package installs the hello_lsnif example, under its prefix.
const fs::path kExamples = "share/lsnif/examples/hello_lsnif";
const std::string kLibDir = LSNIF_INSTALL_LIBDIR;  // CMAKE_INSTALL_LIBDIR of this build
const std::string kVersion = LSNIF_VERSION;
const std::string kBunny = std::string(LSNIF_DATA_DIR) + "/meshes/bunny00.off";
constexpr bool kTools = LSNIF_PACKAGE_TOOLS;  // this build has the lsnif program (lsnif-tools)
constexpr bool kPython = LSNIF_PACKAGE_PYTHON;  // this build has the Python module (python3-lsnif)
const std::string kPythonExecutable = LSNIF_PYTHON_EXECUTABLE;  // the interpreter it is built for

// ---- running things ---------------------------------------------------------------------------

// `args` single-quoted for /bin/sh.
std::string quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

// Runs a shell command line with stderr folded into the output.
test::CommandResult sh(const std::string& command) { return test::run_command(command + " 2>&1"); }

std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

bool contains(const std::string& text, const std::string& what) { return text.find(what) != std::string::npos; }

std::string lower(std::string s) {
  for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// ---- the scene of samples/hello_lsnif/hello_lsnif.c (its header comment), on the CPU -----------

constexpr uint32_t kWidth = 160, kHeight = 120;
enum Kind : uint32_t { kMiss = 0, kGround = 1, kLsnif = 2, kKinds = 3 };
const char* const kKindNames[kKinds] = {"background", "ground", "LSNIF"};

struct Pixel {
  uint32_t kind = kMiss;
  float t = 0.0f;
  glm::vec3 normal{0.0f};
  glm::vec3 color{0.0f};
};
static_assert(sizeof(Pixel) == 32, "the record of hello_lsnif's --hits file");

struct Picture {
  std::vector<Pixel> pixels;  // kWidth x kHeight, row-major from the top
  std::vector<uint8_t> rgb;   // the quantized picture
};

// Object to world of the LSNIF instance: A (x - c) + (0, 0.4 e.y / s, 0), A = R diag(1.25, 0.8, 1) / s.
Transform3x4 hello_transform(const Aabb& bounds) {
  const float rotation[3][3] = {{0.6f, 0.0f, 0.8f}, {0.0f, 1.0f, 0.0f}, {-0.8f, 0.0f, 0.6f}};
  const glm::vec3 c = bounds.center(), e = bounds.extent();
  const float s = std::max(e.x, std::max(e.y, e.z));
  const float scale[3] = {1.25f / s, 0.8f / s, 1.0f / s};
  Transform3x4 xf;
  for (int r = 0; r < 3; ++r) {
    float t = r == 1 ? 0.4f * e.y / s : 0.0f;
    for (int k = 0; k < 3; ++k) {
      xf.m[r][k] = rotation[r][k] * scale[k];
      t -= xf.m[r][k] * c[k];
    }
    xf.m[r][3] = t;
  }
  return xf;
}

// The camera ray of pixel (x, y): eye (1.6, 1.1, 2.4) towards (0, 0.3, 0), half-height 0.27.
Ray camera_ray(uint32_t x, uint32_t y) {
  const glm::vec3 eye(1.6f, 1.1f, 2.4f), at(0.0f, 0.3f, 0.0f);
  const glm::vec3 f = glm::normalize(at - eye);
  const glm::vec3 r = glm::normalize(glm::vec3(-f.z, 0.0f, f.x));
  const glm::vec3 u = glm::cross(r, f);
  const float a = 2.0f * (float(x) + 0.5f) / float(kWidth) - 1.0f;
  const float b = 1.0f - 2.0f * (float(y) + 0.5f) / float(kHeight);
  Ray ray;
  ray.origin = eye;
  ray.direction = glm::normalize(f + a * (r * 0.27f * (float(kWidth) / float(kHeight))) + b * (u * 0.27f));
  ray.tmin = 0.0f;
  ray.tmax = 100.0f;
  return ray;
}

// The ground quad's two triangles by Moeller-Trumbore in double: t or -1.
double ground_hit(const Ray& ray) {
  const double g = -0.01;
  const glm::dvec3 v[4] = {{-2, g, -2}, {2, g, -2}, {2, g, 2}, {-2, g, 2}};
  const int tris[2][3] = {{0, 2, 1}, {0, 3, 2}};
  const glm::dvec3 o(ray.origin), d(ray.direction);
  double best = -1.0;
  for (const auto& tri : tris) {
    const glm::dvec3 e1 = v[tri[1]] - v[tri[0]], e2 = v[tri[2]] - v[tri[0]];
    const glm::dvec3 p = glm::cross(d, e2);
    const double det = glm::dot(e1, p);
    if (std::fabs(det) < 1e-12) continue;
    const glm::dvec3 s = o - v[tri[0]];
    const double bu = glm::dot(s, p) / det;
    const glm::dvec3 q = glm::cross(s, e1);
    const double bv = glm::dot(d, q) / det;
    const double t = glm::dot(e2, q) / det;
    if (bu < 0 || bv < 0 || bu + bv > 1 || t < ray.tmin || t > ray.tmax) continue;
    if (best < 0 || t < best) best = t;
  }
  return best;
}

glm::vec3 shade(glm::vec3 albedo, glm::vec3 normal) {
  const glm::vec3 light(1.0f / 3.0f, 2.0f / 3.0f, 2.0f / 3.0f);
  return albedo * (0.25f + 0.75f * std::max(glm::dot(normal, light), 0.0f));
}

uint8_t quantize(float v) { return uint8_t(std::clamp(v, 0.0f, 1.0f) * 255.0f + 0.5f); }

Status reference_picture(const Model& model, Picture& out) {
  std::vector<Ray> rays(size_t(kWidth) * kHeight);
  for (uint32_t y = 0; y < kHeight; ++y)
    for (uint32_t x = 0; x < kWidth; ++x) rays[size_t(y) * kWidth + x] = camera_ray(x, y);
  std::vector<LsnifHit> hits(rays.size());
  if (Status s = intersect(model, hello_transform(model.bounds()), rays.data(), rays.size(), hits.data()); !s) return s;
  out.pixels.assign(rays.size(), Pixel());
  out.rgb.assign(rays.size() * 3, 0);
  for (size_t i = 0; i < rays.size(); ++i) {
    Pixel& p = out.pixels[i];
    const double tg = ground_hit(rays[i]);
    if (hits[i].hit && (tg < 0 || double(hits[i].t) < tg)) {
      p.kind = kLsnif;
      p.t = hits[i].t;
      p.normal = hits[i].normal;
      p.color = shade(hits[i].albedo, hits[i].normal);
    } else if (tg >= 0) {
      p.kind = kGround;
      p.t = float(tg);
      p.normal = glm::vec3(0, 1, 0);
      const glm::vec3 at = rays[i].origin + p.t * rays[i].direction;
      const int cell = int(std::floor(4.0f * at.x)) + int(std::floor(4.0f * at.z));
      p.color = shade(glm::vec3((cell & 1) == 0 ? 0.75f : 0.35f), p.normal);
    } else {
      p.color = glm::vec3(0.06f, 0.08f, 0.12f);
    }
    for (int c = 0; c < 3; ++c) out.rgb[3 * i + size_t(c)] = quantize(p.color[c]);
  }
  return Status();
}

// hello_lsnif's outputs: the --hits file and the PPM.
Status read_picture(const fs::path& hits_path, const fs::path& ppm_path, Picture& out) {
  const std::string hits = read_text(hits_path);
  const size_t n = size_t(kWidth) * kHeight;
  uint32_t size[2] = {0, 0};
  if (hits.size() != 16 + n * sizeof(Pixel) || hits.compare(0, 8, "LSNIFHIT") != 0)
    return Status::error("%s: not a %ux%u hits file (%zu bytes)", hits_path.c_str(), kWidth, kHeight, hits.size());
  std::memcpy(size, hits.data() + 8, sizeof size);
  if (size[0] != kWidth || size[1] != kHeight)
    return Status::error("%s: %ux%u pixels, expected %ux%u", hits_path.c_str(), size[0], size[1], kWidth, kHeight);
  out.pixels.resize(n);
  std::memcpy(out.pixels.data(), hits.data() + 16, n * sizeof(Pixel));
  const std::string ppm = read_text(ppm_path);
  const std::string header = "P6\n" + std::to_string(kWidth) + " " + std::to_string(kHeight) + "\n255\n";
  if (ppm.size() != header.size() + 3 * n || ppm.compare(0, header.size(), header) != 0)
    return Status::error("%s: not a binary %ux%u PPM", ppm_path.c_str(), kWidth, kHeight);
  out.rgb.assign(ppm.begin() + std::ptrdiff_t(header.size()), ppm.end());
  return Status();
}

// Agreement bounds. Kind (hit/miss and which object): >= 99.9% of the pixels, the bound of
// rt_conformance_test for the same intersection shader against the same CPU reference (pixels whose
// occlusion logit is within fp16 rounding of the threshold may flip). For pixels on the LSNIF object
// in both: that test's bounds, 2e-4 object diagonals in t and 0.3 degrees in the normal (fp16
// parameters evaluated in fp32 on both sides, the object-space ray from the driver). Shaded values:
// albedo x (0.25 + 0.75 n.L) changes by at most |d albedo| (< 0.5 / 255 + 1e-4, the hit attributes'
// unorm8) + 0.75 sin(0.3 deg) (0.004) = 1.6 / 255 on the object, plus less than one step of
// rounding: < 2.6 / 255, so at most 2 / 255 apart. On the
// ground the color is exact except where the hit point lies within float error of a checker line:
// those pixels count with the kind flips against the 0.1%.
constexpr double kKindAgreement = 0.999, kTErrMax = 2e-4, kNormalDegMax = 0.3;
constexpr int kColorTolerance = 2;

struct Comparison {
  size_t pixels = 0, kind_agree = 0, color_off = 0;
  size_t gpu[kKinds] = {0, 0, 0}, cpu[kKinds] = {0, 0, 0};
  size_t lsnif_both = 0, ppm_mismatch = 0;
  double t_err_max = 0, normal_deg_max = 0, ground_t_rel_max = 0;
  int lsnif_color_max = 0;
  std::string text() const {
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "%zu pixels, kinds agree %.3f%%, gpu/cpu background %zu/%zu ground %zu/%zu LSNIF %zu/%zu; "
                  "LSNIF: t err max %.2e diagonals, normal max %.3f deg, color max %d/255; ground t rel err max "
                  "%.1e; pixels off (kind or color) %zu",
                  pixels, 100.0 * double(kind_agree) / double(pixels), gpu[kMiss], cpu[kMiss], gpu[kGround],
                  cpu[kGround], gpu[kLsnif], cpu[kLsnif], t_err_max, normal_deg_max, lsnif_color_max,
                  ground_t_rel_max, color_off);
    return buf;
  }
};

Comparison compare(const Model& model, const Picture& gpu, const Picture& cpu) {
  Comparison c;
  c.pixels = cpu.pixels.size();
  const Transform3x4 xf = hello_transform(model.bounds());
  glm::mat3 A;
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) A[k][r] = xf.m[r][k];
  const glm::mat3 A_inv = glm::inverse(A);
  const double diag = double(model.bounds().diagonal());
  for (size_t i = 0; i < c.pixels; ++i) {
    const Pixel &g = gpu.pixels[i], &h = cpu.pixels[i];
    if (g.kind < kKinds) ++c.gpu[g.kind];
    ++c.cpu[h.kind];
    for (int k = 0; k < 3; ++k) c.ppm_mismatch += gpu.rgb[3 * i + size_t(k)] != quantize(g.color[k]);
    int color_diff = 0;
    for (int k = 0; k < 3; ++k)
      color_diff = std::max(color_diff, std::abs(int(gpu.rgb[3 * i + size_t(k)]) - int(cpu.rgb[3 * i + size_t(k)])));
    if (g.kind != h.kind) {
      ++c.color_off;
      continue;
    }
    ++c.kind_agree;
    if (color_diff > kColorTolerance) ++c.color_off;
    const Ray ray = camera_ray(uint32_t(i % kWidth), uint32_t(i / kWidth));
    if (h.kind == kLsnif) {
      ++c.lsnif_both;
      const double span = diag / double(glm::length(A_inv * ray.direction));  // world t of one object diagonal
      c.t_err_max = std::max(c.t_err_max, std::fabs(double(g.t) - double(h.t)) / span);
      const double cosine = std::clamp(double(glm::dot(g.normal, h.normal)) /
                                           (double(glm::length(g.normal)) * double(glm::length(h.normal))),
                                       -1.0, 1.0);
      c.normal_deg_max = std::max(c.normal_deg_max, std::acos(cosine) * 180.0 / M_PI);
      c.lsnif_color_max = std::max(c.lsnif_color_max, color_diff);
    } else if (h.kind == kGround) {
      c.ground_t_rel_max = std::max(c.ground_t_rel_max, std::fabs(double(g.t) - double(h.t)) / double(h.t));
    }
  }
  return c;
}

// ---- the fixture: one model, one reference picture, one installed prefix ------------------------

class Package : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = fs::temp_directory_path() / ("lsnif_package_test_" + std::to_string(::getpid()));
    fs::remove_all(root_);
    fs::create_directories(root_);
    model_path_ = (root_ / "bunny.lsnif").string();
    if (!fs::exists(kBunny)) {
      setup_ = Status::error("%s missing: run scripts/setup.sh", kBunny.c_str());
      return;
    }
    TrainSettings settings = test::tiny_train_settings();
    settings.steps = 300;
    settings.seed = 5;
    Model trained;
    setup_ = load_mesh(kBunny, mesh_);
    if (setup_) setup_ = train_model(mesh_, settings, trained);
    if (setup_) setup_ = save_model(trained, model_path_);
    if (setup_) setup_ = load_model(model_path_, model_);  // the fp16 parameters the plugin uploads
    if (setup_) setup_ = reference_picture(model_, reference_);
    if (!setup_) return;
    prefix_ = root_ / "prefix";
    const test::CommandResult r = sh(quote(kCmake) + " --install " + quote(kBuildDir) + " --prefix " + quote(prefix_));
    if (r.code != 0) setup_ = Status::error("cmake --install failed:\n%s", r.out.c_str());
  }
  static void TearDownTestSuite() {
    if (std::getenv("LSNIF_PACKAGE_TEST_KEEP")) {  // for looking into a failure
      std::printf("kept %s (LSNIF_PACKAGE_TEST_KEEP)\n", root_.c_str());
      return;
    }
    std::error_code ec;
    fs::remove_all(root_, ec);
  }
  void SetUp() override { ASSERT_TRUE(setup_) << setup_.message(); }

  // Configures (with `options`) and builds the hello_lsnif example at `source` (the copy a package
  // installed: <prefix>/share/lsnif/examples/hello_lsnif) in `dir`; the executable's path.
  static std::string build_hello(const fs::path& source, const fs::path& dir, const std::string& options) {
    EXPECT_TRUE(fs::exists(source / "hello_lsnif.c")) << source << " holds no hello_lsnif example";
    test::CommandResult r = sh(quote(kCmake) + " -S " + quote(source) + " -B " +
                               quote(dir) + " -G " + quote(kGenerator) + " -DCMAKE_BUILD_TYPE=Release -DHELLO_LSNIF_WERROR=ON " +
                               "-DCMAKE_EXPORT_COMPILE_COMMANDS=ON " + options);
    EXPECT_EQ(r.code, 0) << "configuring hello_lsnif failed:\n" << r.out;
    if (r.code != 0) return "";
    r = sh(quote(kCmake) + " --build " + quote(dir));
    EXPECT_EQ(r.code, 0) << "building hello_lsnif failed:\n" << r.out;
    return r.code == 0 ? (dir / "hello_lsnif").string() : "";
  }

  // Runs hello_lsnif on the model with the validation layer (any message fails it) and compares its
  // picture with the reference; `name` labels the outputs and messages.
  static void run_and_compare(const std::string& exe, const std::string& name) {
    const fs::path ppm = root_ / (name + ".ppm"), hits = root_ / (name + ".hits");
    const test::CommandResult r = sh(quote(exe) + " " + quote(model_path_) + " --validate --device llvmpipe -o " +
                                     quote(ppm) + " --hits " + quote(hits));
    ASSERT_EQ(r.code, 0) << name << ": hello_lsnif failed:\n" << r.out;
    EXPECT_FALSE(contains(r.out, "validation")) << r.out;
    Picture gpu;
    const Status s = read_picture(hits, ppm, gpu);
    ASSERT_TRUE(s) << s.message();
    const Comparison c = compare(model_, gpu, reference_);
    std::printf("%s: %s\n", name.c_str(), c.text().c_str());
    EXPECT_EQ(c.ppm_mismatch, 0u) << "the PPM is not the quantized colors of the hits file";
    EXPECT_GE(double(c.kind_agree), kKindAgreement * double(c.pixels)) << c.text();
    EXPECT_LE(double(c.color_off), (1.0 - kKindAgreement) * double(c.pixels)) << c.text();
    EXPECT_LT(c.t_err_max, kTErrMax) << c.text();
    EXPECT_LT(c.normal_deg_max, kNormalDegMax) << c.text();
    EXPECT_LE(c.lsnif_color_max, kColorTolerance) << c.text();
    EXPECT_LT(c.ground_t_rel_max, 1e-5) << c.text();
    // Not a trivial picture: every kind covers a good part of it, in both.
    const double min_share[kKinds] = {0.05, 0.2, 0.08};
    for (uint32_t k = 0; k < kKinds; ++k) {
      EXPECT_GE(double(c.cpu[k]), min_share[k] * double(c.pixels)) << kKindNames[k] << ": " << c.text();
      EXPECT_GE(double(c.gpu[k]), min_share[k] * double(c.pixels)) << kKindNames[k] << ": " << c.text();
    }
  }

  // The shared library `exe` resolves liblsnif_vk.so.0 to, from ldd.
  static std::string resolved_lsnif_library(const std::string& exe) {
    const test::CommandResult r = sh("ldd " + quote(exe));
    const std::string key = "liblsnif_vk.so.0 => ";
    const size_t at = r.out.find(key);
    if (at != std::string::npos) {
      const size_t begin = at + key.size(), end = r.out.find_first_of(" \t\n", begin);
      return r.out.substr(begin, end == std::string::npos ? std::string::npos : end - begin);
    }
    return "(not found in ldd output:\n" + r.out + ")";
  }

  static fs::path root_, prefix_;
  static std::string model_path_;
  static Status setup_;
  static Mesh mesh_;
  static Model model_;
  static Picture reference_;
};
fs::path Package::root_, Package::prefix_;
std::string Package::model_path_;
Status Package::setup_;
Mesh Package::mesh_;
Model Package::model_;
Picture Package::reference_;

std::string real_path(const fs::path& p) {
  std::error_code ec;
  const fs::path c = fs::canonical(p, ec);
  return ec ? p.string() : c.string();
}

TEST_F(Package, HelloThroughFindPackage) {
  const std::string exe = build_hello(prefix_ / kExamples, root_ / "hello_find_package",
                                      "-DHELLO_LSNIF_BUILD_ENGINE=ON -DCMAKE_PREFIX_PATH=" + quote(prefix_));
  ASSERT_FALSE(exe.empty());
  EXPECT_EQ(real_path(resolved_lsnif_library(exe)), real_path(prefix_ / kLibDir / ("liblsnif_vk.so." + kVersion)));
  run_and_compare(exe, "find_package");

  // hello_lsnif_engine, built beside it: an engine with its own push constants at offset 0, its own
  // custom-index table, a feature chain it built itself (completed by
  // lsnifEnableDeviceFeaturesInCreateInfo) and an intersection shader built from the installed
  // source for that layout must render the same picture, validation clean; with a Vulkan 1.1
  // instance, lsnifCreateContext must fail naming the API version, still validation clean.
  const fs::path engine = fs::path(exe).parent_path() / "hello_lsnif_engine";
  ASSERT_TRUE(fs::exists(engine));
  run_and_compare(engine.string(), "engine");
  const test::CommandResult r = sh(quote(engine) + " " + quote(model_path_) + " --validate --device llvmpipe " +
                                   "--vulkan-api 1.1 -o " + quote(root_ / "engine_1_1.ppm"));
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(contains(r.out, "lsnifCreateContext")) << r.out;
  EXPECT_TRUE(contains(r.out, "apiVersion below 1.2")) << r.out;
  EXPECT_FALSE(contains(r.out, "validation")) << r.out;
  EXPECT_FALSE(fs::exists(root_ / "engine_1_1.ppm"));
}

TEST_F(Package, HelloThroughPkgConfig) {
  const std::string exe = build_hello(prefix_ / kExamples, root_ / "hello_pkg_config",
                                      "-DHELLO_LSNIF_USE_PKG_CONFIG=ON -DCMAKE_PREFIX_PATH=" + quote(prefix_));
  ASSERT_FALSE(exe.empty());
  EXPECT_EQ(real_path(resolved_lsnif_library(exe)), real_path(prefix_ / kLibDir / ("liblsnif_vk.so." + kVersion)));
  // The variables of lsnif.pc point into the prefix wherever it is (prefix from ${pcfiledir}).
  const std::string pc = "PKG_CONFIG_PATH=" + quote(prefix_ / kLibDir / "pkgconfig") + " pkg-config ";
  test::CommandResult r = sh(pc + "--variable=glsldir lsnif");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(real_path(r.out.substr(0, r.out.find('\n'))), real_path(prefix_ / "include"));
  r = sh(pc + "--libs lsnif");
  EXPECT_TRUE(contains(r.out, "-llsnif_vk")) << r.out;
  run_and_compare(exe, "pkg_config");
}

// The .deb packages of `cpack -G DEB`: names, dependencies, contents; extracted (not installed)
// into a temporary root, they must be usable there.
TEST_F(Package, HelloFromTheDebPackages) {
  const fs::path debs = root_ / "debs";
  test::CommandResult r = sh(quote(kCpack) + " -G DEB --config " + quote(kBuildDir + "/CPackConfig.cmake") + " -B " +
                             quote(debs));
  ASSERT_EQ(r.code, 0) << "cpack failed:\n" << r.out;
  std::set<std::string> want = {"liblsnif-vk0", "liblsnif-dev", "liblsnif-train-dev"};
  if (kTools) want.insert("lsnif-tools");
  if (kPython) want.insert("python3-lsnif");
  std::set<std::string> got;
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(debs))
    if (entry.path().extension() == ".deb") {
      files.push_back(entry.path());
      got.insert(entry.path().filename().string().substr(0, entry.path().filename().string().find('_')));
    }
  EXPECT_EQ(got, want);
  const fs::path root = root_ / "debroot";
  for (const fs::path& f : files) {
    const std::string name = f.filename().string().substr(0, f.filename().string().find('_'));
    r = sh("dpkg-deb -f " + quote(f) + " Package Version Depends");
    ASSERT_EQ(r.code, 0) << r.out;
    EXPECT_TRUE(contains(r.out, "Version: " + kVersion)) << name << ":\n" << r.out;
    if (name == "liblsnif-dev") {
      EXPECT_TRUE(contains(r.out, "liblsnif-vk0 (= " + kVersion + ")")) << r.out;
      EXPECT_TRUE(contains(r.out, "libvulkan-dev")) << r.out;
    }
    if (name == "lsnif-tools") {  // libc6, libembree3-3 and OpenImageIO (of the image module) from dpkg-shlibdeps
      for (const std::string& dep : {"liblsnif-vk0 (= " + kVersion + ")", std::string("libvulkan1"),
                                     std::string("libc6"), std::string("libembree3-3"), std::string("libopenimageio")})
        EXPECT_TRUE(contains(r.out, dep)) << dep << " missing:\n" << r.out;
      const test::CommandResult contents = sh("dpkg-deb -c " + quote(f));
      EXPECT_TRUE(contains(contents.out, "./usr/" + kLibDir + "/lsnif/liblsnif_image_oiio.so")) << contents.out;
    }
    if (name == "python3-lsnif") {  // the runtime, NumPy and the Python versions the extension loads in
      for (const std::string& dep : {"liblsnif-vk0 (= " + kVersion + ")", std::string("python3-numpy"),
                                     std::string("python3 (>= 3."), std::string("python3 (<< 3.")})
        EXPECT_TRUE(contains(r.out, dep)) << dep << " missing:\n" << r.out;
    }
    const test::CommandResult list = sh("dpkg-deb -c " + quote(f));
    if (name == "liblsnif-vk0") {  // the shared library (file and SONAME link) and its license, nothing else
      std::set<std::string> entries;
      std::istringstream lines(list.out);
      for (std::string line; std::getline(lines, line);)
        if (!line.empty() && line[0] != 'd') entries.insert(line.substr(line.find("./usr/")));
      const std::string lib = "./usr/" + kLibDir + "/liblsnif_vk.so.0";
      const std::set<std::string> want_entries = {lib + " -> liblsnif_vk.so." + kVersion, "./usr/" + kLibDir + "/liblsnif_vk.so." + kVersion,
                                                  "./usr/share/doc/liblsnif-vk0/copyright"};
      EXPECT_EQ(entries, want_entries) << list.out;
    }
    r = sh("dpkg-deb -x " + quote(f) + " " + quote(root));
    ASSERT_EQ(r.code, 0) << r.out;
  }
  const fs::path usr = root / "usr";
  EXPECT_TRUE(fs::exists(usr / "include/lsnif/lsnif_hit.glsl"));
  EXPECT_TRUE(fs::exists(usr / "include/lsnif/lsnif_hit.hlsl"));
  EXPECT_TRUE(fs::exists(usr / "include/lsnif/shaders/lsnif_intersection.glsl"));
  const std::string exe = build_hello(usr / kExamples, root_ / "hello_deb", "-DCMAKE_PREFIX_PATH=" + quote(usr));
  ASSERT_FALSE(exe.empty());
  EXPECT_EQ(real_path(resolved_lsnif_library(exe)), real_path(usr / kLibDir / ("liblsnif_vk.so." + kVersion)));
  run_and_compare(exe, "deb");
  if (kPython) {  // the extracted module imports, finding the extracted liblsnif_vk beside it
    const fs::path site = usr / "lib/python3/dist-packages";
    r = sh("PYTHONPATH=" + quote(site) + " " + quote(kPythonExecutable) +
           " -c 'import lsnif, os; print(lsnif.__version__, os.path.realpath(lsnif._lsnif.__file__))'");
    EXPECT_EQ(r.code, 0) << r.out;
    EXPECT_TRUE(contains(r.out, kVersion + " " + real_path(site / "lsnif"))) << r.out;
    r = sh("ldd " + quote(site / "lsnif") + "/_lsnif*.so");
    EXPECT_TRUE(contains(r.out, "liblsnif_vk.so.0 => ") && !contains(r.out, "not found")) << r.out;
  }
}

// What a consumer of the installed lsnif::vk gets: Vulkan headers and liblsnif_vk, nothing of the CPU
// libraries (OpenMP, Eigen, Embree, glm) nor LSNIF's own build flags.
TEST_F(Package, PluginInterfaceIsThePluginOnly) {
  const fs::path cmake_dir = prefix_ / kLibDir / "cmake/lsnif";
  const std::string targets = read_text(cmake_dir / "lsnifTargets.cmake");
  const std::string key = "set_target_properties(lsnif::vk PROPERTIES\n";
  const size_t at = targets.find(key);
  ASSERT_NE(at, std::string::npos) << targets;
  const size_t end = targets.find(')', at + key.size());
  ASSERT_NE(end, std::string::npos) << targets;
  const std::string props = targets.substr(at + key.size(), end - at - key.size());
  EXPECT_TRUE(contains(props, "INTERFACE_LINK_LIBRARIES \"Vulkan::Headers\"\n")) << props;
  for (const char* p : {"INTERFACE_COMPILE_OPTIONS", "INTERFACE_COMPILE_DEFINITIONS", "INTERFACE_LINK_OPTIONS"})
    EXPECT_FALSE(contains(props, p)) << p << " in lsnif::vk:\n" << props;
  for (const char* file : {"lsnifTargets.cmake", "lsnifTargets-release.cmake"}) {
    const std::string text = lower(read_text(cmake_dir / file));
    for (const char* bad : {"openmp", "eigen", "embree", "glm", "-march", "-werror", "-fsanitize"})
      EXPECT_FALSE(contains(text, bad)) << bad << " in " << file;
  }
  const fs::path so = prefix_ / kLibDir / ("liblsnif_vk.so." + kVersion);
  test::CommandResult r = sh("ldd " + quote(so));
  ASSERT_EQ(r.code, 0) << r.out;
  for (const char* bad : {"libgomp", "libembree", "libtbb", "libvulkan"})  // it loads Vulkan through the app's loader
    EXPECT_FALSE(contains(r.out, bad)) << bad << " in ldd " << so << ":\n" << r.out;
  r = sh("readelf -d " + quote(so));
  EXPECT_TRUE(contains(r.out, "Library soname: [liblsnif_vk.so.0]")) << r.out;
  // Exported: exactly the functions that include/lsnif/lsnif.h declares with LSNIF_API.
  r = sh("nm -D --defined-only " + quote(so));
  ASSERT_EQ(r.code, 0) << r.out;
  std::set<std::string> exported, declared;
  std::istringstream lines(r.out);
  for (std::string line; std::getline(lines, line);) {
    std::istringstream fields(line);
    std::string address, type, name;
    if (fields >> address >> type >> name) exported.insert(name);
  }
  const std::string header = read_text(prefix_ / "include/lsnif/lsnif.h");
  // Each "LSNIF_API ... name(" up to the first parenthesis: the identifier before it.
  for (size_t api = header.find("LSNIF_API "); api != std::string::npos; api = header.find("LSNIF_API ", api + 1)) {
    const size_t paren = header.find('(', api);
    if (paren == std::string::npos) break;
    size_t begin = paren;
    while (begin > api && (std::isalnum(static_cast<unsigned char>(header[begin - 1])) || header[begin - 1] == '_'))
      --begin;
    const std::string name = header.substr(begin, paren - begin);
    if (name.rfind("lsnif", 0) == 0) declared.insert(name);
  }
  EXPECT_GE(declared.size(), 20u);  // the header was parsed
  EXPECT_EQ(exported, declared);
}

// The guides the package installs (share/doc/lsnif/) name only what a reader of the package can
// open: every path in backquotes that points into the package (`lsnif/...` under include/,
// `include/...`, `share/...`, `<prefix>/...`, a guide beside it) exists in the installed prefix, and a
// path of the repository (src/, tests/, samples/, docs/, scripts/, bench/, cmake/) appears only in a
// guide that says such paths are the repository's. Fails on a guide that names a file the package
// does not ship.
TEST_F(Package, InstalledGuidesNameWhatThePackageHolds) {
  const fs::path doc = prefix_ / "share/doc/lsnif";
  ASSERT_TRUE(fs::exists(doc / "integration.md")) << doc << " holds no integration guide";
  const char* const repository_roots[] = {"src/", "tests/", "samples/", "docs/", "scripts/", "bench/", "cmake/"};
  size_t guides = 0, checked = 0;
  for (const auto& entry : fs::directory_iterator(doc)) {
    if (entry.path().extension() != ".md") continue;
    ++guides;
    const std::string text = read_text(entry.path());
    const bool marks_repository = contains(text, "are the LSNIF repository's");
    for (size_t open = text.find('`'); open != std::string::npos; open = text.find('`', open + 1)) {
      const size_t close = text.find('`', open + 1);
      if (close == std::string::npos) break;
      const std::string token = text.substr(open + 1, close - open - 1);
      open = close;
      // A path: no blanks, a slash, and a last part with an extension or a trailing slash.
      if (token.find_first_of(" \t\n\"'(),;") != std::string::npos || token.find('/') == std::string::npos) continue;
      const std::string last = token.substr(token.rfind('/') + 1);
      if (!(token.back() == '/' || last.find('.') != std::string::npos)) continue;
      if (token[0] == '<' && token.rfind("<prefix>/", 0) != 0) continue;  // <vulkan/vulkan.h>
      bool repository = false;
      for (const char* root : repository_roots) repository = repository || token.rfind(root, 0) == 0;
      const std::string where = entry.path().filename().string() + ": `" + token + "`";
      if (repository) {
        EXPECT_TRUE(marks_repository) << where << " is a repository path in a guide that does not say so";
        continue;
      }
      fs::path in_package;
      if (token.rfind("<prefix>/", 0) == 0) in_package = prefix_ / token.substr(9);
      else if (token.rfind("lsnif/", 0) == 0) in_package = prefix_ / "include" / token;
      else if (token.rfind("include/", 0) == 0 || token.rfind("share/", 0) == 0) in_package = prefix_ / token;
      else in_package = doc / token;  // beside the guide (images/...)
      ++checked;
      EXPECT_TRUE(fs::exists(in_package)) << where << " is not in the package (" << in_package << ")";
    }
  }
  EXPECT_GE(guides, 2u);
  EXPECT_GE(checked, 10u);  // the guides were read
}

// A parent project that vendors the source tree (tests/package/parent): with the defaults it gets
// the plugin only. Built with -march=native and -Werror for LSNIF's own code, neither may reach the
// consumer's compile line.
TEST_F(Package, AddSubdirectoryBuildsThePluginOnly) {
  const fs::path dir = root_ / "parent";
  test::CommandResult r = sh(quote(kCmake) + " -S " + quote(kSourceDir + "/tests/package/parent") + " -B " +
                             quote(dir) + " -G " + quote(kGenerator) + " -DCMAKE_BUILD_TYPE=Release -DLSNIF_SOURCE_DIR=" +
                             quote(kSourceDir) + " -DLSNIF_NATIVE=ON -DLSNIF_WERROR=ON -DCMAKE_EXPORT_COMPILE_COMMANDS=ON");
  ASSERT_EQ(r.code, 0) << "configuring the parent failed:\n" << r.out;
  // Comment lines hold the options' help texts, which name the dependencies of LSNIF_BUILD_TRAIN.
  std::istringstream cache(read_text(dir / "CMakeCache.txt"));
  for (std::string line; std::getline(cache, line);) {
    if (line.rfind("//", 0) == 0) continue;
    for (const char* bad : {"embree", "openimageio", "glfw", "eigen", "openmp", "glm", "gtest"})
      EXPECT_FALSE(contains(lower(line), bad)) << bad << " in the parent's CMakeCache.txt: " << line;
  }
  r = sh(quote(kCmake) + " --build " + quote(dir));
  ASSERT_EQ(r.code, 0) << "building the parent failed:\n" << r.out;
  const std::string commands = read_text(dir / "compile_commands.json");
  // The "command" entry of compile_commands.json that compiles hello_lsnif.c.
  std::string command;
  std::istringstream entries(commands);
  for (std::string line; std::getline(entries, line);)
    if (contains(line, "\"command\": \"") && contains(line, "hello_lsnif.c")) command = line;
  ASSERT_FALSE(command.empty()) << commands;
  for (const char* bad : {"-march", "-Werror", "-fopenmp", "EIGEN", "-fsanitize", "-mno-avx512f"})
    EXPECT_FALSE(contains(command, bad)) << bad << " in the consumer's compile command: " << command;
  EXPECT_TRUE(contains(commands, "-march=native")) << "LSNIF's own code should have been built with LSNIF_NATIVE";
  run_and_compare((dir / "hello_lsnif" / "hello_lsnif").string(), "add_subdirectory");
}

// The CPU libraries and the plugin as a renderer's project gets them (find_package(lsnif COMPONENTS
// train)), with its own config.h, status.h, mesh.h, model.h and host_device.h on its include path
// ahead of LSNIF's and behind it (tests/package/consumer): every program compiles only with its own
// headers (an #error otherwise), the C++ one evaluates the model on the bunny with the counts of the
// same evaluation in this process, and the C one reads LSNIF's host_device.h through lsnif/lsnif.h.
TEST_F(Package, ConsumerWithHeadersOfTheSameNames) {
  const fs::path dir = root_ / "consumer";
  test::CommandResult r = sh(quote(kCmake) + " -S " + quote(kSourceDir + "/tests/package/consumer") + " -B " +
                             quote(dir) + " -G " + quote(kGenerator) + " -DCMAKE_BUILD_TYPE=Release " +
                             "-DCMAKE_PREFIX_PATH=" + quote(prefix_));
  ASSERT_EQ(r.code, 0) << "configuring the consumer failed:\n" << r.out;
  r = sh(quote(kCmake) + " --build " + quote(dir));
  ASSERT_EQ(r.code, 0) << "building the consumer failed:\n" << r.out;
  for (const char* order : {"own_first", "lsnif_first"})
    EXPECT_TRUE(fs::exists(dir / ("consumer_" + std::string(order) + ".rchit.spv"))) << order;
  constexpr size_t kRays = 2000;
  EvalSettings settings;
  settings.rays = kRays;
  EvalReport report;
  const Status s = evaluate_model(model_, mesh_, settings, report);
  ASSERT_TRUE(s) << s.message();
  const EvalMetrics& m = report.model;
  char want[320];
  std::snprintf(want, sizeof want,
                "rays %llu\ntrue_hits %llu\nfalse_hits %llu\ntrue_misses %llu\nfalse_misses %llu\nplugin %s\n",
                static_cast<unsigned long long>(m.rays), static_cast<unsigned long long>(m.true_hits),
                static_cast<unsigned long long>(m.false_hits), static_cast<unsigned long long>(m.true_misses),
                static_cast<unsigned long long>(m.false_misses), kVersion.c_str());
  EXPECT_GT(m.true_hits, kRays / 10);  // a real evaluation
  for (const char* order : {"own_first", "lsnif_first"}) {
    r = sh(quote((dir / ("consumer_" + std::string(order))).string()) + " " + quote(model_path_) + " " +
           quote(kBunny) + " " + std::to_string(kRays));
    ASSERT_EQ(r.code, 0) << order << ": " << r.out;
    EXPECT_EQ(r.out, want) << order;
    r = sh(quote((dir / ("consumer_c_" + std::string(order))).string()));
    ASSERT_EQ(r.code, 0) << order << ": " << r.out;
    EXPECT_EQ(r.out, "plugin " + kVersion + "\nmax_points " + std::to_string(LSNIF_MAX_POINTS) +
                         "\nsurface 1 1.00 0.20 0.00\n")
        << order;
  }
}

// The installed lsnif program runs from the prefix and names nothing of the build tree.
TEST_F(Package, InstalledToolIsRelocatable) {
  if (!kTools) GTEST_SKIP() << "LSNIF_BUILD_TOOLS is off: no lsnif program";
  const fs::path tool = prefix_ / "bin/lsnif";
  ASSERT_TRUE(fs::exists(tool));
  test::CommandResult r = sh("strings " + quote(tool));
  ASSERT_EQ(r.code, 0) << r.out;
  std::istringstream lines(r.out);
  for (std::string line; std::getline(lines, line);) {
    EXPECT_FALSE(contains(line, kBuildDir)) << "the build folder in the installed lsnif: " << line;
    // The one source-tree path: the default of --data (scripts/setup.sh fetches the data there), a
    // NUL-terminated string of its own (src/lsnif/apps/lsnif/data_dir.cpp; `strings` may print other
    // printable bytes before it on the same line).
    if (contains(line, kSourceDir)) {
      EXPECT_EQ(line.substr(line.find(kSourceDir)), std::string(LSNIF_DATA_DIR)) << line;
    }
  }
  // It runs from the prefix (its shared libraries resolve there or in the system).
  r = sh(quote(tool) + " info " + quote(model_path_));
  EXPECT_EQ(r.code, 0) << r.out;
  // And opens the image module installed beside it (lib/lsnif), not the build tree's.
  const fs::path ppm = root_ / "tool.ppm";
  {
    std::ofstream f(ppm, std::ios::binary);
    f << "P6\n2 1\n255\n";
    f.write("\x10\x80\xf0\x10\x80\xf0", 6);
  }
  r = sh("LD_DEBUG=files " + quote(tool) + " flip " + quote(ppm) + " " + quote(ppm));
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(contains(r.out, (prefix_ / kLibDir / "lsnif/liblsnif_image_oiio.so").string())) << r.out;
  EXPECT_FALSE(contains(r.out, kBuildDir + "/")) << r.out;
}

}  // namespace
}  // namespace lsnif
