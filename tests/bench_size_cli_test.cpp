// `lsnif bench-size` as a user runs it: a quick run on the bunny with two settings in a temporary
// folder writes results.md, whose cells are checked against independent truths: the model files'
// sizes, `lsnif bench-memory` (the plugin's upload) for the device bytes, the mesh files' triangle
// counts for the heavy scene, and the table's own ratios; a second run reuses the models; bad
// settings, meshes and missing data are clear errors.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "lsnif/testing/test_support.h"

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using lsnif::test::number;
using lsnif::test::read_text;
using lsnif::test::off_faces;
using lsnif::test::table_row;
const std::string kData = LSNIF_DATA_DIR;
const std::string kBunny = kData + "/meshes/bunny00.off";

lsnif::test::CommandResult run_cli(const std::string& args) {
  return lsnif::test::run_command(std::string(LSNIF_CLI) + " " + args + " 2>&1");
}

bool has(const std::string& text, const std::string& what) { return text.find(what) != std::string::npos; }

TEST(BenchSizeCli, QuickBunnyTableMatchesTheFilesAndTheDevice) {
  for (const char* f : {"bunny00.off", "armadillo.off", "ChineseDragon-10kv.off"})
    if (!fs::exists(kData + "/meshes/" + f)) GTEST_SKIP() << f << " missing: run scripts/setup.sh";
  lsnif::test::ScopedTestDir dir("lsnif_bench_size_cli_test");
  const std::string out = dir.path().string();
  // The baseline is the paper's grid (a named setting); the second setting's list value keeps its
  // comma; its hashed levels' tables differ in size (version 4).
  const std::string small_name = "grid-bits=8+indexed=0+table-log2=10,12";
  const std::string settings = "fp16-hashed," + small_name;
  lsnif::test::CommandResult r = run_cli("bench-size bunny --quick --settings " + settings + " --out " + out);
  ASSERT_EQ(r.code, 0) << r.out;
  for (const char* want : {"model     training", "render (LSNIF)", "LDR-FLIP", "results.md"})
    EXPECT_TRUE(has(r.out, want)) << want << " missing in:\n" << r.out;

  const std::string md = read_text(dir.path() / "results.md");
  const std::vector<std::string> base = table_row(md, "| bunny | fp16-hashed |");
  const std::vector<std::string> small = table_row(md, "| bunny | " + small_name + " |");
  ASSERT_EQ(base.size(), 11u) << md;
  ASSERT_EQ(small.size(), 11u) << md;
  // Model bytes: the files themselves.
  const fs::path base_model = dir.path() / "bunny" / "fp16-hashed.lsnif";
  const fs::path small_model = dir.path() / "bunny" / (small_name + ".lsnif");
  ASSERT_TRUE(fs::exists(base_model) && fs::exists(small_model)) << md;
  EXPECT_EQ(number(base[2]), double(fs::file_size(base_model)));
  EXPECT_EQ(number(small[2]), double(fs::file_size(small_model)));
  // 2^10 + 2^12 entries instead of 2 x 2^12 (--quick), at a byte each instead of two.
  EXPECT_LT(fs::file_size(small_model), fs::file_size(base_model));
  EXPECT_EQ(read_text(small_model)[8], 4);
  EXPECT_EQ(base[3], "1.00x");
  EXPECT_NEAR(number(small[3].substr(0, small[3].size() - 1)),
              double(fs::file_size(base_model)) / double(fs::file_size(small_model)), 0.006);
  for (const auto& [row, model] : {std::pair{&base, base_model}, std::pair{&small, small_model}}) {
    const std::vector<std::string>& c = *row;
    // FLOPs per evaluation from the layer shapes `lsnif info` reads from the file: H*L*F inputs,
    // hidden layers of W, 8 + Nmat outputs.
    r = lsnif::test::run_command(std::string(LSNIF_CLI) + " info " + model.string() + " --json 2>/dev/null");
    ASSERT_EQ(r.code, 0) << r.out;
    const json info = json::parse(r.out);
    const double in = info["max_points"].get<double>() * info["grid_levels"].get<double>() *
                      info["features"].get<double>();
    const double w = info["hidden_width"].get<double>(), layers = info["hidden_layers"].get<double>();
    const double flops = 2.0 * (in * w + (layers - 1.0) * w * w + w * (8.0 + info["material_count"].get<double>()));
    EXPECT_NEAR(number(c[4]), flops * 1e-3, 0.051) << c[4];
    EXPECT_NEAR(number(c[5].substr(0, c[5].size() - 1)), 100.0 * flops / 62720.0, 0.51) << c[5];
    const double accuracy = number(c[6].substr(0, c[6].size() - 1));
    EXPECT_GT(accuracy, 50.0);
    EXPECT_LE(accuracy, 100.0);
    EXPECT_GE(number(c[7].substr(0, c[7].size() - 1)), 0.0);
    EXPECT_GE(number(c[8]), 0.0);
    EXPECT_GT(number(c[9]), 0.0);
    EXPECT_LT(number(c[9]), 0.5);  // a render that lost the object entirely would be far off here
  }
  EXPECT_EQ(base[10], "+0.0000");
  EXPECT_NEAR(number(small[10]), number(small[9]) - number(base[9]), 1.5e-4);

  // The memory table: device bytes as `lsnif bench-memory` measures them (the plugin's upload of
  // the same file, a separate path from the renderer's statistics); the heavy scene's triangles
  // from the mesh files (2, 2 and 3 levels of 1-to-4 subdivision).
  const uint64_t heavy_triangles = off_faces(kBunny) * 16 + off_faces(kData + "/meshes/armadillo.off") * 16 +
                                   off_faces(kData + "/meshes/ChineseDragon-10kv.off") * 64;
  ASSERT_GT(heavy_triangles, 1000000u);
  for (const auto& [name, model] : {std::pair{std::string("fp16-hashed"), base_model},
                                    std::pair{small_name, small_model}}) {
    const std::vector<std::string> h = table_row(md, "| " + name + " | ");
    ASSERT_EQ(h.size(), 6u) << md;
    r = lsnif::test::run_command(std::string(LSNIF_CLI) + " bench-memory " + kBunny + " " + model.string() +
                                 " --subdivide-targets '' --json 2>/dev/null");
    ASSERT_EQ(r.code, 0) << r.out;
    const json mem = json::parse(r.out);
    const double device_bytes = mem["lsnif"]["total_bytes"].get<double>();
    EXPECT_EQ(number(h[1]), device_bytes) << name;
    EXPECT_EQ(number(h[2]), double(heavy_triangles)) << name;
    const double blas = number(h[3]) * 1048576.0;
    EXPECT_GT(blas, 50.0 * double(heavy_triangles));  // a BLAS keeps at least its triangles' vertices
    EXPECT_NEAR(number(h[4]), blas / device_bytes, 0.002 * number(h[4])) << name;
    EXPECT_NEAR(number(h[5].substr(0, h[5].find(' '))), blas / (3.0 * device_bytes), 0.002 * blas / (3.0 * device_bytes)) << name;
    EXPECT_TRUE(has(h[5], "(3 models)")) << h[5];
  }
  EXPECT_TRUE(fs::exists(dir.path() / "bunny-fp16-hashed.png"));
  EXPECT_TRUE(has(md, "![bunny fp16-hashed](bunny-fp16-hashed.png)")) << md;

  // Run again: the models are reused, not retrained.
  const auto model_time = fs::last_write_time(base_model);
  r = run_cli("bench-size bunny --quick --settings " + settings + " --spp 1 --out " + out);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(has(r.out, "model     reusing")) << r.out;
  EXPECT_FALSE(has(r.out, "model     training")) << r.out;
  EXPECT_EQ(fs::last_write_time(base_model), model_time);
  EXPECT_TRUE(has(read_text(dir.path() / "results.md"), "reused (same mesh and settings)"));
}

