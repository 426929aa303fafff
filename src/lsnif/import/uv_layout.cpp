// uv_layout.cpp -- the measurements of uv_layout.h.
#include "lsnif/import/uv_layout.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numeric>
#include <tuple>
#include <vector>

#include "lsnif/format/numbers.h"

namespace lsnif {
namespace {

// Union-find over the material's triangles (indices into its own list).
struct Charts {
  std::vector<uint32_t> parent;
  explicit Charts(size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0u); }
  uint32_t find(uint32_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  }
  void join(uint32_t a, uint32_t b) { parent[find(a)] = find(b); }
};

float signed_uv_area(glm::vec2 a, glm::vec2 b, glm::vec2 c) {
  const glm::vec2 e1 = b - a, e2 = c - a;
  return 0.5f * (e1.x * e2.y - e1.y * e2.x);
}

}  // namespace

std::string UvLayout::describe() const {
  return format("%u charts, %u seam edges, %u mirrored, %.1f%% overlap, uv in [%g, %g] x [%g, %g]%s", charts,
                seam_edges, mirrored_triangles, 100.0 * overlap_fraction, double(uv_min.x), double(uv_max.x),
                double(uv_min.y), double(uv_max.y), tiling ? " (tiling)" : "");
}

UvLayout analyze_uv_layout(const Mesh& mesh, uint32_t material, float weld, float uv_tolerance, uint32_t grid) {
  UvLayout out;
  if (mesh.uvs.size() != mesh.positions.size() || mesh.uvs.empty()) return out;
  std::vector<uint32_t> tris;
  for (uint32_t t = 0; t < mesh.triangles.size(); ++t)
    if ((mesh.triangle_material.empty() ? 0u : mesh.triangle_material[t]) == material) tris.push_back(t);
  out.triangles = uint32_t(tris.size());
  if (tris.empty()) return out;

  // Welded position ids: positions on one cell of a grid `weld` x the diagonal apart are one point.
  const Aabb box = mesh.bounds();
  const float diagonal = glm::length(box.hi - box.lo);
  const float cell = std::isfinite(diagonal) && diagonal > 0.0f ? std::max(weld * diagonal, 1e-30f) : 1.0f;
  std::map<std::array<int64_t, 3>, uint32_t> ids;
  uint32_t unwelded = 0;  // ids of non-finite positions (and those too far to cell), each its own
  auto weld_id = [&](uint32_t v) {
    const glm::vec3 q = glm::floor(mesh.positions[v] / cell);
    const float limit = 4e18f;  // within int64_t
    if (!(std::fabs(q.x) < limit && std::fabs(q.y) < limit && std::fabs(q.z) < limit))
      return uint32_t(0x80000000u) + unwelded++;
    const std::array<int64_t, 3> key = {int64_t(q.x), int64_t(q.y), int64_t(q.z)};
    return ids.emplace(key, uint32_t(ids.size())).first->second;
  };

  // Each edge's sides: (triangle of the list, uv at the smaller welded id, uv at the larger).
  struct Side {
    uint32_t tri;
    glm::vec2 uv_lo, uv_hi;
  };
  std::map<std::pair<uint32_t, uint32_t>, std::vector<Side>> edges;
  out.uv_min = glm::vec2(INFINITY);
  out.uv_max = glm::vec2(-INFINITY);
  uint32_t positive = 0, negative = 0;
  for (uint32_t i = 0; i < tris.size(); ++i) {
    const glm::uvec3 t = mesh.triangles[tris[i]];
    const uint32_t w[3] = {weld_id(t.x), weld_id(t.y), weld_id(t.z)};
    const glm::vec2 uv[3] = {mesh.uvs[t.x], mesh.uvs[t.y], mesh.uvs[t.z]};
    for (int k = 0; k < 3; ++k) {
      out.uv_min = glm::min(out.uv_min, uv[k]);
      out.uv_max = glm::max(out.uv_max, uv[k]);
      const int n = (k + 1) % 3;
      if (w[k] == w[n]) continue;
      const bool forward = w[k] < w[n];
      edges[{std::min(w[k], w[n]), std::max(w[k], w[n])}].push_back(
          {i, forward ? uv[k] : uv[n], forward ? uv[n] : uv[k]});
    }
    const float area = signed_uv_area(uv[0], uv[1], uv[2]);
    if (area > 0.0f) ++positive;
    else if (area < 0.0f) ++negative;
  }
  out.mirrored_triangles = std::min(positive, negative);
  const float eps = 1e-6f;
  out.tiling = out.uv_min.x < -eps || out.uv_min.y < -eps || out.uv_max.x > 1.0f + eps || out.uv_max.y > 1.0f + eps;

  // Charts: triangles joined across edges whose sides agree on both uvs; an edge where they do not
  // is a seam.
  Charts charts(tris.size());
  auto same = [uv_tolerance](glm::vec2 a, glm::vec2 b) {
    return std::fabs(a.x - b.x) <= uv_tolerance && std::fabs(a.y - b.y) <= uv_tolerance;
  };
  for (const auto& [key, sides] : edges) {
    if (sides.size() < 2) continue;  // the surface's boundary
    bool seam = false;
    for (size_t s = 1; s < sides.size(); ++s) {
      if (same(sides[s].uv_lo, sides[0].uv_lo) && same(sides[s].uv_hi, sides[0].uv_hi)) charts.join(sides[s].tri, sides[0].tri);
      else seam = true;
    }
    if (seam) ++out.seam_edges;
  }
  out.triangle_chart.assign(mesh.triangles.size(), UvLayout::kNoChart);
  std::vector<uint32_t> chart_of_root(tris.size(), UvLayout::kNoChart);
  for (uint32_t i = 0; i < tris.size(); ++i) {
    uint32_t& chart = chart_of_root[charts.find(i)];
    if (chart == UvLayout::kNoChart) chart = out.charts++;
    out.triangle_chart[tris[i]] = chart;
  }

  // Overlap: cell centres of a grid over the uv box inside two or more triangles.
  const glm::vec2 lo = out.uv_min, extent = glm::max(out.uv_max - out.uv_min, glm::vec2(1e-12f));
  std::vector<uint8_t> cover(size_t(grid) * grid, 0);
  for (uint32_t i = 0; i < tris.size(); ++i) {
    const glm::uvec3 t = mesh.triangles[tris[i]];
    glm::vec2 p[3] = {mesh.uvs[t.x], mesh.uvs[t.y], mesh.uvs[t.z]};
    for (glm::vec2& v : p) v = (v - lo) / extent * float(grid);  // in cells
    const float area = signed_uv_area(p[0], p[1], p[2]);
    if (area == 0.0f) continue;
    const glm::vec2 tmin = glm::min(p[0], glm::min(p[1], p[2])), tmax = glm::max(p[0], glm::max(p[1], p[2]));
    const uint32_t x0 = uint32_t(std::clamp(std::floor(tmin.x), 0.0f, float(grid - 1)));
    const uint32_t x1 = uint32_t(std::clamp(std::ceil(tmax.x), 0.0f, float(grid - 1)));
    const uint32_t y0 = uint32_t(std::clamp(std::floor(tmin.y), 0.0f, float(grid - 1)));
    const uint32_t y1 = uint32_t(std::clamp(std::ceil(tmax.y), 0.0f, float(grid - 1)));
    for (uint32_t y = y0; y <= y1; ++y)
      for (uint32_t x = x0; x <= x1; ++x) {
        // Off the cell centre by a fraction no grid-aligned edge passes through, so that a point on
        // the edge two neighbours share is not counted as covered by both.
        const glm::vec2 c(float(x) + 0.5137f, float(y) + 0.4871f);
        const float a = signed_uv_area(p[1], p[2], c) / area, b = signed_uv_area(p[2], p[0], c) / area;
        if (a >= 0.0f && b >= 0.0f && a + b <= 1.0f) {
          uint8_t& n = cover[size_t(y) * grid + x];
          n = uint8_t(std::min(n + 1, 255));
        }
      }
  }
  size_t covered = 0, twice = 0;
  for (uint8_t n : cover) {
    covered += n >= 1;
    twice += n >= 2;
  }
  out.overlap_fraction = covered ? double(twice) / double(covered) : 0.0;
  return out;
}

