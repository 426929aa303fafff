// The `lsnif` program as a user runs it: --help everywhere, a small src/lsnif/train/info/eval round trip,
// and clear errors with the right exit codes for bad input.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>

#include <nlohmann/json.hpp>

#include "lsnif/testing/test_support.h"

namespace {

namespace fs = std::filesystem;
const std::string kElephant = std::string(LSNIF_DATA_DIR) + "/meshes/elephant.off";

struct CliResult {
  int code = -1;
  std::string out;  // stdout and stderr together
};

// `env` (e.g. "VAR=value ") is put before the program on the shell command line.
CliResult run_cli(const std::string& args, const std::string& env = "") {
  CliResult r;
  std::string cmd = env + std::string(LSNIF_CLI) + " " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

fs::path temp_dir() {
  fs::path d = fs::temp_directory_path() / ("lsnif_cli_test_" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d;
}

// Trains a tiny elephant model (the --tiny preset: 30 steps, seconds) into `model`.
CliResult train_tiny(const std::string& model) {
  return run_cli("train " + kElephant + " -o " + model + " --tiny --quiet");
}

TEST(Cli, HelpForEveryCommand) {
  CliResult top = run_cli("--help");
  EXPECT_EQ(top.code, 0);
  for (const char* cmd : {"demo", "train", "eval", "info", "devices", "render", "flip", "bench", "view", "convert", "bench-trace", "bench-memory"}) {
    EXPECT_NE(top.out.find(cmd), std::string::npos) << cmd;
    CliResult r = run_cli(std::string(cmd) + " --help");
    EXPECT_EQ(r.code, 0) << cmd;
    EXPECT_NE(r.out.find(std::string("usage: lsnif ") + cmd), std::string::npos) << r.out;
  }
  // The presets, with what they set.
  for (const char* cmd : {"train", "convert"}) {
    CliResult r = run_cli(std::string(cmd) + " --help");
    EXPECT_NE(r.out.find("--quality TEXT"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("--paper "), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("--tiny                a tiny model trained in seconds, for tests and first trials: "
                         "--voxels 16 --res-min 32 --res-max 64 --table-log2 12 --width 32 --steps 30 --batch 1024\n"),
              std::string::npos)
        << r.out;
  }
}

// The program does not link OpenImageIO (its ~260 libraries cost ~0.4 s at every start): it opens
// the image module at its first image call, as `lsnif flip` on two PPM files shows.
TEST(Cli, OpenImageIOOnlyForImages) {
  lsnif::test::CommandResult r = lsnif::test::run_command("ldd " + std::string(LSNIF_CLI));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(r.out.find("libOpenImageIO"), std::string::npos) << r.out;
  const fs::path d = temp_dir();
  for (const char* name : {"a.ppm", "b.ppm"}) {
    std::ofstream f(d / name, std::ios::binary);
    f << "P6\n2 1\n255\n";
    f.write("\x10\x80\xf0\x10\x80\xf0", 6);
  }
  r = lsnif::test::run_command("LD_DEBUG=files " + std::string(LSNIF_CLI) + " flip " + (d / "a.ppm").string() + " " +
                               (d / "b.ppm").string() + " 2>&1");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("liblsnif_image_oiio.so"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("libOpenImageIO"), std::string::npos) << r.out;
  EXPECT_TRUE(std::regex_search(r.out, std::regex("\nmean +0\\.000000\n"))) << r.out;
}

// `lsnif demo` without its data folder (an installed lsnif away from the source tree): the folder
// is named with how to get the data, before anything is trained; an explicit --mesh does not need it.
TEST(Cli, DemoNamesAMissingDataFolder) {
  const fs::path d = temp_dir();
  const std::string nodata = (d / "nodata").string();
  CliResult r = run_cli("demo --data " + nodata);
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("the data folder " + nodata + " does not exist"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("scripts/setup.sh"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("--data DIR"), std::string::npos) << r.out;
  r = run_cli("demo --data " + nodata + " --mesh " + (d / "none.off").string() + " --no-render");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("none.off not found"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("data folder"), std::string::npos) << r.out;
  fs::remove_all(d);
}

// `lsnif devices` on this machine (lavapipe with ray tracing): llvmpipe is listed and supports
// the ray-tracing pipeline, in text and JSON; with the Vulkan driver hidden it fails with exit
// code 1 and says why.
TEST(Cli, DevicesListsLavapipeWithRayTracing) {
  CliResult r = run_cli("devices");
  ASSERT_EQ(r.code, 0) << r.out;
  const size_t at = r.out.find("llvmpipe");
  ASSERT_NE(at, std::string::npos) << r.out;
  const size_t rt = r.out.find("ray-tracing pipeline", at);
  ASSERT_NE(rt, std::string::npos) << r.out;
  EXPECT_EQ(r.out.compare(r.out.find_first_not_of(' ', rt + 20), 3, "yes"), 0) << r.out;
  for (const char* line : {"ray query", "primitive culling", "query broad phase       ray-query",
                           "batched MLP kernel", "NV cooperative matrix", "KHR cooperative matrix",
                           "NV cooperative vector", "driver", "Vulkan"})
    EXPECT_NE(r.out.find(line, at), std::string::npos) << line << "\n" << r.out;

  r = run_cli("devices --json");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(r.out.front(), '{') << r.out;
  const size_t name = r.out.find("\"name\": \"llvmpipe");
  ASSERT_NE(name, std::string::npos) << r.out;
  const size_t end = r.out.find('}', name);
  const std::string device = r.out.substr(name, end - name);
  EXPECT_NE(device.find("\"ray_tracing_pipeline\": true"), std::string::npos) << device;
  EXPECT_NE(device.find("\"ray_tracing_pipeline_missing\": []"), std::string::npos) << device;
  EXPECT_NE(device.find("\"ray_query\": "), std::string::npos) << device;
  EXPECT_NE(device.find("\"nv_cooperative_vector\": "), std::string::npos) << device;
  // lavapipe offers both broad phases of lsnifCmdQuery; the automatic choice takes ray queries.
  EXPECT_NE(device.find("\"ray_traversal_primitive_culling\": true"), std::string::npos) << device;
  EXPECT_NE(device.find("\"query_broad_phase\": \"ray-query\""), std::string::npos) << device;
  EXPECT_NE(device.find("\"mlp_kernel\": \"portable\""), std::string::npos) << device;

  r = run_cli("devices", "VK_DRIVER_FILES=/nonexistent/icd.json VK_ICD_FILENAMES=/nonexistent/icd.json ");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("no Vulkan driver"), std::string::npos) << r.out;

  r = run_cli("devices --frobnicate");
  EXPECT_EQ(r.code, 2) << r.out;
}

size_t occurrences(const std::string& text, const std::string& part) {
  size_t n = 0;
  for (size_t at = text.find(part); at != std::string::npos; at = text.find(part, at + part.size())) ++n;
  return n;
}

// The JSON object of the device `lsnif devices --json` marks as selected ("" when none).
std::string selected_device(const std::string& json) {
  const size_t mark = json.find("\"selected\": true");
  if (mark == std::string::npos) return "";
  const size_t begin = json.rfind('{', mark);
  return json.substr(begin, json.find('}', mark) + 1 - begin);
}

// The device the commands use: every command on a Vulkan device takes --device; `lsnif devices`
// marks exactly one device, automatically or as --device names it (by part of the name in any
// case, by index); a --device naming no device is an error that lists the devices, for `devices`
// and for `render`; naming lavapipe renders.
TEST(Cli, DeviceChoice) {
  for (const char* cmd : {"render", "view", "bench", "bench-trace", "bench-memory", "demo", "devices"}) {
    const CliResult help = run_cli(std::string(cmd) + " --help");
    EXPECT_NE(help.out.find("--device TEXT"), std::string::npos) << cmd << ":\n" << help.out;
  }
  CliResult r = run_cli("devices --json");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(occurrences(r.out, "\"selected\": true"), 1u) << r.out;
  EXPECT_EQ(occurrences(r.out, "\"selected\": "), occurrences(r.out, "\"index\": ")) << r.out;
  EXPECT_NE(r.out.find("\"selection\": \"automatic\""), std::string::npos) << r.out;
  r = run_cli("devices");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(occurrences(r.out, "* device "), 1u) << r.out;
  EXPECT_NE(r.out.find("automatic choice"), std::string::npos) << r.out;

  r = run_cli("devices --json --device LLVMpipe");
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string lavapipe = selected_device(r.out);
  ASSERT_NE(lavapipe.find("\"name\": \"llvmpipe"), std::string::npos) << r.out;
  const std::string index_key = "\"index\": ";
  const size_t index_at = lavapipe.find(index_key) + index_key.size();
  const std::string index = lavapipe.substr(index_at, lavapipe.find(',', index_at) - index_at);
  r = run_cli("devices --json --device " + index);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(selected_device(r.out), lavapipe) << r.out;
  for (const char* bad : {"99", "no-such-gpu"}) {
    r = run_cli(std::string("devices --device ") + bad);
    EXPECT_EQ(r.code, 1) << r.out;
    EXPECT_NE(r.out.find(std::string("'") + bad + "'"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("llvmpipe"), std::string::npos) << r.out;
  }

  if (!fs::exists(kElephant)) GTEST_SKIP() << kElephant << " missing: run scripts/setup.sh";
  const lsnif::test::ScopedTestDir dir("lsnif_cli_device");
  const std::string model = dir.path("elephant.lsnif"), image = dir.path("render.png");
  r = train_tiny(model);
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string render = "render " + std::string(LSNIF_SCENE_EXAMPLE) + " --lsnif bunny=" + model +
                             " --width 8 --height 8 --spp 1 -o " + image + " --device ";
  r = run_cli(render + "99");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("there is no device 99"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("'llvmpipe"), std::string::npos) << r.out;
  r = run_cli(render + "no-such-gpu");
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_NE(r.out.find("'no-such-gpu' matches no device"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("llvmpipe"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(image));
  r = run_cli(render + lsnif::test::test_device());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(fs::exists(image));
  EXPECT_NE(r.out.find("device           llvmpipe"), std::string::npos) << r.out;

  // The wavefront pipeline's broad phase: the automatic one (ray queries on lavapipe) or forced,
  // printed; a wrong name is a usage error before any work.
  for (const char* phase : {"auto", "trace-rays", "ray-query"}) {
    r = run_cli(render + lsnif::test::test_device() + " --pipeline wavefront --broad-phase " + phase);
    ASSERT_EQ(r.code, 0) << r.out;
    const std::string ran = std::string(phase) == "auto" ? "ray-query" : phase;
    EXPECT_NE(r.out.find("broad phase      " + ran + " (lsnifCmdQuery)"), std::string::npos) << r.out;
  }
  fs::remove(image);
  r = run_cli(render + lsnif::test::test_device() + " --pipeline wavefront --broad-phase sideways");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--broad-phase must be auto, trace-rays or ray-query, not 'sideways'"), std::string::npos)
      << r.out;
  EXPECT_FALSE(fs::exists(image));
}

TEST(Cli, UsageErrors) {
  CliResult r = run_cli("frobnicate");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("unknown command"), std::string::npos);
  r = run_cli("train mesh.off -o x.lsnif --no-such-option");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("--no-such-option"), std::string::npos);
  r = run_cli("train mesh.off -o x.lsnif --steps many");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("--steps"), std::string::npos);
  r = run_cli("train mesh.off");
  EXPECT_EQ(r.code, 2);
  r = run_cli("train mesh.off -o x.lsnif --voxels 32 --res-min 40 --res-max 40");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("multiple of the voxel resolution"), std::string::npos) << r.out;
}

TEST(Cli, BadInputFiles) {
  fs::path d = temp_dir();
  CliResult r = run_cli("train " + (d / "missing.off").string() + " -o " + (d / "m.lsnif").string());
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.out.find("missing.off"), std::string::npos) << r.out;
  std::ofstream(d / "garbage.lsnif") << "this is not a model";
  r = run_cli("info " + (d / "garbage.lsnif").string());
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.out.find("garbage.lsnif"), std::string::npos) << r.out;
  fs::remove_all(d);
}

TEST(Cli, TrainWithinATimeBudget) {
  // The run plans the steps that fit, records them in the model and prints them with the held-out
  // metrics; out-of-range budgets are refused before any work.
  if (!fs::exists(kElephant)) GTEST_SKIP() << kElephant << " missing: run scripts/setup.sh";
  fs::path d = temp_dir();
  const std::string model = (d / "b.lsnif").string();
  const std::string base = "train " + kElephant + " -o " + model +
                           " --voxels 16 --res-min 32 --res-max 64 --table-log2 12 --width 16 --batch 256 --quiet";
  CliResult r = run_cli(base + " --steps 1000000 --time-budget 1");
  ASSERT_EQ(r.code, 0) << r.out;
  unsigned planned = 0, run = 0, most = 0;
  const size_t at = r.out.find("budget    1.0 s: ");
  ASSERT_NE(at, std::string::npos) << r.out;
  ASSERT_EQ(std::sscanf(r.out.c_str() + at, "budget    1.0 s: %u steps planned (of at most %u), %u run", &planned,
                        &most, &run), 3) << r.out;
  EXPECT_EQ(most, 1000000u);
  EXPECT_GE(planned, 8u);
  EXPECT_LT(planned, most);
  EXPECT_LE(run, planned);
  EXPECT_NE(r.out.find("eval      occlusion "), std::string::npos) << r.out;
  // The model's record holds the planned steps (its learning-rate schedule's).
  r = run_cli("info " + model);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find(" steps=" + std::to_string(planned) + " "), std::string::npos) << r.out;
  for (const char* bad : {"-1", "1e9", "nan"}) {
    r = run_cli(base + " --steps 10 --time-budget " + bad);
    EXPECT_EQ(r.code, 2) << bad << ": " << r.out;
    EXPECT_NE(r.out.find("--time-budget"), std::string::npos) << bad << ": " << r.out;
  }
  fs::remove_all(d);
}

