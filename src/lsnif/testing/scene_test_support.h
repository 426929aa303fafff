// test_support.h -- helpers shared by the scene tests (not part of lsnif_scene): temporary folders,
// fake .lsnif files, and check_scene(), which checks every guarantee scene_gltf.h makes about a
// successfully loaded Scene.
#pragma once
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>
#include <unistd.h>

#include "lsnif/core/model.h"
#include "lsnif/format/model_format.h"
#include "lsnif/scene/scene_gltf.h"

namespace lsnif::scene {

inline void write_file(const std::string& path, const std::string& data) {
  std::filesystem::create_directories(std::filesystem::path(path).parent_path());
  std::ofstream(path, std::ios::binary).write(data.data(), std::streamsize(data.size()));
}

// A file that passes check_lsnif_file: the magic and some bytes (not a valid model).
inline void write_fake_lsnif(const std::string& path) {
  write_file(path, std::string("LSNIF\0\r\n", 8) + std::string(64, '\0'));
}

// A valid model of an untrained network (V=4, one grid level of 8^3, a 2x8 hash table entry
// layout, one 8-wide hidden layer) whose stored box is `lo`..`hi`, with one material per name and
// every parameter 0 and every voxel occupied.
inline Model tiny_model(glm::vec3 lo, glm::vec3 hi, const std::vector<std::string>& material_names = {"m"}) {
  Model m;
  m.config.voxel_resolution = 4;
  m.config.max_points = 4;
  m.config.grid_levels = 1;
  set_grid_resolutions(m.config, 8, 8);
  set_table_log2(m.config, 5);
  m.config.features = 2;
  m.config.hidden_width = 8;
  m.config.hidden_layers = 1;
  m.config.material_count = uint32_t(material_names.size());
  m.voxels.resolution = 4;
  m.voxels.bounds.lo = lo;
  m.voxels.bounds.hi = hi;
  m.voxels.bits.assign(size_t(model_voxel_words(m.config)), ~0u);
  for (const std::string& name : material_names) m.materials.push_back({name, glm::vec3(0.5f)});
  m.grid.assign(m.config.grid_parameter_count(), 0.0f);
  m.mlp.assign(m.config.mlp_parameter_count(), 0.0f);
  return m;
}

class TempDir {
 public:
  TempDir() {
    static int counter = 0;
    path_ = std::filesystem::temp_directory_path() /
            ("lsnif_scene_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  std::string str() const { return path_.string(); }
  std::string operator/(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

// The guarantees of scene_gltf.h on a successfully loaded scene; "" or the first violation.
inline std::string check_scene(const Scene& s) {
  auto finite = [](glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); };
  if (s.instances.empty()) return "no instances";
  for (const Texture& t : s.textures)
    if (t.width == 0 || t.height == 0 || t.rgba.size() != size_t(t.width) * t.height * 4) return "texture size";
  for (const Material& m : s.materials) {
    for (int32_t t : {m.base_color_texture, m.metallic_roughness_texture, m.emission_texture})
      if (t < -1 || t >= int32_t(s.textures.size())) return "material texture index";
    if (!finite(m.base_color) || !finite(m.emission)) return "material factors";
  }
  for (const Mesh& m : s.meshes) {
    if (m.primitives.empty()) return "mesh without primitives";
    for (const Primitive& p : m.primitives) {
      if (p.indices.empty() || p.indices.size() % 3) return "index count";
      for (uint32_t i : p.indices)
        if (i >= p.positions.size()) return "index out of range";
      for (const glm::vec3& v : p.positions)
        if (!finite(v)) return "position";
      if (!p.normals.empty()) {
        if (p.normals.size() != p.positions.size()) return "normal count";
        for (const glm::vec3& n : p.normals)
          if (!finite(n) || std::abs(glm::length(n) - 1.0f) > 1e-3f) return "normal";
      }
      if (!p.uvs.empty() && p.uvs.size() != p.positions.size()) return "uv count";
      for (const glm::vec2& uv : p.uvs)
        if (!std::isfinite(uv.x) || !std::isfinite(uv.y)) return "uv";
      if (p.material >= s.materials.size()) return "material index";
    }
  }
  for (const LsnifObject& o : s.lsnif_objects) {
    if (o.material_map.empty()) return "empty material map";
    for (uint32_t m : o.material_map)
      if (m >= s.materials.size()) return "material map index";
    if (!check_lsnif_file(o.resolved_path)) return "lsnif file";
  }
  for (const Instance& inst : s.instances) {
    if (inst.mesh < -1 || inst.mesh >= int32_t(s.meshes.size())) return "instance mesh";
    if (inst.lsnif < -1 || inst.lsnif >= int32_t(s.lsnif_objects.size())) return "instance lsnif";
    if (inst.mesh < 0 && inst.lsnif < 0) return "empty instance";
    for (int c = 0; c < 4; ++c)
      if (!finite(glm::vec3(inst.object_to_world[c]))) return "transform";
    if (!(std::abs(glm::determinant(glm::mat3(inst.object_to_world))) > 0.0f)) return "singular transform";
  }
  for (const Camera& c : s.cameras) {
    if (!(c.yfov > 0.0f && c.yfov < 3.1416f) || !(c.aspect >= 0.0f)) return "camera";
    for (int k = 0; k < 4; ++k)
      if (!finite(glm::vec3(c.camera_to_world[k]))) return "camera transform";
  }
  const Environment& e = s.environment;
  if (!finite(e.color) || e.color.x < 0.0f || e.color.y < 0.0f || e.color.z < 0.0f ||
      !std::isfinite(e.rotation))
    return "environment";
  if (!e.path.empty() && !std::filesystem::is_regular_file(e.path)) return "environment file";
  return "";
}

}  // namespace lsnif::scene
