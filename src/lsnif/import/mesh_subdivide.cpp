// mesh_subdivide.cpp -- uniform 1-to-4 midpoint subdivision (mesh_subdivide.h). Edges are found by
// sorting the 3F undirected edge keys (deterministic, no hash map): the midpoint of the k-th
// distinct edge in key order is vertex V + k.
#include "lsnif/import/mesh_subdivide.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace lsnif {

namespace {

uint64_t edge_key(uint32_t a, uint32_t b) {
  return a < b ? (uint64_t(a) << 32) | b : (uint64_t(b) << 32) | a;
}

bool finite3(const glm::vec3& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }

// Checks what subdivide_midpoint promises to reject (see the header).
Status check_input(const Mesh& in) {
  if (in.positions.empty() || in.triangles.empty())
    return Status::error("subdivide: empty mesh (%zu vertices, %zu triangles)", in.positions.size(),
                         in.triangles.size());
  const size_t n = in.positions.size();
  for (size_t v = 0; v < n; ++v)
    if (!finite3(in.positions[v])) return Status::error("subdivide: vertex %zu has a non-finite position", v);
  for (size_t i = 0; i < in.triangles.size(); ++i) {
    const glm::uvec3 t = in.triangles[i];
    if (t.x >= n || t.y >= n || t.z >= n)
      return Status::error("subdivide: triangle %zu (%u %u %u) has an index out of range (%zu vertices)", i, t.x,
                           t.y, t.z, n);
    if (t.x == t.y || t.y == t.z || t.x == t.z)
      return Status::error("subdivide: triangle %zu (%u %u %u) is degenerate (repeated index)", i, t.x, t.y, t.z);
    const glm::dvec3 a(in.positions[t.x]), b(in.positions[t.y]), c(in.positions[t.z]);
    const glm::dvec3 cr = glm::cross(b - a, c - a);
    if (cr.x == 0.0 && cr.y == 0.0 && cr.z == 0.0)
      return Status::error("subdivide: triangle %zu (%u %u %u) is degenerate (zero area)", i, t.x, t.y, t.z);
  }
  return Status::ok();
}

// One level on an input already checked by check_input (children of checked triangles need no
// new check: they keep distinct indices by construction).
Status subdivide_once(const Mesh& in, Mesh& out) {
  const size_t n = in.positions.size(), f = in.triangles.size();
  std::vector<uint64_t> keys(3 * f);
  for (size_t i = 0; i < f; ++i) {
    const glm::uvec3 t = in.triangles[i];
    keys[3 * i + 0] = edge_key(t.x, t.y);
    keys[3 * i + 1] = edge_key(t.y, t.z);
    keys[3 * i + 2] = edge_key(t.z, t.x);
  }
  std::vector<uint64_t> edges = keys;
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  const size_t e = edges.size();
  if (n + e > size_t(std::numeric_limits<uint32_t>::max()))
    return Status::error("subdivide: %zu vertices + %zu edges do not fit 32-bit indices", n, e);
  if (4 * f > size_t(std::numeric_limits<uint32_t>::max()))
    return Status::error("subdivide: %zu triangles x 4 exceed 2^32 - 1", f);

  Mesh m;
  m.materials = in.materials;
  m.textures = in.textures;
  const bool normals = in.normals.size() == n, uvs = in.uvs.size() == n, colors = in.colors.size() == n;
  m.positions.resize(n + e);
  if (normals) m.normals.resize(n + e);
  if (uvs) m.uvs.resize(n + e);
  if (colors) m.colors.resize(n + e);
  std::copy(in.positions.begin(), in.positions.end(), m.positions.begin());
  if (normals) std::copy(in.normals.begin(), in.normals.end(), m.normals.begin());
  if (uvs) std::copy(in.uvs.begin(), in.uvs.end(), m.uvs.begin());
  if (colors) std::copy(in.colors.begin(), in.colors.end(), m.colors.begin());
  for (size_t k = 0; k < e; ++k) {
    const uint32_t a = uint32_t(edges[k] >> 32), b = uint32_t(edges[k] & 0xffffffffu);
    m.positions[n + k] = 0.5f * (in.positions[a] + in.positions[b]);
    if (normals) {
      const glm::vec3 sum = in.normals[a] + in.normals[b];
      const float len = glm::length(sum);
      m.normals[n + k] = len > 0.0f && std::isfinite(len) ? sum / len : in.normals[a];
    }
    if (uvs) m.uvs[n + k] = 0.5f * (in.uvs[a] + in.uvs[b]);
    if (colors) m.colors[n + k] = 0.5f * (in.colors[a] + in.colors[b]);
  }

  const bool materials = in.triangle_material.size() == f;
  m.triangles.resize(4 * f);
  if (materials) m.triangle_material.resize(4 * f);
  auto mid = [&](size_t slot) {
    const auto it = std::lower_bound(edges.begin(), edges.end(), keys[slot]);
    return uint32_t(n + size_t(it - edges.begin()));
  };
  for (size_t i = 0; i < f; ++i) {
    const glm::uvec3 t = in.triangles[i];
    const uint32_t ab = mid(3 * i), bc = mid(3 * i + 1), ca = mid(3 * i + 2);
    m.triangles[4 * i + 0] = glm::uvec3(t.x, ab, ca);
    m.triangles[4 * i + 1] = glm::uvec3(ab, t.y, bc);
    m.triangles[4 * i + 2] = glm::uvec3(ca, bc, t.z);
    m.triangles[4 * i + 3] = glm::uvec3(ab, bc, ca);
    if (materials)
      for (size_t c = 0; c < 4; ++c) m.triangle_material[4 * i + c] = in.triangle_material[i];
  }
  out = std::move(m);
  return Status::ok();
}

}  // namespace

Status subdivide_midpoint(const Mesh& in, Mesh& out) {
  Status s = check_input(in);
  if (!s) return s;
  return subdivide_once(in, out);
}

Status subdivide_midpoint(const Mesh& in, uint32_t levels, Mesh& out) {
  Status s = check_input(in);
  if (!s) return s;
  if (levels == 0) {
    out = in;
    return Status::ok();
  }
  Mesh current;
  s = subdivide_once(in, current);
  for (uint32_t l = 1; l < levels && s; ++l) {
    Mesh next;
    s = subdivide_once(current, next);
    if (s) current = std::move(next);
  }
  if (!s) return s;
  out = std::move(current);
  return Status::ok();
}

uint32_t subdivision_level_for(uint64_t triangles, uint64_t target, uint32_t max_level) {
  if (triangles == 0) return 0;
  uint32_t best = 0;
  uint64_t best_diff = triangles > target ? triangles - target : target - triangles;
  uint64_t count = triangles;
  for (uint32_t level = 1; level <= max_level; ++level) {
    if (count > std::numeric_limits<uint64_t>::max() / 4) break;
    count *= 4;
    const uint64_t diff = count > target ? count - target : target - count;
    if (diff < best_diff) {
      best = level;
      best_diff = diff;
    }
    if (count > target) break;  // further levels only move away from the target
  }
  return best;
}

}  // namespace lsnif
