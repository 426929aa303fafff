// `lsnif flip` as a user runs it: LDR and HDR pairs, text and JSON output, the heatmap file, and
// clear errors with the right exit codes (1 failure, 2 usage).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>

#include "lsnif/image/image_io.h"
#include "lsnif/testing/test_support.h"

namespace {

namespace fs = std::filesystem;
using lsnif::image::Image;

using CliResult = lsnif::test::CommandResult;  // out: stdout and stderr together

CliResult run_cli(const std::string& args) {
  return lsnif::test::run_command(std::string(LSNIF_CLI) + " " + args + " 2>&1");
}

class FlipCli : public ::testing::Test {
 protected:
  std::string path(const std::string& name) const { return dir_.path(name); }

  // A soft gradient; `noise` adds a fixed pattern of that amplitude.
  static Image picture(uint32_t w, uint32_t h, float noise, float scale = 1.0f) {
    Image img;
    img.width = w;
    img.height = h;
    img.rgb.resize(size_t(w) * h * 3);
    for (uint32_t y = 0; y < h; ++y)
      for (uint32_t x = 0; x < w; ++x)
        for (uint32_t c = 0; c < 3; ++c) {
          const float pattern = float(((x * 7 + y * 13 + c * 5) % 11)) / 10.0f - 0.5f;
          const float v = 0.2f + 0.6f * float(x + c * 3) / float(w) + noise * pattern;
          img.at(x, y)[c] = scale * std::max(0.0f, std::min(1.0f, v));
        }
    return img;
  }
  void save(const std::string& name, const Image& img) {
    ASSERT_TRUE(lsnif::image::save_image(path(name), img).is_ok()) << name;
  }

  lsnif::test::ScopedTestDir dir_{"lsnif_flip_cli_test"};
};

double json_number(const std::string& json, const std::string& key) {
  const size_t at = json.find("\"" + key + "\": ");
  if (at == std::string::npos) return -1.0;
  return std::stod(json.substr(at + key.size() + 4));
}

TEST_F(FlipCli, HelpAndUsage) {
  CliResult r = run_cli("flip --help");
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.out.find("usage: lsnif flip REFERENCE TEST"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("--heatmap"), std::string::npos) << r.out;
  r = run_cli("--help");
  EXPECT_NE(r.out.find("flip"), std::string::npos) << r.out;
  r = run_cli("flip");
  EXPECT_EQ(r.code, 2) << r.out;
  r = run_cli("flip a.png");
  EXPECT_EQ(r.code, 2) << r.out;
}

TEST_F(FlipCli, LdrPairTextJsonAndHeatmap) {
  save("ref.png", picture(64, 48, 0.0f));
  save("test.png", picture(64, 48, 0.1f));
  CliResult r = run_cli("flip " + path("ref.png") + " " + path("test.png") + " --heatmap " + path("heat.png"));
  ASSERT_EQ(r.code, 0) << r.out;
  for (const char* line : {"LDR-FLIP, 64 x 48, 67 pixels per degree", "mean ", "weighted median ",
                           "1st weighted quartile ", "3rd weighted quartile ", "min ", "max ", "heatmap "})
    EXPECT_NE(r.out.find(line), std::string::npos) << line << "\n" << r.out;
  Image heat;
  ASSERT_TRUE(lsnif::image::load_image(path("heat.png"), heat).is_ok());
  EXPECT_EQ(heat.width, 64u);
  EXPECT_EQ(heat.height, 48u);

  r = run_cli("flip " + path("ref.png") + " " + path("test.png") + " --json");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(r.out.front(), '{') << r.out;
  EXPECT_NE(r.out.find("\"metric\": \"LDR-FLIP\""), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("\"heatmap\": null"), std::string::npos) << r.out;
  const double mean = json_number(r.out, "mean"), median = json_number(r.out, "weighted_median");
  EXPECT_GT(mean, 0.0);
  EXPECT_LT(mean, 1.0);
  EXPECT_GE(median, json_number(r.out, "weighted_quartile1"));
  EXPECT_GE(json_number(r.out, "weighted_quartile3"), median);
  EXPECT_GE(json_number(r.out, "max"), json_number(r.out, "weighted_quartile3"));

  // More viewing distance (more pixels per degree) hides more of the fine noise.
  CliResult far = run_cli("flip " + path("ref.png") + " " + path("test.png") + " --json --ppd 200");
  ASSERT_EQ(far.code, 0) << far.out;
  EXPECT_LT(json_number(far.out, "mean"), mean);

  r = run_cli("flip " + path("ref.png") + " " + path("ref.png"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("mean                    0.000000"), std::string::npos) << r.out;
}

TEST_F(FlipCli, HdrPair) {
  save("ref.exr", picture(40, 30, 0.0f, 12.0f));
  save("test.exr", picture(40, 30, 0.05f, 12.0f));
  CliResult r = run_cli("flip " + path("ref.exr") + " " + path("test.exr"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("HDR-FLIP, 40 x 30"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("automatic, from the reference"), std::string::npos) << r.out;
  r = run_cli("flip " + path("ref.exr") + " " + path("test.exr") +
              " --json --start-exposure -3 --stop-exposure 1 --num-exposures 5 --heatmap " + path("h.exr"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(json_number(r.out, "start_exposure"), -3.0);
  EXPECT_EQ(json_number(r.out, "stop_exposure"), 1.0);
  EXPECT_EQ(json_number(r.out, "num_exposures"), 5.0);
  EXPECT_TRUE(fs::exists(path("h.exr")));
}

TEST_F(FlipCli, ClearErrors) {
  save("a.png", picture(32, 32, 0.0f));
  save("b.png", picture(32, 31, 0.0f));
  save("a.exr", picture(32, 32, 0.0f));
  CliResult r = run_cli("flip " + path("a.png") + " " + path("b.png"));
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("differ in size"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("32 x 31"), std::string::npos) << r.out;

  r = run_cli("flip " + path("a.png") + " " + path("a.exr"));
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("8-bit"), std::string::npos) << r.out;

  r = run_cli("flip " + path("a.png") + " " + path("missing.png"));
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("missing.png"), std::string::npos) << r.out;

  r = run_cli("flip " + path("a.png") + " " + path("a.png") + " --ppd 0");
  EXPECT_EQ(r.code, 2) << r.out;
  r = run_cli("flip " + path("a.png") + " " + path("a.png") + " --start-exposure 1");
  EXPECT_EQ(r.code, 2) << r.out;
  r = run_cli("flip " + path("a.exr") + " " + path("a.exr") + " --start-exposure lots");
  EXPECT_EQ(r.code, 2) << r.out;
  r = run_cli("flip " + path("a.exr") + " " + path("a.exr") + " --start-exposure 3 --stop-exposure 1");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("start exposure"), std::string::npos) << r.out;
  r = run_cli("flip " + path("a.png") + " " + path("a.png") + " --heatmap " + path("out.xyz"));
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("unknown image extension"), std::string::npos) << r.out;
}

}  // namespace
