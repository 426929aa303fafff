// training_record_test.cpp -- a model's training record against its header: every model setting the
// header also stores must agree with it, every recorded setting must be of its kind and within its
// declared range, the record must be a JSON object, and what the record lacks (older records) or
// the table does not know (newer writers) is not checked.
#include "lsnif/format/training_record.h"

#include <gtest/gtest.h>

#include <string>

namespace lsnif {
namespace {

// The header of the tests: the default model of `lsnif train --tiny` as the settings table gives it
// (V=16, L=2 of 32 and 64, 2^12 entries, F=3, W=32x2, H=18, segments, slope 0.01, 8-bit grid with
// the coarsest level indexed), written out here by hand.
Config tiny_header() {
  Config c;
  c.voxel_resolution = 16;
  c.max_points = 18;
  c.grid_levels = 2;
  c.grid_resolution[0] = 32;
  c.grid_resolution[1] = 64;
  set_table_log2(c, 12);
  c.features = 3;
  c.hidden_width = 32;
  c.hidden_layers = 2;
  c.hit_param = HitParam::VoxelSegments;
  c.leaky_slope = 0.01f;
  c.grid_bits = 8;
  c.index_slots[0] = 5000;
  c.index_buckets[0] = 1000;
  return c;
}

// The model settings of that header as `lsnif train --tiny` records them, and training settings.
const std::string kSettings =
    R"("voxels":16,"points":18,"levels":2,"res-min":32,"res-max":64,"table-log2":12,"features":3,"width":32,)"
    R"("layers":2,"hit":"segments","leaky-slope":0.01,"grid-bits":"8","indexed":[1,0],"surface-maps":"auto",)"
    R"("steps":30,"batch":1024,"seed":1,"lr":0.01)";

std::string record(const std::string& settings) {
  return R"({"settings":{)" + settings + R"(},"mesh":{"name":"elephant.off"},"threads":2})";
}

// `settings` in place of the same key's value in kSettings (or added).
std::string with(const std::string& key, const std::string& value) {
  std::string s = kSettings;
  const std::string quoted = "\"" + key + "\":";
  const size_t at = s.find(quoted);
  if (at == std::string::npos) return record(s + "," + quoted + value);
  size_t end = at + quoted.size();
  int depth = 0;
  while (end < s.size() && (depth > 0 || s[end] != ',')) {
    depth += s[end] == '[' ? 1 : s[end] == ']' ? -1 : 0;
    ++end;
  }
  return record(s.substr(0, at) + quoted + value + s.substr(end));
}

void expect_error(const std::string& rec, std::initializer_list<const char*> parts, const Config& header = tiny_header()) {
  const Status s = check_training_record(rec, header);
  ASSERT_FALSE(s) << rec << " accepted";
  for (const char* p : parts) EXPECT_NE(s.message().find(p), std::string::npos) << p << " not in: " << s.message();
}

TEST(TrainingRecord, TheWritersRecordOfTheHeaderPasses) {
  const Config h = tiny_header();
  EXPECT_TRUE(check_training_record(record(kSettings), h));
  EXPECT_TRUE(check_training_record("", h));                   // version 1: no record
  EXPECT_TRUE(check_training_record("{}", h));                 // no settings
  EXPECT_TRUE(check_training_record(R"({"settings":{}})", h));  // an older record holds fewer settings
  EXPECT_TRUE(check_training_record(R"({"settings":{"voxels":16,"seed":3}})", h));
  EXPECT_TRUE(check_training_record(with("future-setting", "[1,{\"a\":2}]"), h));  // a newer writer's
  EXPECT_TRUE(check_training_record(with("table-log2", "[12,12]"), h));
  EXPECT_TRUE(check_training_record(with("table-log2", "[20,12]"), h));  // level 0 is indexed: unused
  EXPECT_TRUE(check_training_record(with("seed", "18446744073709551615"), h));
}

TEST(TrainingRecord, ModelSettingsMustEqualTheHeader) {
  expect_error(with("voxels", "32"), {"training record: voxels is 32", "voxel resolution is 16"});
  expect_error(with("points", "10"), {"points is 10", "18"});
  expect_error(with("levels", "3"), {"levels is 3", "grid levels is 2"});
  expect_error(with("res-min", "16"), {"res-min is 16", "32"});
  expect_error(with("res-max", "128"), {"res-max is 128", "64"});
  expect_error(with("table-log2", "13"), {"table-log2 is 13", "level 1", "12"});
  expect_error(with("table-log2", "[12,14]"), {"table-log2 is 12,14", "level 1: 14", "is 12"});
  expect_error(with("table-log2", "[12,12,12]"), {"table-log2", "3 values", "2 grid levels"});
  expect_error(with("features", "2"), {"features is 2", "3"});
  expect_error(with("width", "64"), {"width is 64", "hidden width is 32"});
  expect_error(with("layers", "1"), {"layers is 1", "2"});
  expect_error(with("hit", "\"aabb\""), {"hit is aabb", "segments"});
  expect_error(with("leaky-slope", "0.02"), {"leaky-slope is 0.02", "0.01"});
  expect_error(with("grid-bits", "\"16\""), {"grid-bits is 16", "grid bits is 8"});
  expect_error(with("indexed", "0"), {"indexed is 0", "level 0", "is 1"});
  expect_error(with("indexed", "[1,1]"), {"indexed is 1,1", "level 1", "is 0"});
  expect_error(with("surface-maps", "\"on\""), {"surface-maps is on", "no surface channels"});
  Config surface = tiny_header();
  surface.surface_channels = 1;
  surface.emission_scale = 1.0f;
  expect_error(with("surface-maps", "\"off\""), {"surface-maps is off", "surface channels"}, surface);
  EXPECT_TRUE(check_training_record(with("surface-maps", "\"on\""), surface));
  EXPECT_TRUE(check_training_record(record(kSettings), surface));  // auto: either
}

TEST(TrainingRecord, ValuesMustBeOfTheirKindAndInTheirRange) {
  expect_error(with("voxels", "-5"), {"training record: voxels", "unsigned integer", "-5"});
  expect_error(with("voxels", "0"), {"voxels 0 out of range [1, 256]"});
  expect_error(with("voxels", "16.5"), {"voxels", "16.5"});
  expect_error(with("steps", "0"), {"steps", "0 out of range [1, 10000000]"});
  expect_error(with("lr", "-1"), {"lr -1", "positive"});
  expect_error(with("lr-warm", "1"), {"lr-warm 1 out of range [0, 1)"});
  expect_error(with("seed", "\"one\""), {"seed", "unsigned integer", "string"});
  expect_error(with("hit", "\"bogus\""), {"hit", "'segments' or 'aabb'", "bogus"});
  expect_error(with("hit", "1"), {"hit", "one of"});
  expect_error(with("table-log2", "[12,30]"), {"table-log2", "30", "level 1", "out of range"});
  expect_error(with("table-log2", "[]"), {"table-log2", "list of 1 to"});
}

TEST(TrainingRecord, TheRecordMustBeAJsonObject) {
  const Config h = tiny_header();
  expect_error("not json", {"training record is not valid JSON", "not json"});
  expect_error("[1, 2]", {"training record is array", "not a JSON object"});
  expect_error(R"({"settings":[1]})", {"\"settings\" is array"});
  expect_error(record(kSettings) + "x", {"not valid JSON"});
  std::string deep = R"({"settings":{"future":)";
  deep += std::string(5000, '[') + std::string(5000, ']') + "}}";
  expect_error(deep, {"deeper than 16 levels"});
  std::string fine = R"({"settings":{"future":)";
  fine += std::string(10, '[') + std::string(10, ']') + "}}";
  EXPECT_TRUE(check_training_record(fine, h));
}

}  // namespace
}  // namespace lsnif