namespace {

// Distance (max norm, per axis) from p to triangle abc, 0 inside: the point's nearest point on the
// triangle by barycentric clamping against each edge.
float uv_distance(glm::vec2 p, glm::vec2 a, glm::vec2 b, glm::vec2 c) {
  const float area = signed_uv_area(a, b, c);
  if (area != 0.0f) {
    const float u = signed_uv_area(b, c, p) / area, v = signed_uv_area(c, a, p) / area;
    if (u >= 0.0f && v >= 0.0f && u + v <= 1.0f) return 0.0f;
  }
  auto segment = [](glm::vec2 q, glm::vec2 s0, glm::vec2 s1) {
    const glm::vec2 d = s1 - s0;
    const float len2 = glm::dot(d, d);
    const float t = len2 > 0.0f ? std::clamp(glm::dot(q - s0, d) / len2, 0.0f, 1.0f) : 0.0f;
    const glm::vec2 e = glm::abs(q - (s0 + t * d));
    return std::max(e.x, e.y);
  };
  return std::min(segment(p, a, b), std::min(segment(p, b, c), segment(p, c, a)));
}

}  // namespace

UvChartMap::UvChartMap(const Mesh& mesh, const UvLayout& layout, uint32_t grid)
    : mesh_(mesh), layout_(layout), grid_(std::max(grid, 1u)), lo_(layout.uv_min),
      cell_(glm::max(layout.uv_max - layout.uv_min, glm::vec2(1e-12f)) / float(std::max(grid, 1u))) {
  const size_t cells = size_t(grid_) * grid_;
  std::vector<std::vector<uint32_t>> buckets(cells);
  for (uint32_t t = 0; t < layout.triangle_chart.size(); ++t) {
    if (layout.triangle_chart[t] == UvLayout::kNoChart) continue;
    const glm::uvec3 tri = mesh.triangles[t];
    const glm::vec2 p[3] = {mesh.uvs[tri.x], mesh.uvs[tri.y], mesh.uvs[tri.z]};
    const glm::vec2 tmin = (glm::min(p[0], glm::min(p[1], p[2])) - lo_) / cell_;
    const glm::vec2 tmax = (glm::max(p[0], glm::max(p[1], p[2])) - lo_) / cell_;
    const float top = float(grid_ - 1);
    const uint32_t x0 = uint32_t(std::clamp(std::floor(tmin.x), 0.0f, top)), x1 = uint32_t(std::clamp(std::floor(tmax.x), 0.0f, top));
    const uint32_t y0 = uint32_t(std::clamp(std::floor(tmin.y), 0.0f, top)), y1 = uint32_t(std::clamp(std::floor(tmax.y), 0.0f, top));
    for (uint32_t y = y0; y <= y1; ++y)
      for (uint32_t x = x0; x <= x1; ++x) buckets[size_t(y) * grid_ + x].push_back(t);
  }
  first_.assign(cells + 1, 0);
  for (size_t c = 0; c < cells; ++c) first_[c + 1] = first_[c] + uint32_t(buckets[c].size());
  triangles_.reserve(first_[cells]);
  for (const std::vector<uint32_t>& b : buckets) triangles_.insert(triangles_.end(), b.begin(), b.end());
}

