// `lsnif bench-memory` as a user runs it: usage errors (exit 2) and bad files (exit 1) with a
// message naming the problem, a missing Vulkan driver (exit 1), and a real run on lavapipe with a
// tiny model of the elephant whose JSON is checked for internal consistency (stdout holds only the
// JSON object) and against `lsnif info`.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "lsnif/testing/test_support.h"

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
const std::string kElephant = std::string(LSNIF_DATA_DIR) + "/meshes/elephant.off";

struct CliRun {
  int code = -1;
  std::string out, err;
};

fs::path temp_dir() {
  fs::path d = fs::temp_directory_path() / ("lsnif_bench_memory_test_" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d;
}

// Runs `lsnif ARGS` with `env` before it on the shell line; stdout and stderr kept apart.
CliRun run_cli(const std::string& args, const std::string& env = "") {
  const fs::path err_file = temp_dir() / "stderr.txt";
  const lsnif::test::CommandResult run =
      lsnif::test::run_command(env + std::string(LSNIF_CLI) + " " + args + " 2>" + err_file.string());
  CliRun r;
  r.code = run.code;
  r.out = run.out;
  std::ifstream in(err_file);
  std::stringstream ss;
  ss << in.rdbuf();
  r.err = ss.str();
  return r;
}

bool has(const std::string& text, const std::string& what) { return text.find(what) != std::string::npos; }

// Removes this process's temporary folder after all tests.
class TempCleanup : public ::testing::Environment {
 public:
  void TearDown() override { fs::remove_all(temp_dir()); }
};
[[maybe_unused]] ::testing::Environment* const kTempCleanup = ::testing::AddGlobalTestEnvironment(new TempCleanup);

TEST(BenchMemoryCli, Help) {
  const CliRun top = run_cli("--help");
  EXPECT_EQ(top.code, 0);
  EXPECT_TRUE(has(top.out, "bench-memory")) << top.out;
  const CliRun r = run_cli("bench-memory --help");
  EXPECT_EQ(r.code, 0);
  EXPECT_TRUE(has(r.out, "usage: lsnif bench-memory MESH MODEL")) << r.out;
  EXPECT_TRUE(has(r.out, "--subdivide-targets")) << r.out;
}

TEST(BenchMemoryCli, UsageErrors) {
  CliRun r = run_cli("bench-memory");
  EXPECT_EQ(r.code, 2);
  EXPECT_TRUE(has(r.err, "missing argument MESH")) << r.err;
  r = run_cli("bench-memory mesh.off");
  EXPECT_EQ(r.code, 2);
  EXPECT_TRUE(has(r.err, "missing argument MODEL")) << r.err;
  r = run_cli("bench-memory mesh.off model.lsnif --frobnicate");
  EXPECT_EQ(r.code, 2);
  EXPECT_TRUE(has(r.err, "--frobnicate")) << r.err;
  for (const char* bad : {"many", "1000,", ",1000", "0", "1000,-5", "1e6"}) {
    r = run_cli(std::string("bench-memory mesh.off model.lsnif --subdivide-targets=") + bad);
    EXPECT_EQ(r.code, 2) << bad;
    EXPECT_TRUE(has(r.err, "--subdivide-targets")) << bad << ": " << r.err;
  }
  EXPECT_TRUE(r.out.empty()) << r.out;
}

TEST(BenchMemoryCli, BadFiles) {
  const fs::path d = temp_dir();
  std::ofstream(d / "garbage.lsnif") << "this is not a model";
  CliRun r = run_cli("bench-memory " + kElephant + " " + (d / "missing.lsnif").string());
  EXPECT_EQ(r.code, 1);
  EXPECT_TRUE(has(r.err, "missing.lsnif")) << r.err;
  r = run_cli("bench-memory " + kElephant + " " + (d / "garbage.lsnif").string());
  EXPECT_EQ(r.code, 1);
  EXPECT_TRUE(has(r.err, "garbage.lsnif")) << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;
}

// One tiny model for the runs below (trained once): the shape of the --tiny preset, deliberately
// with fewer steps and rays (5 of 512): the memory figures do not depend on how well it is trained.
class BenchMemoryRun : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (!fs::exists(kElephant)) return;
    model_ = (temp_dir() / "elephant.lsnif").string();
    const CliRun r = run_cli("train " + kElephant + " -o " + model_ +
                          " --voxels 16 --res-min 32 --res-max 64 --table-log2 12 --width 32 --steps 5 --batch 512 "
                          "--quiet");
    if (r.code != 0) model_.clear();
  }
  void SetUp() override {
    if (!fs::exists(kElephant)) GTEST_SKIP() << kElephant << " missing: run scripts/setup.sh";
    ASSERT_FALSE(model_.empty()) << "training the tiny model failed";
  }
  static std::string model_;
};
std::string BenchMemoryRun::model_;

