// lsnif_uv_cells.glsl -- the texture coordinate of an LSNIF hit from the model's uv cells on the
// device: src/lsnif/core/uv_cells.cpp (UvCells::lookup, unpack_uv_map) line by line, reading the
// words the GPU block holds (host_device.h: uv_rank_offset, uv_record_offset, uv_map_offset; their
// layout src/lsnif/format/uv_cell_layout.h).
#ifndef LSNIF_UV_CELLS_GLSL
#define LSNIF_UV_CELLS_GLSL

#include "lsnif/shaders/lsnif_model.glsl"

struct LsnifUvMap {
  vec2 uv0;
  vec3 du, dv;
  vec3 normal;
  float offset;
};

float lsnif_from_snorm8(uint b) { return max(float(bitfieldExtract(int(b), 0, 8)) / 127.0, -1.0); }

// unpack_uv_map of map `index`.
LsnifUvMap lsnif_uv_map(LsnifModel m, uint index) {
  const uint base = m.h.uv_map_offset + 6u * index;
  LsnifUvMap map;
  map.uv0 = vec2(uintBitsToFloat(m.words.w[base]), uintBitsToFloat(m.words.w[base + 1u]));
  const vec2 a = unpackHalf2x16(m.words.w[base + 2u]), b = unpackHalf2x16(m.words.w[base + 3u]),
             c = unpackHalf2x16(m.words.w[base + 4u]);
  map.du = vec3(a.x, a.y, b.x);
  map.dv = vec3(b.y, c.x, c.y);
  const uint w = m.words.w[base + 5u];
  const vec3 n = vec3(lsnif_from_snorm8(w & 0xffu), lsnif_from_snorm8((w >> 8) & 0xffu), lsnif_from_snorm8((w >> 16) & 0xffu));
  const float len = length(n);
  map.normal = len > 0.0 ? n / len : vec3(0.0, 0.0, 1.0);
  map.offset = lsnif_from_snorm8(w >> 24) * 0.8660254;
  return map;
}

// UvCells::lookup: the texture coordinate for a hit predicted at object-space point x with
// object-space normal `normal` by a ray of object-space direction `direction`; false when no piece
// lies within the cells around x facing the normal's way, or the model has no uv cells.
bool lsnif_uv_lookup(LsnifModel m, vec3 x, vec3 normal, vec3 direction, out vec2 uv) {
  uv = vec2(0.0);
  if (m.h.uv_cells == 0u) return false;
  const uint V = m.h.voxel_resolution, S = m.h.uv_cells, N = V * S;
  const vec3 lo = lsnif_bounds_lo(m);
  const vec3 cell_size = (lsnif_bounds_hi(m) - lo) / float(N);
  const vec3 u = (x - lo) / cell_size;
  if (any(isnan(u)) || any(isinf(u))) return false;
  const ivec3 q = clamp(ivec3(floor(clamp(u, vec3(-1.0), vec3(float(N))))), ivec3(0), ivec3(int(N) - 1));
  const vec3 nc = normal * cell_size, dc = direction / cell_size;
  float best = 1.0 / 0.0;
  LsnifUvMap chosen;
  vec3 chosen_r = vec3(0.0);
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const ivec3 p = q + ivec3(dx, dy, dz);
        if (any(lessThan(p, ivec3(0))) || any(greaterThanEqual(p, ivec3(int(N))))) continue;
        const uvec3 vox = uvec3(p) / S, sub = uvec3(p) % S;
        const uint vi = vox.x + V * (vox.y + V * vox.z);
        const uint word = m.words.w[m.h.voxel_offset + (vi >> 5)];
        if (((word >> (vi & 31u)) & 1u) == 0u) continue;
        const uint rank = m.words.w[m.h.uv_rank_offset + (vi >> 5)] + uint(bitCount(word & ((1u << (vi & 31u)) - 1u)));
        const uint rec = m.h.uv_record_offset + 5u * rank;
        const uvec2 first = uvec2(m.words.w[rec + 1u], m.words.w[rec + 2u]);
        const uvec2 second = uvec2(m.words.w[rec + 3u], m.words.w[rec + 4u]);
        const uint cell = sub.x + S * (sub.y + S * sub.z);
        const uint half_index = cell >> 5, bit = cell & 31u;
        if (((first[half_index] >> bit) & 1u) == 0u) continue;
        const uint below = (1u << bit) - 1u;
        uint at = m.words.w[rec];
        if (half_index == 1u) at += uint(bitCount(first.x) + bitCount(second.x));
        at += uint(bitCount(first[half_index] & below) + bitCount(second[half_index] & below));
        const uint count = 1u + ((second[half_index] >> bit) & 1u);
        const vec3 r = u - (vec3(p) + 0.5);
        for (uint k = 0u; k < count; ++k) {
          const LsnifUvMap map = lsnif_uv_map(m, at + k);
          if (dot(map.normal, nc) < 0.0) continue;
          const float along = dot(map.normal, r);
          const float plane = along - map.offset;
          const float across = max(length(r - along * map.normal) - 0.5, 0.0);
          const float score = plane * plane + across * across;
          if (score < best) {
            best = score;
            chosen = map;
            chosen_r = r;
          }
        }
      }
  if (!(best < 1.0 / 0.0)) return false;
  const float gap = chosen.offset - dot(chosen.normal, chosen_r);
  const float facing = dot(chosen.normal, dc);
  vec3 y = chosen_r + gap * chosen.normal;
  if (abs(facing) > 0.05 * length(dc) && abs(gap / facing) * length(dc) <= 2.0) y = chosen_r + (gap / facing) * dc;
  uv = chosen.uv0 + vec2(dot(chosen.du, y), dot(chosen.dv, y));
  return true;
}

#endif
