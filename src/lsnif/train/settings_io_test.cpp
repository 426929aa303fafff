// The settings table (src/lsnif/format/settings_table.h) and its values (settings_io.h): every default within
// its range and the defaults a valid run, presets valid, --config JSON errors naming the file and
// the key, layer precedence, and the JSON / TrainSettings round trips.
#include "lsnif/train/settings_io.h"

#include <gtest/gtest.h>

#include <set>
#include <string>

namespace lsnif {
namespace {

// Resolves `json` as a --config file "cfg.json" on its own; the error message, or "" when valid.
std::string config_error(const std::string& json, SettingValues* out = nullptr) {
  SettingLayer layer;
  if (Status s = parse_settings_json(json, "cfg.json", layer); !s) return s.message();
  SettingValues v;
  if (Status s = resolve_settings({&layer}, v); !s) return s.message();
  if (out) *out = v;
  return "";
}

void expect_error(const std::string& json, std::initializer_list<const char*> parts) {
  const std::string message = config_error(json);
  EXPECT_FALSE(message.empty()) << json << " accepted";
  for (const char* part : parts) EXPECT_NE(message.find(part), std::string::npos) << part << " not in: " << message;
}

TEST(SettingsTable, EveryDefaultIsInItsRangeAndTheDefaultsAreValid) {
  std::set<std::string> names;
  for (const SettingDef& d : kSettingDefs) {
    SCOPED_TRACE(d.name);
    EXPECT_TRUE(names.insert(d.name).second) << "two settings named " << d.name;
    EXPECT_FALSE(std::string(d.help).empty());
    switch (d.kind) {
      case SettingKind::U32:
      case SettingKind::U32PerLevel:
        EXPECT_LE(d.min, d.def);
        EXPECT_LE(d.def, d.max);
        EXPECT_LE(d.max, kU32Max);
        break;
      case SettingKind::F32:
        EXPECT_TRUE(d.min_open ? d.def > d.min : d.def >= d.min);
        EXPECT_TRUE(d.max_open ? d.def < d.max : d.def <= d.max);
        EXPECT_LE(d.max, kF32Max);
        break;
      case SettingKind::Choice: {
        bool found = false;
        for (uint32_t c = 0; c < d.choice_count; ++c) found |= d.choices[c].value == d.def;
        EXPECT_TRUE(found) << "default is none of the choices";
        break;
      }
      case SettingKind::U64: break;
    }
  }
  SettingValues v;
  ASSERT_EQ(config_error("{}", &v), "");
  EXPECT_EQ(v, SettingValues::defaults());
  // The structs' own defaults are the table's.
  EXPECT_EQ(from_train_settings(TrainSettings()), SettingValues::defaults());
}

TEST(SettingsTable, EveryPresetIsValidAndChangesWhatItNames) {
  for (const Preset& p : kPresets) {
    SCOPED_TRACE(std::string(p.option) + " " + (p.choice ? p.choice : ""));
    SettingLayer layer;
    layer.presets.push_back(&p);
    SettingValues v;
    ASSERT_TRUE(resolve_settings({&layer}, v)) << resolve_settings({&layer}, v).message();
    for (uint32_t k = 0; k < p.count; ++k) {
      const SettingDef& d = setting_def(p.values[k].id);
      EXPECT_EQ(v[d.id], setting_value(d, p.values[k].value)) << d.name;
    }
    if (p.count) {
      EXPECT_NE(v, SettingValues::defaults()) << "the preset changes nothing";
    }
  }
  // The two the CLI documents.
  SettingValues v;
  ASSERT_EQ(config_error(R"({"quality": "low"})", &v), "");
  EXPECT_EQ(v[SettingId::Width].u, 64u);
  EXPECT_EQ(v[SettingId::Points].u, 10u);
  ASSERT_EQ(config_error(R"({"paper": true})", &v), "");
  EXPECT_EQ(v[SettingId::Batch].u, 1u << 18);
  TrainSettings s;
  to_train_settings(v, s);
  EXPECT_EQ(s.config.hit_param, HitParam::AabbInterval);
  EXPECT_EQ(s.loss_settings.normal_loss, NormalLoss::Cosine);
  // The paper's optimization (5.2, 6): Adam at a constant 0.01 for 2000 steps.
  EXPECT_EQ(s.steps, 2000u);
  for (uint32_t step : {1u, 1001u, 1999u, 2000u})
    EXPECT_EQ(scheduled_learning_rate(s.lr_schedule, s.adam.learning_rate, step, s.steps), 0.01f) << step;
}

// The tiny preset of the tests and `lsnif bench --quick`, from the command line, a settings file
// and preset_train_settings alike.
TEST(SettingsTable, TheTinyPresetIsOneSetOfValues) {
  EXPECT_EQ(find_preset("tiny", nullptr), &kTinyPreset);
  SettingValues v;
  ASSERT_EQ(config_error(R"({"tiny": true})", &v), "");
  TrainSettings s;
  Status st = preset_train_settings(kTinyPreset, s);
  ASSERT_TRUE(st) << st.message();
  EXPECT_EQ(from_train_settings(s), v);
  EXPECT_EQ(s.config.voxel_resolution, 16u);
  EXPECT_EQ(s.config.grid_resolution[0], 32u);
  EXPECT_EQ(s.config.grid_resolution[1], 64u);
  EXPECT_EQ(s.config.table_log2[0], 12u);
  EXPECT_EQ(s.config.table_log2[1], 12u);
  EXPECT_EQ(s.config.hidden_width, 32u);
  EXPECT_EQ(s.steps, 30u);
  EXPECT_EQ(s.batch_size, 1024u);
  EXPECT_EQ(uint32_t(preset_value(kTinyPreset, SettingId::Steps)), 30u);
  EXPECT_EQ(uint32_t(preset_value(kTinyPreset, SettingId::Points)), default_u32(SettingId::Points));  // not set
  // The rest is the defaults.
  SettingValues rest = v;
  for (uint32_t k = 0; k < kTinyPreset.count; ++k) {
    const SettingId id = kTinyPreset.values[k].id;
    rest[id] = SettingValues::defaults()[id];
  }
  EXPECT_EQ(rest, SettingValues::defaults());
  // A preset that sets nothing gives TrainSettings().
  ASSERT_TRUE(preset_train_settings(*find_preset("quality", "high"), s));
  EXPECT_EQ(from_train_settings(s), SettingValues::defaults());
  // Like every preset, refused together with a value it sets.
  expect_error(R"({"tiny": true, "steps": 5})", {"cfg.json", "\"tiny\"", "\"steps\": 30", "give either"});
}

TEST(SettingsConfig, ErrorsNameTheFileTheKeyAndTheProblem) {
  expect_error("[1, 2]", {"cfg.json", "JSON object", "not array"});
  expect_error("not json", {"cfg.json", "not valid JSON"});
  expect_error(R"({"voxelz": 32})", {"cfg.json", "\"voxelz\"", "unknown setting"});
  expect_error(R"({"voxels": "32"})", {"cfg.json", "\"voxels\"", "unsigned integer", "not string"});
  expect_error(R"({"voxels": 32.5})", {"cfg.json", "\"voxels\"", "unsigned integer", "32.5"});
  expect_error(R"({"voxels": -1})", {"cfg.json", "\"voxels\"", "unsigned integer", "-1"});
  expect_error(R"({"voxels": 4294967296})", {"cfg.json", "\"voxels\"", "larger than"});
  expect_error(R"({"voxels": 0})", {"cfg.json", "\"voxels\" 0 out of range [1, 256]"});
  expect_error(R"({"lr": 0})", {"cfg.json", "\"lr\" 0 must be a positive, finite learning rate"});
  expect_error(R"({"lr": 1e39})", {"cfg.json", "\"lr\"", "beyond the range of a 32-bit float"});
  expect_error(R"({"lr": true})", {"cfg.json", "\"lr\"", "a number", "not boolean"});
  expect_error(R"({"lr-final": 0})", {"cfg.json", "\"lr-final\" 0 out of range (0, 1]"});
  expect_error(R"({"lr-warm": 1})", {"cfg.json", "\"lr-warm\" 1 out of range [0, 1)"});
  expect_error(R"({"lr-schedule": "linear"})", {"cfg.json", "\"lr-schedule\"", "'constant', 'exponential' or 'cosine'"});
  expect_error(R"({"w-normal": -1})", {"cfg.json", "\"w-normal\" -1 must be a finite weight >= 0"});
  expect_error(R"({"adam-beta1": 1})", {"cfg.json", "\"adam-beta1\" 1 out of range [0, 1)"});
  expect_error(R"({"hit": "sideways"})", {"cfg.json", "\"hit\" must be 'segments' or 'aabb' (got 'sideways')"});
  expect_error(R"({"hit": 1})", {"cfg.json", "\"hit\"", "one of 'segments' or 'aabb'"});
  expect_error(R"({"quality": "medium"})", {"cfg.json", "\"quality\"", "'high' or 'low'", "medium"});
  expect_error(R"({"paper": 1})", {"cfg.json", "\"paper\"", "true or false"});
  expect_error(R"({"quality": "low", "width": 32})",
               {"cfg.json", "\"quality\": low sets \"width\": 64 and \"points\": 10", "give either"});
  expect_error(R"({"voxels": 48})", {"cfg.json", "--res-min 64 and --res-max 128", "multiple", "(\"voxels\""});
  expect_error(R"({"res-min": 256})", {"cfg.json", "need \"res-min\" <= --res-max (got 256, 128)"});
  expect_error(R"({"batch": 4, "ray-reuse": 5})", {"cfg.json", "\"ray-reuse\" 5 must be in [1, \"batch\" 4]"});
  expect_error(R"({"w-occlusion": 0, "w-distance": 0, "w-normal": 0, "w-albedo": 0, "w-material": 0})",
               {"cfg.json", "every loss weight"});
  // Deep nesting is refused before parsing.
  expect_error(std::string(200, '[') + std::string(200, ']'), {"cfg.json", "nested deeper"});
}

TEST(SettingsConfig, LaterLayersWinAndPresetsComeFirstInTheirLayer) {
  SettingLayer file, cli;
  ASSERT_TRUE(parse_settings_json(R"({"steps": 7, "seed": 5, "quality": "low"})", "cfg.json", file));
  cli.set(SettingId::Steps, {.u = 9});
  cli.set(SettingId::Width, {.u = 32});
  SettingValues v;
  ASSERT_TRUE(resolve_settings({&file, &cli}, v)) << resolve_settings({&file, &cli}, v).message();
  EXPECT_EQ(v[SettingId::Steps].u, 9u);   // the command line over the file
  EXPECT_EQ(v[SettingId::Seed].u, 5u);    // the file over the default
  EXPECT_EQ(v[SettingId::Width].u, 32u);  // the command line over the file's preset
  EXPECT_EQ(v[SettingId::Points].u, 10u);  // the file's preset over the default
  EXPECT_EQ(v[SettingId::Batch], SettingValues::defaults()[SettingId::Batch]);
  // A preset on the command line overrides the file's values.
  SettingLayer plain_file, preset_cli;
  ASSERT_TRUE(parse_settings_json(R"({"width": 32})", "cfg.json", plain_file));
  preset_cli.presets.push_back(find_preset("quality", "low"));
  ASSERT_TRUE(resolve_settings({&plain_file, &preset_cli}, v));
  EXPECT_EQ(v[SettingId::Width].u, 64u);
}

TEST(SettingsConfig, JsonAndTrainSettingsRoundTrip) {
  // Every setting away from its default, floats that are not short decimals included.
  SettingLayer layer;
  ASSERT_TRUE(parse_settings_json(
      R"({"voxels": 16, "points": 7, "levels": 3, "res-min": 32, "res-max": 256, "table-log2": [10, 9, 11], "indexed": [1, 0, 1], "features": 2,
          "width": 24, "layers": 3, "hit": "aabb", "leaky-slope": 0.02, "grid-bits": "16", "steps": 3, "batch": 100,
          "seed": 18446744073709551615, "ray-reuse": 2, "lr": 0.0033333333, "lr-schedule": "cosine",
          "lr-final": 0.05, "lr-warm": 0.3, "adam-beta1": 0.8, "adam-beta2": 0.95,
          "adam-epsilon": 1e-12, "ema-decay": 0.95, "normal-loss": "cosine", "mlp-precision": "fp32", "w-occlusion": 0.5, "w-distance": 2, "w-normal": 0.1,
          "w-albedo": 0, "w-material": 3, "surface-fraction": 0.25, "sphere-scale": 2, "surface-offset": 0.001, "surface-rays": 3,
          "grid-init-range": 0.01, "surface-maps": "on", "w-surface": 0.5,
          "texture-coordinates": "off", "uv-cells": 3})",
      "cfg.json", layer));
  for (bool g : layer.given) EXPECT_TRUE(g);
  SettingValues v;
  ASSERT_TRUE(resolve_settings({&layer}, v)) << resolve_settings({&layer}, v).message();
  for (const SettingDef& d : kSettingDefs) EXPECT_NE(v[d.id], SettingValues::defaults()[d.id]) << d.name;
  TrainSettings s;
  to_train_settings(v, s);
  EXPECT_EQ(from_train_settings(s), v);
  const std::string text = settings_to_json(v).dump();
  EXPECT_NE(text.find("\"lr\":0.0033333334,"), std::string::npos) << text;  // the float's shortest decimal
  EXPECT_NE(text.find("\"surface-offset\":0.001,"), std::string::npos) << text;
  EXPECT_NE(text.find("\"seed\":18446744073709551615"), std::string::npos) << text;
  SettingLayer again;
  ASSERT_TRUE(parse_settings_json(text, "again.json", again));
  SettingValues w;
  ASSERT_TRUE(resolve_settings({&again}, w));
  EXPECT_EQ(w, v);
}