TEST(Cli, TrainingOptionsReachTheTrainer) {
  // Each option must show up in the settings line the trainer reports (a parsed but dropped
  // option once went unnoticed).
  if (!fs::exists(kElephant)) GTEST_SKIP() << kElephant << " missing: run scripts/setup.sh";
  fs::path d = temp_dir();
  // Not --tiny: one step is all these runs need, and they give --batch themselves, which --tiny
  // would refuse (a preset and a value it sets contradict each other).
  const std::string base = "train " + kElephant + " -o " + (d / "o.lsnif").string() +
                           " --voxels 16 --res-min 32 --res-max 64 --table-log2 12 --width 16 --steps 1 --quiet";
  CliResult r = run_cli(base + " --batch 256 --normal-loss cosine --ray-reuse 2 --hit aabb --seed 7 --lr 0.003");
  ASSERT_EQ(r.code, 0) << r.out;
  for (const char* want : {"normal loss cosine", "ray_reuse=2", "hit=aabb", "seed=7", "lr=0.003", "batch=256", "V=16"})
    EXPECT_NE(r.out.find(want), std::string::npos) << want << " missing in:\n" << r.out;
  r = run_cli(base + " --batch 256");
  ASSERT_EQ(r.code, 0) << r.out;
  for (const char* want : {"normal loss angle", "ray_reuse=1", "hit=segments"})
    EXPECT_NE(r.out.find(want), std::string::npos) << want << " missing in:\n" << r.out;
  r = run_cli(base + " --normal-loss sideways");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("--normal-loss"), std::string::npos) << r.out;
  // The paper's low-quality configuration: W = 64 and H = 10 in the saved model, the same option
  // combined with --width or --points refused, an unknown quality named.
  // (Not --tiny: one step of 256 rays is all these runs need, fewer than its 30 of 1024.)
  const std::string quality = "train " + kElephant + " -o " + (d / "q.lsnif").string() +
                              " --voxels 16 --res-min 32 --res-max 64 --table-log2 12 --steps 1 --batch 256 --quiet";
  r = run_cli(quality + " --quality low");
  ASSERT_EQ(r.code, 0) << r.out;
  r = run_cli("info --json " + (d / "q.lsnif").string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("\"hidden_width\": 64"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("\"max_points\": 10"), std::string::npos) << r.out;
  r = run_cli(quality + " --quality low --width 32");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--quality low sets --width 64 and --points 10"), std::string::npos) << r.out;
  r = run_cli(quality + " --quality medium");
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--quality must be 'high' or 'low'"), std::string::npos) << r.out;
  fs::remove_all(d);
}

