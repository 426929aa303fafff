// scene_gltf_materials.cpp -- SceneBuilder's materials and textures (scene_gltf_builder.h): glTF
// material i becomes scene material i, each glTF image a material uses is decoded once into a
// scene texture (through src/lsnif/import/gltf_access.h), and the default material is appended on
// first use.
#include "lsnif/renderer/scene_gltf_builder.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "lsnif/import/gltf_access.h"

namespace lsnif::scene::detail {
namespace {

bool all_finite(const std::vector<double>& v) {
  return std::all_of(v.begin(), v.end(), [](double d) { return std::isfinite(d); });
}

}  // namespace

Status SceneBuilder::load_materials() {
  scene_.materials.reserve(model_.materials.size() + 1);
  for (size_t i = 0; i < model_.materials.size(); ++i) {
    Status s = load_material(i);
    if (!s) return s;
  }
  return Status::ok();
}

Status SceneBuilder::load_material(size_t index) {
  const tinygltf::Material& gm = model_.materials[index];
  Material m;
  m.name = gm.name.empty() ? format("material_%zu", index) : gm.name;
  const std::string where = format("%s: material %zu ('%s')", file(), index, excerpt(m.name).c_str());
  const tinygltf::PbrMetallicRoughness& pbr = gm.pbrMetallicRoughness;
  const std::vector<double>& bc = pbr.baseColorFactor;
  if (bc.size() != 4 || !all_finite(bc))
    return Status::error("%s: baseColorFactor must be 4 finite numbers", where.c_str());
  const std::vector<double>& ef = gm.emissiveFactor;
  if (ef.size() != 3 || !all_finite(ef))
    return Status::error("%s: emissiveFactor must be 3 finite numbers", where.c_str());
  if (!std::isfinite(pbr.metallicFactor) || !std::isfinite(pbr.roughnessFactor))
    return Status::error("%s: metallicFactor / roughnessFactor must be finite", where.c_str());
  bool clamped = false;
  auto unit = [&](double v) {
    const double c = std::clamp(v, 0.0, 1.0);
    clamped |= c != v;
    return static_cast<float>(c);
  };
  m.base_color = glm::vec4(unit(bc[0]), unit(bc[1]), unit(bc[2]), unit(bc[3]));
  m.metallic = unit(pbr.metallicFactor);
  m.roughness = unit(pbr.roughnessFactor);
  glm::dvec3 emission(std::max(ef[0], 0.0), std::max(ef[1], 0.0), std::max(ef[2], 0.0));
  clamped |= emission != glm::dvec3(ef[0], ef[1], ef[2]);
  if (auto it = gm.extensions.find("KHR_materials_emissive_strength"); it != gm.extensions.end()) {
    double strength = 1.0;
    if (!it->second.IsObject())
      return Status::error("%s: KHR_materials_emissive_strength must be an object", where.c_str());
    const tinygltf::Value& v = it->second.Get("emissiveStrength");
    if (it->second.Has("emissiveStrength") && (!number_of(v, strength) || strength < 0.0))
      return Status::error("%s: emissiveStrength must be a finite number >= 0", where.c_str());
    emission *= strength;
  }
  m.emission = glm::vec3(to_float(emission.x), to_float(emission.y), to_float(emission.z));
  if (!std::isfinite(m.emission.x + m.emission.y + m.emission.z))
    return Status::error("%s: emission overflows a float", where.c_str());
  if (clamped) warn(where.substr(name_.size() + 2) + ": factors outside their range were clamped");

  Status s = texture_slot(pbr.baseColorTexture, "baseColorTexture", where, m.base_color_texture);
  if (s) s = texture_slot(pbr.metallicRoughnessTexture, "metallicRoughnessTexture", where,
                          m.metallic_roughness_texture);
  if (s) s = texture_slot(gm.emissiveTexture, "emissiveTexture", where, m.emission_texture);
  if (!s) return s;
  if (gm.normalTexture.index >= 0 || gm.occlusionTexture.index >= 0)
    warn_counted("normal/occlusion maps", where.substr(name_.size() + 2) +
                                              ": normal / occlusion textures ignored");
  // The uv set the renderer's single uv channel should carry: the base color's, else the first
  // textured slot's.
  int set = -1;
  for (const tinygltf::TextureInfo* info :
       {&pbr.baseColorTexture, &pbr.metallicRoughnessTexture, &gm.emissiveTexture}) {
    if (info->index < 0) continue;
    if (set < 0) set = info->texCoord;
    else if (info->texCoord != set)
      warn(where.substr(name_.size() + 2) + format(": textures use different TEXCOORD sets; "
                                                   "TEXCOORD_%d used for all", set));
  }
  if (set < 0 || set > 15) {
    if (set > 15) warn(where.substr(name_.size() + 2) + format(": texCoord %d unsupported; TEXCOORD_0 used", set));
    set = 0;
  }
  material_uv_set_.push_back(set);
  scene_.materials.push_back(std::move(m));
  return Status::ok();
}

Status SceneBuilder::texture_slot(const tinygltf::TextureInfo& info, const char* slot, const std::string& where,
                                  int32_t& out) {
  out = -1;
  if (info.index < 0) return Status::ok();
  if (size_t(info.index) >= model_.textures.size())
    return Status::error("%s: %s references missing texture %d (%zu textures)", where.c_str(), slot,
                         info.index, model_.textures.size());
  if (info.extensions.count("KHR_texture_transform"))
    warn_counted("KHR_texture_transform", where.substr(name_.size() + 2) + ": " + slot +
                                                ": KHR_texture_transform ignored");
  const int source = model_.textures[size_t(info.index)].source;
  if (source < 0) {
    warn(where.substr(name_.size() + 2) +
         format(": %s: texture %d has no PNG/JPEG source (extension-only images are not "
                "supported); untextured", slot, info.index));
    return Status::ok();
  }
  if (size_t(source) >= model_.images.size())
    return Status::error("%s: %s: texture %d references missing image %d (%zu images)",
                         where.c_str(), slot, info.index, source, model_.images.size());
  out = image_texture(source, where);
  return Status::ok();
}

// Scene texture for glTF image `source` (decoded once), or -1 with a warning.
int32_t SceneBuilder::image_texture(int source, const std::string& where) {
  int32_t& mapped = image_map_[size_t(source)];
  if (mapped != -2) return mapped;
  mapped = -1;
  tinygltf::Image image = model_.images[size_t(source)];
  std::string why = image.uri.empty() ? "no image data" : "image data missing or undecodable";
  if (!gltf::resolve_image(model_, image, kMaxPixels, why)) {
    warn(where.substr(name_.size() + 2) +
         format(": image %d could not be used (%s); untextured", source, why.c_str()));
    return -1;
  }
  Texture t;
  t.name = !image.name.empty() ? image.name
           : (!image.uri.empty() && image.uri.rfind("data:", 0) != 0) ? image.uri
                                                                       : format("image_%d", source);
  t.width = static_cast<uint32_t>(image.width);
  t.height = static_cast<uint32_t>(image.height);
  t.rgba = std::move(image.image);
  mapped = int32_t(scene_.textures.size());
  scene_.textures.push_back(std::move(t));
  return mapped;
}

uint32_t SceneBuilder::default_material() {
  if (default_material_ < 0) {
    default_material_ = int32_t(scene_.materials.size());
    Material m;
    m.name = "default";
    scene_.materials.push_back(std::move(m));
    material_uv_set_.push_back(0);
  }
  return uint32_t(default_material_);
}

}  // namespace lsnif::scene::detail