// table-log2: one value for every level (the form before per-level sizes) or a list of one per level.
TEST(SettingsConfig, TableSizesPerLevel) {
  SettingValues v;
  TrainSettings s;
  ASSERT_EQ(config_error(R"({"table-log2": 15})", &v), "");
  to_train_settings(v, s);
  EXPECT_EQ(s.config.table_log2[0], 15u);
  EXPECT_EQ(s.config.table_log2[1], 15u);
  EXPECT_EQ(s.config.table_log2[2], 0u);
  EXPECT_EQ(settings_to_json(v)["table-log2"], 15);  // written as before
  ASSERT_EQ(config_error(R"({"table-log2": [15, 17]})", &v), "");
  to_train_settings(v, s);
  EXPECT_EQ(s.config.table_log2[0], 15u);
  EXPECT_EQ(s.config.table_log2[1], 17u);
  ASSERT_TRUE(s.config.validate());
  EXPECT_EQ(s.config.grid_parameter_count(), uint64_t((1u << 15) + (1u << 17)) * 3);
  EXPECT_EQ(from_train_settings(s), v);
  EXPECT_EQ(settings_to_json(v)["table-log2"], nlohmann::json::array({15, 17}));
  EXPECT_EQ(setting_text(setting_def(SettingId::TableLog2), v[SettingId::TableLog2]), "15,17");
  // Three levels, three sizes; a list of one is every level.
  ASSERT_EQ(config_error(R"({"levels": 3, "table-log2": [12, 14, 16]})", &v), "");
  to_train_settings(v, s);
  EXPECT_EQ(s.config.describe().find("M=12,14,16 "), s.config.describe().find("M=")) << s.config.describe();
  ASSERT_EQ(config_error(R"({"levels": 3, "table-log2": [13]})", &v), "");
  to_train_settings(v, s);
  for (uint32_t l = 0; l < 3; ++l) EXPECT_EQ(s.config.table_log2[l], 13u);
  // Equal values per level are the same model as one value: recorded as one.
  ASSERT_EQ(config_error(R"({"table-log2": [16, 16]})", &v), "");
  to_train_settings(v, s);
  EXPECT_EQ(settings_to_json(from_train_settings(s))["table-log2"], 16);
  // Errors name the key, the list and the problem.
  expect_error(R"({"table-log2": [15, 16, 17]})",
               {"cfg.json", "\"table-log2\" 15,16,17 gives 3 values for 2 levels", "one per level"});
  expect_error(R"({"levels": 3, "table-log2": [15, 17]})", {"cfg.json", "2 values for 3 levels", "\"levels\""});
  expect_error(R"({"table-log2": [15, 30]})", {"cfg.json", "\"table-log2\" 15,30: 30 (level 1) out of range [4, 24]"});
  expect_error(R"({"table-log2": 3})", {"cfg.json", "\"table-log2\" 3 out of range [4, 24]"});
  expect_error(R"({"table-log2": []})", {"cfg.json", "\"table-log2\"", "list of 1 to 4"});
  expect_error(R"({"table-log2": [15, "17"]})", {"cfg.json", "\"table-log2\"", "unsigned integer or a list"});
  expect_error(R"({"table-log2": [1, 2, 3, 4, 5]})", {"cfg.json", "\"table-log2\"", "list of 1 to 4"});
  expect_error(R"({"table-log2": -2})", {"cfg.json", "\"table-log2\"", "unsigned integer"});
}