TEST(Cli, TrainInfoEvalRoundTrip) {
  if (!fs::exists(kElephant)) GTEST_SKIP() << kElephant << " missing: run scripts/setup.sh";
  fs::path d = temp_dir();
  const std::string model = (d / "elephant.lsnif").string();
  CliResult r = train_tiny(model);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(fs::exists(model));
  EXPECT_TRUE(fs::exists(model + ".csv"));
  {
    std::ifstream csv(model + ".csv");
    std::string header, line;
    std::getline(csv, header);
    EXPECT_NE(header.find("occlusion"), std::string::npos);
    int rows = 0;
    while (std::getline(csv, line)) ++rows;
    EXPECT_EQ(rows, 30);
  }
  r = run_cli("info " + model);
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("V=16"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("total"), std::string::npos);
  r = run_cli("info --json " + model);
  EXPECT_EQ(r.code, 0);
  EXPECT_EQ(r.out.front(), '{');
  EXPECT_EQ(r.out.find("grid_usage"), std::string::npos) << "only with --grid-usage";
  r = run_cli("info --json --grid-usage " + model);
  EXPECT_EQ(r.code, 0) << r.out;
  {
    // Per level, in order: its resolution first, then its counts.
    const nlohmann::ordered_json j = nlohmann::ordered_json::parse(r.out, nullptr, false);
    ASSERT_TRUE(j.is_object()) << r.out;
    const nlohmann::ordered_json& usage = j["grid_usage"];
    ASSERT_TRUE(usage.is_array() && usage.size() >= 2) << r.out;
    EXPECT_EQ(usage[0].begin().key(), "resolution") << r.out;
    EXPECT_EQ(usage[0]["resolution"], 32) << r.out;
    EXPECT_TRUE(usage[0]["vertices"].is_number_unsigned()) << r.out;
    EXPECT_EQ(usage[1]["resolution"], 64) << r.out;
    EXPECT_TRUE(usage[1]["indexed_slots"].is_number_unsigned()) << r.out;
  }
  r = run_cli("info --grid-usage " + model);
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("level 1 (R=64)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("collision-free (indexed): "), std::string::npos) << r.out;
  r = run_cli("eval " + model + " " + kElephant + " --rays 2000 --json");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("\"voxel_baseline\""), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("\"accuracy\""), std::string::npos);
  fs::remove_all(d);
}

