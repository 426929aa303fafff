// gltf_material.cpp -- the material reader of gltf_material.h.
#include "lsnif/import/gltf_material.h"


#include <algorithm>
#include <array>
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
  Material& m = out.material;
  m.base_color = glm::vec3(unit(bc[0]), unit(bc[1]), unit(bc[2]));
  m.alpha = unit(bc[3]);
  m.metallic = unit(pbr.metallicFactor);
  m.roughness = unit(pbr.roughnessFactor);
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
  m.emission = glm::vec3(to_float(emission.x), to_float(emission.y), to_float(emission.z));
  if (!std::isfinite(m.emission.x + m.emission.y + m.emission.z))
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

// `count` finite numbers of `value` (an array of that many) into `out`.
bool read_numbers(const tinygltf::Value& value, int count, double* out) {
  if (!value.IsArray() || int(value.ArrayLen()) != count) return false;
  for (int i = 0; i < count; ++i) {
    const tinygltf::Value& v = value.Get(i);
    if (!v.IsNumber() || !std::isfinite(v.GetNumberAsDouble())) return false;
    out[i] = v.GetNumberAsDouble();
  }
  return true;
}

// The KHR_texture_transform of slot `info` into `out` (the identity without one), and in
// `tex_coord` its texCoord override (-1: none).
Status read_uv_transform(const tinygltf::TextureInfo& info, const char* slot, const std::string& where,
                         UvTransform& out, int& tex_coord) {
  out = kIdentityUvTransform;
  tex_coord = -1;
  const auto it = info.extensions.find("KHR_texture_transform");
  if (it == info.extensions.end()) return Status::ok();
  const tinygltf::Value& ext = it->second;
  if (!ext.IsObject()) return Status::error("%s: %s: KHR_texture_transform must be an object", where.c_str(), slot);
  double offset[2] = {0, 0}, rotation = 0, scale[2] = {1, 1};
  if (ext.Has("offset") && !read_numbers(ext.Get("offset"), 2, offset))
    return Status::error("%s: %s: KHR_texture_transform offset must be 2 finite numbers", where.c_str(), slot);
  if (ext.Has("rotation")) {
    const tinygltf::Value& r = ext.Get("rotation");
    if (!r.IsNumber() || !std::isfinite(r.GetNumberAsDouble()))
      return Status::error("%s: %s: KHR_texture_transform rotation must be a finite number", where.c_str(), slot);
    rotation = r.GetNumberAsDouble();
  }
  if (ext.Has("scale") && !read_numbers(ext.Get("scale"), 2, scale))
    return Status::error("%s: %s: KHR_texture_transform scale must be 2 finite numbers", where.c_str(), slot);
  if (ext.Has("texCoord")) {
    const tinygltf::Value& t = ext.Get("texCoord");
    if (!t.IsInt() || t.GetNumberAsInt() < 0)
      return Status::error("%s: %s: KHR_texture_transform texCoord must be an integer >= 0", where.c_str(), slot);
    tex_coord = t.GetNumberAsInt();
  }
  // T(offset) R(rotation) S(scale), the extension's order, with R's rows (cos, sin) and (-sin, cos):
  // the direction Khronos' TextureTransformTest asset marks correct (its "Rotation" quad, rendered
  // in docs/convert.md's check). m holds the three columns of the 2x3 result.
  const double c = std::cos(rotation), s = std::sin(rotation);
  const double m[6] = {c * scale[0], -s * scale[0], s * scale[1], c * scale[1], offset[0], offset[1]};
  for (int k = 0; k < 6; ++k)
    if (!std::isfinite(float(m[k])))
      return Status::error("%s: %s: KHR_texture_transform overflows a float", where.c_str(), slot);
  out = UvTransform(float(m[0]), float(m[1]), float(m[2]), float(m[3]), float(m[4]), float(m[5]));
  return Status::ok();
}

// The slot's texture index, uv set and extensions as a TextureInfo.
template <class Slot>
tinygltf::TextureInfo texture_info(const Slot& slot) {
  tinygltf::TextureInfo info;
  info.index = slot.index;
  info.texCoord = slot.texCoord;
  info.extensions = slot.extensions;
  return info;
}

// alphaMode, alphaCutoff and doubleSided.
Status read_alpha(const tinygltf::Material& gm, const std::string& where, const std::string& label, GltfMaterial& out,
                  std::vector<GltfWarning>& warnings) {
  if (gm.alphaMode.empty() || gm.alphaMode == "OPAQUE")
    out.material.alpha_mode = AlphaMode::Opaque;
  else if (gm.alphaMode == "MASK")
    out.material.alpha_mode = AlphaMode::Mask;
  else if (gm.alphaMode == "BLEND")
    out.material.alpha_mode = AlphaMode::Blend;
  else
    return Status::error("%s: alphaMode '%s' is none of OPAQUE, MASK and BLEND", where.c_str(),
                         excerpt(gm.alphaMode).c_str());
  if (!std::isfinite(gm.alphaCutoff) || gm.alphaCutoff < 0.0)
    return Status::error("%s: alphaCutoff must be a finite number of at least 0", where.c_str());
  out.material.alpha_cutoff = static_cast<float>(std::min(gm.alphaCutoff, 1.0));
  if (gm.alphaCutoff > 1.0)
    warnings.push_back({"", label + ": alphaCutoff above 1 was clamped to 1 (only alpha 1 is opaque)"});
  out.double_sided = gm.doubleSided;
  if (out.material.alpha_mode == AlphaMode::Blend)
    warnings.push_back({"", label + format(": alphaMode BLEND is read as a cut-out at alpha %.1f (ray tracing does not "
                                           "blend; docs/convert.md, \"Materials\")", double(kBlendCutoff))});
  return Status::ok();
}

}  // namespace

