// mesh.h -- an object's triangle soup in object space, as the importers produce it and the
// voxelizer, the ground-truth ray caster and the model's material table consume it.
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "lsnif/core/geometry.h"
#include "lsnif/format/status.h"

namespace lsnif {

// An 8-bit RGBA texture as stored in the file: the training mesh's and the scene's (scene.h).
struct Texture {
  uint32_t width = 0, height = 0;
  std::vector<uint8_t> rgba;  // 8-bit RGBA, row-major, top row first (glTF uv (0, 0); colour: sRGB-encoded)
  std::string name;           // where it came from, for messages (a glTF image's name or file), or empty
  // Bilinear lookup with repeat wrapping at uv; returns linear RGB: sRGB decoded (colour textures:
  // base colour, emission) or, with srgb false, the 8-bit values / 255 (data textures:
  // metallic-roughness, occlusion).
  glm::vec3 sample(glm::vec2 uv, bool srgb = true) const;
  // The alpha channel / 255 with the same bilinear lookup and wrapping (alpha is linear); 1 for an
  // empty texture.
  float sample_alpha(glm::vec2 uv) const;
};

// How a material's alpha (base colour factor alpha x base colour texture alpha) is read: glTF's
// alphaMode. Ray tracing has no blending: a BLEND surface is a cut-out at kBlendCutoff, as a MASK one
// at its alphaCutoff (docs/convert.md, "Materials").
enum class AlphaMode : uint32_t { Opaque = 0, Mask = 1, Blend = 2 };
inline constexpr float kBlendCutoff = 0.5f;

// The texture slots of a metallic-roughness material, the index of the per-slot arrays
// (Material::uv_transform, Material::textures(), RenderMaterial's).
enum TextureSlot : uint32_t {
  kSlotBaseColor = 0, kSlotMetallicRoughness, kSlotEmission, kSlotOcclusion, kSlotNormal, kTextureSlotCount
};

// A slot's uv transform (glTF's KHR_texture_transform): uv' = m * vec3(uv, 1), glm's 3 columns of 2
// rows.
using UvTransform = glm::mat3x2;
inline constexpr UvTransform kIdentityUvTransform(1, 0, 0, 1, 0, 0);
inline glm::vec2 apply_uv_transform(const UvTransform& m, glm::vec2 uv) { return m * glm::vec3(uv, 1.0f); }

// The one material of every tool: glTF's metallic-roughness material as the importer (training,
// `eval`, `convert`), the scene loader and the renderer hold it. Read from glTF by read_gltf_material
// (gltf_material.h); texture indices index the owner's texture list (Mesh::textures,
// scene::Scene::textures), -1 for none. The renderer packs it into its GPU layout (RenderMaterial,
// renderer/shaders/render_host_device.h).
struct Material {
  std::string name;
  glm::vec3 base_color{1.0f};  // linear RGB factor (glTF baseColorFactor.rgb)
  int base_color_texture = -1; // glTF baseColorTexture (sRGB; its alpha multiplies `alpha`)
  // The rest of glTF's metallic-roughness material, learned as surface channels
  // (src/lsnif/core/head.h): factors, and textures.
  float metallic = 1.0f, roughness = 1.0f;     // metallicFactor, roughnessFactor
  glm::vec3 emission{0.0f};                    // emissiveFactor x emissive strength, linear RGB
  float occlusion_strength = 1.0f;             // occlusionTexture.strength: occlusion = 1 + strength x (R - 1)
  float normal_scale = 1.0f;                   // normalTexture.scale
  int metallic_roughness_texture = -1;         // metallic in B, roughness in G (linear)
  int emission_texture = -1;                   // sRGB
  int occlusion_texture = -1;                  // occlusion in R (linear)
  int normal_texture = -1;                     // tangent-space normal map (linear, glTF's +Y up)
  // Alpha cut-outs: a point of the surface exists where alpha >= cutoff() (always with Opaque).
  AlphaMode alpha_mode = AlphaMode::Opaque;    // alphaMode
  float alpha = 1.0f;                          // baseColorFactor alpha
  float alpha_cutoff = 0.5f;                   // alphaCutoff (MASK)
  // Per TextureSlot: the uv transform the slot's texture is read with.
  UvTransform uv_transform[kTextureSlotCount] = {kIdentityUvTransform, kIdentityUvTransform, kIdentityUvTransform,
                                                 kIdentityUvTransform, kIdentityUvTransform};
  // Whether a channel besides the base colour varies over the surface (a metallic-roughness,
  // emission or occlusion texture): what surface channels are for.
  bool has_surface_textures() const {
    return metallic_roughness_texture >= 0 || emission_texture >= 0 || occlusion_texture >= 0;
  }
  bool has_textures() const { return base_color_texture >= 0 || has_surface_textures() || normal_texture >= 0; }
  // The alpha below which the surface is a hole: alpha_cutoff (MASK), kBlendCutoff (BLEND); none (0)
  // for OPAQUE.
  float cutoff() const {
    return alpha_mode == AlphaMode::Mask ? alpha_cutoff : alpha_mode == AlphaMode::Blend ? kBlendCutoff : 0.0f;
  }
  // The texture index of each slot, in TextureSlot order.
  std::array<int*, kTextureSlotCount> textures() {
    return {&base_color_texture, &metallic_roughness_texture, &emission_texture, &occlusion_texture, &normal_texture};
  }
  std::array<const int*, kTextureSlotCount> textures() const {
    return {&base_color_texture, &metallic_roughness_texture, &emission_texture, &occlusion_texture, &normal_texture};
  }
};

// The material channels at a point of the surface (Mesh::surface).
struct SurfaceSample {
  glm::vec3 albedo{1.0f};       // base colour factor x texture x vertex colour
  float metallic = 1.0f, roughness = 1.0f;
  float ambient_occlusion = 1.0f;  // 1 + strength x (texture.r - 1); 1 without a texture
  glm::vec3 emission{0.0f};
  // The shading normal with the material's normal map applied (normal_mapped_shading_normal); the
  // interpolated shading normal without one.
  glm::vec3 normal{0.0f, 0.0f, 1.0f};
};

// The shading normal `n` (unit) of a triangle with positions p0..p2 and texture coordinates
// uv0..uv2, perturbed by the tangent-space normal map value `texel` (linear RGB in [0, 1]) with
// glTF's `scale`: the tangent T and bitangent B are the triangle's directions of increasing u and v
// (its uv derivatives; glTF's TANGENT attribute is not read), made orthonormal to n with B's
// handedness kept, and the result is normalize(T (2 r - 1) s + B (2 g - 1) s + n (2 b - 1)). A
// triangle whose uv map is degenerate, or a result that is not finite or not in n's hemisphere,
// keeps n. The one rule of the trainer (Mesh::surface) and the renderer (render_surface.glsl).
glm::vec3 normal_mapped_shading_normal(glm::vec3 n, const glm::vec3 p[3], const glm::vec2 uv[3], glm::vec3 texel,
                                       float scale);

struct Mesh {
  std::vector<glm::vec3> positions;
  std::vector<glm::vec3> normals;    // per vertex; empty -> computed by compute_vertex_normals()
  std::vector<glm::vec2> uvs;        // per vertex; may be empty
  std::vector<glm::vec3> colors;     // per vertex linear RGB; may be empty (white)
  std::vector<glm::uvec3> triangles; // vertex indices
  std::vector<uint32_t> triangle_material;  // per triangle, index into materials
  std::vector<Material> materials;   // at least one after import
  std::vector<Texture> textures;

