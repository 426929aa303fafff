// settings_io.cpp -- see settings_io.h.
#include "lsnif/train/settings_io.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iterator>
#include <type_traits>

#include "lsnif/format/file_io.h"
#include "lsnif/core/grid_usage.h"
#include "lsnif/import/json_text.h"
#include "lsnif/import/training_mesh.h"

namespace lsnif {

namespace {

constexpr uint64_t kMaxConfigFileBytes = 1u << 20;

// How each setting reads and writes its TrainSettings field: `get` puts the field's value into
// the setting's place of a SettingValues, `set` writes it back from there (reading other settings
// where the field depends on them). to_train_settings and from_train_settings are one loop over
// these, in table order (a field set after those it depends on: the levels before the grid's
// per-level fields). `words` name the field in the messages of check_train_settings.
struct SettingField {
  SettingId id;
  const char* words;
  void (*get)(const TrainSettings& s, SettingValues& v);
  void (*set)(const SettingValues& v, TrainSettings& s);
};

// The field `s .* path...` (settings.config.voxel_resolution: &TrainSettings::config,
// &Config::voxel_resolution).
template <auto... path, class Settings>
auto& member(Settings& s) {
  return (s .* ... .* path);
}

// A plain field: a float in SettingValue::f, an unsigned integer or an enum (a Choice's value) in ::u.
template <SettingId id, auto... path>
constexpr SettingField field(const char* words) {
  return {id, words,
          [](const TrainSettings& s, SettingValues& v) {
            const auto& f = member<path...>(s);
            if constexpr (std::is_same_v<std::remove_cvref_t<decltype(f)>, float>) v[id].f = f;
            else v[id].u = static_cast<uint64_t>(f);
          },
          [](const SettingValues& v, TrainSettings& s) {
            auto& f = member<path...>(s);
            using T = std::remove_cvref_t<decltype(f)>;
            if constexpr (std::is_same_v<T, float>) f = v[id].f;
            else f = static_cast<T>(v[id].u);
          }};
}

bool valid_levels(const Config& c) { return c.grid_levels >= 1 && c.grid_levels <= LSNIF_MAX_LEVELS; }

constexpr std::array<SettingField, kSettingCount> setting_fields() {
  using enum SettingId;
  using T = TrainSettings;
  return {{
      field<Voxels, &T::config, &Config::voxel_resolution>("voxel resolution"),
      field<Points, &T::config, &Config::max_points>("boundary points"),
      field<Levels, &T::config, &Config::grid_levels>("grid levels"),
      // The grid's resolutions: the coarsest and the finest level's, every level set from both
      // (set_grid_resolutions) with the finest.
      {ResMin, "coarsest grid resolution",
       [](const T& s, SettingValues& v) { v[ResMin].u = s.config.grid_resolution[0]; },
       [](const SettingValues&, T&) {}},
      {ResMax, "finest grid resolution",
       [](const T& s, SettingValues& v) {
         const Config& c = s.config;
         v[ResMax].u = valid_levels(c) ? c.grid_resolution[c.grid_levels - 1] : 0;
       },
       [](const SettingValues& v, T& s) {
         set_grid_resolutions(s.config, static_cast<uint32_t>(v[ResMin].u), static_cast<uint32_t>(v[ResMax].u));
       }},
      // One value when every level has the same size.
      {TableLog2, "table size (log2)",
       [](const T& s, SettingValues& v) {
         const Config& c = s.config;
         if (valid_levels(c)) per_level_value(c.table_log2, c.uniform_table_log2() ? 1 : c.grid_levels, v[TableLog2]);
       },
       [](const SettingValues& v, T& s) {
         const SettingValue& m = v[TableLog2];
         if (m.level_count) set_table_log2(s.config, m.per_level.data(), m.level_count);
         else set_table_log2(s.config, static_cast<uint32_t>(m.u));
       }},
      field<Features, &T::config, &Config::features>("features per entry"),
      field<Width, &T::config, &Config::hidden_width>("hidden width"),
      field<Layers, &T::config, &Config::hidden_layers>("hidden layers"),
      field<Hit, &T::config, &Config::hit_param>("hit parametrization"),
      field<LeakySlope, &T::config, &Config::leaky_slope>("leaky slope"),
      field<GridBits, &T::config, &Config::grid_bits>("grid bits"),
      // One value when every level is alike; the levels past the config's not indexed.
      {Indexed, "indexed levels",
       [](const T& s, SettingValues& v) {
         const Config& c = s.config;
         if (!valid_levels(c)) return;
         uint32_t indexed[LSNIF_MAX_LEVELS] = {};
         bool uniform = true;
         for (uint32_t l = 0; l < c.grid_levels; ++l) {
           indexed[l] = s.indexed[l] ? 1 : 0;
           uniform = uniform && indexed[l] == indexed[0];
         }
         per_level_value(indexed, uniform ? 1 : c.grid_levels, v[Indexed]);
       },
       [](const SettingValues& v, T& s) {
         const SettingValue& ix = v[Indexed];
         for (uint32_t l = 0; l < LSNIF_MAX_LEVELS; ++l)
           s.indexed[l] =
               l < s.config.grid_levels && (ix.level_count ? l < ix.level_count && ix.per_level[l] : ix.u) != 0;
       }},
      field<SurfaceMaps, &T::surface_maps>("surface maps"),
      field<TextureCoordinates, &T::texture_coordinates>("texture coordinates"),
      field<UvCells, &T::uv_cells>("uv cells per voxel"),
      field<Steps, &T::steps>("steps"),
      field<Batch, &T::batch_size>("batch size"),
      field<Seed, &T::seed>("seed"),
      field<RayReuse, &T::ray_reuse>("ray reuse"),
      field<MlpPrecision, &T::mlp_precision>("MLP precision"),
      field<Lr, &T::adam, &AdamSettings::learning_rate>("learning rate"),
      field<LrSchedule, &T::lr_schedule, &LrScheduleSettings::schedule>("learning-rate schedule"),
      field<LrFinal, &T::lr_schedule, &LrScheduleSettings::final_fraction>(
          "learning-rate schedule: the final fraction"),
      field<LrWarm, &T::lr_schedule, &LrScheduleSettings::warm_fraction>("learning-rate schedule: the warm share"),
      field<AdamBeta1, &T::adam, &AdamSettings::beta1>("Adam beta1"),
      field<AdamBeta2, &T::adam, &AdamSettings::beta2>("Adam beta2"),
      field<AdamEpsilon, &T::adam, &AdamSettings::epsilon>("Adam epsilon"),
      field<EmaDecay, &T::ema_decay>("parameter average decay"),
      field<NormalLoss, &T::loss_settings, &LossSettings::normal_loss>("normal loss"),
      field<WOcclusion, &T::loss_settings, &LossSettings::occlusion>("loss weights: occlusion"),
      field<WDistance, &T::loss_settings, &LossSettings::distance>("loss weights: distance"),
      field<WNormal, &T::loss_settings, &LossSettings::normal>("loss weights: normal"),
      field<WAlbedo, &T::loss_settings, &LossSettings::albedo>("loss weights: albedo"),
      field<WMaterial, &T::loss_settings, &LossSettings::material>("loss weights: material"),
      field<WSurface, &T::loss_settings, &LossSettings::surface>("loss weights: surface"),
      field<SurfaceFraction, &T::sampler, &SamplerSettings::surface_fraction>("surface fraction"),
      field<SphereScale, &T::sampler, &SamplerSettings::sphere_scale>("sphere scale"),
      field<SurfaceOffset, &T::sampler, &SamplerSettings::surface_offset>("surface offset"),
      field<SurfaceRays, &T::sampler, &SamplerSettings::surface_rays>("surface rays"),
      field<GridInitRange, &T::grid_init_range>("grid init range"),
  }};
}
constexpr std::array<SettingField, kSettingCount> kSettingFields = setting_fields();

constexpr bool fields_in_id_order() {
  for (size_t i = 0; i < kSettingCount; ++i)
    if (static_cast<size_t>(kSettingFields[i].id) != i) return false;
  return true;
}
static_assert(fields_in_id_order(), "kSettingFields must bind every setting, in SettingId order");

// Where each resolved value came from, for messages: the layer (nullptr: a default or a preset of
// no layer).
using Origins = std::array<const SettingLayer*, kSettingCount>;

// How the checks name the settings in their messages: as given, by the option or the file's key
// and the file (`origin`: a resolve), or, for a TrainSettings made in code (`origin` nullptr), by
// their fields' words.
struct Names {
  const Origins* origin;

