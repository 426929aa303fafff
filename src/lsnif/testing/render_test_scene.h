// render_test_scene.h -- the scene of the renderer's GPU tests (render_test, viewer_test): the
// elephant, whose node carries both its triangle mesh and an LSNIF model, on a ground quad under
// a sky color, with one camera close on the elephant.
#pragma once
#include <string>

#include <glm/glm.hpp>

#include "lsnif/import/mesh.h"
#include "lsnif/scene/scene.h"

namespace lsnif::gputest {

// `mesh` is the elephant as loaded; `color` the base color its model learned (the material the
// reference uses); `model_path` its .lsnif file.
inline scene::Scene elephant_on_ground(const Mesh& mesh, const std::string& model_path, glm::vec3 color) {
  scene::Scene scene;
  // Scene: the elephant (mesh 0, LSNIF object 0) standing on a quad (mesh 1) under a sky color.
  scene.path = "(render_test)";
  scene::Material grey, ground;
  grey.base_color = color;
  grey.metallic = 0.0f;
  grey.roughness = 0.6f;
  ground.base_color = glm::vec3(0.5f);
  ground.metallic = 0.0f;
  scene.materials = {grey, ground};
  scene::Mesh elephant;
  elephant.name = "elephant";
  elephant.primitives.push_back(scene::primitive_from(mesh, 0));
  const Aabb b = mesh.bounds();
  scene::Mesh quad;
  quad.name = "ground";
  scene::Primitive q;
  const float r = 2.0f * b.diagonal(), y = b.lo.y;
  const glm::vec3 c = b.center();
  q.positions = {{c.x - r, y, c.z - r}, {c.x + r, y, c.z - r}, {c.x + r, y, c.z + r}, {c.x - r, y, c.z + r}};
  q.indices = {0, 2, 1, 0, 3, 2};
  q.material = 1;
  quad.primitives.push_back(q);
  scene.meshes = {elephant, quad};
  scene::LsnifObject obj;
  obj.model_path = model_path;
  obj.material_map = {0};
  scene.lsnif_objects = {obj};
  scene::Instance e, g;
  e.node_name = "elephant";
  e.mesh = 0;
  e.lsnif = 0;
  g.node_name = "ground";
  g.mesh = 1;
  scene.instances = {e, g};
  scene.environment.color = glm::vec3(0.9f, 0.95f, 1.0f);
  // A camera on the elephant, from the front-right and above, the object filling most of the view.
  scene::Camera cam;
  cam.name = "closeup";
  cam.yfov = 0.7f;
  const glm::vec3 eye = c + 1.3f * b.diagonal() * glm::normalize(glm::vec3(0.7f, 0.45f, 1.0f));
  const glm::vec3 fwd = glm::normalize(c - eye), right = glm::normalize(glm::cross(fwd, glm::vec3(0, 1, 0)));
  cam.camera_to_world = glm::mat4(glm::vec4(right, 0), glm::vec4(glm::cross(right, fwd), 0), glm::vec4(-fwd, 0),
                                  glm::vec4(eye, 1));
  scene.cameras = {cam};
  return scene;
}

}  // namespace lsnif::gputest
