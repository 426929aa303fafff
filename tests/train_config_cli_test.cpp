// `lsnif train --config` and the settings a model records: bad config files fail with exit code 2
// and a message naming the file and the key, options on the command line override the file, and
// train -> info --json / --settings -> train --config reproduces the same settings (and the same
// model bytes). Tiny models: each run takes well under a second.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "lsnif/testing/test_support.h"

namespace {

namespace fs = std::filesystem;
using lsnif::test::ProcessResult;

const std::string kMesh = std::string(LSNIF_DATA_DIR) + "/meshes/elephant.off";

class TrainConfigCli : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(kMesh)) GTEST_SKIP() << kMesh << " missing: run scripts/setup.sh";
  }
  ProcessResult lsnif(std::vector<std::string> args) {
    args.insert(args.begin(), LSNIF_CLI);
    return lsnif::test::run_process(args, 60);
  }
  // `lsnif train` of the test mesh into `model` with tiny settings, then `extra`.
  ProcessResult train(const std::string& model, const std::vector<std::string>& extra) {
    std::vector<std::string> args = {"train", kMesh, "-o", model, "--quiet"};
    args.insert(args.end(), extra.begin(), extra.end());
    return lsnif(args);
  }
  std::string write(const std::string& name, const std::string& text) {
    const std::string p = dir_.path(name);
    std::ofstream(p, std::ios::binary) << text;
    return p;
  }
  static std::string read(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }
  // The "training" object of `lsnif info --json MODEL`.
  nlohmann::json training_of(const std::string& model) {
    const ProcessResult r = lsnif({"info", "--json", model});
    EXPECT_EQ(r.exit_code, 0) << r.output;
    const nlohmann::json j = nlohmann::json::parse(r.output, nullptr, false);
    EXPECT_FALSE(j.is_discarded()) << r.output;
    return j.is_object() && j.contains("training") ? j["training"] : nlohmann::json();
  }

  // `lsnif info --settings MODEL` as a --config file trains `model`'s bytes again.
  void expect_record_reproduces(const std::string& model) {
    ProcessResult r = lsnif({"info", "--settings", model});
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const std::string again = dir_.path("again.lsnif");
    r = train(again, {"--config", write("recorded.json", r.output)});
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_EQ(read(again), read(model));
  }
  struct BadArgs {
    std::vector<std::string> args;
    std::string message;
  };
  // Each `lsnif train --config cfg ARGS` is a usage error (exit 2) naming `message`, writing nothing.
  void expect_usage_errors(const std::string& cfg, const std::vector<BadArgs>& cases) {
    for (const BadArgs& c : cases) {
      std::vector<std::string> args = {"--config", cfg};
      args.insert(args.end(), c.args.begin(), c.args.end());
      const ProcessResult r = train(dir_.path("bad.lsnif"), args);
      EXPECT_EQ(r.exit_code, 2) << r.output;
      EXPECT_NE(r.output.find(c.message), std::string::npos) << r.output;
      EXPECT_FALSE(fs::exists(dir_.path("bad.lsnif")));
    }
  }

  lsnif::test::ScopedTestDir dir_{"lsnif_train_config"};
  // Small enough for a fraction of a second per run. Not the --tiny preset, deliberately: these
  // tests check that a file's values reach the model, so the file lists them (smaller still than
  // --tiny's).
  // The paper's grid (fp16, both levels hashed): the tests below add 8-bit features, per-level
  // sizes and indexed levels one at a time.
  const std::string tiny_ = R"({"voxels": 8, "res-min": 16, "res-max": 32, "table-log2": 8, "width": 16,
                                "points": 6, "steps": 2, "batch": 128, "grid-bits": "16", "indexed": 0})";
};

