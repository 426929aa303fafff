// settings_io.h -- the settings of src/lsnif/format/settings_table.h as values: given on the command line or
// in a `--config` JSON file (one SettingLayer per source), resolved in order (defaults, then each
// layer: its presets, then its values) with every range and cross check, converted to and from
// TrainSettings (settings_io.cpp binds each setting to its field), and written as JSON: the object
// a `--config` file holds, and the training record a model stores (the settings, the input mesh's
// name and hash, the thread count).
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "lsnif/import/mesh.h"
#include "lsnif/format/setting_value.h"
#include "lsnif/format/settings_table.h"
#include "lsnif/format/status.h"
#include "lsnif/train/trainer.h"

namespace lsnif {

// A number of the table (a default, a bound, a preset's value) as a value of setting `def`.
SettingValue setting_value(const SettingDef& def, double value);
// The default of --indexed for `levels` grid levels (default_indexed per level).
SettingValue default_indexed_value(uint32_t levels);

// Every setting's value, indexed by SettingId.
struct SettingValues {
  std::array<SettingValue, kSettingCount> v;
  SettingValue& operator[](SettingId id) { return v[static_cast<size_t>(id)]; }
  const SettingValue& operator[](SettingId id) const { return v[static_cast<size_t>(id)]; }
  bool operator==(const SettingValues&) const = default;
  static SettingValues defaults();
};

// The settings one source gives: the command line (`file` empty) or a `--config` file.
struct SettingLayer {
  std::string file;
  std::vector<const Preset*> presets;              // in the order given
  std::array<bool, kSettingCount> given{};         // set explicitly
  std::array<std::string, kSettingCount> choice{};  // given Choice settings, by name (checked when applied)
  SettingValues values;                            // given U32, U64 and F32 settings (checked when applied)

  // Records a value; `text` is the choice's name for a Choice setting.
  void set(SettingId id, SettingValue value, std::string text = {});
  // How a message names a setting or option of this layer: "--voxels" or "\"voxels\"".
  std::string label(const char* name) const;
};

// The preset `option` / `choice` (choice nullptr: a flag), or nullptr.
const Preset* find_preset(std::string_view option, const char* choice);
// The setting called `name`, or nullptr.
const SettingDef* find_setting(std::string_view name);

// Reads a `--config` file: a JSON object of setting name -> value (numbers, choice names as
// strings) and presets ("quality": "low", "paper": true, "tiny": true). Files larger than 1 MiB,
// JSON nested deeper than json::kMaxDepth, anything but an object, unknown keys and wrong types are
// errors that name the file and the key. Ranges are checked when the layer is applied.
Status read_settings_file(const std::string& path, SettingLayer& out);
Status parse_settings_json(std::string_view text, const std::string& file, SettingLayer& out);

// Defaults, then each layer in order: its presets, then its values (a preset and a value it sets
// in the same layer are an error). Checks every value's range and the settings together (grid
// resolutions multiples of the voxel resolution, ray reuse up to the batch, a weight above 0, the
// model config). Errors name the option or key as given, and the file.
Status resolve_settings(const std::vector<const SettingLayer*>& layers, SettingValues& out);
// The same, as the TrainSettings the values give: every field of the table set in `out`, the
// others (loss_curve) left as they are.
Status resolve_settings(const std::vector<const SettingLayer*>& layers, TrainSettings& out);

// The checks of a TrainSettings, made in code or resolved, that train_model makes first
// (check_training_inputs): every setting in its range, a choice one of its choices, then the checks
// resolve_settings makes of the settings together; the messages name the fields in words
// ("learning rate 0 must be a positive, finite learning rate", "batch size (0) out of range [1, 262144]").
Status check_train_settings(const TrainSettings& settings);

void to_train_settings(const SettingValues& values, TrainSettings& out);
// The settings preset `p` alone gives (`lsnif train --tiny` less the command's loss curve): the
// table's defaults with the preset's values, over TrainSettings(). Fails only for a preset with a
// value out of range (settings_io_test resolves every preset).
Status preset_train_settings(const Preset& p, TrainSettings& out);
// The values that give these settings (the coarsest and finest grid resolutions from the config).
SettingValues from_train_settings(const TrainSettings& settings);

// The settings as a JSON object in table order, the form a `--config` file takes; floats written as
// the shortest decimal that reads back as the same float. Of a TrainSettings: the values
// from_train_settings gives (what a model's training record, a converted model's sidecar and the
// caches' keys hold).
nlohmann::ordered_json settings_to_json(const SettingValues& values);
nlohmann::ordered_json settings_to_json(const TrainSettings& settings);

// 64-bit FNV-1a of `bytes`.
uint64_t fnv1a64(std::string_view bytes);
// 64-bit FNV-1a of the mesh's contents (geometry, attributes, materials, textures).
uint64_t mesh_hash(const Mesh& mesh);

// A model's training record (Model::training), parsed: null when none is recorded (a version 1
// file). The record is untrusted text: one that does not parse, or is not an object with
// "settings", is an error.
Status parse_training_record(const std::string& record, nlohmann::json& out);

// What `lsnif info --json` prints of a model (and the Python module's Model.info gives): its
// configuration ("config" in words, then every field), the occupied voxels, the memory breakdown
// ("bytes": voxels, grid, mlp, header, uv_cells, total), with `grid_usage` the usage of every grid
// level (grid_usage.h), and the training record parsed ("training", null when none). Fails only on a
// training record that does not parse.
Status model_info_json(const Model& model, bool grid_usage, nlohmann::ordered_json& out);

// The name a training record gives the mesh read from `path`: its file name, or for a training mesh
// file (training_mesh.h: a cluster job's, written for the object its stem names) that object, as the
// converter's own training names it.
std::string recorded_mesh_name(const std::string& path);

// The training record a model stores (Model::training, docs/model-format.md): compact JSON
// {"settings": {...}, "mesh": {"name", "triangles", "hash"}, "threads": N}.
std::string training_record(const TrainSettings& settings, const Mesh& mesh, const std::string& mesh_name,
                            int threads);

// How a training record writes a mesh hash: "fnv1a64:" and 16 hex digits.
std::string recorded_mesh_hash(uint64_t mesh_hash);

// The first way the training record `record` differs from the one `settings` and a mesh of hash
// `mesh_hash` (mesh_hash()) give: a setting of another value, missing or unknown ("it records
// seed=5, the settings give seed=3"), another mesh hash, no record or one that does not parse; an
// empty string when the record holds exactly these settings and this mesh hash.
std::string training_record_difference(const std::string& record, const TrainSettings& settings, uint64_t mesh_hash);

// Whether the model whose training record is `record` learned its normal with the materials'
// normal maps applied (bakes_normal_maps of its "surface-maps" setting): false without a record,
// for a record that does not parse, and for records written before the setting existed (no normal
// maps were baked then).
bool recorded_normal_maps(const std::string& record);

}  // namespace lsnif
