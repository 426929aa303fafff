// gltf_material.h -- the one reader of a glTF material for every tool: its factors checked and
// clamped, KHR_materials_emissive_strength applied, its texture slots resolved to image indices and
// its TEXCOORD set chosen, with what is ignored as warnings. The mesh importer (`lsnif train`,
// `eval`, `convert`) and the renderer's scene loader keep all of it. Both decode images under the same budget (kGltfMaxImagePixels) and read accessors under the
// same element limit (kGltfMaxAccessorCount). Part of lsnif_import.
#pragma once
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

#include "lsnif/format/status.h"
#include "lsnif/import/gltf_access.h"
#include "lsnif/import/mesh.h"

namespace lsnif {

inline constexpr uint64_t kGltfMaxImagePixels = uint64_t(1) << 26;  // per decoded image (8192 x 8192)
inline constexpr size_t kGltfMaxAccessorCount = size_t(1) << 30;    // elements per accessor

// A glTF material as read: the one Material (mesh.h), its texture indices glTF image indices (-1:
// none, or a texture without a PNG / JPEG source: warned), which each reader turns into indices of
// the images it decodes; and what glTF says besides.
struct GltfMaterial {
  // name: the material's, or "material_<index>"; factors clamped to [0, 1] (emission: negative
  // parts 0, times emissiveStrength, finite); occlusion_strength clamped to [0, 1]; normal_scale
  // finite; alpha_cutoff finite, clamped to [0, 1]; uv_transform: each slot's KHR_texture_transform.
  Material material;
  std::string label;          // "material INDEX ('NAME')" for messages (the name excerpted)
  int uv_set = 0;             // TEXCOORD set: the base colour texture's, else the first textured slot's
  bool double_sided = false;  // doubleSided
};

// A warning of read_gltf_material: `text` names the material; `kind` is empty, or a kind the
// renderer lists a few of and counts the rest (none at present).
struct GltfWarning {
  std::string kind;
  std::string text;
};

// Reads material `index` of `model` into `out`, appending warnings to `warnings` (factors clamped,
// textures on different TEXCOORD
// sets, a texCoord above 15, a texture without a PNG / JPEG source). Errors name `name`, the material
// and the problem: a baseColorFactor that is not 4 finite numbers, an emissiveFactor that is not 3
// (an empty one is absent: glTF's default),
// a non-finite metallic or roughness factor, a bad KHR_materials_emissive_strength, an emission
// that overflows a float, a texture or image index past its list, a KHR_texture_transform that is
// not an object or whose offset, rotation or scale is not finite numbers of the right count, an
// alphaMode other than OPAQUE, MASK and BLEND, a non-finite or negative alphaCutoff (one above 1 is
// clamped, with a warning: no alpha reaches it).
Status read_gltf_material(const tinygltf::Model& model, size_t index, const std::string& name, GltfMaterial& out,
                          std::vector<GltfWarning>& warnings);

// Image `source` of `model` (a texture slot of GltfMaterial::material) as a texture of at most
// kGltfMaxImagePixels RGBA8 pixels (gltf::resolve_image), named by the image's name, else its file,
// else "image_<source>". False, with `why` ("no image data", "image data missing or undecodable" or
// the decoder's reason), when the image holds nothing usable; the caller warns in its own words.
bool read_gltf_image(const tinygltf::Model& model, int source, Texture& out, std::string& why);

// The textures a reader makes of a glTF's images: each image a material uses, decoded once
// (read_gltf_image) and appended to the reader's list (Mesh::textures, scene::Scene::textures).
class GltfTextures {
 public:
  GltfTextures(const tinygltf::Model& model, std::vector<Texture>& list)
      : model_(model), list_(list), index_(model.images.size(), -2) {}
  // `gm`'s material with each texture slot's glTF image replaced by the image's index in the list,
  // slots in TextureSlot order; -1 for an image that holds nothing usable, for which
  // `unusable(source, why)` is called once, by the first material that uses it.
  template <class Unusable>
  Material material(const GltfMaterial& gm, Unusable&& unusable) {
    Material m = gm.material;
    for (int* t : m.textures())
      if (*t >= 0) *t = texture(*t, unusable);
    return m;
  }

 private:
  template <class Unusable>
  int texture(int source, Unusable& unusable) {
    int& index = index_[size_t(source)];
    if (index != -2) return index;
    index = -1;
    Texture t;
    std::string why;
    if (!read_gltf_image(model_, source, t, why)) {
      unusable(source, why);
      return -1;
    }
    index = int(list_.size());
    list_.push_back(std::move(t));
    return index;
  }
  const tinygltf::Model& model_;
  std::vector<Texture>& list_;
  std::vector<int> index_;  // per glTF image: its index in the list (-2: not yet read, -1: unusable)
};

}  // namespace lsnif
