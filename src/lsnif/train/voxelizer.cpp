// voxelizer.cpp -- LSNIF local geometry voxelization (paper 3.1): marks the voxels of a V^3 grid
// over the padded object AABB that the surface triangles overlap, with an exact separating-axis
// triangle/box test.
#include "lsnif/train/voxelizer.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

namespace lsnif {
namespace {

// The 13 candidate separating axes of a triangle against any axis-aligned box (3 box normals, the
// triangle normal, the 9 cross products of a triangle edge with a box axis), each with the
// triangle's projection interval [lo, hi] on it. Built once per triangle, tested against many boxes.
struct TriangleAxes {
  glm::vec3 axis[13];
  float lo[13];
  float hi[13];
};

TriangleAxes triangle_axes(const glm::vec3& a, const glm::vec3& b, const glm::vec3& c) {
  TriangleAxes t;
  const glm::vec3 edge[3] = {b - a, c - b, a - c};
  int n = 0;
  for (int j = 0; j < 3; ++j) {
    glm::vec3 u(0.0f);
    u[j] = 1.0f;
    t.axis[n++] = u;
  }
  t.axis[n++] = glm::cross(edge[0], edge[1]);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      glm::vec3 u(0.0f);
      u[j] = 1.0f;
      t.axis[n++] = glm::cross(edge[i], u);
    }
  // Projection intervals over all three vertices (for the normal axis the three values agree in
  // exact arithmetic; taking min/max keeps the test conservative under rounding).
  for (int k = 0; k < 13; ++k) {
    float pa = glm::dot(t.axis[k], a), pb = glm::dot(t.axis[k], b), pc = glm::dot(t.axis[k], c);
    t.lo[k] = std::min(pa, std::min(pb, pc));
    t.hi[k] = std::max(pa, std::max(pb, pc));
  }
  return t;
}

// True when no axis separates the triangle from the closed box (touching is overlap). A zero axis
// (degenerate triangle, edge parallel to a box axis) projects everything to 0 and never separates,
// so the test stays exact for degenerate triangles (segments, points).
bool overlaps(const TriangleAxes& t, const glm::vec3& box_center, const glm::vec3& box_half) {
  for (int k = 0; k < 13; ++k) {
    float center = glm::dot(t.axis[k], box_center);
    float radius = glm::dot(glm::abs(t.axis[k]), box_half);
    if (t.lo[k] > center + radius || t.hi[k] < center - radius) return false;
  }
  return true;
}

bool finite(const glm::vec3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

// Marks the voxels of grid space (voxel (i,j,k) = the box [i,i+1]x[j,j+1]x[k,k+1]) whose closed box
// overlaps the triangle g[0..2] (grid coordinates, finite).
void mark_triangle(const glm::vec3 g[3], int V, uint32_t* words) {
  const float Vf = static_cast<float>(V);
  const glm::vec3 half(0.5f);
  glm::vec3 gmin = glm::min(g[0], glm::min(g[1], g[2]));
  glm::vec3 gmax = glm::max(g[0], glm::max(g[1], g[2]));
  // Voxels whose closed box meets the triangle's bounding box: i <= gmax and i + 1 >= gmin, i.e.
  // i in [ceil(gmin) - 1, floor(gmax)] (a vertex exactly on plane m also touches voxel m - 1).
  int lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    float mn = std::clamp(gmin[a], -2.0f, Vf + 2.0f), mx = std::clamp(gmax[a], -2.0f, Vf + 2.0f);
    lo[a] = std::max(0, static_cast<int>(std::ceil(mn)) - 1);
    hi[a] = std::min(V - 1, static_cast<int>(std::floor(mx)));
    if (lo[a] > hi[a]) return;
  }
  const TriangleAxes axes = triangle_axes(g[0], g[1], g[2]);
  for (int k = lo[2]; k <= hi[2]; ++k)
    for (int j = lo[1]; j <= hi[1]; ++j)
      for (int i = lo[0]; i <= hi[0]; ++i) {
        uint32_t index = static_cast<uint32_t>(i + V * (j + V * k));
        uint32_t bit = 1u << (index & 31u);
        std::atomic_ref<uint32_t> word(words[index >> 5]);
        if (word.load(std::memory_order_relaxed) & bit) continue;
        glm::vec3 center(static_cast<float>(i) + 0.5f, static_cast<float>(j) + 0.5f, static_cast<float>(k) + 0.5f);
        if (overlaps(axes, center, half)) word.fetch_or(bit, std::memory_order_relaxed);
      }
}

// The alpha test of one cut-out triangle, bounded from above over uv regions: Mesh::alpha is the
// factor alpha times a bilinear blend of at most four texels, so over any region it is at most the
// factor times the largest alpha of the texels the region's lookups can touch.
class CutoutBound {
 public:
  // The triangle's base colour uvs (slot transform applied) in texel space, where texel (x, y)'s
  // centre is at (x, y): uv * size - 0.5, as Texture::sample_alpha reads them.
  CutoutBound(const Texture& texture, float factor, float cutoff, const glm::vec2 uv[3])
      : texture_(texture), factor_(factor), cutoff_(cutoff) {
    for (int v = 0; v < 3; ++v)
      texel_[v] = glm::dvec2(uv[v]) * glm::dvec2(texture.width, texture.height) - 0.5;
  }
  // Texel space positions of barycentrics (u, v).
  glm::dvec2 at(double u, double v) const { return (1.0 - u - v) * texel_[0] + u * texel_[1] + v * texel_[2]; }
  // The longest edge in texels (infinite for non-finite uvs).
  double span() const {
    double m = 0.0;
    for (int e = 0; e < 3; ++e) m = std::max(m, glm::length(texel_[(e + 1) % 3] - texel_[e]));
    return std::isfinite(m) ? m : std::numeric_limits<double>::infinity();
  }
  // False only when alpha < cutoff everywhere on the sub-triangle with texel-space corners p[0..2].
  bool may_be_opaque(const glm::dvec2 p[3]) const {
    constexpr double kMargin = 1e-3;  // texels: rounding of the lookups' own uv interpolation
    constexpr int64_t kMaxTexels = 64 * 64;
    const glm::dvec2 lo = glm::min(p[0], glm::min(p[1], p[2])) - kMargin;
    const glm::dvec2 hi = glm::max(p[0], glm::max(p[1], p[2])) + kMargin;
    if (!std::isfinite(lo.x) || !std::isfinite(lo.y) || !std::isfinite(hi.x) || !std::isfinite(hi.y)) return true;
    const int64_t x0 = int64_t(std::floor(lo.x)), x1 = int64_t(std::floor(hi.x)) + 1;
    const int64_t y0 = int64_t(std::floor(lo.y)), y1 = int64_t(std::floor(hi.y)) + 1;
    if ((x1 - x0 + 1) * (y1 - y0 + 1) > kMaxTexels) return true;  // not worth bounding: kept
    const int64_t w = texture_.width, h = texture_.height;
    uint8_t peak = 0;
    for (int64_t y = y0; y <= y1; ++y)
      for (int64_t x = x0; x <= x1; ++x) {
        const size_t tx = size_t(((x % w) + w) % w), ty = size_t(((y % h) + h) % h);
        peak = std::max(peak, texture_.rgba[(ty * size_t(w) + tx) * 4 + 3]);
      }
    return factor_ * (float(peak) / 255.0f) >= cutoff_;
  }