TEST_F(TrainConfigCli, BadConfigFilesFailNamingTheFileAndTheKey) {
  struct Case {
    std::string json;
    std::vector<std::string> message;
  };
  const std::vector<Case> cases = {
      {R"({"voxelz": 8})", {"\"voxelz\"", "unknown setting"}},
      {R"({"voxels": "8"})", {"\"voxels\"", "must be an unsigned integer, not string"}},
      {R"({"lr": "fast"})", {"\"lr\"", "must be a number, not string"}},
      {R"({"voxels": 300})", {"\"voxels\" 300 out of range [1, 256]"}},
      {R"({"hit": "sideways"})", {"\"hit\" must be 'segments' or 'aabb' (got 'sideways')"}},
      {R"([{"voxels": 8}])", {"a settings file holds a JSON object", "not array"}},
      {R"({"voxels": 8,)", {"not valid JSON"}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.json);
    const std::string cfg = write("bad.json", c.json);
    const ProcessResult r = train(dir_.path("m.lsnif"), {"--config", cfg});
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find(cfg), std::string::npos) << r.output;
    for (const std::string& part : c.message) EXPECT_NE(r.output.find(part), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("trained "), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(dir_.path("m.lsnif")));
  }
  const ProcessResult missing = train(dir_.path("m.lsnif"), {"--config", dir_.path("none.json")});
  EXPECT_EQ(missing.exit_code, 2) << missing.output;
  EXPECT_NE(missing.output.find("none.json: no such file"), std::string::npos) << missing.output;
}

