// scene_edit.cpp -- see scene_edit.h.
#include "lsnif/scene/scene_edit.h"

#include <cmath>
#include <algorithm>
#include <cstdlib>
#include <sstream>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "lsnif/core/geometry.h"
#include "lsnif/format/model_format.h"
#include "lsnif/format/number_text.h"
#include "lsnif/scene/scene_gltf.h"

namespace lsnif::scene {

namespace {

// Finite and invertible (determinant of the 3x3 part not tiny against the product of its column norms).
Status check_affine(const glm::mat4& m) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(m[c][r])) return Status::error("the transform has a non-finite entry");
  const glm::mat3 a(m);
  const double norm = double(glm::length(a[0])) * glm::length(a[1]) * glm::length(a[2]);
  if (!(std::fabs(double(glm::determinant(a))) > 1e-9 * norm)) return Status::error("the transform is singular");
  return Status::ok();
}

// "A,B,C" as finite numbers; `what` names the option in errors.
Status parse_numbers(const std::string& text, const char* what, std::vector<double>& v) {
  v.clear();
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    // Spaces around a number are layout ("1, 2, 3"), not part of it.
    const size_t first = item.find_first_not_of(' '), last = item.find_last_not_of(' ');
    item = first == std::string::npos ? std::string() : item.substr(first, last - first + 1);
    double x = 0.0;
    if (!parse_f64(item, x))
      return Status::error("%s '%s': '%s': %s", what, excerpt(text, 120).c_str(), excerpt(item, 40).c_str(),
                           real_number_error(item).c_str());
    v.push_back(x);
  }
  if (!text.empty() && text.back() == ',') return Status::error("%s '%s': trailing comma", what, text.c_str());
  return Status::ok();
}

}  // namespace

Status parse_point(const std::string& text, const char* what, glm::vec3& out) {
  std::vector<double> v;
  if (Status s = parse_numbers(text, what, v); !s) return s;
  if (v.size() != 3) return Status::error("%s '%s': expected X,Y,Z, got %zu numbers", what, text.c_str(), v.size());
  out = glm::vec3(float(v[0]), float(v[1]), float(v[2]));
  if (!std::isfinite(out.x + out.y + out.z)) return Status::error("%s '%s': out of float range", what, text.c_str());
  return Status::ok();
}

Status parse_transform(const std::string& text, glm::mat4& out) {
  std::vector<double> v;
  if (Status s = parse_numbers(text, "transform", v); !s) return s;
  glm::mat4 m(1.0f);
  if (v.size() == 12) {
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) m[c][r] = float(v[size_t(r * 4 + c)]);
  } else if (v.size() >= 3 && v.size() <= 5) {
    const double scale = v.size() >= 4 ? v[3] : 1.0, degrees = v.size() == 5 ? v[4] : 0.0;
    if (!(scale > 0.0)) return Status::error("transform '%s': the scale must be positive", text.c_str());
    m = glm::translate(glm::mat4(1.0f), glm::vec3(float(v[0]), float(v[1]), float(v[2])));
    m = glm::rotate(m, float(degrees * 3.14159265358979323846 / 180.0), glm::vec3(0, 1, 0));
    m = glm::scale(m, glm::vec3(float(scale)));
  } else {
    return Status::error("transform '%s': expected X,Y,Z[,SCALE[,DEGREES_ABOUT_Y]] or 12 numbers (a row-major 3x4 "
                         "matrix), got %zu numbers",
                         text.c_str(), v.size());
  }
  if (Status s = check_affine(m); !s) return s.context("transform '" + text + "'");
  out = m;
  return Status::ok();
}

Status set_node_transform(Scene& scene, const std::string& node, const glm::mat4& object_to_world) {
  if (Status s = check_affine(object_to_world); !s) return s.context("node '" + node + "'");
  size_t found = 0;
  for (Instance& in : scene.instances)
    if (in.node_name == node) {
      in.object_to_world = object_to_world;
      ++found;
    }
  if (found == 0) return Status::error("the scene %s has no node named '%s'", scene.path.c_str(), node.c_str());
  return Status::ok();
}

Status add_lsnif_instance(Scene& scene, const std::string& model_path, const glm::mat4& object_to_world,
                          const std::string& name) {
  if (name.empty()) return Status::error("an added LSNIF object needs a name");
  if (Status s = check_affine(object_to_world); !s) return s.context("added object '" + name + "'");
  if (Status s = check_lsnif_file(model_path); !s) return s;
  Material material;
  material.name = name;
  material.base_color = glm::vec3(1.0f);
  material.metallic = 0.0f;
  material.roughness = 0.5f;
  scene.materials.push_back(material);
  LsnifObject object;
  object.model_path = model_path;
  object.resolved_path = model_path;
  object.material_map = {uint32_t(scene.materials.size() - 1)};
  scene.lsnif_objects.push_back(object);
  Instance instance;
  instance.node_name = name;
  instance.object_to_world = object_to_world;
  instance.lsnif = int32_t(scene.lsnif_objects.size() - 1);
  scene.instances.push_back(instance);
  return Status::ok();
}