 private:
  const Texture& texture_;
  float factor_, cutoff_;
  glm::dvec2 texel_[3];
};

// Sub-triangles per edge for a triangle spanning `span` texels: about two per texel, at most 64.
int subdivisions(double span) { return int(std::clamp(std::ceil(2.0 * span), 1.0, 64.0)); }

}  // namespace

bool triangle_box_overlap(const glm::vec3& box_center, const glm::vec3& box_half,
                          const glm::vec3& a, const glm::vec3& b, const glm::vec3& c) {
  // Work relative to the box centre: small coordinates keep the products accurate.
  TriangleAxes t = triangle_axes(a - box_center, b - box_center, c - box_center);
  return overlaps(t, glm::vec3(0.0f), box_half);
}

// Contract: returns a grid with resolution V and every voxel set whose closed box (in the unit
// cube [i/V,(i+1)/V]^3, mapped linearly onto `bounds` exactly as VoxelGrid::to_unit does) overlaps a
// triangle. Parts of triangles outside `bounds` mark nothing. Triangles with an out-of-range vertex
// index or a non-finite vertex are skipped (load_mesh/finalize_mesh already drop them). An invalid
// request (V outside [1, 256], which Config::validate rejects, or `bounds` without positive extent on
// every axis) yields resolution 0 and no bits. Runs in parallel over triangles (OpenMP); the result
// does not depend on the thread count (bits are only ever OR-ed in, atomically).
VoxelGrid voxelize(const Mesh& mesh, uint32_t resolution, const Aabb& bounds, bool opaque_cells_only) {
  VoxelGrid grid;
  glm::vec3 extent = bounds.extent();
  if (resolution < 1 || resolution > 256 || !finite(bounds.lo) || !finite(extent) ||
      !(extent.x > 0.0f && extent.y > 0.0f && extent.z > 0.0f))
    return grid;
  grid.resolution = resolution;
  grid.bounds = bounds;
  uint64_t voxels = uint64_t(resolution) * resolution * resolution;
  grid.bits.assign(static_cast<size_t>((voxels + 31) / 32), 0u);

  const int V = static_cast<int>(resolution);
  const float Vf = static_cast<float>(resolution);
  const int64_t triangle_count = static_cast<int64_t>(mesh.triangles.size());
  const size_t vertex_count = mesh.positions.size();
  uint32_t* words = grid.bits.data();

#pragma omp parallel for schedule(dynamic, 1024)
  for (int64_t tri = 0; tri < triangle_count; ++tri) {
    const glm::uvec3 idx = mesh.triangles[static_cast<size_t>(tri)];
    if (idx.x >= vertex_count || idx.y >= vertex_count || idx.z >= vertex_count) continue;
    // Grid space: the unit cube scaled by V, so voxel (i,j,k) is the box [i,i+1]x[j,j+1]x[k,k+1].
    glm::vec3 g[3];
    for (int v = 0; v < 3; ++v) g[v] = grid.to_unit(mesh.positions[idx[v]]) * Vf;
    if (!finite(g[0]) || !finite(g[1]) || !finite(g[2])) continue;
    const Material* m = static_cast<size_t>(tri) < mesh.triangle_material.size() &&
                                mesh.triangle_material[size_t(tri)] < mesh.materials.size()
                            ? &mesh.materials[mesh.triangle_material[size_t(tri)]]
                            : nullptr;
    if (!m || m->alpha_mode == AlphaMode::Opaque || !opaque_cells_only) {
      mark_triangle(g, V, words);
      continue;
    }
    // A cut-out: only the sub-triangles where the surface may exist mark voxels. Without a usable
    // texture or uvs its alpha is the factor's (Mesh::alpha).
    const Texture* texture = m->base_color_texture >= 0 && size_t(m->base_color_texture) < mesh.textures.size()
                                 ? &mesh.textures[size_t(m->base_color_texture)]
                                 : nullptr;
    const bool textured = texture && mesh.uvs.size() == vertex_count && texture->width > 0 && texture->height > 0 &&
                          texture->rgba.size() >= size_t(texture->width) * texture->height * 4;
    if (!textured) {
      if (m->alpha >= m->cutoff()) mark_triangle(g, V, words);
      continue;
    }
    glm::vec2 uv[3];
    for (int v = 0; v < 3; ++v) uv[v] = apply_uv_transform(m->uv_transform[kSlotBaseColor], mesh.uvs[idx[v]]);
    const CutoutBound bound(*texture, m->alpha, m->cutoff(), uv);
    const double span = bound.span();
    if (!std::isfinite(span)) {
      mark_triangle(g, V, words);
      continue;
    }
    const int n = subdivisions(span);
    // Sub-triangle corners at barycentrics (a / n, b / n); per cell of the lattice an upright
    // triangle and, except on the diagonal, an inverted one.
    auto position = [&](int a, int b) {
      const float u = float(a) / float(n), v = float(b) / float(n);
      return (1.0f - u - v) * g[0] + u * g[1] + v * g[2];
    };
    for (int b = 0; b < n; ++b)
      for (int a = 0; a + b < n; ++a)
        for (int flip = 0; flip < 2; ++flip) {
          if (flip && a + b + 2 > n) continue;
          const int corners[3][2] = {{a + flip, b + flip}, {a + 1 - flip, b + flip}, {a + flip, b + 1 - flip}};
          glm::dvec2 p[3];
          glm::vec3 sub[3];
          for (int c = 0; c < 3; ++c) {
            p[c] = bound.at(double(corners[c][0]) / n, double(corners[c][1]) / n);
            sub[c] = position(corners[c][0], corners[c][1]);
          }
          if (bound.may_be_opaque(p)) mark_triangle(sub, V, words);
        }
  }
  return grid;
}

}  // namespace lsnif
