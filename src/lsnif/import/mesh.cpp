// mesh.cpp -- the Mesh queries (bounds, reference albedo, shading normal), texture lookup, the
// clean-up step every importer ends with (finalize_mesh) and load_mesh's dispatch by extension.
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <new>
#include <stdexcept>

#include "lsnif/import/mesh.h"
#include "lsnif/import/mesh_formats.h"
#include "lsnif/import/training_mesh.h"
#include "lsnif/format/file_io.h"
#include "lsnif/format/model_format.h"

namespace lsnif {
namespace {

bool finite3(const glm::vec3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

// sRGB transfer function decode of an 8-bit value, tabulated once.
const std::array<float, 256>& srgb_to_linear_table() {
  static const std::array<float, 256> table = [] {
    std::array<float, 256> t{};
    for (int i = 0; i < 256; ++i) {
      double c = i / 255.0;
      t[static_cast<size_t>(i)] = static_cast<float>(
          c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4));
    }
    return t;
  }();
  return table;
}

// Wraps a texel coordinate into [0, n) (repeat addressing).
uint32_t wrap(int64_t i, uint32_t n) {
  int64_t m = i % static_cast<int64_t>(n);
  if (m < 0) m += n;
  return static_cast<uint32_t>(m);
}

glm::dvec3 face_cross(const Mesh& mesh, const glm::uvec3& t) {
  glm::dvec3 p0(mesh.positions[t.x]), p1(mesh.positions[t.y]), p2(mesh.positions[t.z]);
  return glm::cross(p1 - p0, p2 - p0);
}

// Coordinates beyond this magnitude overflow the squared distances of float ray math (half the
// model file's limit: the trainer pads the box).
constexpr double kMaxCoordinate = 0.5 * kMaxModelCoordinate;
// Triangle areas at or below this underflow the float ray math (edges of ~1e-15).
constexpr double kMinTriangleArea = 1e-30;
// A triangle whose area is at most this times its longest edge squared has collinear corners (its
// height is below float resolution relative to the edge).
constexpr double kMinAreaPerEdge2 = 1e-8;

bool within_range(const glm::vec3& v) {
  return finite3(v) && std::abs(v.x) <= kMaxCoordinate && std::abs(v.y) <= kMaxCoordinate &&
         std::abs(v.z) <= kMaxCoordinate;
}

// Removes the vertices no triangle uses (with their attributes) and renumbers the triangles, so
// that an unused broken vertex cannot reach the voxelizer, the ray caster or the bounds.
void remove_unused_vertices(Mesh& mesh) {
  const size_t n = mesh.positions.size();
  std::vector<uint32_t> remap(n, mesh_io::kInvalidIndex);
  for (const glm::uvec3& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) remap[t[k]] = 0;
  uint32_t next = 0;
  for (size_t i = 0; i < n; ++i)
    if (remap[i] == 0) remap[i] = next++;
  if (next == n) return;
  auto compact = [&](auto& v) {
    if (v.size() != n) return;
    for (size_t i = 0; i < n; ++i)
      if (remap[i] != mesh_io::kInvalidIndex) v[remap[i]] = v[i];
    v.resize(next);
  };
  compact(mesh.positions);
  compact(mesh.normals);
  compact(mesh.uvs);
  compact(mesh.colors);
  for (glm::uvec3& t : mesh.triangles) t = glm::uvec3(remap[t.x], remap[t.y], remap[t.z]);
}

}  // namespace

namespace {

// The four texels a bilinear lookup at uv blends (repeat wrapping) and its weights.
struct Footprint {
  uint32_t xs[2], ys[2];
  float fx, fy;
};

Footprint footprint(glm::vec2 uv, uint32_t width, uint32_t height) {
  // Wrap into [0, 1) first so huge coordinates cannot overflow the texel arithmetic.
  double u = std::isfinite(uv.x) ? uv.x - std::floor(double(uv.x)) : 0.0;
  double v = std::isfinite(uv.y) ? uv.y - std::floor(double(uv.y)) : 0.0;
  // Texel centres sit at (i + 0.5) / size.
  double x = u * width - 0.5, y = v * height - 0.5;
  double x0 = std::floor(x), y0 = std::floor(y);
  return {{wrap(int64_t(x0), width), wrap(int64_t(x0) + 1, width)},
          {wrap(int64_t(y0), height), wrap(int64_t(y0) + 1, height)},
          static_cast<float>(x - x0),
          static_cast<float>(y - y0)};
}

// The uv at barycentrics (u, v) of triangle t of `mesh`, when the mesh has a uv per vertex.
bool interpolated_uv(const Mesh& mesh, const glm::uvec3& t, float u, float v, glm::vec2& uv) {
  const size_t n = mesh.uvs.size();
  if (n != mesh.positions.size() || t.x >= n || t.y >= n || t.z >= n) return false;
  uv = (1.0f - u - v) * mesh.uvs[t.x] + u * mesh.uvs[t.y] + v * mesh.uvs[t.z];
  return true;
}

}  // namespace

bool Mesh::uv_at(uint32_t triangle, float u, float v, glm::vec2& uv) const {
  return triangle < triangles.size() && interpolated_uv(*this, triangles[triangle], u, v, uv);
}

glm::vec3 Texture::sample(glm::vec2 uv, bool srgb) const {
  if (width == 0 || height == 0 || rgba.size() < size_t(width) * height * 4) return glm::vec3(1.0f);
  const Footprint f = footprint(uv, width, height);
  const auto& lut = srgb_to_linear_table();
  auto texel = [&](uint32_t tx, uint32_t ty) {
    size_t o = (size_t(ty) * width + tx) * 4;
    if (!srgb) return glm::vec3(rgba[o], rgba[o + 1], rgba[o + 2]) / 255.0f;
    return glm::vec3(lut[rgba[o]], lut[rgba[o + 1]], lut[rgba[o + 2]]);
  };
  glm::vec3 top = glm::mix(texel(f.xs[0], f.ys[0]), texel(f.xs[1], f.ys[0]), f.fx);
  glm::vec3 bottom = glm::mix(texel(f.xs[0], f.ys[1]), texel(f.xs[1], f.ys[1]), f.fx);
  return glm::mix(top, bottom, f.fy);
}

float Texture::sample_alpha(glm::vec2 uv) const {
  if (width == 0 || height == 0 || rgba.size() < size_t(width) * height * 4) return 1.0f;
  const Footprint f = footprint(uv, width, height);
  auto texel = [&](uint32_t tx, uint32_t ty) { return float(rgba[(size_t(ty) * width + tx) * 4 + 3]) / 255.0f; };
  const float top = glm::mix(texel(f.xs[0], f.ys[0]), texel(f.xs[1], f.ys[0]), f.fx);
  const float bottom = glm::mix(texel(f.xs[0], f.ys[1]), texel(f.xs[1], f.ys[1]), f.fx);
  return glm::mix(top, bottom, f.fy);
}

Aabb Mesh::bounds() const {
  Aabb box;
  const uint32_t n = static_cast<uint32_t>(positions.size());
  for (const glm::uvec3& t : triangles) {
    for (int k = 0; k < 3; ++k) {
      if (t[k] >= n) continue;
      const glm::vec3& p = positions[t[k]];
      if (finite3(p)) box.grow(p);
    }
  }
  return box;
}

glm::vec3 normal_mapped_shading_normal(glm::vec3 n, const glm::vec3 p[3], const glm::vec2 uv[3], glm::vec3 texel,
                                       float scale) {
  const glm::vec3 dp1 = p[1] - p[0], dp2 = p[2] - p[0];
  const glm::vec2 duv1 = uv[1] - uv[0], duv2 = uv[2] - uv[0];
  const float det = duv1.x * duv2.y - duv2.x * duv1.y;
  if (!(std::fabs(det) > 1e-20f)) return n;
  const glm::vec3 t = (dp1 * duv2.y - dp2 * duv1.y) / det;
  const glm::vec3 b = (dp2 * duv1.x - dp1 * duv2.x) / det;
  const glm::vec3 t_ortho = t - n * glm::dot(n, t);
  const float t_len = glm::length(t_ortho);
  if (!(t_len > 1e-20f) || !std::isfinite(t_len)) return n;
  const glm::vec3 tangent = t_ortho / t_len;
  const glm::vec3 bitangent = glm::cross(n, tangent) * (glm::dot(glm::cross(n, tangent), b) < 0.0f ? -1.0f : 1.0f);
  const glm::vec3 m = 2.0f * texel - 1.0f;
  const glm::vec3 mapped = tangent * (m.x * scale) + bitangent * (m.y * scale) + n * m.z;
  const float len = glm::length(mapped);
  if (!(len > 1e-20f) || !std::isfinite(len) || !(glm::dot(mapped, n) > 0.0f)) return n;
  return mapped / len;
}

namespace {

// Material `mat`'s factors times its metallic-roughness, emission and occlusion textures at `uv`
// (`uv` null: the factors), into `out` (albedo and normal untouched).
void material_channels(const Mesh& mesh, const Material& mat, const glm::vec2* uv, SurfaceSample& out) {
  out.metallic = mat.metallic;
  out.roughness = mat.roughness;
  out.emission = mat.emission;
  if (!uv) return;
  auto texture = [&](int index) {
    return index >= 0 && size_t(index) < mesh.textures.size() ? &mesh.textures[size_t(index)] : nullptr;
  };
  auto at = [&](TextureSlot slot) { return apply_uv_transform(mat.uv_transform[slot], *uv); };
  if (const Texture* tex = texture(mat.metallic_roughness_texture)) {
    const glm::vec3 mr = tex->sample(at(kSlotMetallicRoughness), false);
    out.metallic *= mr.b;
    out.roughness *= mr.g;
  }
  if (const Texture* tex = texture(mat.emission_texture)) out.emission *= tex->sample(at(kSlotEmission), true);
  if (const Texture* tex = texture(mat.occlusion_texture))
    out.ambient_occlusion = 1.0f + mat.occlusion_strength * (tex->sample(at(kSlotOcclusion), false).r - 1.0f);
}

// Material `mat`'s base colour factor times its base colour texture at `uv` (`uv` null: the factor).
glm::vec3 base_colour(const Mesh& mesh, const Material& mat, const glm::vec2* uv) {
  glm::vec3 colour = mat.base_color;
  if (uv && mat.base_color_texture >= 0 && size_t(mat.base_color_texture) < mesh.textures.size())
    colour *= mesh.textures[size_t(mat.base_color_texture)].sample(apply_uv_transform(mat.uv_transform[kSlotBaseColor], *uv));
  return colour;
}

}  // namespace

SurfaceSample Mesh::surface(uint32_t triangle, float u, float v) const {
  SurfaceSample out;
  out.albedo = albedo(triangle, u, v);
  out.normal = shading_normal(triangle, u, v);
  if (triangle >= triangles.size()) return out;
  const uint32_t m = triangle < triangle_material.size() ? triangle_material[triangle] : 0u;
  if (m >= materials.size()) return out;
  const Material& mat = materials[m];
  const glm::uvec3& t = triangles[triangle];
  glm::vec2 uv;
  const bool has_uv = interpolated_uv(*this, t, u, v, uv);
  material_channels(*this, mat, has_uv ? &uv : nullptr, out);
  if (has_uv && mat.normal_texture >= 0 && size_t(mat.normal_texture) < textures.size()) {
    const Texture& tex = textures[size_t(mat.normal_texture)];
    // The tangent frame follows the uvs the normal map is read with.
    const UvTransform& transform = mat.uv_transform[kSlotNormal];
    const glm::vec3 p[3] = {positions[t.x], positions[t.y], positions[t.z]};
    const glm::vec2 uvs3[3] = {apply_uv_transform(transform, uvs[t.x]), apply_uv_transform(transform, uvs[t.y]),
                               apply_uv_transform(transform, uvs[t.z])};
    out.normal = normal_mapped_shading_normal(out.normal, p, uvs3, tex.sample(apply_uv_transform(transform, uv), false),
                                              mat.normal_scale);
  }
  return out;
}

SurfaceSample Mesh::material_at(uint32_t m, glm::vec2 uv) const {
  SurfaceSample out;
  if (m >= materials.size()) return out;
  const Material& mat = materials[m];
  out.albedo = base_colour(*this, mat, &uv);
  material_channels(*this, mat, &uv, out);
  return out;
}

float Mesh::max_emission() const {
  float largest = 0.0f;
  for (const Material& mat : materials)
    for (int c = 0; c < 3; ++c) largest = std::max(largest, mat.emission[c]);
  return largest;
}

glm::vec3 Mesh::albedo(uint32_t triangle, float u, float v) const {
  if (triangle >= triangles.size()) return glm::vec3(0.0f);
  const glm::uvec3& t = triangles[triangle];
  const float w = 1.0f - u - v;
  glm::vec3 color(1.0f);
  uint32_t m = triangle < triangle_material.size() ? triangle_material[triangle] : 0u;
  if (m < materials.size()) {
    glm::vec2 uv;
    const bool has_uv = interpolated_uv(*this, t, u, v, uv);
    color = base_colour(*this, materials[m], has_uv ? &uv : nullptr);
  }
  if (colors.size() == positions.size() && t.x < colors.size() && t.y < colors.size() &&
      t.z < colors.size()) {
    color *= w * colors[t.x] + u * colors[t.y] + v * colors[t.z];
  }
  return color;
}

float Mesh::alpha(uint32_t triangle, float u, float v) const {
  if (triangle >= triangles.size() || triangle >= triangle_material.size() ||
      triangle_material[triangle] >= materials.size())
    return 1.0f;
  const Material& mat = materials[triangle_material[triangle]];
  float a = mat.alpha;
  glm::vec2 uv;
  if (mat.base_color_texture >= 0 && size_t(mat.base_color_texture) < textures.size() && interpolated_uv(*this, triangles[triangle], u, v, uv))
    a *= textures[size_t(mat.base_color_texture)].sample_alpha(apply_uv_transform(mat.uv_transform[kSlotBaseColor], uv));
  return a;
}

bool Mesh::opaque_at(uint32_t triangle, float u, float v) const {
  if (triangle >= triangle_material.size() || triangle_material[triangle] >= materials.size()) return true;
  const Material& mat = materials[triangle_material[triangle]];
  return mat.alpha_mode == AlphaMode::Opaque || alpha(triangle, u, v) >= mat.cutoff();
}

bool Mesh::has_cutouts() const {
  for (const Material& m : materials)
    if (m.alpha_mode != AlphaMode::Opaque) return true;
  return false;
}

glm::vec3 Mesh::shading_normal(uint32_t triangle, float u, float v) const {
  if (triangle >= triangles.size()) return glm::vec3(0.0f, 0.0f, 1.0f);
  const glm::uvec3& t = triangles[triangle];
  const size_t n = positions.size();
  if (t.x >= n || t.y >= n || t.z >= n) return glm::vec3(0.0f, 0.0f, 1.0f);
  if (normals.size() == n) {
    glm::vec3 s = (1.0f - u - v) * normals[t.x] + u * normals[t.y] + v * normals[t.z];
    float len = glm::length(s);
    if (std::isfinite(len) && len > 1e-12f) return s / len;
  }
  glm::dvec3 c = face_cross(*this, t);
  double len = glm::length(c);
  if (std::isfinite(len) && len > 0.0) return glm::vec3(c / len);
  return glm::vec3(0.0f, 0.0f, 1.0f);
}

void compute_vertex_normals(Mesh& mesh) {
  const size_t n = mesh.positions.size();
  std::vector<glm::dvec3> sum(n, glm::dvec3(0.0));
  for (const glm::uvec3& t : mesh.triangles) {
    if (t.x >= n || t.y >= n || t.z >= n) continue;
    glm::dvec3 c = face_cross(mesh, t);  // |c| = 2 * area: area weighting for free
    if (!std::isfinite(c.x) || !std::isfinite(c.y) || !std::isfinite(c.z)) continue;
    sum[t.x] += c;
    sum[t.y] += c;
    sum[t.z] += c;
  }
  mesh.normals.assign(n, glm::vec3(0.0f, 0.0f, 1.0f));
  for (size_t i = 0; i < n; ++i) {
    double len = glm::length(sum[i]);
    if (std::isfinite(len) && len > 0.0) mesh.normals[i] = glm::vec3(sum[i] / len);
  }
}

namespace {

// Colors are reflectances: non-finite -> white (counted in bad_attr), the rest clamped to [0, 1]
// (counted in clamped).
void sanitize_color(glm::vec3& c, size_t& bad_attr, size_t& clamped) {
  if (!finite3(c)) {
    c = glm::vec3(1.0f);
    ++bad_attr;
  } else if (glm::clamp(c, 0.0f, 1.0f) != c) {
    c = glm::clamp(c, 0.0f, 1.0f);
    ++clamped;
  }
}

// Drops uv and color arrays that do not match the vertex count (a warning each), then zeroes non-finite
// uvs and sanitizes colors, counting the replaced values in bad_attr and the clamped colors in clamped.
void clean_vertex_attributes(Mesh& mesh, const std::string& name, MeshImportReport& rep, size_t& bad_attr,
                             size_t& clamped) {
  const size_t n = mesh.positions.size();
  if (!mesh.uvs.empty() && mesh.uvs.size() != n) {
    rep.warnings.push_back(format("%s: %zu texture coordinates for %zu vertices; dropped them",
                                  name.c_str(), mesh.uvs.size(), n));
    mesh.uvs.clear();
  }
  if (!mesh.colors.empty() && mesh.colors.size() != n) {
    rep.warnings.push_back(format("%s: %zu vertex colors for %zu vertices; dropped them",
                                  name.c_str(), mesh.colors.size(), n));
    mesh.colors.clear();
  }
  for (glm::vec2& uv : mesh.uvs) {
    if (!std::isfinite(uv.x) || !std::isfinite(uv.y)) {
      uv = glm::vec2(0.0f);
      ++bad_attr;
    }
  }
  for (glm::vec3& c : mesh.colors) sanitize_color(c, bad_attr, clamped);
}

// At least one material; each with a sanitized base color (counted as in sanitize_color), a clean
// name (the renamed ones warned about together) and no reference to a missing texture (a warning each).
void clean_materials(Mesh& mesh, const std::string& name, MeshImportReport& rep, size_t& bad_attr,
                     size_t& clamped) {
  if (mesh.materials.empty()) mesh.materials.push_back(Material{"default", glm::vec3(1.0f), -1});
  size_t renamed = 0;
  for (Material& m : mesh.materials) {
    sanitize_color(m.base_color, bad_attr, clamped);
    // A model file stores names of at most 63 bytes of clean UTF-8: fixed here, not at the save
    // after the training.
    std::string clean = clean_utf8(m.name, kModelMaterialNameBytes - 1);
    if (clean != m.name) {
      m.name = std::move(clean);
      ++renamed;
    }
    if (m.base_color_texture >= 0 && size_t(m.base_color_texture) >= mesh.textures.size()) {
      rep.warnings.push_back(format("%s: material '%s' references missing texture %d; ignored",
                                    name.c_str(), m.name.c_str(), m.base_color_texture));
      m.base_color_texture = -1;
    }
  }
  if (renamed)
    rep.warnings.push_back(format("%s: %zu material names were not clean UTF-8 or longer than %zu bytes; control "
                                  "characters and invalid bytes became '?', long names were cut", name.c_str(),
                                  renamed, kModelMaterialNameBytes - 1));
}

// One material index per triangle (a list of another length padded with 0 or cut), each in range
// (out-of-range ones set to 0).
void clean_triangle_materials(Mesh& mesh, const std::string& name, MeshImportReport& rep) {
  if (mesh.triangle_material.size() != mesh.triangles.size()) {
    if (!mesh.triangle_material.empty())
      rep.warnings.push_back(format("%s: %zu material indices for %zu triangles; padded with 0",
                                    name.c_str(), mesh.triangle_material.size(),
                                    mesh.triangles.size()));
    mesh.triangle_material.resize(mesh.triangles.size(), 0u);
  }
  size_t bad_material = 0;
  for (uint32_t& m : mesh.triangle_material) {
    if (m >= mesh.materials.size()) {
      m = 0;
      ++bad_material;
    }
  }
  if (bad_material)
    rep.warnings.push_back(format("%s: %zu triangles had an out-of-range material; set to 0",
                                  name.c_str(), bad_material));
}

// Drops the invalid and the degenerate triangles (with their material indices), counted and warned
// about; an error when none is left, or, unless allow_dropping_most, when too many went.
Status drop_bad_triangles(Mesh& mesh, const std::string& name, bool allow_dropping_most, MeshImportReport& rep) {
  // Invalid triangles: bad indices, non-finite corners or corners too far out for float ray math.
  // Degenerate ones: a repeated vertex, or an area not above both the absolute bound and the bound
  // relative to the triangle's own longest edge (judged per triangle: a stray triangle far away
  // does not change which of the others are kept).
  const size_t n = mesh.positions.size();
  const size_t total = mesh.triangles.size();
  uint32_t invalid = 0, degenerate = 0;
  size_t kept = 0;
  for (size_t i = 0; i < total; ++i) {
    const glm::uvec3 t = mesh.triangles[i];
    if (t.x >= n || t.y >= n || t.z >= n || !within_range(mesh.positions[t.x]) ||
        !within_range(mesh.positions[t.y]) || !within_range(mesh.positions[t.z])) {
      ++invalid;
      continue;
    }
    const glm::dvec3 p0(mesh.positions[t.x]), p1(mesh.positions[t.y]), p2(mesh.positions[t.z]);
    const double edge2 = std::max({glm::dot(p1 - p0, p1 - p0), glm::dot(p2 - p1, p2 - p1), glm::dot(p0 - p2, p0 - p2)});
    const double area = 0.5 * glm::length(face_cross(mesh, t));
    if (t.x == t.y || t.y == t.z || t.x == t.z || !(area > kMinTriangleArea) || !(area > kMinAreaPerEdge2 * edge2)) {
      ++degenerate;
      continue;
    }
    mesh.triangles[kept] = t;
    mesh.triangle_material[kept] = mesh.triangle_material[i];
    ++kept;
  }
  mesh.triangles.resize(kept);
  mesh.triangle_material.resize(kept);
  rep.dropped_invalid += invalid;
  rep.dropped_degenerate += degenerate;
  if (invalid)
    rep.warnings.push_back(format("%s: dropped %u triangles with out-of-range indices or non-finite "
                                  "positions (or coordinates beyond +-%g)", name.c_str(), invalid, kMaxCoordinate));
  if (degenerate)
    rep.warnings.push_back(format("%s: dropped %u degenerate (repeated-index, collinear or smaller than %g in area) "
                                  "triangles", name.c_str(), degenerate, kMinTriangleArea));
  if (kept == 0)
    return Status::error("%s: no valid triangles (%u degenerate, %u invalid)", name.c_str(),
                         degenerate, invalid);
  if (!allow_dropping_most && double(total - kept) > kMaxDroppedFraction * double(total))
    return Status::error("%s: %zu of its %zu triangles would be dropped (%u degenerate, %u invalid), more than %.0f%%: "
                         "the rest is unlikely to be the object meant (allow it with --allow-dropped-triangles)",
                         name.c_str(), total - kept, total, degenerate, invalid, 100.0 * kMaxDroppedFraction);
  return Status::ok();
}

// Recomputes the missing or unusable normals from the cleaned triangles, counted in
// rep.fixed_normals: all of them when the mesh was imported with `imported_normals` normals for
// `imported_vertices` vertices (a count that differs, 0 included); else the non-finite or zero ones
// (the normals of the vertices kept by remove_unused_vertices).
void fix_normals(Mesh& mesh, size_t imported_normals, size_t imported_vertices, const std::string& name,
                 MeshImportReport& rep) {
  uint32_t fixed = 0;
  const size_t n = mesh.positions.size();
  if (imported_normals != imported_vertices || mesh.normals.size() != n) {
    if (imported_normals != 0)
      rep.warnings.push_back(format("%s: %zu normals for %zu vertices; recomputed all",
                                    name.c_str(), imported_normals, imported_vertices));
    else
      rep.warnings.push_back(format("%s: no vertex normals; computed %zu (area-weighted)",
                                    name.c_str(), n));
    compute_vertex_normals(mesh);
    fixed = static_cast<uint32_t>(n);
  } else {
    std::vector<uint32_t> bad;
    for (size_t i = 0; i < n; ++i) {
      const glm::vec3& v = mesh.normals[i];
      if (!finite3(v) || !(glm::dot(v, v) > 0.0f)) bad.push_back(static_cast<uint32_t>(i));
    }
    if (!bad.empty()) {
      std::vector<glm::vec3> given = std::move(mesh.normals);
      compute_vertex_normals(mesh);
      for (uint32_t i : bad) given[i] = mesh.normals[i];
      mesh.normals = std::move(given);
      fixed = static_cast<uint32_t>(bad.size());
      rep.warnings.push_back(format("%s: recomputed %u missing or non-finite vertex normals",
                                    name.c_str(), fixed));
    }
  }
  rep.fixed_normals += fixed;
}

}  // namespace

Status finalize_mesh(Mesh& mesh, MeshImportReport* report, const std::string& name, bool allow_dropping_most) {
  MeshImportReport local;
  MeshImportReport& rep = report ? *report : local;
  const size_t n = mesh.positions.size();
  if (n >= mesh_io::kInvalidIndex)
    return Status::error("%s: too many vertices (%zu)", name.c_str(), n);

  // Per-vertex attribute arrays are all-or-nothing.
  size_t bad_attr = 0, clamped = 0;
  clean_vertex_attributes(mesh, name, rep, bad_attr, clamped);

  // Materials: at least one, one valid index per triangle.
  clean_materials(mesh, name, rep, bad_attr, clamped);
  if (bad_attr)
    rep.warnings.push_back(format("%s: replaced %zu non-finite texture coordinates/colors",
                                  name.c_str(), bad_attr));
  if (clamped)
    rep.warnings.push_back(format("%s: clamped %zu vertex/material colors to [0, 1]", name.c_str(),
                                  clamped));
  clean_triangle_materials(mesh, name, rep);

  Status s = drop_bad_triangles(mesh, name, allow_dropping_most, rep);
  if (!s) return s;
  const size_t imported_normals = mesh.normals.size();
  remove_unused_vertices(mesh);  // keeps a complete normal array aligned with the kept vertices

  // Normals: recompute the missing or unusable ones from the cleaned triangles.
  fix_normals(mesh, imported_normals, n, name, rep);
  return Status::ok();
}

namespace mesh_io {

MeshFormat format_from_path(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".off") return MeshFormat::Off;
  if (ext == ".obj") return MeshFormat::Obj;
  if (ext == ".ply") return MeshFormat::Ply;
  if (ext == ".gltf") return MeshFormat::Gltf;
  if (ext == ".glb") return MeshFormat::Glb;
  if (ext == kTrainingMeshExtension) return MeshFormat::TrainingMesh;
  return MeshFormat::Unknown;
}

Status parse_mesh(std::string_view data, MeshFormat format, const std::string& name,
                  const std::string& base_dir, Mesh& mesh, MeshImportReport* report,
                  const MeshImportOptions& options) {
  mesh = Mesh{};
  MeshImportReport local;
  MeshImportReport& rep = report ? *report : local;
  if (data.empty()) return Status::error("%s: empty file", name.c_str());
  try {
    Status s;
    switch (format) {
      case MeshFormat::Off: s = parse_off(data, name, mesh, rep); break;
      case MeshFormat::Obj: s = parse_obj(data, name, base_dir, options, mesh, rep); break;
      case MeshFormat::Ply: s = parse_ply(data, name, mesh, rep); break;
      case MeshFormat::Gltf: s = parse_gltf(data, false, name, base_dir, options, mesh, rep); break;
      case MeshFormat::Glb: s = parse_gltf(data, true, name, base_dir, options, mesh, rep); break;
      case MeshFormat::TrainingMesh: s = parse_training_mesh(data, name, mesh); break;
      case MeshFormat::Unknown:
        return Status::error("%s: unsupported mesh format (expected .off, .obj, .ply, .gltf, .glb or .lsmesh)",
                             name.c_str());
    }
    if (!s) {
      mesh = Mesh{};
      return s;
    }
    s = finalize_mesh(mesh, &rep, name, options.allow_dropping_most);
    if (!s) mesh = Mesh{};
    return s;
  } catch (const std::bad_alloc&) {
    mesh = Mesh{};
    return Status::error("%s: out of memory while importing", name.c_str());
  } catch (const std::exception& e) {
    mesh = Mesh{};
    return Status::error("%s: import failed: %s", name.c_str(), e.what());
  }
}

}  // namespace mesh_io