TEST_F(BenchMemoryRun, MissingMeshAndMissingDriver) {
  CliRun r = run_cli("bench-memory /nonexistent/mesh.off " + model_);
  EXPECT_EQ(r.code, 1);
  EXPECT_TRUE(has(r.err, "/nonexistent/mesh.off")) << r.err;
  r = run_cli("bench-memory " + kElephant + " " + model_,
              "VK_DRIVER_FILES=/nonexistent/icd.json VK_ICD_FILENAMES=/nonexistent/icd.json ");
  EXPECT_EQ(r.code, 1) << r.out << r.err;
  EXPECT_TRUE(has(r.err, "no usable Vulkan ray-tracing device")) << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;
}

TEST_F(BenchMemoryRun, JsonIsConsistent) {
  // elephant: 5558 triangles; 22232 is level 1 exactly, 20000 is closest to level 1 too.
  const CliRun r = run_cli("bench-memory " + kElephant + " " + model_ + " --json --subdivide-targets 22232,20000");
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  EXPECT_TRUE(has(r.err, "building the triangle BLAS")) << r.err;
  const json j = json::parse(r.out);  // throws (fails the test) on anything but one JSON object
  ASSERT_TRUE(j.is_object());

  const CliRun info = run_cli("info --json " + model_);
  ASSERT_EQ(info.code, 0);
  const json ij = json::parse(info.out);
  const json& l = j.at("lsnif");
  EXPECT_EQ(l.at("model_bytes").get<uint64_t>(), ij.at("bytes").at("total").get<uint64_t>());
  const uint64_t block = l.at("block_bytes"), blas = l.at("aabb_blas_bytes"), total = l.at("total_bytes");
  EXPECT_EQ(total, block + blas);
  EXPECT_GT(blas, 0u);
  EXPECT_GE(block, l.at("model_bytes").get<uint64_t>() / 2);  // fp16 block vs the file's fp16 data
  EXPECT_GE(l.at("allocated_bytes").get<uint64_t>(), total);

  const json& v = j.at("triangle_blas");
  ASSERT_EQ(v.size(), 2u);  // level 0 and level 1 (both targets)
  EXPECT_EQ(v[0].at("level"), 0);
  EXPECT_EQ(v[0].at("triangles"), 5558);
  EXPECT_TRUE(v[0].at("targets").empty());
  EXPECT_EQ(v[1].at("level"), 1);
  EXPECT_EQ(v[1].at("triangles"), 4 * 5558);
  EXPECT_EQ(v[1].at("targets"), json::array({22232, 20000}));
  for (const json& e : v) {
    const uint64_t tris = e.at("triangles"), verts = e.at("vertices");
    EXPECT_EQ(e.at("vertex_bytes").get<uint64_t>(), 12 * verts);
    EXPECT_EQ(e.at("index_bytes").get<uint64_t>(), 12 * tris);
    const uint64_t b = e.at("blas_bytes"), compacted = e.at("compacted_bytes");
    EXPECT_GT(b, 0u);
    EXPECT_GT(compacted, 0u);
    EXPECT_LE(compacted, e.at("blas_bytes_allow_compaction").get<uint64_t>());
    EXPECT_NEAR(e.at("ratio_blas").get<double>(), double(b) / double(total), 1e-3);
    EXPECT_NEAR(e.at("ratio_compacted").get<double>(), double(compacted) / double(total), 1e-3);
    EXPECT_NEAR(e.at("ratio_compacted_with_geometry").get<double>(),
                double(compacted + 12 * verts + 12 * tris) / double(total), 1e-3);
  }
  // Subdivision adds one vertex per edge: V1 = V0 + E0 > V0, and the BLAS grows.
  EXPECT_GT(v[1].at("vertices").get<uint64_t>(), v[0].at("vertices").get<uint64_t>());
  EXPECT_GT(v[1].at("blas_bytes").get<uint64_t>(), v[0].at("blas_bytes").get<uint64_t>());
}

TEST_F(BenchMemoryRun, TextTable) {
  const CliRun r = run_cli("bench-memory " + kElephant + " " + model_ + " --subdivide-targets ''");
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  for (const char* want : {"model block", "AABB BLAS", "total", "compacted", "5,558", "llvmpipe"})
    EXPECT_TRUE(has(r.out, want)) << want << " missing in:\n" << r.out;
}

}  // namespace