bool UvChartMap::on_chart(glm::vec2 uv, uint32_t chart, float tolerance) const {
  if (!std::isfinite(uv.x) || !std::isfinite(uv.y) || triangles_.empty()) return false;
  // The cells the tolerance square around uv touches.
  const glm::vec2 a = (uv - tolerance - lo_) / cell_, b = (uv + tolerance - lo_) / cell_;
  const float top = float(grid_ - 1);
  if (b.x < 0.0f || b.y < 0.0f || a.x > float(grid_) || a.y > float(grid_)) return false;
  const uint32_t x0 = uint32_t(std::clamp(std::floor(a.x), 0.0f, top)), x1 = uint32_t(std::clamp(std::floor(b.x), 0.0f, top));
  const uint32_t y0 = uint32_t(std::clamp(std::floor(a.y), 0.0f, top)), y1 = uint32_t(std::clamp(std::floor(b.y), 0.0f, top));
  for (uint32_t y = y0; y <= y1; ++y)
    for (uint32_t x = x0; x <= x1; ++x) {
      const size_t c = size_t(y) * grid_ + x;
      for (uint32_t k = first_[c]; k < first_[c + 1]; ++k) {
        const uint32_t t = triangles_[k];
        if (layout_.triangle_chart[t] != chart) continue;
        const glm::uvec3 tri = mesh_.triangles[t];
        if (uv_distance(uv, mesh_.uvs[tri.x], mesh_.uvs[tri.y], mesh_.uvs[tri.z]) <= tolerance) return true;
      }
    }
  return false;
}

}  // namespace lsnif
