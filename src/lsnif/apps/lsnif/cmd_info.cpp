// lsnif info MODEL: configuration and memory breakdown of a model file.
#include <cstdio>
#include <string>

#include "lsnif/apps/lsnif/args.h"
#include "lsnif/apps/lsnif/commands.h"
#include "lsnif/core/grid_usage.h"
#include "lsnif/import/json_text.h"
#include "lsnif/core/model.h"
#include "lsnif/train/settings_io.h"

namespace lsnif::cli {

namespace {

// "name=value" of every recorded setting, in table order, wrapped to lines of about 100 columns;
// keys the table does not know (a newer writer's) after them.
std::string settings_lines(const nlohmann::json& settings, const char* indent) {
  // As an option takes it: strings bare, lists (one value per level) joined by commas.
  const auto text = [](const nlohmann::json& v) {
    if (v.is_string()) return v.get<std::string>();
    if (!v.is_array()) return v.dump();
    std::string joined;
    for (const nlohmann::json& e : v) {
      if (!joined.empty()) joined += ',';
      joined += e.is_string() ? e.get<std::string>() : e.dump();
    }
    return joined;
  };
  std::vector<std::string> items;
  for (const SettingDef& d : kSettingDefs)
    if (settings.contains(d.name)) items.push_back(std::string(d.name) + "=" + text(settings[d.name]));
  for (const auto& [key, v] : settings.items())
    if (!find_setting(key)) items.push_back(key + "=" + text(v));
  std::string out, line;
  for (const std::string& item : items) {
    if (!line.empty() && line.size() + item.size() > 90) {
      out += line + "\n" + indent;
      line.clear();
    }
    if (!line.empty()) line += ' ';
    line += printable(item);
  }
  return out + line;
}

}  // namespace

int cmd_info(int argc, char** argv) {
  std::string path;
  bool json = false, usage = false, settings_only = false;
  Args args("info", "Prints the configuration, bounds, materials and memory breakdown of an .lsnif model.");
  args.positional("MODEL", "model file (.lsnif)", &path);
  args.flag("json", "print JSON instead of text", &json);
  args.flag("settings", "print only the training settings the model records, as JSON (a `--config` file for "
            "`lsnif train` and `lsnif convert`)", &settings_only);
  args.flag("grid-usage", "also count, per level, the grid vertices the encoding can read and their hash collisions",
            &usage);
  if (int r = args.parse(argc, argv)) return r == 1 ? 0 : 2;
  Model model;
  if (Status s = load_model(path, model); !s) {
    std::fprintf(stderr, "lsnif info: %s\n", s.message().c_str());
    return 1;
  }
  nlohmann::json training;
  if (Status s = parse_training_record(model.training, training); !s) {
    std::fprintf(stderr, "lsnif info: %s: %s\n", printable(path).c_str(), s.message().c_str());
    return 1;
  }
  if (settings_only) {
    if (training.is_null()) {
      std::fprintf(stderr, "lsnif info: %s records no training settings (a format version 1 file)\n",
                   printable(path).c_str());
      return 1;
    }
    // In table order, then keys the table does not know (they fail as a --config file, naming them).
    const nlohmann::json& recorded = training["settings"];
    nlohmann::ordered_json ordered = nlohmann::ordered_json::object();
    for (const SettingDef& d : kSettingDefs)
      if (recorded.contains(d.name)) ordered[d.name] = recorded[d.name];
    for (const auto& [key, v] : recorded.items())
      if (!find_setting(key)) ordered[key] = v;
    std::printf("%s\n", json::dump(ordered).c_str());
    return 0;
  }
  if (json) {
    nlohmann::ordered_json j;
    if (Status s = model_info_json(model, usage, j); !s) {
      std::fprintf(stderr, "lsnif info: %s: %s\n", printable(path).c_str(), s.message().c_str());
      return 1;
    }
    std::printf("%s\n", json::dump(j).c_str());
    return 0;
  }
  const MemoryBreakdown m = memory_breakdown(model);
  const std::vector<GridLevelUsage> levels = usage ? grid_usage(model.config, model.voxels) : std::vector<GridLevelUsage>();
  const Config& c = model.config;
  const Aabb& b = model.bounds();
  // Per level: "2^15 + 2^17" or "43190 (indexed) + 2^17".
  std::string table_entries_text;
  for (uint32_t l = 0; l < c.grid_levels; ++l)
    table_entries_text += c.indexed(l) ? format("%s%u (indexed)", l ? " + " : "", c.index_slots[l])
                                       : format("%s2^%u", l ? " + " : "", c.table_log2[l]);
  std::printf("model      %s\n", printable(path).c_str());
  std::printf("config     %s\n", c.describe().c_str());
  std::printf("bounds     [%g %g %g] - [%g %g %g]\n", double(b.lo.x), double(b.lo.y), double(b.lo.z),
              double(b.hi.x), double(b.hi.y), double(b.hi.z));
  std::printf("voxels     %u^3, %u occupied\n", c.voxel_resolution, model.voxels.count_occupied());
  if (training.is_null()) {
    // Only version 1 files lack the record, and version 3 and 4 files written without one.
    std::printf("training   not recorded%s\n", c.grid_bits == 16 && c.uniform_table_log2() ? " (format version 1)" : "");
  } else {
    std::printf("settings   %s\n", settings_lines(training["settings"], "           ").c_str());
    const nlohmann::json& mesh = training.contains("mesh") ? training["mesh"] : nlohmann::json();
    if (mesh.is_object() && mesh.contains("name") && mesh["name"].is_string() && mesh.contains("triangles") &&
        mesh.contains("hash") && mesh["hash"].is_string())
      std::printf("mesh       %s: %s triangles, %s\n", printable(mesh["name"].get<std::string>()).c_str(),
                  printable(mesh["triangles"].dump()).c_str(), printable(mesh["hash"].get<std::string>()).c_str());
    else if (!mesh.is_null())
      std::printf("mesh       %s\n", printable(mesh.dump()).c_str());
    if (training.contains("threads")) std::printf("threads    %s\n", printable(training["threads"].dump()).c_str());
  }
  for (size_t i = 0; i < model.materials.size(); ++i)
    std::printf("material   %zu: %s (base color %.3f %.3f %.3f)\n", i, printable(model.materials[i].name).c_str(),
                double(model.materials[i].base_color.r), double(model.materials[i].base_color.g),
                double(model.materials[i].base_color.b));
  std::printf("memory     voxels %8.1f KB\n", double(m.voxel_bytes) / 1024.0);
  const std::string tables = c.uniform_table_log2() ? format("%u levels x 2^%u entries", c.grid_levels, c.table_log2[0])
                                                    : format("%u levels: %s entries", c.grid_levels,
                                                             table_entries_text.c_str());
  std::printf("           grid   %8.1f KB (%s x %u features, %s%s)\n", double(m.grid_bytes) / 1024.0, tables.c_str(),
              c.features, c.grid_bits == 8 ? "int8 x an fp32 scale per level" : "fp16",
              c.any_indexed() ? format(", %llu 2-byte displacements", (unsigned long long)c.grid_index_count()).c_str()
                              : "");
  std::printf("           mlp    %8.1f KB (%llu parameters, fp16)\n", double(m.mlp_bytes) / 1024.0,
              (unsigned long long)c.mlp_parameter_count());
  if (c.texture_coordinates())
    std::printf("           uv     %8.1f KB (uv cells: %u per voxel edge, %u pieces; materials 0x%llx report texture "
                "coordinates)\n", double(m.uv_cell_bytes) / 1024.0, c.uv_cells, c.uv_cell_maps,
                (unsigned long long)c.uv_materials);
  std::printf("           header %8.1f KB\n", double(m.header_bytes) / 1024.0);
  std::printf("           total  %8.1f KB (%.3f MiB)\n", double(m.total()) / 1024.0, double(m.total()) / 1048576.0);
  for (size_t l = 0; l < levels.size(); ++l) {
    const GridLevelUsage& u = levels[l];
    const std::string indexed =
        u.indexed_slots ? format("%llu entries + %llu 2-byte displacements", (unsigned long long)u.indexed_slots,
                                 (unsigned long long)u.indexed_buckets)
                        : u.vertices > max_indexed_vertices()
                              ? format("not possible (more than the %llu vertices an indexed level takes)",
                                       (unsigned long long)max_indexed_vertices())
                              : std::string("not found (no displacement placed every bucket)");
    std::printf("%s level %zu (R=%u): %llu vertices on occupied voxel faces -> %llu of %llu entries used (%.1f%%), "
                "%llu shared by 2+ vertices (%.1f%% of the vertices); collision-free (indexed): %s\n",
                l ? "          " : "grid use  ", l, u.resolution, (unsigned long long)u.vertices,
                (unsigned long long)u.entries_used, (unsigned long long)u.table_entries,
                100.0 * double(u.entries_used) / double(u.table_entries), (unsigned long long)u.entries_shared,
                u.vertices ? 100.0 * double(u.vertices_in_shared) / double(u.vertices) : 0.0, indexed.c_str());
  }
  return 0;
}

}  // namespace lsnif::cli