TEST_F(TrainConfigCli, CommandLineOptionsOverrideTheFile) {
  const std::string cfg = write("tiny.json", tiny_.substr(0, tiny_.size() - 1) + R"(, "seed": 5, "hit": "aabb"})");
  const std::string model = dir_.path("m.lsnif");
  ProcessResult r = train(model, {"--config", cfg, "--seed", "11", "--steps", "3"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  nlohmann::json s = training_of(model)["settings"];
  EXPECT_EQ(s["seed"], 11);      // the command line
  EXPECT_EQ(s["steps"], 3);
  EXPECT_EQ(s["hit"], "aabb");   // the file
  EXPECT_EQ(s["voxels"], 8);
  EXPECT_EQ(s["lr"], 0.01);      // the default
  // A preset on the command line overrides the file's values it sets; the file's value is
  // checked in its own right first ("width": 16 is fine, "width": 0 is not).
  r = train(model, {"--config", cfg, "--quality", "low"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  s = training_of(model)["settings"];
  EXPECT_EQ(s["width"], 64);
  EXPECT_EQ(s["points"], 10);
  // An invalid value in the file fails even when the command line sets that setting too.
  const std::string bad = write("bad.json", R"({"voxels": 0})");
  r = train(model, {"--config", bad, "--voxels", "8"});
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("bad.json: \"voxels\" 0 out of range"), std::string::npos) << r.output;
}

TEST_F(TrainConfigCli, InfoSettingsRoundTripReproducesTheModel) {
  const std::string cfg = write("tiny.json", tiny_);
  const std::string first = dir_.path("first.lsnif"), second = dir_.path("second.lsnif");
  ProcessResult r = train(first, {"--config", cfg, "--seed", "7", "--normal-loss", "cosine", "--lr", "0.003"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json recorded = training_of(first);
  ASSERT_TRUE(recorded.is_object()) << recorded.dump();
  EXPECT_EQ(recorded["settings"]["seed"], 7);
  EXPECT_EQ(recorded["settings"]["normal-loss"], "cosine");
  EXPECT_EQ(recorded["settings"]["lr"], 0.003);
  EXPECT_EQ(recorded["mesh"]["name"], "elephant.off");
  EXPECT_EQ(recorded["mesh"]["triangles"], 5558);
  EXPECT_EQ(recorded["mesh"]["hash"].get<std::string>().rfind("fnv1a64:", 0), 0u);
  // The settings object of `info --json`, and `info --settings`, as a --config file.
  const std::string from_json = write("from_json.json", recorded["settings"].dump(2));
  r = lsnif({"info", "--settings", first});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(nlohmann::json::parse(r.output), recorded["settings"]);
  const std::string from_settings = write("from_settings.json", r.output);
  for (const std::string& config : {from_json, from_settings}) {
    SCOPED_TRACE(config);
    r = train(second, {"--config", config});
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_EQ(training_of(second), recorded);
    EXPECT_EQ(read(second), read(first));  // the same training: the same bytes
  }
}

TEST_F(TrainConfigCli, ModelsWithoutARecordStillLoad) {
  // A model written without a training record (the lsnif library's save_model of a Model whose
  // record is empty, e.g. one loaded from a version 1 file) is a version 1 file.
  const std::string model = dir_.path("m.lsnif");
  ProcessResult r = train(model, {"--config", write("tiny.json", tiny_)});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  // Strip the record: rewrite the header as version 1 and drop the training section.
  std::string b = read(model);
  ASSERT_EQ(b[8], 2);
  const auto rd64 = [&b](size_t at) {
    uint64_t v = 0;
    for (int i = 7; i >= 0; --i) v = (v << 8) | uint8_t(b[at + size_t(i)]);
    return v;
  };
  const auto wr64 = [&b](size_t at, uint64_t v) {
    for (int i = 0; i < 8; ++i) b[at + size_t(i)] = char(uint8_t(v >> (8 * i)));
  };
  std::string v1 = b.substr(0, 168) + std::string(8, '\0');  // the v1 header, padded to 176
  v1[8] = 1;
  v1[12] = char(168);
  for (int s = 0; s < 4; ++s) {  // each section 16 bytes earlier
    const uint64_t at = rd64(104 + 16 * size_t(s));
    wr64(104 + 16 * size_t(s), at - 16);
    v1.replace(104 + 16 * size_t(s), 8, b.substr(104 + 16 * size_t(s), 8));
  }
  const uint64_t mlp_end = rd64(104 + 48) + 16 + rd64(104 + 56);
  v1 += b.substr(192, mlp_end - 192);
  v1.resize((v1.size() + 15) / 16 * 16 + 4, '\0');
  for (int i = 0; i < 8; ++i) v1[16 + size_t(i)] = char(uint8_t(uint64_t(v1.size()) >> (8 * i)));
  lsnif::test::fix_model_crc(v1);
  const std::string old = write("old.lsnif", v1);
  r = lsnif({"info", old});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("training   not recorded (format version 1)"), std::string::npos) << r.output;
  EXPECT_TRUE(training_of(old).is_null());
  r = lsnif({"info", "--settings", old});
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("records no training settings"), std::string::npos) << r.output;
  r = lsnif({"eval", old, kMesh, "--rays", "200"});
  EXPECT_EQ(r.exit_code, 0) << r.output;
}

// `--grid-bits 8`: a version 3 file whose grid takes one byte per feature (plus a 4-byte scale per
// level); `lsnif info` reports it, the record reproduces it, and `lsnif eval` runs on it.
TEST_F(TrainConfigCli, EightBitGridEndToEnd) {
  const std::string cfg = write("tiny.json", tiny_);
  const std::string wide = dir_.path("wide.lsnif"), narrow = dir_.path("narrow.lsnif");
  ProcessResult r = train(wide, {"--config", cfg, "--seed", "5"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = train(narrow, {"--config", cfg, "--seed", "5", "--grid-bits", "8"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string w = read(wide), n = read(narrow);
  EXPECT_EQ(w[8], 2);  // fp16 grids: format version 2 as before
  EXPECT_EQ(n[8], 3);
  const uint64_t features = 2 * 256 * 3;  // L * 2^M * F of tiny_
  r = lsnif({"info", "--json", narrow});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json jn = nlohmann::json::parse(r.output);
  r = lsnif({"info", "--json", wide});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json jw = nlohmann::json::parse(r.output);
  EXPECT_EQ(jn["grid_bits"], 8);
  EXPECT_EQ(jw["grid_bits"], 16);
  EXPECT_EQ(jw["bytes"]["grid"], 2 * features);
  EXPECT_EQ(jn["bytes"]["grid"], features + 2 * 4);
  EXPECT_EQ(jn["bytes"]["mlp"], jw["bytes"]["mlp"]);
  EXPECT_LT(jn["bytes"]["total"].get<uint64_t>(), jw["bytes"]["total"].get<uint64_t>() - features + 64);
  EXPECT_EQ(jn["training"]["settings"]["grid-bits"], "8");
  // The file: the 16-bit one less half its grid, give or take header and padding.
  EXPECT_NEAR(double(n.size()), double(w.size() - features), 64.0);
  r = lsnif({"info", narrow});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("grid-bits=8"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("int8 x an fp32 scale per level"), std::string::npos) << r.output;
  // The recorded settings reproduce the model byte for byte.
  r = lsnif({"info", "--settings", narrow});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string again = dir_.path("again.lsnif");
  r = train(again, {"--config", write("narrow.json", r.output)});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(read(again), n);
  r = lsnif({"eval", narrow, kMesh, "--rays", "200"});
  EXPECT_EQ(r.exit_code, 0) << r.output;
  r = train(narrow, {"--config", cfg, "--grid-bits", "12"});
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("grid-bits"), std::string::npos) << r.output;
}

// `--table-log2 6,8`: level 0's table 2^6 entries, level 1's 2^8, a version 4 file; `lsnif info`
// reports the sizes, the record reproduces the model, and bad lists fail naming the option.
TEST_F(TrainConfigCli, TableSizesPerLevelEndToEnd) {
  const std::string cfg = write("tiny.json", tiny_);
  const std::string model = dir_.path("levels.lsnif"), same = dir_.path("same.lsnif");
  ProcessResult r = train(model, {"--config", cfg, "--seed", "5", "--table-log2", "6,8", "--grid-bits", "8"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string b = read(model);
  EXPECT_EQ(b[8], 4);
  r = lsnif({"info", "--json", model});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j["table_log2"], nlohmann::json::array({6, 8}));
  EXPECT_EQ(j["bytes"]["grid"], (64 + 256) * 3 + 2 * 4);  // one byte per feature, a scale per level
  EXPECT_EQ(j["training"]["settings"]["table-log2"], nlohmann::json::array({6, 8}));
  r = lsnif({"info", "--grid-usage", model});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("M=6,8 "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(" table-log2=6,8 "), std::string::npos) << r.output;  // the recorded settings
  EXPECT_NE(r.output.find("(2 levels: 2^6 + 2^8 entries x 3 features, int8"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(" of 64 entries used"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(" of 256 entries used"), std::string::npos) << r.output;
  expect_record_reproduces(model);
  r = lsnif({"eval", model, kMesh, "--rays", "200"});
  EXPECT_EQ(r.exit_code, 0) << r.output;
  // One value per level, all equal: the model of one value, written as before (version 2).
  ProcessResult one = train(same, {"--config", cfg, "--seed", "5", "--table-log2", "8,8"});
  ASSERT_EQ(one.exit_code, 0) << one.output;
  const std::string equal_list = read(same);
  one = train(same, {"--config", cfg, "--seed", "5", "--table-log2", "8"});
  ASSERT_EQ(one.exit_code, 0) << one.output;
  EXPECT_EQ(equal_list[8], 2);
  EXPECT_EQ(read(same), equal_list);
  expect_usage_errors(cfg, {
      {{"--table-log2", "6,8,10"}, "--table-log2 6,8,10 gives 3 values for 2 levels (--levels)"},
      {{"--table-log2", "6,30"}, "--table-log2 6,30: 30 (level 1) out of range [4, 24]"},
      {{"--table-log2", "6,"}, "--table-log2"},
      {{"--table-log2", "6,x"}, "--table-log2"},
      {{"--table-log2", "1,2,3,4,5"}, "--table-log2"},
      {{"--levels", "3", "--table-log2", "6,8"}, "2 values for 3 levels"},
  });
}

// Without grid options a model gets the default grid: 8-bit features with the coarse level indexed
// (a version 5 file), as `lsnif info` and the record report.
TEST_F(TrainConfigCli, TheDefaultGridIsEightBitWithTheCoarseLevelIndexed) {
  const std::string cfg = write("small.json", R"({"voxels": 8, "res-min": 16, "res-max": 32, "table-log2": 8,
                                                  "width": 16, "points": 6, "steps": 2, "batch": 128})");
  const std::string model = dir_.path("default.lsnif");
  ProcessResult r = train(model, {"--config", cfg, "--seed", "5"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(read(model)[8], 5);
  r = lsnif({"info", "--json", model});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j["grid_bits"], 8);
  EXPECT_GT(j["index_slots"][0].get<uint64_t>(), 0u);
  EXPECT_EQ(j["index_slots"][1], 0);
  EXPECT_EQ(j["training"]["settings"]["grid-bits"], "8");
  EXPECT_EQ(j["training"]["settings"]["indexed"], nlohmann::json::array({1, 0}));
  expect_record_reproduces(model);
  // --paper's grid is the paper's: fp16, every level hashed (a version 2 file).
  r = train(model, {"--config", cfg, "--seed", "5", "--grid-bits", "16", "--indexed", "0"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(read(model)[8], 2);
}

// `--indexed 1,0`: level 0's table indexed (one entry per vertex it can read, a few spare), level 1
// hashed; a version 5 file whose index `lsnif info` reports, the record reproduces the model, and
// bad lists fail naming the option.
TEST_F(TrainConfigCli, IndexedLevelEndToEnd) {
  const std::string cfg = write("tiny.json", tiny_);
  const std::string model = dir_.path("indexed.lsnif");
  ProcessResult r = train(model, {"--config", cfg, "--seed", "5", "--indexed", "1,0", "--grid-bits", "8"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string b = read(model);
  EXPECT_EQ(b[8], 5);
  r = lsnif({"info", "--json", "--grid-usage", model});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j["table_log2"], nlohmann::json::parse("[null, 8]"));
  const uint64_t vertices = j["grid_usage"][0]["vertices"], slots = j["index_slots"][0];
  const uint64_t displacements = j["index_displacements"];
  EXPECT_EQ(j["index_slots"][1], 0);
  EXPECT_GE(slots, vertices);  // every readable vertex its own entry
  EXPECT_LE(slots, vertices + vertices / 100 * 8 + 8);  // at most 8 tries of 1% more
  EXPECT_EQ(displacements, (vertices + 3) / 4);
  EXPECT_EQ(j["grid_usage"][0]["entries_shared"], 0);
  EXPECT_EQ(j["bytes"]["grid"], (slots + 256) * 3 + 2 * 4 + 2 * displacements);
  EXPECT_EQ(j["training"]["settings"]["indexed"], nlohmann::json::array({1, 0}));
  r = lsnif({"info", model});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find(lsnif::format("M=indexed:%llu,8 ", (unsigned long long)slots)), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(lsnif::format("(2 levels: %llu (indexed) + 2^8 entries", (unsigned long long)slots)),
            std::string::npos) << r.output;
  expect_record_reproduces(model);
  r = lsnif({"eval", model, kMesh, "--rays", "200"});
  EXPECT_EQ(r.exit_code, 0) << r.output;
  expect_usage_errors(cfg, {
      {{"--indexed", "1,0,1"}, "--indexed 1,0,1 gives 3 values for 2 levels (--levels)"},
      {{"--indexed", "2"}, "--indexed"},
      {{"--indexed", "1,"}, "--indexed"},
  });
}

TEST_F(TrainConfigCli, ConvertTakesTheConfigAndRecordsTheSettings) {
  const fs::path example =
      fs::path(__FILE__).parent_path().parent_path() / "samples/scenes/bunny_on_plane.gltf";
  fs::create_directories(dir_.path() / "out");
  fs::copy_file(example, dir_.path() / "scene.gltf");
  // The bunny's model only has to exist with the right magic for the scene to load.
  write("bunny.lsnif", std::string("LSNIF\0\r\n", 8) + "rest");
  const std::string cfg = write("tiny.json", tiny_);
  std::vector<std::string> args = {"convert", dir_.path("scene.gltf"), "-o", dir_.path("out/s.gltf"),
                                   "--convert-when", "triangles", "--min-triangles", "1", "--eval-rays", "0", "--quiet", "--allow-outside-refs",
                                   "--config", cfg, "--seed", "3"};
  ProcessResult r = lsnif(args);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json t = training_of(dir_.path("out/s.ground_quad.lsnif"));
  ASSERT_TRUE(t.is_object()) << t.dump();
  EXPECT_EQ(t["settings"]["seed"], 3);    // the command line
  EXPECT_EQ(t["settings"]["voxels"], 8);  // the file
  EXPECT_EQ(t["mesh"]["name"], "ground_quad");
  EXPECT_EQ(t["mesh"]["triangles"], 2);
  // The sidecar holds the same settings.
  const nlohmann::json sidecar = nlohmann::json::parse(read(dir_.path("out/s.ground_quad.lsnif.json")));
  EXPECT_EQ(sidecar["settings"], t["settings"]);
  const std::string bad = write("bad.json", R"({"steps": 0})");
  args[args.size() - 3] = bad;
  r = lsnif(args);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("bad.json: \"steps\" 0 out of range [1, 10000000]"), std::string::npos) << r.output;
}

}  // namespace