TEST(SettingsConfig, TheDefaultGridIsEightBitWithTheCoarseLevelIndexedAndPaperRestoresThePapers) {
  SettingValues v;
  TrainSettings s;
  ASSERT_EQ(config_error("{}", &v), "");
  to_train_settings(v, s);
  EXPECT_EQ(s.config.grid_bits, 8u);
  EXPECT_TRUE(s.indexed[0]);
  EXPECT_FALSE(s.indexed[1]);
  EXPECT_EQ(settings_to_json(v)["indexed"], nlohmann::json::array({1, 0}));
  // The default follows the level count: the coarsest level indexed, the finer ones hashed.
  ASSERT_EQ(config_error(R"({"levels": 3})", &v), "");
  to_train_settings(v, s);
  EXPECT_TRUE(s.indexed[0]);
  EXPECT_FALSE(s.indexed[1]);
  EXPECT_FALSE(s.indexed[2]);
  ASSERT_EQ(config_error(R"({"levels": 1})", &v), "");
  to_train_settings(v, s);
  EXPECT_TRUE(s.indexed[0]);
  // Given, it is the value given (and a list must still match the levels).
  ASSERT_EQ(config_error(R"({"indexed": 0})", &v), "");
  to_train_settings(v, s);
  EXPECT_FALSE(s.indexed[0]);
  expect_error(R"({"levels": 3, "indexed": [1, 0]})", {"cfg.json", "2 values for 3 levels"});
  // --paper: the paper's grid (fp16, every level hashed) besides its training.
  ASSERT_EQ(config_error(R"({"paper": true})", &v), "");
  to_train_settings(v, s);
  EXPECT_EQ(s.config.grid_bits, 16u);
  EXPECT_FALSE(s.indexed[0]);
  EXPECT_FALSE(s.indexed[1]);
  EXPECT_EQ(s.config.hit_param, HitParam::AabbInterval);
  // The default network is the paper's 2x128 with H = 18 (--quality high); --quality low is its
  // W=64, H=10 on the default grid: only the network changes.
  ASSERT_EQ(config_error("{}", &v), "");
  to_train_settings(v, s);
  EXPECT_EQ(s.config.hidden_width, 128u);
  EXPECT_EQ(s.config.max_points, 18u);
  EXPECT_EQ(mlp_flops_per_evaluation(s.config), 62720u);
  ASSERT_EQ(config_error(R"({"quality": "low"})", &v), "");
  to_train_settings(v, s);
  EXPECT_EQ(s.config.grid_bits, 8u);
  EXPECT_TRUE(s.indexed[0]);
  EXPECT_EQ(s.config.hidden_width, 64u);
  EXPECT_EQ(s.config.max_points, 10u);
}

