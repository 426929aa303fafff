// uv_cells.cpp -- packing and reading the uv cells (uv_cells.h).
#include "lsnif/core/uv_cells.h"

#include <algorithm>
#include <bit>
#include <cmath>

#include "lsnif/core/half.h"
#include "lsnif/format/uv_cell_layout.h"

namespace lsnif {

namespace {

constexpr float kHalfDiagonal = 0.8660254f;  // sqrt(3) / 2: the farthest a plane through a cell lies from its centre

uint32_t half_pair(float lo, float hi) { return uint32_t(float_to_half(lo)) | uint32_t(float_to_half(hi)) << 16; }
float half_at(uint32_t w, int k) { return half_to_float(uint16_t(w >> (16 * k))); }
uint32_t snorm8(float x) { return uint32_t(int32_t(std::lround(std::clamp(x, -1.0f, 1.0f) * 127.0f))) & 0xffu; }
float from_snorm8(uint32_t b) { return std::max(float(int8_t(uint8_t(b))) / 127.0f, -1.0f); }

}  // namespace

void pack_uv_map(const UvMap& m, uint32_t* w) {
  w[0] = std::bit_cast<uint32_t>(m.uv0.x);
  w[1] = std::bit_cast<uint32_t>(m.uv0.y);
  w[2] = half_pair(m.du.x, m.du.y);
  w[3] = half_pair(m.du.z, m.dv.x);
  w[4] = half_pair(m.dv.y, m.dv.z);
  const float len = glm::length(m.normal);
  const glm::vec3 n = len > 0.0f ? m.normal / len : glm::vec3(0.0f, 0.0f, 1.0f);
  // The normal scaled so its largest component is +-1: the most of snorm8's precision.
  const float big = std::max(std::fabs(n.x), std::max(std::fabs(n.y), std::fabs(n.z)));
  const glm::vec3 s = n / big;
  w[5] = snorm8(s.x) | snorm8(s.y) << 8 | snorm8(s.z) << 16 | snorm8(m.offset / kHalfDiagonal) << 24;
}

UvMap unpack_uv_map(const uint32_t* w) {
  UvMap m;
  m.uv0 = {std::bit_cast<float>(w[0]), std::bit_cast<float>(w[1])};
  m.du = {half_at(w[2], 0), half_at(w[2], 1), half_at(w[3], 0)};
  m.dv = {half_at(w[3], 1), half_at(w[4], 0), half_at(w[4], 1)};
  const glm::vec3 n(from_snorm8(w[5] & 0xffu), from_snorm8((w[5] >> 8) & 0xffu), from_snorm8((w[5] >> 16) & 0xffu));
  const float len = glm::length(n);
  m.normal = len > 0.0f ? n / len : glm::vec3(0.0f, 0.0f, 1.0f);
  m.offset = from_snorm8(w[5] >> 24) * kHalfDiagonal;
  return m;
}

UvCells::UvCells(const Model& model) : model_(model) {
  const Config& c = model.config;
  if (!c.texture_coordinates() || model.uv_cells.size() != uv_cell_words(c)) return;
  cells_per_axis_ = c.voxel_resolution * c.uv_cells;
  cell_size_ = model.voxels.bounds.extent() / float(cells_per_axis_);
  rank_.resize(model.voxels.bits.size());
  uint32_t n = 0;
  for (size_t w = 0; w < rank_.size(); ++w) {
    rank_[w] = n;
    n += uint32_t(std::popcount(model.voxels.bits[w]));
  }
}

bool UvCells::lookup(glm::vec3 x, glm::vec3 normal, glm::vec3 direction, glm::vec2& uv) const {
  if (cells_per_axis_ == 0) return false;
  const Config& c = model_.config;
  const uint32_t V = c.voxel_resolution, S = c.uv_cells, N = cells_per_axis_;
  const glm::vec3 u = (x - model_.voxels.bounds.lo) / cell_size_;  // in cells
  if (!std::isfinite(u.x) || !std::isfinite(u.y) || !std::isfinite(u.z)) return false;
  const glm::ivec3 q = glm::clamp(glm::ivec3(glm::floor(glm::clamp(u, glm::vec3(-1.0f), glm::vec3(float(N))))),
                                  glm::ivec3(0), glm::ivec3(int(N) - 1));
  // The predicted normal and the ray's direction in cell units (a normal scales inversely).
  const glm::vec3 nc = normal * cell_size_, dc = direction / cell_size_;
  const uint32_t* records = model_.uv_cells.data();
  const uint32_t* maps = records + size_t(c.uv_cell_voxels) * kUvVoxelWords;
  float best = INFINITY;
  UvMap chosen;
  glm::vec3 chosen_r(0.0f);
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const glm::ivec3 p = q + glm::ivec3(dx, dy, dz);
        if (p.x < 0 || p.y < 0 || p.z < 0 || p.x >= int(N) || p.y >= int(N) || p.z >= int(N)) continue;
        const glm::uvec3 vox = glm::uvec3(p) / S, sub = glm::uvec3(p) % S;
        const uint32_t vi = vox.x + V * (vox.y + V * vox.z);
        const uint32_t word = model_.voxels.bits[vi >> 5];
        if (!((word >> (vi & 31u)) & 1u)) continue;
        const uint32_t* rec =
            records + size_t(rank_[vi >> 5] + uint32_t(std::popcount(word & ((1u << (vi & 31u)) - 1u)))) * kUvVoxelWords;
        const uint64_t first = uint64_t(rec[1]) | uint64_t(rec[2]) << 32, second = uint64_t(rec[3]) | uint64_t(rec[4]) << 32;
        const uint32_t cell = sub.x + S * (sub.y + S * sub.z);
        if (!((first >> cell) & 1u)) continue;
        const uint64_t below = cell == 0 ? 0 : (uint64_t(1) << cell) - 1;
        const uint32_t at = rec[0] + uint32_t(std::popcount(first & below) + std::popcount(second & below));
        const uint32_t count = 1u + uint32_t((second >> cell) & 1u);
        const glm::vec3 r = u - (glm::vec3(p) + 0.5f);
        for (uint32_t k = 0; k < count; ++k) {
          const UvMap m = unpack_uv_map(maps + size_t(at + k) * kUvMapWords);
          if (glm::dot(m.normal, nc) < 0.0f) continue;
          const float along = glm::dot(m.normal, r);
          const float plane = along - m.offset;
          const float across = std::max(glm::length(r - along * m.normal) - 0.5f, 0.0f);
          const float score = plane * plane + across * across;
          if (score < best) {
            best = score;
            chosen = m;
            chosen_r = r;
          }
        }
      }
  if (!(best < INFINITY)) return false;
  // Where the ray meets the piece's plane (at most 2 cells away), else the point's projection on it.
  const float gap = chosen.offset - glm::dot(chosen.normal, chosen_r);
  const float facing = glm::dot(chosen.normal, dc);
  glm::vec3 y = chosen_r + gap * chosen.normal;
  if (std::fabs(facing) > 0.05f * glm::length(dc) && std::fabs(gap / facing) * glm::length(dc) <= 2.0f)
    y = chosen_r + (gap / facing) * dc;
  uv = chosen.uv0 + glm::vec2(glm::dot(chosen.du, y), glm::dot(chosen.dv, y));
  return true;
}

}  // namespace lsnif