TEST(BenchSizeCli, BadSettingsMeshesAndMissingData) {
  lsnif::test::ScopedTestDir dir("lsnif_bench_size_cli_test");
  const std::string out = (dir.path() / "out").string();
  struct Case {
    std::string args, message;
  };
  const Case cases[] = {
      {"--settings default,teapot", "unknown setting 'teapot'"},
      {"--settings default,default", "'default' appears twice"},
      {"--settings default,,b8", "empty entry"},
      {"--settings grid-bits=9", "grid-bits"},
      {"--settings grid-bits=8+", "malformed"},
      {"--settings colour=8", "unknown setting 'colour'"},
      {"--settings table-log2=many", "invalid value 'many' for table-log2"},
      {"--settings table-log2=30", "table-log2"},
      {"--settings table-log2=15,30", "table-log2 15,30: 30 (level 1) out of range"},
      {"--settings table-log2=15,16,17", "table-log2 15,16,17 gives 3 values for 2 levels"},
      {"--settings default,17", "unknown setting '17'"},
      {"unicorn", "unknown mesh 'unicorn'"},
  };
  for (const Case& c : cases) {
    const lsnif::test::CommandResult r = run_cli("bench-size " + c.args + " --quick --out " + out);
    EXPECT_EQ(r.code, 2) << c.args << "\n" << r.out;
    EXPECT_TRUE(has(r.out, c.message)) << c.args << "\n" << r.out;
    EXPECT_FALSE(fs::exists(out)) << c.args;
  }
  const fs::path nodata = dir.path() / "nodata";
  fs::create_directories(nodata);
  const lsnif::test::CommandResult r = run_cli("bench-size dragon --quick --data " + nodata.string() + " --out " + out);
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(has(r.out, "nodata/meshes/")) << r.out;
  EXPECT_TRUE(has(r.out, "run scripts/setup.sh")) << r.out;
  EXPECT_FALSE(fs::exists(out));
}

}  // namespace