// Texture coordinates from the command line: `train --texture-coordinates auto` of a textured glTF
// says which materials report them and writes a version 7 model, `info` lists its uv cells (their
// bytes counted in the total), `eval` reports the texel error and wrong-chart share of the material.
TEST(Cli, TextureCoordinatesTrainInfoEval) {
  const std::string box = std::string(LSNIF_DATA_DIR) + "/gltf/BoxTextured-glTF/BoxTextured.gltf";
  if (!fs::exists(box)) GTEST_SKIP() << box << " missing: run scripts/setup.sh";
  fs::path d = temp_dir();
  const std::string model = (d / "box.lsnif").string();
  CliResult r = run_cli("train " + box + " -o " + model + " --tiny --quiet --texture-coordinates auto --uv-cells 1");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("materials 0x1 report texture coordinates (uv cells: 1 per voxel edge)"), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("; uv cells "), std::string::npos) << r.out;
  r = run_cli("info " + model);
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("uv-materials=0x1 uv-cells=1"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("(uv cells: 1 per voxel edge, "), std::string::npos) << r.out;
  r = run_cli("info --json " + model);
  EXPECT_EQ(r.code, 0) << r.out;
  const nlohmann::ordered_json j = nlohmann::ordered_json::parse(r.out, nullptr, false);
  ASSERT_TRUE(j.is_object()) << r.out;
  const auto& bytes = j["bytes"];
  EXPECT_GT(bytes["uv_cells"].get<uint64_t>(), 0u) << r.out;
  EXPECT_EQ(bytes["total"].get<uint64_t>(), bytes["voxels"].get<uint64_t>() + bytes["grid"].get<uint64_t>() +
                                                bytes["mlp"].get<uint64_t>() + bytes["header"].get<uint64_t>() +
                                                bytes["uv_cells"].get<uint64_t>());
  r = run_cli("eval " + model + " " + box + " --rays 2000");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("uv material 0 "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("wrong chart"), std::string::npos) << r.out;
  fs::remove_all(d);
}

