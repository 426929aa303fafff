// gltf_material.cpp -- the material reader of gltf_material.h.
#include "lsnif/import/gltf_material.h"


#include <algorithm>
#include <cmath>
#include <limits>

#include "lsnif/format/numbers.h"

namespace lsnif {
namespace {

bool all_finite(const std::vector<double>& v) {
  return std::all_of(v.begin(), v.end(), [](double d) { return std::isfinite(d); });
}

// Factors of `gm` into `out`; `clamped` is set when one lay outside its range.
Status read_factors(const tinygltf::Material& gm, const std::string& where, GltfMaterial& out, bool& clamped) {
  const tinygltf::PbrMetallicRoughness& pbr = gm.pbrMetallicRoughness;
  // An empty factor is an absent one (a model built in memory): glTF's default.
  const std::vector<double> bc = pbr.baseColorFactor.empty() ? std::vector<double>{1, 1, 1, 1} : pbr.baseColorFactor;
  if (bc.size() != 4 || !all_finite(bc))
    return Status::error("%s: baseColorFactor must be 4 finite numbers", where.c_str());
  const std::vector<double> ef = gm.emissiveFactor.empty() ? std::vector<double>{0, 0, 0} : gm.emissiveFactor;
  if (ef.size() != 3 || !all_finite(ef))
    return Status::error("%s: emissiveFactor must be 3 finite numbers", where.c_str());
  if (!std::isfinite(pbr.metallicFactor) || !std::isfinite(pbr.roughnessFactor))
    return Status::error("%s: metallicFactor / roughnessFactor must be finite", where.c_str());
  auto unit = [&](double v) {
    const double c = std::clamp(v, 0.0, 1.0);
    clamped |= c != v;
    return static_cast<float>(c);
  };
  out.base_color = glm::vec4(unit(bc[0]), unit(bc[1]), unit(bc[2]), unit(bc[3]));
  out.metallic = unit(pbr.metallicFactor);
  out.roughness = unit(pbr.roughnessFactor);
  glm::dvec3 emission(std::max(ef[0], 0.0), std::max(ef[1], 0.0), std::max(ef[2], 0.0));
  clamped |= emission != glm::dvec3(ef[0], ef[1], ef[2]);
  if (auto it = gm.extensions.find("KHR_materials_emissive_strength"); it != gm.extensions.end()) {
    if (!it->second.IsObject())
      return Status::error("%s: KHR_materials_emissive_strength must be an object", where.c_str());
    double strength = 1.0;
    if (it->second.Has("emissiveStrength")) {
      const tinygltf::Value& v = it->second.Get("emissiveStrength");
      if (!v.IsNumber() || !std::isfinite(v.GetNumberAsDouble()) || v.GetNumberAsDouble() < 0.0)
        return Status::error("%s: emissiveStrength must be a finite number >= 0", where.c_str());
      strength = v.GetNumberAsDouble();
    }
    emission *= strength;
  }
  out.emission = glm::vec3(to_float(emission.x), to_float(emission.y), to_float(emission.z));
  if (!std::isfinite(out.emission.x + out.emission.y + out.emission.z))
    return Status::error("%s: emission overflows a float", where.c_str());
  return Status::ok();
}

// The glTF image of texture slot `info` (-1 without one, or with a warning when the texture has
// no PNG / JPEG source); `label` names the material in warnings.
Status read_slot(const tinygltf::Model& model, const tinygltf::TextureInfo& info, const char* slot,
                 const std::string& where, const std::string& label, int& out, std::vector<GltfWarning>& warnings) {
  out = -1;
  if (info.index < 0) return Status::ok();
  if (size_t(info.index) >= model.textures.size())
    return Status::error("%s: %s references missing texture %d (%zu textures)", where.c_str(), slot, info.index,
                         model.textures.size());
  if (info.extensions.count("KHR_texture_transform"))
    warnings.push_back({"KHR_texture_transform", label + ": " + slot + ": KHR_texture_transform ignored"});
  const int source = model.textures[size_t(info.index)].source;
  if (source < 0) {
    warnings.push_back({"", label + format(": %s: texture %d has no PNG/JPEG source (extension-only images are not "
                                           "supported); untextured", slot, info.index)});
    return Status::ok();
  }
  if (size_t(source) >= model.images.size())
    return Status::error("%s: %s: texture %d references missing image %d (%zu images)", where.c_str(), slot,
                         info.index, source, model.images.size());
  out = source;
  return Status::ok();
}

}  // namespace

Status read_gltf_material(const tinygltf::Model& model, size_t index, const std::string& name, GltfMaterial& out,
                          std::vector<GltfWarning>& warnings) {
  const tinygltf::Material& gm = model.materials[index];
  out = GltfMaterial{};
  out.name = gm.name.empty() ? format("material_%zu", index) : gm.name;
  out.label = format("material %zu ('%s')", index, excerpt(out.name).c_str());
  const std::string& label = out.label;
  const std::string where = name + ": " + label;
  bool clamped = false;
  Status s = read_factors(gm, where, out, clamped);
  if (!s) return s;
  if (clamped) warnings.push_back({"", label + ": factors outside their range were clamped"});
  const tinygltf::PbrMetallicRoughness& pbr = gm.pbrMetallicRoughness;
  s = read_slot(model, pbr.baseColorTexture, "baseColorTexture", where, label, out.base_color_image, warnings);
  if (s)
    s = read_slot(model, pbr.metallicRoughnessTexture, "metallicRoughnessTexture", where, label,
                  out.metallic_roughness_image, warnings);
  if (s) s = read_slot(model, gm.emissiveTexture, "emissiveTexture", where, label, out.emission_image, warnings);
  if (!s) return s;
  if (gm.normalTexture.index >= 0 || gm.occlusionTexture.index >= 0)
    warnings.push_back({"normal/occlusion maps", label + ": normal / occlusion textures ignored"});
  // The one uv set: the base colour's, else the first textured slot's.
  int set = -1;
  for (const tinygltf::TextureInfo* info : {&pbr.baseColorTexture, &pbr.metallicRoughnessTexture, &gm.emissiveTexture}) {
    if (info->index < 0) continue;
    if (set < 0) set = info->texCoord;
    else if (info->texCoord != set)
      warnings.push_back({"", label + format(": textures use different TEXCOORD sets; TEXCOORD_%d used for all", set)});
  }
  if (set > 15) warnings.push_back({"", label + format(": texCoord %d unsupported; TEXCOORD_0 used", set)});
  out.uv_set = set < 0 || set > 15 ? 0 : set;
  return Status::ok();
}

}  // namespace lsnif