// The mesh of the training records below.
Mesh one_triangle() {
  Mesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  mesh.triangles = {{0, 1, 2}};
  return mesh;
}

TEST(SettingsConfig, TrainingRecordHoldsTheSettingsAndTheMesh) {
  const Mesh mesh = one_triangle();
  TrainSettings s;
  s.seed = 42;
  const nlohmann::json j = nlohmann::json::parse(training_record(s, mesh, "tri\x1b.obj", 3));
  EXPECT_EQ(j["settings"]["seed"], 42);
  EXPECT_EQ(j["mesh"]["name"], "tri?.obj");  // control characters replaced
  EXPECT_EQ(j["mesh"]["triangles"], 1);
  EXPECT_EQ(j["threads"], 3);
  // The record's settings restore the training settings, the learning-rate schedule included.
  s.lr_schedule.schedule = LrSchedule::Cosine;
  s.lr_schedule.final_fraction = 0.125f;
  s.lr_schedule.warm_fraction = 0.3f;
  SettingLayer layer;
  ASSERT_TRUE(parse_settings_json(nlohmann::json::parse(training_record(s, mesh, "tri.obj", 1))["settings"].dump(),
                                  "record", layer));
  SettingValues v;
  ASSERT_TRUE(resolve_settings({&layer}, v));
  TrainSettings restored;
  to_train_settings(v, restored);
  EXPECT_EQ(restored.lr_schedule.schedule, LrSchedule::Cosine);
  EXPECT_EQ(restored.lr_schedule.final_fraction, 0.125f);
  EXPECT_EQ(restored.lr_schedule.warm_fraction, 0.3f);
  EXPECT_EQ(restored.seed, 42u);
  const std::string hash = j["mesh"]["hash"];
  Mesh moved = mesh;
  moved.positions[2].y = 2;
  EXPECT_NE(hash, nlohmann::json::parse(training_record(s, moved, "tri.obj", 3))["mesh"]["hash"]);
  EXPECT_EQ(hash, nlohmann::json::parse(training_record(s, mesh, "other.obj", 1))["mesh"]["hash"]);
}