// `lsnif render` and the render part of `lsnif demo` on lavapipe with a tiny model: an image is
// written in LSNIF mode; reference mode or rasterized primary visibility of a node without a mesh,
// a bad --primary, a missing scene, a malformed or unknown --lsnif override give clear errors with
// the right exit codes.
TEST(Cli, RenderAndDemoWithATinyModel) {
  if (!fs::exists(kElephant)) GTEST_SKIP() << kElephant << " missing: run scripts/setup.sh";
  fs::path d = temp_dir();
  const std::string model = (d / "elephant.lsnif").string();
  CliResult r = train_tiny(model);
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string scene = std::string(LSNIF_SCENE_EXAMPLE);
  const std::string image = (d / "render.png").string();
  r = run_cli("render " + scene + " --lsnif bunny=" + model + " --width 32 --height 24 --spp 2 -o " + image);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(fs::exists(image));
  EXPECT_NE(r.out.find("ms per sample"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("1 LSNIF"), std::string::npos) << r.out;
  // The automatic choice, printed: lavapipe runs lsnifCmdQuery (ray queries), and the node keeps no
  // mesh to rasterize.
  EXPECT_NE(r.out.find("wavefront pipeline, traced primary"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("pipeline choice  wavefront: the device runs lsnifCmdQuery (ray-query broad phase); traced "
                       "primary: LSNIF node 'bunny' keeps no triangle mesh"),
            std::string::npos)
      << r.out;
  // The wavefront pipeline's stage times: reported with --stage-times, refused for the inline one.
  r = run_cli("render " + scene + " --lsnif bunny=" + model +
              " --width 16 --height 12 --spp 1 --pipeline wavefront --stage-times -o " + image);
  ASSERT_EQ(r.code, 0) << r.out;
  for (const char* want : {"stages (device)", "broad phase", "encode", "MLP", "total"})
    EXPECT_NE(r.out.find(want), std::string::npos) << want << " missing in:\n" << r.out;
  r = run_cli("render " + scene + " --lsnif bunny=" + model +
              " --pipeline inline --width 8 --height 8 --spp 1 --stage-times -o " + image);
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_NE(r.out.find("--stage-times needs the wavefront pipeline"), std::string::npos) << r.out;
  r = run_cli("render " + scene + " --lsnif bunny=" + model + " --reference --width 8 --height 8 --spp 1 -o " + image);
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.out.find("bunny"), std::string::npos) << r.out;
  // Rasterized primary visibility needs the LSNIF node's mesh, which this scene lacks.
  r = run_cli("render " + scene + " --lsnif bunny=" + model + " --primary raster --width 8 --height 8 --spp 1 -o " +
              image);
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.out.find("'bunny' has no triangle mesh"), std::string::npos) << r.out;
  r = run_cli("render " + scene + " --lsnif bunny=" + model + " --primary rasterized -o " + image);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("--primary must be auto, traced or raster"), std::string::npos) << r.out;
  r = run_cli("render " + (d / "nothing.gltf").string() + " -o " + image);
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.out.find("nothing.gltf"), std::string::npos) << r.out;
  r = run_cli("render " + scene + " --lsnif bunny -o " + image);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("--lsnif"), std::string::npos) << r.out;
  r = run_cli("render " + scene + " --lsnif nobody=" + model + " -o " + image);
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.out.find("nobody"), std::string::npos) << r.out;
  // The demo's render comparison on the elephant with the tiny model (reused, not retrained).
  const std::string picture = (d / "compare.png").string();
  r = run_cli("demo --reuse --mesh " + kElephant + " -o " + model +
              " --eval-rays 1000 --image-width 32 --image-height 24 --spp 2 --picture " + picture);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(fs::exists(picture));
  for (const char* want : {"reusing", "LDR-FLIP", "geometry memory", "ms per sample", "summary:"})
    EXPECT_NE(r.out.find(want), std::string::npos) << want << " missing in:\n" << r.out;
  // The object on the ground keeps its mesh: the default is the wavefront pipeline with rasterized
  // primary visibility against the inline triangle reference, and the inline path is the second row.
  EXPECT_TRUE(fs::exists(d / "compare_inline.png"));
  const auto line_of = [](const std::string& out, const std::string& label) {
    const size_t at = out.find("  " + label + " ");
    return at == std::string::npos ? std::string() : out.substr(at, out.find('\n', at) - at);
  };
  for (const auto& [label, path] : {std::pair{"reference (triangles)", "inline, traced"},
                                    std::pair{"LSNIF (default)", "wavefront, raster"},
                                    std::pair{"LSNIF (inline path)", "inline, traced"}})
    EXPECT_NE(line_of(r.out, label).find(path), std::string::npos) << label << ": " << path << " missing in:\n" << r.out;
  // Forced, the inline path is the only LSNIF row.
  r = run_cli("demo --reuse --mesh " + kElephant + " -o " + model + " --eval-rays 1000 --image-width 16 "
              "--image-height 12 --spp 1 --pipeline inline --primary traced --picture " + picture);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("forced by --pipeline inline and --primary traced"), std::string::npos) << r.out;
  EXPECT_NE(line_of(r.out, "LSNIF (default)").find("inline, traced"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("LSNIF (inline path)"), std::string::npos) << r.out;
  fs::remove_all(d);
}

}  // namespace
