// convert_integrity_cli_test.cpp -- `lsnif convert` keeps only what it can prove: a model whose
// sidecar is of another run (the state a kill between the model's and the sidecar's rename leaves)
// is retrained, not reported up to date; temporary files of an interrupted run are removed and
// logged; two runs on one output folder never interleave (the second fails at once, naming the
// lock). And what the tools show of a model is checked on load: a training record edited against
// its header fails `lsnif info` and `lsnif info --settings`; a training run that diverges ends its
// progress bar at the step it reached, not at 100%.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <memory>
#include <regex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "lsnif/testing/test_support.h"

namespace {

namespace fs = std::filesystem;
using lsnif::test::ProcessResult;

const fs::path kExample = fs::path(__FILE__).parent_path().parent_path() / "samples/scenes/bunny_on_plane.gltf";
const std::string kElephant = std::string(LSNIF_DATA_DIR) + "/meshes/elephant.off";
// The converter's model of the example's ground quad, and the lock file of its output folder.
const std::string kModel = "scene.ground_quad.lsnif";
const std::string kLock = ".lsnif-convert.lock";

ProcessResult lsnif_run(std::vector<std::string> args) {
  args.insert(args.begin(), LSNIF_CLI);
  return lsnif::test::run_process(args, 120.0, 0, {"MESA_SHADER_CACHE_DISABLE=true"});
}

// Expects a clean failure: exit code `code`, no signal, and `message` in the output.
#define EXPECT_FAILS_WITH(result, code, message)                                                      \
  do {                                                                                                \
    const ProcessResult& r_ = (result);                                                               \
    EXPECT_FALSE(r_.crashed()) << "signal " << r_.signal << "\n" << r_.output;                        \
    EXPECT_EQ(r_.exit_code, code) << r_.output;                                                       \
    EXPECT_NE(r_.output.find(message), std::string::npos) << "expected '" << (message) << "' in\n" << r_.output; \
  } while (0)

// The seed a model records, as `lsnif info --settings` prints it (-1 when it does not).
int64_t recorded_seed(const std::string& model) {
  const ProcessResult r = lsnif_run({"info", model, "--settings"});
  EXPECT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json j = nlohmann::json::parse(r.output, nullptr, false);
  return j.is_object() && j.contains("seed") ? j["seed"].get<int64_t>() : -1;
}

// The seed of the settings a sidecar holds (-1 when it holds none).
int64_t sidecar_seed(const std::string& model) {
  const nlohmann::json j = nlohmann::json::parse(lsnif::test::read_text(model + ".json"), nullptr, false);
  return j.is_object() && j.contains("settings") && j["settings"].contains("seed") ? j["settings"]["seed"].get<int64_t>()
                                                                                   : -1;
}

class ConvertIntegrityCli : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(kElephant)) GTEST_SKIP() << kElephant << " missing: run scripts/setup.sh";
    dir_ = std::make_unique<lsnif::test::ScopedTestDir>("lsnif_convert_integrity");
    fs::create_directories(dir_->path() / "in");
    fs::copy_file(kExample, dir_->path() / "in/scene.gltf");
    // The bunny's model only has to exist with the right magic for the scene to load.
    std::ofstream(dir_->path("in/bunny.lsnif"), std::ios::binary) << std::string("LSNIF\0\r\n", 8) << "rest";
  }
  std::string path(const std::string& name) const { return dir_->path(name); }

  // `lsnif convert` of the example into FOLDER/scene.gltf: the ground quad becomes a model trained
  // with `training` (the tiny preset by default) and `seed`.
  ProcessResult convert(const std::string& folder, int seed, std::vector<std::string> training = {"--tiny"}) const {
    std::vector<std::string> args = {"convert", path("in/scene.gltf"), "-o", path(folder + "/scene.gltf"),
                                     "--convert-when", "triangles", "--min-triangles", "1", "--eval-rays", "200",
                                     "--allow-outside-refs", "--quiet", "--seed", std::to_string(seed)};
    args.insert(args.end(), training.begin(), training.end());
    return lsnif_run(args);
  }

  std::unique_ptr<lsnif::test::ScopedTestDir> dir_;
};