Status read_gltf_material(const tinygltf::Model& model, size_t index, const std::string& name, GltfMaterial& out,
                          std::vector<GltfWarning>& warnings) {
  const tinygltf::Material& gm = model.materials[index];
  out = GltfMaterial{};
  Material& m = out.material;
  m.name = gm.name.empty() ? format("material_%zu", index) : gm.name;
  out.label = format("material %zu ('%s')", index, excerpt(m.name).c_str());
  const std::string& label = out.label;
  const std::string where = name + ": " + label;
  bool clamped = false;
  Status s = read_factors(gm, where, out, clamped);
  if (!s) return s;
  if (clamped) warnings.push_back({"", label + ": factors outside their range were clamped"});
  const tinygltf::PbrMetallicRoughness& pbr = gm.pbrMetallicRoughness;
  // tinygltf keeps the occlusion and normal slots in types of their own: their common fields are
  // read through a TextureInfo.
  const tinygltf::TextureInfo occlusion = texture_info(gm.occlusionTexture);
  const tinygltf::TextureInfo normal = texture_info(gm.normalTexture);
  const tinygltf::TextureInfo* slots[kTextureSlotCount] = {&pbr.baseColorTexture, &pbr.metallicRoughnessTexture,
                                                           &gm.emissiveTexture, &occlusion, &normal};
  const char* slot_names[kTextureSlotCount] = {"baseColorTexture", "metallicRoughnessTexture", "emissiveTexture",
                                               "occlusionTexture", "normalTexture"};
  const std::array<int*, kTextureSlotCount> images = m.textures();  // glTF image indices here
  for (uint32_t k = 0; k < kTextureSlotCount && s; ++k)
    s = read_slot(model, *slots[k], slot_names[k], where, label, *images[k], warnings);
  if (!s) return s;
  if (!std::isfinite(gm.normalTexture.scale) || std::fabs(gm.normalTexture.scale) > 1e6)
    return Status::error("%s: normalTexture.scale must be a finite number within +-1e6", where.c_str());
  m.normal_scale = static_cast<float>(gm.normalTexture.scale);
  if (!std::isfinite(gm.occlusionTexture.strength))
    return Status::error("%s: occlusionTexture.strength must be finite", where.c_str());
  const double strength = std::clamp(gm.occlusionTexture.strength, 0.0, 1.0);
  m.occlusion_strength = static_cast<float>(strength);
  if (strength != gm.occlusionTexture.strength)
    warnings.push_back({"", label + ": occlusionTexture.strength outside [0, 1] was clamped"});
  // Each slot's KHR_texture_transform, and the one uv set: the base colour's, else the first
  // textured slot's (a transform's texCoord overrides its slot's).
  int set = -1;
  for (uint32_t k = 0; k < kTextureSlotCount; ++k) {
    const tinygltf::TextureInfo* info = slots[k];
    if (info->index < 0) continue;
    int tex_coord = -1;
    if (Status st = read_uv_transform(*info, slot_names[k], where, m.uv_transform[k], tex_coord); !st) return st;
    const int slot_set = tex_coord >= 0 ? tex_coord : info->texCoord;
    if (set < 0) set = slot_set;
    else if (slot_set != set)
      warnings.push_back({"", label + format(": textures use different TEXCOORD sets; TEXCOORD_%d used for all", set)});
  }
  if (set > 15) warnings.push_back({"", label + format(": texCoord %d unsupported; TEXCOORD_0 used", set)});
  out.uv_set = set < 0 || set > 15 ? 0 : set;
  return read_alpha(gm, where, label, out, warnings);
}

bool read_gltf_image(const tinygltf::Model& model, int source, Texture& out, std::string& why) {
  out = Texture();
  tinygltf::Image image = model.images[size_t(source)];
  why = image.uri.empty() ? "no image data" : "image data missing or undecodable";
  if (!gltf::resolve_image(model, image, kGltfMaxImagePixels, why)) return false;
  out.name = !image.name.empty() ? image.name
             : (!image.uri.empty() && image.uri.rfind("data:", 0) != 0) ? image.uri
                                                                         : format("image_%d", source);
  out.width = static_cast<uint32_t>(image.width);
  out.height = static_cast<uint32_t>(image.height);
  out.rgba = std::move(image.image);
  return true;
}

}  // namespace lsnif