Status make_look_at_camera(glm::vec3 from, glm::vec3 to, float yfov_degrees, const std::string& name, Camera& out) {
  const glm::vec3 d = to - from;
  if (!std::isfinite(d.x + d.y + d.z + from.x + from.y + from.z))
    return Status::error("camera '%s': positions must be finite", name.c_str());
  if (!(glm::length(d) > 1e-20f)) return Status::error("camera '%s': it looks from and at the same point", name.c_str());
  if (!(yfov_degrees > 0.0f && yfov_degrees < 180.0f))
    return Status::error("camera '%s': field of view %g must be in (0, 180) degrees", name.c_str(), double(yfov_degrees));
  const glm::vec3 fwd = glm::normalize(d);
  const glm::vec3 up_hint = std::fabs(fwd.y) > 0.999f ? glm::vec3(0, 0, -1) : glm::vec3(0, 1, 0);
  const glm::vec3 right = glm::normalize(glm::cross(fwd, up_hint)), up = glm::cross(right, fwd);
  out = Camera();
  out.name = name;
  out.camera_to_world = glm::mat4(glm::vec4(right, 0), glm::vec4(up, 0), glm::vec4(-fwd, 0), glm::vec4(from, 1));
  out.yfov = float(double(yfov_degrees) * 3.14159265358979323846 / 180.0);
  return Status::ok();
}

Status make_sun(glm::dvec3 direction, glm::dvec3 irradiance, double diameter_degrees, const std::string& where,
                Sun& out) {
  const double len = glm::length(direction);
  if (!std::isfinite(len) || !(len > 1e-12)) return Status::error("%s: the direction must be finite and non-zero", where.c_str());
  if (!std::isfinite(irradiance.x + irradiance.y + irradiance.z) || irradiance.x < 0.0 || irradiance.y < 0.0 ||
      irradiance.z < 0.0 || std::max(irradiance.x, std::max(irradiance.y, irradiance.z)) > 1e30)
    return Status::error("%s: the irradiance must be finite and >= 0", where.c_str());
  if (!(diameter_degrees > 0.0 && diameter_degrees < 90.0))
    return Status::error("%s: the angular diameter %g must be in (0, 90) degrees", where.c_str(), diameter_degrees);
  out = Sun();
  out.enabled = true;
  out.direction = glm::vec3(direction / len);
  out.irradiance = glm::vec3(irradiance);
  out.angular_diameter = float(diameter_degrees * 3.14159265358979323846 / 180.0);
  return Status::ok();
}

Status parse_sun(const std::string& text, Sun& out) {
  std::vector<double> v;
  if (Status s = parse_numbers(text, "--sun", v); !s) return s;
  if (v.size() != 4 && v.size() != 5)
    return Status::error("--sun '%s': expected DX,DY,DZ,IRRADIANCE[,DIAMETER_DEGREES], got %zu numbers", text.c_str(),
                         v.size());
  return make_sun({v[0], v[1], v[2]}, glm::dvec3(v[3]), v.size() == 5 ? v[4] : 0.53, "--sun '" + text + "'", out);
}

Status check_models_fit_meshes(const Scene& scene) {
  std::vector<int> checked(scene.lsnif_objects.size() * (scene.meshes.size() + 1), 0);
  for (const Instance& inst : scene.instances) {
    if (inst.mesh < 0 || inst.lsnif < 0 || size_t(inst.mesh) >= scene.meshes.size() ||
        size_t(inst.lsnif) >= scene.lsnif_objects.size())
      continue;
    int& done = checked[size_t(inst.lsnif) * (scene.meshes.size() + 1) + size_t(inst.mesh)];
    if (done) continue;
    done = 1;
    Aabb mesh_box;
    for (const Primitive& p : scene.meshes[size_t(inst.mesh)].primitives)
      for (uint32_t i : p.indices) mesh_box.grow(p.positions[i]);
    const Aabb expect = pad_aabb(mesh_box);
    const std::string& path = scene.lsnif_objects[size_t(inst.lsnif)].resolved_path;
    std::vector<uint8_t> bytes;
    ModelFileView view;
    Status s = read_model_file(path, bytes);
    if (s) s = parse_model_file(bytes.data(), bytes.size(), view).context(path);
    if (!s) return s.context("node '" + inst.node_name + "'");
    const glm::vec3 lo(view.bounds_lo[0], view.bounds_lo[1], view.bounds_lo[2]);
    const glm::vec3 hi(view.bounds_hi[0], view.bounds_hi[1], view.bounds_hi[2]);
    const float tolerance = 0.1f * std::max(expect.diagonal(), glm::length(hi - lo));
    const glm::vec3 d = glm::max(glm::abs(expect.lo - lo), glm::abs(expect.hi - hi));
    if (std::max(d.x, std::max(d.y, d.z)) <= tolerance) continue;
    return Status::error(
        "node '%s': model %s was trained in another object space than the node's mesh: its box is (%g %g %g)..(%g %g "
        "%g), a model of the mesh would have (%g %g %g)..(%g %g %g); train it on the mesh as the scene places it",
        inst.node_name.c_str(), path.c_str(), double(lo.x), double(lo.y), double(lo.z), double(hi.x), double(hi.y),
        double(hi.z), double(expect.lo.x), double(expect.lo.y), double(expect.lo.z), double(expect.hi.x),
        double(expect.hi.y), double(expect.hi.z));
  }
  return Status::ok();
}

}  // namespace lsnif::scene