// A run killed between renaming the model and renaming its sidecar leaves the model of its seed
// beside the sidecar of the run before. A rerun with the earlier seed finds a sidecar that matches
// its settings, but the model says otherwise: it is retrained, never kept. (The reverse, a model of
// the settings beside a sidecar of another seed, is src/lsnif/apps/convert/convert_test.cpp's.)
TEST_F(ConvertIntegrityCli, AModelItsSidecarDisagreesWithIsRetrained) {
  for (const int seed : {3, 5}) {
    const std::string folder = "seed" + std::to_string(seed);
    const ProcessResult r = convert(folder, seed);
    ASSERT_EQ(r.exit_code, 0) << r.output;
    ASSERT_EQ(recorded_seed(path(folder + "/" + kModel)), seed);
    ASSERT_EQ(sidecar_seed(path(folder + "/" + kModel)), seed);
  }
  // The seed 3 run's folder with the model of a seed 5 run swapped in.
  fs::copy_file(path("seed5/" + kModel), path("seed3/" + kModel), fs::copy_options::overwrite_existing);
  const std::string model = path("seed3/" + kModel);
  ASSERT_EQ(recorded_seed(model), 5);
  ASSERT_EQ(sidecar_seed(model), 3);

  ProcessResult r = convert("seed3", 3);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("trained   1, up to date 0, failed 0"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("retrained: the model on disk is not of these settings and this mesh: it records seed=5, "
                          "the settings give seed=3"), std::string::npos) << r.output;
  EXPECT_EQ(recorded_seed(model), 3);
  EXPECT_EQ(sidecar_seed(model), 3);
  // Consistent now: the next run keeps it.
  r = convert("seed3", 3);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("trained   0, up to date 1, failed 0"), std::string::npos) << r.output;
}

// Temporary files an interrupted run left (the atomic writer's ".NAME.tmp-" + 12 hex digits) of the
// files a conversion writes are removed and logged; other files, even of the same pattern for
// another kind of file, are not. No lock file stays behind.
TEST_F(ConvertIntegrityCli, LeftoverTemporaryFilesAreRemovedAndLogged) {
  ProcessResult r = convert("out", 3);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::vector<std::string> stale = {"." + kModel + ".tmp-0123456789ab", "." + kModel + ".json.tmp-00000000ffff",
                                          ".scene.gltf.tmp-abcdefabcdef", ".scene.bin.tmp-a1b2c3d4e5f6"};
  const std::vector<std::string> kept = {".notes.txt.tmp-0123456789ab", "." + kModel + ".tmp-xyz", "notes.tmp"};
  for (const std::string& name : stale) std::ofstream(path("out/" + name)) << "partial";
  for (const std::string& name : kept) std::ofstream(path("out/" + name)) << "someone else's";
  r = convert("out", 3);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("trained   0, up to date 1, failed 0"), std::string::npos) << r.output;
  for (const std::string& name : stale) {
    EXPECT_FALSE(fs::exists(path("out/" + name))) << name;
    EXPECT_NE(r.output.find("cleanup   removed " + path("out/" + name)), std::string::npos) << r.output;
  }
  for (const std::string& name : kept) EXPECT_TRUE(fs::exists(path("out/" + name))) << name;
  EXPECT_FALSE(fs::exists(path("out/" + kLock)));
}

