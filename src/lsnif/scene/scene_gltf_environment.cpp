// scene_gltf_environment.cpp -- SceneBuilder's environment (scene_gltf_builder.h): the root's
// LSNIF_environment (docs/scene-format.md) with its sun, and the `--env ...` overrides.
#include "lsnif/scene/scene_gltf_builder.h"

#include <cmath>
#include <filesystem>
#include <numbers>
#include <system_error>

#include "lsnif/import/resolve_path.h"
#include "lsnif/scene/scene_edit.h"

namespace lsnif::scene::detail {

// LSNIF_environment "sun": {"direction": [x, y, z], "color": [r, g, b], "intensity": E,
// "angular_diameter_degrees": D}; irradiance = color * intensity.
Status SceneBuilder::load_sun(const tinygltf::Value& v, const std::string& where) {
  if (!v.IsObject()) return Status::error("%s must be a JSON object", where.c_str());
  glm::dvec3 direction(0.0), color(1.0);
  double intensity = 1.0, diameter = 0.53;
  bool has_direction = false;
  auto vec3_of = [](const tinygltf::Value& f, glm::dvec3& out) {
    return f.IsArray() && f.ArrayLen() == 3 && number_of(f.Get(0), out.x) && number_of(f.Get(1), out.y) &&
           number_of(f.Get(2), out.z);
  };
  for (const std::string& key : v.Keys()) {
    const tinygltf::Value& f = v.Get(key);
    if (key == "direction") {
      if (!vec3_of(f, direction)) return Status::error("%s: \"direction\" must be 3 finite numbers", where.c_str());
      has_direction = true;
    } else if (key == "color") {
      if (!vec3_of(f, color)) return Status::error("%s: \"color\" must be 3 finite numbers", where.c_str());
    } else if (key == "intensity") {
      if (!number_of(f, intensity)) return Status::error("%s: \"intensity\" must be a finite number", where.c_str());
    } else if (key == "angular_diameter_degrees") {
      if (!number_of(f, diameter))
        return Status::error("%s: \"angular_diameter_degrees\" must be a finite number", where.c_str());
    } else {
      warn(format("%s: unknown property \"%s\" ignored", where.c_str(), excerpt(key).c_str()));
    }
  }
  if (!has_direction) return Status::error("%s needs a \"direction\" (towards the sun)", where.c_str());
  return make_sun(direction, color * intensity, diameter, where, scene_.sun);
}

Status SceneBuilder::load_environment() {
  Environment& env = scene_.environment;
  env = Environment();
  std::string hdr;
  bool hdr_relative_to_scene = true;
  glm::dvec3 color(1.0);
  double intensity = 1.0, degrees = 0.0;
  const std::string where = std::string(file()) + ": " + kEnvironmentExtension;
  if (auto it = model_.extensions.find(kEnvironmentExtension); it != model_.extensions.end()) {
    const tinygltf::Value& v = it->second;
    if (!v.IsObject()) return Status::error("%s must be a JSON object", where.c_str());
    for (const std::string& key : v.Keys()) {
      const tinygltf::Value& f = v.Get(key);
      if (key == "hdr") {
        if (!f.IsString()) return Status::error("%s: \"hdr\" must be a string", where.c_str());
        hdr = f.Get<std::string>();
      } else if (key == "color") {
        if (!f.IsArray() || f.ArrayLen() != 3 || !number_of(f.Get(0), color.x) ||
            !number_of(f.Get(1), color.y) || !number_of(f.Get(2), color.z))
          return Status::error("%s: \"color\" must be 3 finite numbers", where.c_str());
      } else if (key == "intensity") {
        if (!number_of(f, intensity))
          return Status::error("%s: \"intensity\" must be a finite number", where.c_str());
      } else if (key == "rotation_degrees") {
        if (!number_of(f, degrees))
          return Status::error("%s: \"rotation_degrees\" must be a finite number", where.c_str());
      } else if (key == "sun") {
        if (Status s = load_sun(f, where + ": sun"); !s) return s;
      } else {
        warn(format("%s: unknown property \"%s\" ignored", kEnvironmentExtension, excerpt(key).c_str()));
      }
    }
  }
  const EnvironmentOverride& o = options_.environment;
  if (o.hdr) {
    hdr = *o.hdr;
    hdr_relative_to_scene = false;
  }
  if (o.color) color = glm::dvec3(*o.color);
  if (o.intensity) intensity = double(*o.intensity);
  if (o.rotation_degrees) degrees = double(*o.rotation_degrees);
  if (!std::isfinite(color.x + color.y + color.z) || color.x < 0.0 || color.y < 0.0 || color.z < 0.0)
    return Status::error("%s: color must be finite and >= 0", where.c_str());
  if (!std::isfinite(intensity) || intensity < 0.0 || intensity > kMaxEnvironmentIntensity)
    return Status::error("%s: intensity %g must be in [0, %g]", where.c_str(), intensity, kMaxEnvironmentIntensity);
  if (!std::isfinite(degrees))
    return Status::error("%s: rotation_degrees must be finite", where.c_str());
  const glm::dvec3 radiance = color * intensity;
  env.color = glm::vec3(to_float(radiance.x), to_float(radiance.y), to_float(radiance.z));
  if (!std::isfinite(env.color.x + env.color.y + env.color.z))
    return Status::error("%s: color x intensity overflows a float", where.c_str());
  env.rotation = float(std::fmod(degrees, 360.0) * std::numbers::pi / 180.0);
  if (!hdr.empty()) {
    // The scene's own image follows the reference policy; a --env path is the user's and is used as given.
    Status s = hdr_relative_to_scene ? resolve_reference(base_dir_, hdr, options_.allow_outside_refs, "hdr", env.path)
                                     : resolve_reference("", hdr, true, "--env", env.path);
    std::error_code ec;
    if (s && !std::filesystem::is_regular_file(env.path, ec))
      s = Status::error("'%s' does not exist or is not a regular file", env.path.c_str());
    if (!s) return s.context(where + ": hdr '" + excerpt(hdr) + "'");
  }
  return Status::ok();
}

}  // namespace lsnif::scene::detail
