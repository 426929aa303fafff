// scene_gltf_materials.cpp -- SceneBuilder's materials and textures (scene_gltf_builder.h): glTF
// material i becomes scene material i, each glTF image a material uses is decoded once into a
// scene texture (through src/lsnif/import/gltf_access.h), and the default material is appended on
// first use.
#include "lsnif/scene/scene_gltf_builder.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "lsnif/import/gltf_access.h"
#include "lsnif/import/gltf_material.h"

namespace lsnif::scene::detail {

Status SceneBuilder::load_materials() {
  scene_.materials.reserve(model_.materials.size() + 1);
  gltf_materials_.reserve(model_.materials.size());
  for (size_t i = 0; i < model_.materials.size(); ++i) {
    Status s = load_material(i);
    if (!s) return s;
  }
  return Status::ok();
}

Status SceneBuilder::load_material(size_t index) {
  GltfMaterial gm;  // the one material reader (lsnif/import/gltf_material.h)
  std::vector<GltfWarning> warnings;
  Status s = read_gltf_material(model_, index, name_, gm, warnings);
  for (const GltfWarning& w : warnings) {
    if (w.kind.empty()) warn(w.text);
    else warn_counted(w.kind, w.text);
  }
  if (!s) return s;
  const std::string where = format("%s: %s", file(), gm.label.c_str());
  scene_.materials.push_back(textures_.material(gm, [&](int source, const std::string& why) {
    warn(where.substr(name_.size() + 2) + format(": image %d could not be used (%s); untextured", source, why.c_str()));
  }));
  gltf_materials_.push_back(std::move(gm));
  return Status::ok();
}

uint32_t SceneBuilder::default_material() {
  if (default_material_ < 0) {
    default_material_ = int32_t(scene_.materials.size());
    Material m;
    m.name = "default";
    scene_.materials.push_back(std::move(m));
  }
  return uint32_t(default_material_);
}

}  // namespace lsnif::scene::detail