// Two runs on one output folder: the one that comes second fails at once, naming the folder and
// the lock; the first finishes, and what is left is its model with its own sidecar.
TEST_F(ConvertIntegrityCli, ConcurrentRunsOnOneFolderDoNotInterleave) {
  // The first run trains longer than the tiny preset (its settings with twice the steps: seconds),
  // so that the second, started once the first holds the folder, finds it still held.
  const std::vector<std::string> longer = {"--voxels", "16", "--res-min", "32", "--res-max", "64", "--table-log2", "12",
                                           "--width", "32", "--batch", "1024", "--steps", "60"};
  ProcessResult first;
  std::thread t([&] { first = convert("out", 3, longer); });
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (!fs::exists(path("out/" + kLock)) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  const bool overlapped = fs::exists(path("out/" + kLock));
  const ProcessResult second = convert("out", 5);
  t.join();
  ASSERT_TRUE(overlapped) << "the first run never held the folder:\n" << first.output;
  EXPECT_EQ(first.exit_code, 0) << first.output;
  EXPECT_FAILS_WITH(second, 1, "another lsnif convert is writing into the output folder '" + path("out") + "'");
  EXPECT_NE(second.output.find(path("out/" + kLock)), std::string::npos) << second.output;
  EXPECT_EQ(second.output.find("trained   "), std::string::npos) << second.output;  // no summary: it stopped
  const std::string model = path("out/" + kModel);
  EXPECT_EQ(recorded_seed(model), 3);
  EXPECT_EQ(sidecar_seed(model), 3);
  EXPECT_FALSE(fs::exists(path("out/" + kLock)));
}

// A training record edited against the header (the checksum recomputed): `lsnif info` and `lsnif info
// --settings` fail naming the file, the setting and both values, instead of showing it or handing it
// to `lsnif train --config`.
TEST_F(ConvertIntegrityCli, AnEditedTrainingRecordFailsToLoad) {
  const std::string model = path("m.lsnif");
  ProcessResult r = lsnif_run({"train", kElephant, "-o", model, "--tiny", "--quiet"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string good = lsnif::test::read_text(model);
  const size_t at = good.find("\"voxels\":16,");  // the tiny preset's V=16
  ASSERT_NE(at, std::string::npos);
  for (const auto& [edit, message] : {std::pair<std::string, std::string>{"\"voxels\":-5,", "voxels: must be an unsigned integer, not -5"},
                                      {"\"voxels\":32,", "voxels is 32, the header's voxel resolution is 16"}}) {
    SCOPED_TRACE(edit);
    std::string bytes = good;
    bytes.replace(at, edit.size(), edit);
    lsnif::test::fix_model_crc(bytes);
    const std::string edited = path("edited.lsnif");
    std::ofstream(edited, std::ios::binary) << bytes;
    for (const std::vector<std::string>& args : {std::vector<std::string>{"info", edited},
                                                 std::vector<std::string>{"info", edited, "--settings"}}) {
      r = lsnif_run(args);
      EXPECT_FAILS_WITH(r, 1, message);
      EXPECT_NE(r.output.find(edited), std::string::npos) << r.output;
      EXPECT_EQ(r.output.find("\"seed\""), std::string::npos) << r.output;  // no settings printed
    }
  }
}

// A run that diverges at step N (a huge learning rate) ends its progress bar at the N - 1 steps it
// completed, with "failed", not at 100%.
TEST_F(ConvertIntegrityCli, ADivergingRunEndsItsBarWhereItStopped) {
  const ProcessResult r = lsnif_run({"train", kElephant, "-o", path("lr.lsnif"), "--tiny", "--lr", "1e30"});
  EXPECT_FAILS_WITH(r, 1, "training diverged");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(r.output, m, std::regex("the loss of step ([0-9]+) is"))) << r.output;
  const int step = std::stoi(m[1]);
  ASSERT_GE(step, 1);
  std::string last_bar;
  for (size_t start = 0; start < r.output.size();) {
    const size_t end = std::min(r.output.find('\n', start), r.output.size());
    const std::string line = r.output.substr(start, end - start);
    if (line.rfind("train [", 0) == 0) last_bar = line;
    start = end + 1;
  }
  std::string reached = " ";  // " N/30 ": the steps completed, of the tiny preset's 30
  reached.append(std::to_string(step - 1)).append("/30 ");
  EXPECT_NE(last_bar.find(reached), std::string::npos) << r.output;
  EXPECT_NE(last_bar.find("failed"), std::string::npos) << r.output;
  EXPECT_EQ(last_bar.find("100%"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("100%"), std::string::npos) << r.output;
}

}  // namespace