  std::string label(SettingId id) const {
    if (!origin) return kSettingFields[static_cast<size_t>(id)].words;
    const SettingLayer* l = (*origin)[static_cast<size_t>(id)];
    const char* name = setting_def(id).name;
    if (l) return l->label(name);
    std::string s = "--";
    return s += name;
  }
  // "FILE: " when any of `ids` came from a file.
  std::string file_prefix(std::initializer_list<SettingId> ids) const {
    for (SettingId id : ids) {
      const SettingLayer* l = origin ? (*origin)[static_cast<size_t>(id)] : nullptr;
      if (l && !l->file.empty()) return l->file + ": ";
    }
    return "";
  }
};

Status apply_layer(const SettingLayer& layer, SettingValues& values, Origins& origin) {
  const std::string prefix = layer.file.empty() ? "" : layer.file + ": ";
  for (const Preset* p : layer.presets) {
    // A preset and a value it sets, given together, contradict each other.
    std::string sets, conflicts;
    for (uint32_t k = 0; k < p->count; ++k) {
      const SettingDef& d = setting_def(p->values[k].id);
      if (k) sets += k + 1 == p->count ? " and " : ", ";
      sets += layer.label(d.name) + (layer.file.empty() ? " " : ": ") +
              setting_text(d, setting_value(d, p->values[k].value));
      if (layer.given[static_cast<size_t>(d.id)]) conflicts = layer.label(d.name);
    }
    const std::string preset = layer.label(p->option) + (p->choice ? (layer.file.empty() ? " " : ": ") +
                                                                          std::string(p->choice) : "");
    if (!conflicts.empty())
      return Status::error("%s%s sets %s; give either %s or those", prefix.c_str(), preset.c_str(), sets.c_str(),
                           layer.label(p->option).c_str());
    for (uint32_t k = 0; k < p->count; ++k) {
      const SettingDef& d = setting_def(p->values[k].id);
      values[d.id] = setting_value(d, p->values[k].value);
      origin[static_cast<size_t>(d.id)] = &layer;
    }
  }
  for (const SettingDef& d : kSettingDefs) {
    const size_t i = static_cast<size_t>(d.id);
    if (!layer.given[i]) continue;
    SettingValue v = layer.values.v[i];
    if (d.kind == SettingKind::Choice) {
      const std::string& name = layer.choice[i];
      const SettingChoice* c = find_choice(d, name);
      if (!c)
        return Status::error("%s%s must be %s (got '%s')", prefix.c_str(), layer.label(d.name).c_str(),
                             quoted_alternatives(d.choice_count, [&](size_t k) { return d.choices[k].name; }).c_str(),
                             printable(name).c_str());
      v.u = c->value;
    }
    if (Status s = check_setting_range(d, v, layer.label(d.name)); !s) return layer.file.empty() ? s : s.context(layer.file);
    values.v[i] = v;
    origin[i] = &layer;
  }
  return Status::ok();
}

// The checks that involve several settings; `config` is the model config the values give.
Status check_together(const SettingValues& v, const Config& config, const Names& names) {
  using enum SettingId;
  const auto u32 = [&](SettingId id) { return static_cast<uint32_t>(v[id].u); };
  const auto label = [&](SettingId id) { return names.label(id); };
  if (u32(ResMin) > u32(ResMax))
    return Status::error("%sneed %s <= %s (got %u, %u)", names.file_prefix({ResMin, ResMax}).c_str(),
                         label(ResMin).c_str(), label(ResMax).c_str(), u32(ResMin), u32(ResMax));
  if (u32(ResMin) % u32(Voxels) || u32(ResMax) % u32(Voxels))
    return Status::error("%s%s %u and %s %u must each be a multiple of the voxel resolution %u (%s; voxel faces "
                         "must lie on grid planes)",
                         names.file_prefix({ResMin, ResMax, Voxels}).c_str(), label(ResMin).c_str(), u32(ResMin),
                         label(ResMax).c_str(), u32(ResMax), u32(Voxels), label(Voxels).c_str());
  for (const SettingId id : {TableLog2, Indexed})  // the per-level settings
    if (v[id].level_count != 0 && v[id].level_count != u32(Levels))
      return Status::error("%s%s %s gives %u values for %u levels (%s): give one value for every level or one per "
                           "level", names.file_prefix({id, Levels}).c_str(), label(id).c_str(),
                           setting_text(setting_def(id), v[id]).c_str(), v[id].level_count, u32(Levels),
                           label(Levels).c_str());
  if (u32(RayReuse) > u32(Batch))
    return Status::error("%s%s %u must be in [1, %s %u]", names.file_prefix({RayReuse, Batch}).c_str(),
                         label(RayReuse).c_str(), u32(RayReuse), label(Batch).c_str(), u32(Batch));
  // The surface channels' weight alone trains nothing of the geometry (and nothing at all for a
  // model without them): it does not count here.
  if (!(v[WOcclusion].f + v[WDistance].f + v[WNormal].f + v[WAlbedo].f + v[WMaterial].f > 0.0f))
    return Status::error("%severy loss weight%s is 0: nothing would be trained",
                         names.file_prefix({WOcclusion, WDistance, WNormal, WAlbedo, WMaterial}).c_str(),
                         names.origin ? " (w-*)" : "");
  if (Status st = config.validate(); !st) return st.context("invalid model settings");
  return Status::ok();
}

// 64-bit FNV-1a, continued from `h`.
struct Fnv {
  uint64_t h = 0xcbf29ce484222325ull;
  void bytes(const void* p, size_t n) {
    const auto* b = static_cast<const unsigned char*>(p);
    for (size_t i = 0; i < n; ++i) {
      h ^= b[i];
      h *= 0x100000001b3ull;
    }
  }
  template <class T>
  void vec(const std::vector<T>& v) {
    const uint64_t n = v.size();
    bytes(&n, sizeof n);
    if (!v.empty()) bytes(v.data(), v.size() * sizeof(T));
  }
  void str(const std::string& s) {
    const uint64_t n = s.size();
    bytes(&n, sizeof n);
    bytes(s.data(), s.size());
  }
  template <class T>
  void pod(const T& v) { bytes(&v, sizeof v); }
};

}  // namespace

SettingValue setting_value(const SettingDef& d, double value) {
  SettingValue v;
  if (d.kind == SettingKind::F32) v.f = static_cast<float>(value);
  else v.u = static_cast<uint64_t>(value);
  return v;
}

SettingValue default_indexed_value(uint32_t levels) {
  uint32_t values[LSNIF_MAX_LEVELS] = {};
  levels = std::clamp(levels, 1u, uint32_t(LSNIF_MAX_LEVELS));
  for (uint32_t l = 0; l < levels; ++l) values[l] = default_indexed(l);
  SettingValue v;
  per_level_value(values, levels, v);
  return v;
}

SettingValues SettingValues::defaults() {
  SettingValues v;
  for (const SettingDef& d : kSettingDefs) v[d.id] = setting_value(d, d.def);
  v[SettingId::Indexed] = default_indexed_value(default_u32(SettingId::Levels));
  return v;
}

void SettingLayer::set(SettingId id, SettingValue value, std::string text) {
  const size_t i = static_cast<size_t>(id);
  given[i] = true;
  values.v[i] = value;
  choice[i] = std::move(text);
}

std::string SettingLayer::label(const char* name) const {
  std::string s = file.empty() ? "--" : "\"";
  s += name;
  if (!file.empty()) s += '"';
  return s;
}

const Preset* find_preset(std::string_view option, const char* choice) {
  for (const Preset& p : kPresets)
    if (option == p.option && (choice && p.choice ? std::string_view(choice) == p.choice : !choice && !p.choice))
      return &p;
  return nullptr;
}

const SettingDef* find_setting(std::string_view name) {
  for (const SettingDef& d : kSettingDefs)
    if (name == d.name) return &d;
  return nullptr;
}

Status parse_settings_json(std::string_view text, const std::string& file, SettingLayer& out) {
  nlohmann::json j;
  if (Status s = json::parse(text, file, j); !s) return s;
  if (!j.is_object())
    return Status::error("%s: a settings file holds a JSON object of setting name -> value, not %s", file.c_str(),
                         j.type_name());
  SettingLayer layer;
  layer.file = file;
  for (const auto& [key, value] : j.items()) {
    const std::string where = file + ": \"" + printable(key) + "\"";
    if (const SettingDef* d = find_setting(key)) {
      SettingValue v;
      std::string choice;
      if (Status s = setting_from_json(*d, value, v, choice); !s) return s.context(where);
      layer.set(d->id, v, choice);
      continue;
    }
    bool is_preset = false;
    for (const Preset& p : kPresets) is_preset |= key == p.option;
    if (!is_preset) return Status::error("%s: unknown setting (see `lsnif train --help`)", where.c_str());
    if (find_preset(key, nullptr)) {  // a flag
      if (!value.is_boolean()) return Status::error("%s: must be true or false, not %s", where.c_str(), value.type_name());
      if (value.get<bool>()) layer.presets.push_back(find_preset(key, nullptr));
      continue;
    }
    const std::string choice = value.is_string() ? value.get<std::string>() : std::string();
    const Preset* p = find_preset(key, choice.c_str());
    if (!p) {
      std::vector<const char*> names;
      for (const Preset& q : kPresets)
        if (key == q.option) names.push_back(q.choice);
      return Status::error("%s: must be %s (got %s)", where.c_str(),
                           quoted_alternatives(names.size(), [&](size_t k) { return names[k]; }).c_str(),
                           printable(value.dump()).c_str());
    }
    layer.presets.push_back(p);
  }
  out = std::move(layer);
  return Status::ok();
}

Status read_settings_file(const std::string& path, SettingLayer& out) {
  std::string text;
  ReadFailure f;
  if (!read_file(path, text, kMaxConfigFileBytes, &f)) {
    switch (f.problem) {
      case ReadProblem::Missing: return Status::error("%s: no such file", path.c_str());
      case ReadProblem::CannotAccess:
      case ReadProblem::Directory:
      case ReadProblem::NotRegular: return Status::error("%s: not a regular file", path.c_str());
      case ReadProblem::SizeUnknown:
      case ReadProblem::TooLarge:
        return Status::error("%s: larger than %llu bytes, not a settings file", path.c_str(),
                             (unsigned long long)kMaxConfigFileBytes);
      default: return Status::error("%s: cannot read it (or it changed size while read)", path.c_str());
    }
  }
  return parse_settings_json(text, path, out);
}

Status resolve_settings(const std::vector<const SettingLayer*>& layers, SettingValues& out) {
  SettingValues v = SettingValues::defaults();
  Origins origin{};
  for (const SettingLayer* l : layers)
    if (Status s = apply_layer(*l, v, origin); !s) return s;
  // The default of the per-level --indexed follows the level count.
  if (!origin[static_cast<size_t>(SettingId::Indexed)])
    v[SettingId::Indexed] = default_indexed_value(static_cast<uint32_t>(v[SettingId::Levels].u));
  TrainSettings s;
  to_train_settings(v, s);
  if (Status st = check_together(v, s.config, Names{&origin}); !st) return st;
  out = v;
  return Status::ok();
}

Status resolve_settings(const std::vector<const SettingLayer*>& layers, TrainSettings& out) {
  SettingValues values;
  if (Status s = resolve_settings(layers, values); !s) return s;
  to_train_settings(values, out);
  return Status::ok();
}

void to_train_settings(const SettingValues& v, TrainSettings& s) {
  for (const SettingField& f : kSettingFields) f.set(v, s);
}

Status preset_train_settings(const Preset& p, TrainSettings& out) {
  SettingLayer layer;
  layer.presets.push_back(&p);
  TrainSettings settings;
  if (Status s = resolve_settings({&layer}, settings); !s) return s;
  out = settings;
  return Status::ok();
}

SettingValues from_train_settings(const TrainSettings& s) {
  SettingValues v;
  for (const SettingField& f : kSettingFields) f.get(s, v);
  return v;
}

nlohmann::ordered_json settings_to_json(const SettingValues& values) {
  nlohmann::ordered_json j = nlohmann::ordered_json::object();
  for (const SettingDef& d : kSettingDefs) {
    const SettingValue& v = values[d.id];
    switch (d.kind) {
      case SettingKind::U32:
      case SettingKind::U64: j[d.name] = v.u; break;
      case SettingKind::U32PerLevel:
        if (v.level_count == 0) j[d.name] = v.u;
        else j[d.name] = std::vector<uint32_t>(v.per_level.begin(), v.per_level.begin() + v.level_count);
        break;
      // The shortest decimal of the float as a double: 0.01f is written 0.01, and reads back as 0.01f.
      case SettingKind::F32: j[d.name] = json::float32(v.f); break;
      case SettingKind::Choice: j[d.name] = setting_text(d, v); break;
    }
  }
  return j;
}

Status check_train_settings(const TrainSettings& settings) {
  const SettingValues v = from_train_settings(settings);
  const Names names{nullptr};
  for (const SettingDef& d : kSettingDefs) {
    const SettingValue& x = v[d.id];
    const std::string words = names.label(d.id);
    if (d.kind == SettingKind::Choice) {
      bool known = false;
      for (uint32_t c = 0; c < d.choice_count; ++c) known |= d.choices[c].value == x.u;
      if (!known) return Status::error("unknown %s %llu", words.c_str(), (unsigned long long)x.u);
    } else if (d.kind == SettingKind::U32) {
      // The count in parentheses after the field's words: "batch size (0) out of range [1, 262144]".
      if (double(x.u) < d.min || double(x.u) > d.max)
        return Status::error("%s (%llu) out of range [%u, %u]", words.c_str(), (unsigned long long)x.u,
                             uint32_t(d.min), uint32_t(d.max));
    } else if (Status s = check_setting_range(d, x, words); !s) {
      return s;
    }
  }
  return check_together(v, settings.config, names);
}

nlohmann::ordered_json settings_to_json(const TrainSettings& settings) {
  return settings_to_json(from_train_settings(settings));
}

uint64_t fnv1a64(std::string_view bytes) {
  Fnv h;
  h.bytes(bytes.data(), bytes.size());
  return h.h;
}

uint64_t mesh_hash(const Mesh& mesh) {
  Fnv h;
  h.vec(mesh.positions);
  h.vec(mesh.normals);
  h.vec(mesh.uvs);
  h.vec(mesh.colors);
  h.vec(mesh.triangles);
  h.vec(mesh.triangle_material);
  for (const Material& m : mesh.materials) {
    h.str(m.name);
    h.pod(m.base_color);
    h.pod(m.base_color_texture);
    h.pod(m.metallic);
    h.pod(m.roughness);
    h.pod(m.emission);
    h.pod(m.occlusion_strength);
    h.pod(m.metallic_roughness_texture);
    h.pod(m.emission_texture);
    h.pod(m.occlusion_texture);
    h.pod(m.normal_scale);
    h.pod(m.normal_texture);
    h.pod(m.uv_transform);
    // Cut-outs only where there are some: the hash of an opaque mesh stays what it was before
    // materials had an alpha mode (its models stay up to date).
    if (m.alpha_mode != AlphaMode::Opaque) {
      h.pod(m.alpha_mode);
      h.pod(m.alpha);
      h.pod(m.alpha_cutoff);
    }
  }
  for (const Texture& t : mesh.textures) {
    h.pod(t.width);
    h.pod(t.height);
    h.vec(t.rgba);
  }
  return h.h;
}

bool recorded_normal_maps(const std::string& record) {
  if (record.empty()) return false;
  nlohmann::json j;
  if (!json::parse(record, "training record", j) || !j.is_object() || !j.contains("settings")) return false;
  const nlohmann::json& s = j["settings"];
  const char* name = setting_def(SettingId::SurfaceMaps).name;
  if (!s.is_object() || !s.contains(name) || !s[name].is_string()) return false;
  for (const SettingChoice& c : kSurfaceMapsChoices)
    if (s[name].get<std::string>() == c.name) return bakes_normal_maps(c.value);
  return false;
}

Status parse_training_record(const std::string& record, nlohmann::json& out) {
  out = nullptr;
  if (record.empty()) return Status::ok();
  if (Status s = json::parse(record, "training record", out); !s) return s;
  if (!out.is_object() || !out.contains("settings") || !out["settings"].is_object())
    return Status::error("training record: not an object with \"settings\"");
  return Status::ok();
}

Status model_info_json(const Model& model, bool usage, nlohmann::ordered_json& j) {
  nlohmann::json training;
  if (Status s = parse_training_record(model.training, training); !s) return s;
  const MemoryBreakdown m = memory_breakdown(model);
  const std::vector<GridLevelUsage> levels = usage ? grid_usage(model.config, model.voxels) : std::vector<GridLevelUsage>();
  const Config& c = model.config;
  j = nlohmann::ordered_json::object();
  nlohmann::ordered_json table_log2 = nlohmann::ordered_json::array(), index_slots = table_log2;
  for (uint32_t l = 0; l < c.grid_levels; ++l) {
    // null for an indexed level
    table_log2.push_back(c.indexed(l) ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(c.table_log2[l]));
    index_slots.push_back(c.index_slots[l]);
  }
  j["config"] = c.describe();
  j["voxel_resolution"] = c.voxel_resolution;
  j["max_points"] = c.max_points;
  j["grid_levels"] = c.grid_levels;
  j["table_log2"] = table_log2;
  j["index_slots"] = index_slots;
  j["index_displacements"] = c.grid_index_count();
  j["features"] = c.features;
  j["hidden_width"] = c.hidden_width;
  j["hidden_layers"] = c.hidden_layers;
  j["material_count"] = c.material_count;
  j["hit_param"] = to_string(c.hit_param);
  j["grid_bits"] = c.grid_bits;
  j["occupied_voxels"] = model.voxels.count_occupied();
  j["bytes"] = {{"voxels", m.voxel_bytes},
                {"grid", m.grid_bytes},
                {"mlp", m.mlp_bytes},
                {"header", m.header_bytes},
                {"uv_cells", m.uv_cell_bytes},
                {"total", m.total()}};
  if (usage) {
    nlohmann::ordered_json& grid_usage = j["grid_usage"] = nlohmann::ordered_json::array();
    for (const GridLevelUsage& u : levels)
      grid_usage.push_back({{"resolution", u.resolution},
                            {"vertices", u.vertices},
                            {"table_entries", u.table_entries},
                            {"entries_used", u.entries_used},
                            {"entries_shared", u.entries_shared},
                            {"vertices_in_shared", u.vertices_in_shared},
                            {"indexed_slots", u.indexed_slots},
                            {"indexed_buckets", u.indexed_buckets}});
  }
  j["training"] = training;  // as recorded (null when none is)
  return Status::ok();
}

std::string recorded_mesh_name(const std::string& path) {
  const std::filesystem::path file = std::filesystem::path(path).filename();
  return file.extension() == kTrainingMeshExtension ? file.stem().string() : file.string();
}

std::string training_record(const TrainSettings& settings, const Mesh& mesh, const std::string& mesh_name,
                            int threads) {
  nlohmann::ordered_json j;
  j["settings"] = settings_to_json(settings);
  j["mesh"] = {{"name", clean_utf8(mesh_name, 1024)},
               {"triangles", mesh.triangles.size()},
               {"hash", recorded_mesh_hash(mesh_hash(mesh))}};
  j["threads"] = threads;
  return j.dump();
}

std::string recorded_mesh_hash(uint64_t mesh_hash) { return format("fnv1a64:%016llx", (unsigned long long)mesh_hash); }

std::string training_record_difference(const std::string& record, const TrainSettings& settings, uint64_t mesh_hash) {
  if (record.empty()) return "it has no training record";
  nlohmann::json j;
  if (Status s = json::parse(record, "training record", j); !s) return s.message();
  if (!j.is_object() || !j.contains("settings") || !j["settings"].is_object())
    return "its training record holds no settings";
  const nlohmann::json& recorded = j["settings"];
  // Compared as parsed JSON values: the record's text and this dump read back the same way.
  const nlohmann::json wanted = nlohmann::json::parse(settings_to_json(settings).dump());
  for (const auto& [key, value] : wanted.items()) {
    if (!recorded.contains(key)) return format("it records no %s (the settings give %s)", key.c_str(), value.dump().c_str());
    if (recorded[key] != value)
      return format("it records %s=%s, the settings give %s=%s", key.c_str(), printable(recorded[key].dump()).c_str(),
                    key.c_str(), value.dump().c_str());
  }
  for (const auto& [key, value] : recorded.items())
    if (!wanted.contains(key)) return format("it records the unknown setting %s", printable(key).c_str());
  const std::string hash = recorded_mesh_hash(mesh_hash);
  const nlohmann::json* mesh = j.contains("mesh") && j["mesh"].is_object() ? &j["mesh"] : nullptr;
  if (!mesh || !mesh->contains("hash") || (*mesh)["hash"] != hash)
    return format("it was trained on another mesh (its record's mesh hash is not %s)", hash.c_str());
  return "";
}

}  // namespace lsnif