Status load_mesh(const std::string& path, Mesh& mesh, MeshImportReport* report,
                 const MeshImportOptions& options) {
  mesh = Mesh{};
  mesh_io::MeshFormat format = mesh_io::format_from_path(path);
  if (format == mesh_io::MeshFormat::Unknown)
    return Status::error("%s: unsupported mesh format '%s' (expected .off, .obj, .ply, .gltf, .glb or .lsmesh)",
                         path.c_str(), std::filesystem::path(path).extension().string().c_str());
  std::string data;
  ReadFailure f;
  if (!read_file(path, data, mesh_io::kMaxMeshFileBytes, &f)) {
    const std::string shown = printable(path);
    const char* p = shown.c_str();
    switch (f.problem) {
      case ReadProblem::Missing: return Status::error("%s: no such mesh file", p);
      case ReadProblem::Directory: return Status::error("%s: is a folder, not a mesh file", p);
      case ReadProblem::NotRegular: return Status::error("%s: is not a regular file (a device, FIFO or socket)", p);
      case ReadProblem::CannotOpen: return Status::error("%s: cannot open mesh file", p);
      case ReadProblem::SizeUnknown: return Status::error("%s: cannot read mesh file size", p);
      case ReadProblem::TooLarge: return Status::error("%s: file too large", p);
      case ReadProblem::OutOfMemory: return Status::error("%s: out of memory reading the file", p);
      case ReadProblem::ReadError:
      case ReadProblem::ChangedSize:
        if (f.got < f.size)
          return Status::error("%s: read error (got %llu of %llu bytes)", p, (unsigned long long)f.got,
                               (unsigned long long)f.size);
        return Status::error("%s: read error (the file grew while it was read)", p);
      default: return Status::error("%s: cannot access mesh file: %s", p, f.reason.c_str());
    }
  }
  std::string base_dir = std::filesystem::path(path).parent_path().string();
  return mesh_io::parse_mesh(data, format, path, base_dir, mesh, report, options);
}

}  // namespace lsnif