  Aabb bounds() const;
  // Reference albedo at a hit: base color * texture(uv) * vertex color, barycentrics (u, v) as in
  // Embree (p = (1-u-v) p0 + u p1 + v p2).
  glm::vec3 albedo(uint32_t triangle, float u, float v) const;
  // Alpha at a hit: the material's factor alpha x its base colour texture's alpha at the hit's uv
  // (vertex colour alpha is not read: colours keep RGB).
  float alpha(uint32_t triangle, float u, float v) const;
  // Whether a hit at barycentrics (u, v) of `triangle` is on the surface: always for an OPAQUE
  // material, else alpha() >= the material's cutoff(). The alpha test of the ground truth (training
  // and evaluation) and of the renderer's reference mode.
  bool opaque_at(uint32_t triangle, float u, float v) const;
  // Whether any material is MASK or BLEND (the mesh has cut-outs to test).
  bool has_cutouts() const;
  // Every material channel at a hit (the albedo as albedo()), textures sampled at the hit's uv.
  SurfaceSample surface(uint32_t triangle, float u, float v) const;
  // Material `m`'s channels at texture coordinate `uv` (before its uv transforms): factors times
  // textures, no vertex colours, the normal left at its default (what a hit that reports its
  // texture coordinate shades with). Factors only for a material index past the table.
  SurfaceSample material_at(uint32_t m, glm::vec2 uv) const;
  // The largest emission component any point of the surface can have (factor x texture <= factor).
  float max_emission() const;
  // The texture coordinate at barycentrics (u, v) of `triangle` (where its textures are read, before
  // a material's uv transform); false, `uv` untouched, when the mesh has no uvs.
  bool uv_at(uint32_t triangle, float u, float v, glm::vec2& uv) const;
  // Interpolated shading normal (normalized) at a hit; falls back to the face normal if the
  // interpolated one degenerates.
  glm::vec3 shading_normal(uint32_t triangle, float u, float v) const;
};

struct MeshImportReport {
  uint32_t dropped_degenerate = 0;  // zero-area or repeated-index triangles removed
  uint32_t dropped_invalid = 0;     // triangles referencing NaN/Inf positions or bad indices
  uint32_t fixed_normals = 0;       // vertex normals that were missing/NaN and were recomputed
  std::vector<std::string> warnings;
};

// What the user allows an import to do beyond the safe defaults.
struct MeshImportOptions {
  // Files the mesh refers to (OBJ mtllib, glTF buffers and images) may lie outside the mesh file's
  // folder (`..` escapes, absolute paths). Default: refused (resolve_path.h).
  bool allow_outside_refs = false;
  // Import a mesh of which more than kMaxDroppedFraction of the triangles are dropped as
  // degenerate or invalid (default: an error, since the rest is rarely the object meant).
  bool allow_dropping_most = false;
};

// More than this fraction of a mesh's triangles dropped is an error unless allow_dropping_most.
inline constexpr double kMaxDroppedFraction = 0.5;

// Loads .off, .obj, .ply, .gltf, .glb or .lsmesh (training_mesh.h) by extension (case-insensitive). glTF node transforms are
// flattened into object space; every triangle primitive of every mesh in the default scene is kept.
// Degenerate and invalid triangles are dropped and counted in `report`; a mesh with no valid
// triangle left (or, without options.allow_dropping_most, with most of them dropped), an unreadable
// file, a reference leaving the file's folder or an unsupported format is an error naming the file.
Status load_mesh(const std::string& path, Mesh& mesh, MeshImportReport* report = nullptr,
                 const MeshImportOptions& options = {});

// Cleans a mesh in place (the step load_mesh ends with): drops degenerate/invalid triangles,
// recomputes missing or non-finite vertex normals (area-weighted), fills a default material.
// A triangle is degenerate when it repeats a vertex or its area is not above both an absolute
// bound (the area float coordinates can resolve: 1e-30, below which the ray math underflows) and a
// bound relative to the triangle's own longest edge (area <= 1e-7 * edge^2: collinear corners).
// Vertices no kept triangle uses are removed. Dropping more than kMaxDroppedFraction of the
// triangles is an error unless `allow_dropping_most`.
Status finalize_mesh(Mesh& mesh, MeshImportReport* report, const std::string& name,
                     bool allow_dropping_most = false);

void compute_vertex_normals(Mesh& mesh);

}  // namespace lsnif