TEST(SettingsConfig, TheRecordSaysWhetherNormalMapsWereBaked) {
  const Mesh mesh = one_triangle();
  TrainSettings s;
  EXPECT_TRUE(recorded_normal_maps(training_record(s, mesh, "tri.obj", 1)));  // auto
  s.surface_maps = kSurfaceMapsOn;
  EXPECT_TRUE(recorded_normal_maps(training_record(s, mesh, "tri.obj", 1)));
  s.surface_maps = kSurfaceMapsOff;
  EXPECT_FALSE(recorded_normal_maps(training_record(s, mesh, "tri.obj", 1)));
  // No record, a record from before the setting, and one that does not parse.
  EXPECT_FALSE(recorded_normal_maps(""));
  EXPECT_FALSE(recorded_normal_maps(R"({"settings": {"steps": 10}, "threads": 1})"));
  EXPECT_FALSE(recorded_normal_maps("{\"settings\": "));
}

// What decides whether a converted model is up to date: the record of the same settings and mesh
// matches (whatever its thread count and mesh name), every other record says how it differs.
TEST(SettingsConfig, TheRecordDifferenceNamesTheFirstDifference) {
  const Mesh mesh = one_triangle();
  TrainSettings s;
  s.seed = 3;
  const uint64_t hash = mesh_hash(mesh);
  const std::string record = training_record(s, mesh, "tri.obj", 2);
  EXPECT_EQ(training_record_difference(record, s, hash), "");
  EXPECT_EQ(training_record_difference(training_record(s, mesh, "other.obj", 7), s, hash), "");

  TrainSettings other = s;
  other.seed = 5;
  EXPECT_EQ(training_record_difference(record, other, hash), "it records seed=3, the settings give seed=5");
  other = s;
  other.adam.learning_rate = 0.02f;
  EXPECT_EQ(training_record_difference(record, other, hash), "it records lr=0.01, the settings give lr=0.02");
  Mesh moved = mesh;
  moved.positions[2].y = 2;
  EXPECT_NE(training_record_difference(record, s, mesh_hash(moved)).find("another mesh"), std::string::npos);
  EXPECT_EQ(training_record_difference("", s, hash), "it has no training record");
  EXPECT_NE(training_record_difference("{\"settings\": ", s, hash).find("not valid JSON"), std::string::npos);
  EXPECT_EQ(training_record_difference(R"({"mesh": {}})", s, hash), "its training record holds no settings");

  nlohmann::json edited = nlohmann::json::parse(record);
  edited["settings"].erase("seed");
  EXPECT_EQ(training_record_difference(edited.dump(), s, hash), "it records no seed (the settings give 3)");
  edited = nlohmann::json::parse(record);
  edited["settings"]["future"] = 1;
  EXPECT_EQ(training_record_difference(edited.dump(), s, hash), "it records the unknown setting future");
  edited = nlohmann::json::parse(record);
  edited.erase("mesh");
  EXPECT_NE(training_record_difference(edited.dump(), s, hash).find(recorded_mesh_hash(hash)), std::string::npos);
}

}  // namespace
}  // namespace lsnif
