// ray_walk.cpp -- the LSNIF ray walk (paper 3.1): AABB clipping and a 3D DDA through the voxel
// grid, collecting the points where the ray crosses a face of an occupied voxel. This is the CPU
// reference; src/lsnif/shaders/lsnif_walk.glsl copies it line by line, hence float math only, rolled loops with
// fixed bounds, no recursion and few branches. walk_rays (at the end) runs the same walks 16 rays at
// a time in AVX-512 lanes, for the CPU's batches.
//
// Conventions that ray_walk.h leaves open, fixed here:
//  * The slab test runs in the unit cube with the same plane formula as every other crossing,
//    t(a, n) = (n/V - o_u[a]) / d_u[a] (planes n = 0 and n = V are the AABB faces). It agrees with
//    intersect_aabb in object space up to rounding, and makes the AABB entry/exit bit-identical to
//    the corresponding voxel-plane crossings, so ties (edges, corners) merge exactly. Crossing times
//    are computed from the plane index directly, never accumulated, so they are non-decreasing
//    along each axis and the recorded point can be snapped onto its plane.
//  * Start voxel, per axis: floor(p * V) clamped to [0, V-1] with p = o_u + t_enter * d_u, then
//    corrected by one voxel so that it agrees with the crossing times (the face ahead of the start
//    voxel is crossed after t_enter, the face behind it at or before t_enter). That is the voxel
//    "just after t_enter" even when rounding put p on the wrong side of a plane (one step is
//    enough while the rounding error of p is below a voxel: origins closer than ~1e5 box sizes at
//    V = 32). In particular an origin exactly on plane n with the direction going negative along
//    that axis starts in the lower voxel n - 1 (its face n is behind the ray at t_enter); with the
//    direction positive, in voxel n.
//    An axis with zero direction never steps; its voxel is floor(o_u * V) clamped, so a ray lying
//    exactly in plane n walks the voxels above it (index n).
//  * Nothing is recorded at t_enter except the AABB entry (t_near >= tmin): an origin strictly
//    inside the box, even exactly on a voxel face, and a ray that starts on the box boundary going
//    out, give no point at t_enter.
//  * When several faces are crossed at the same t (an edge or a corner of the voxel lattice), all of
//    those axes step at once; the point is a boundary point when the voxel before or the voxel after
//    is occupied (the voxels that only share the edge/corner are not entered by the ray). Its axis is
//    the lowest axis among the planes through it, and it is snapped onto every one of those planes.
//  * H = min(max_points, LSNIF_MAX_POINTS). After H points the walk continues only to find out
//    whether one more exists (`truncated`).
#include "lsnif/core/ray_walk.h"

#include <algorithm>
#include <cmath>
#include <limits>

#if defined(__AVX512F__)
#include <immintrin.h>
#endif

namespace lsnif {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// The walk's state at t_enter, shared by walk_ray and voxel_baseline.
struct WalkStart {
  glm::vec3 o{0.0f}, d{0.0f};  // the ray in the grid's unit cube
  float t_near = 0.0f;         // AABB entry parameter of the slab test (-inf when no axis moves)
  float t_enter = 0.0f, t_exit = 0.0f;
  bool from_outside = false;   // the AABB entry at t_near is a crossing (t_near >= tmin)
  int cell[3] = {0, 0, 0};     // voxel just after t_enter
  int step[3] = {0, 0, 0};     // +1 / -1 along the direction, 0 for an axis that never steps
  float t_ahead[3] = {kInf, kInf, kInf};     // crossing of the start voxel's face ahead
  float t_behind[3] = {-kInf, -kInf, -kInf};  // crossing of the start voxel's face behind
};

// Parameter at which the unit-space ray crosses plane n (coordinate n/V) of axis a.
inline float plane_t(const glm::vec3& o, const glm::vec3& d, int a, int n, float Vf) {
  return (static_cast<float>(n) / Vf - o[a]) / d[a];
}

inline bool finite3(const glm::vec3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

// Clips the ray to the grid's box and finds the start voxel. False when the clipped interval is
// empty (or the ray is not finite).
bool start_walk(const VoxelGrid& grid, const Ray& ray, WalkStart& s) {
  const int V = static_cast<int>(grid.resolution);
  const float Vf = static_cast<float>(grid.resolution);
  s.o = grid.to_unit(ray.origin);
  s.d = grid.direction_to_unit(ray.direction);
  if (!finite3(s.o) || !finite3(s.d)) return false;

  // Slab test in the unit cube.
  float t_near = -kInf, t_far = kInf;
  for (int a = 0; a < 3; ++a) {
    if (s.d[a] != 0.0f) {
      float t0 = plane_t(s.o, s.d, a, 0, Vf), t1 = plane_t(s.o, s.d, a, V, Vf);
      t_near = std::max(t_near, std::min(t0, t1));
      t_far = std::min(t_far, std::max(t0, t1));
    } else if (!(s.o[a] >= 0.0f && s.o[a] <= 1.0f)) {
      return false;  // parallel to this slab and outside it
    }
  }
  s.t_near = t_near;
  s.t_enter = std::max(ray.tmin, t_near);
  s.t_exit = std::min(ray.tmax, t_far);
  if (!(s.t_enter <= s.t_exit) || !std::isfinite(s.t_enter)) return false;
  s.from_outside = t_near >= ray.tmin;

  // Start voxel: floor guess at t_enter, then agree with the crossing times (see the file comment).
  const glm::vec3 p = s.o + s.t_enter * s.d;
  for (int a = 0; a < 3; ++a) {
    const float coord = s.d[a] != 0.0f ? p[a] : s.o[a];
    int c = static_cast<int>(std::clamp(std::floor(coord * Vf), 0.0f, Vf - 1.0f));
    if (s.d[a] != 0.0f) {
      const int st = s.d[a] > 0.0f ? 1 : -1;
      const int up = st > 0 ? 1 : 0;  // face ahead of voxel c is plane c + up, behind is c + 1 - up
      if (c + st >= 0 && c + st < V && plane_t(s.o, s.d, a, c + up, Vf) <= s.t_enter) c += st;
      if (c - st >= 0 && c - st < V && plane_t(s.o, s.d, a, c + 1 - up, Vf) > s.t_enter) c -= st;
      s.step[a] = st;
      s.t_ahead[a] = plane_t(s.o, s.d, a, c + up, Vf);
      s.t_behind[a] = plane_t(s.o, s.d, a, c + 1 - up, Vf);
    }
    s.cell[a] = c;
  }
  return true;
}

// Appends a boundary point at t lying on the planes `on_plane[a]` (value plane[a] / V). Returns false
// when H points are already recorded: the walk then only sets `truncated` and stops.
bool push_point(RayWalk& walk, uint32_t H, const WalkStart& s, float t, const bool on_plane[3],
                const int plane[3], float Vf) {
  if (walk.count >= H) {
    walk.truncated = true;
    return false;
  }
  glm::vec3 p = glm::clamp(s.o + t * s.d, glm::vec3(0.0f), glm::vec3(1.0f));
  int axis = 3;
  for (int a = 2; a >= 0; --a) {
    if (on_plane[a]) {
      p[a] = static_cast<float>(plane[a]) / Vf;
      axis = a;
    }
  }
  walk.t[walk.count] = t;
  walk.p[walk.count] = p;
  walk.axis[walk.count] = static_cast<uint8_t>(axis == 3 ? 0 : axis);
  ++walk.count;
  return true;
}

// The walk after start_walk: its header and the AABB entry. False when the walk is complete already
// (H points at the entry).
bool enter_walk(const VoxelGrid& grid, uint32_t H, RayWalk& walk, const WalkStart& s, bool& occupied_now) {
  walk.hits_aabb = true;
  walk.t_enter = s.t_enter;
  walk.t_exit = s.t_exit;
  occupied_now = grid.occupied(s.cell[0], s.cell[1], s.cell[2]);
  // The AABB entry: a crossing from outside into the start voxel. The planes through the entry
  // point are the start voxel's faces behind it at t_enter and, for a ray that only grazes the box,
  // faces ahead of it at t_enter (the walk leaves again at once; that crossing merges with this one).
  if (s.from_outside && occupied_now) {
    bool on_plane[3];
    int plane[3];
    for (int a = 0; a < 3; ++a) {
      const int up = s.step[a] > 0 ? 1 : 0;
      on_plane[a] = s.t_behind[a] == s.t_enter || s.t_ahead[a] == s.t_enter;
      plane[a] = s.t_behind[a] == s.t_enter ? s.cell[a] + 1 - up : s.cell[a] + up;
    }
    if (!push_point(walk, H, s, s.t_enter, on_plane, plane, static_cast<float>(grid.resolution))) return false;
  }
  return true;
}

// A walk with no points yet.
void clear_walk(RayWalk& walk) {
  walk.count = 0;
  walk.truncated = false;
  walk.hits_aabb = false;
  walk.t_enter = 0.0f;
  walk.t_exit = 0.0f;
}

// The walk up to its DDA: clears `walk`, clips the ray to the box, finds the start voxel and records
// the AABB entry. False when the walk is complete already (no box, or H points at the entry).
bool begin_walk(const VoxelGrid& grid, const Ray& ray, uint32_t H, RayWalk& walk, WalkStart& s,
                bool& occupied_now) {
  s = WalkStart{};  // start_walk leaves an axis that never steps as initialized here
  clear_walk(walk);
  return start_walk(grid, ray, s) && enter_walk(grid, H, walk, s, occupied_now);
}

// A grid with voxels and all their bits.
bool walkable(const VoxelGrid& grid) {
  const uint64_t V = grid.resolution;
  return V >= 1 && uint64_t(grid.bits.size()) * 32u >= V * V * V;
}

}  // namespace

// Contract: fills `walk` for `ray` (object space) against `grid` as defined in ray_walk.h and the
// file comment above; returns walk.count. A grid without voxels (resolution 0 or too few bits) or a
// non-finite ray gives hits_aabb = false and no points. max_points is clamped to LSNIF_MAX_POINTS.
uint32_t walk_ray(const VoxelGrid& grid, const Ray& ray, uint32_t max_points, RayWalk& walk) {
  if (!walkable(grid)) {
    clear_walk(walk);
    return 0;
  }
  const int V = static_cast<int>(grid.resolution);
  const uint32_t H = std::min(max_points, LSNIF_MAX_POINTS);
  const float Vf = static_cast<float>(V);

  WalkStart s;
  bool occupied_now = false;
  if (!begin_walk(grid, ray, H, walk, s, occupied_now)) return walk.count;

  int cell[3] = {s.cell[0], s.cell[1], s.cell[2]};
  float t_next[3] = {s.t_ahead[0], s.t_ahead[1], s.t_ahead[2]};
  // The crossing of the plane after each axis's next one, found one step ahead: the division is
  // then off the chain from one event to the next (the same values, computed earlier).
  float t_after[3];
  for (int a = 0; a < 3; ++a)
    t_after[a] = s.step[a] != 0 ? plane_t(s.o, s.d, a, cell[a] + (s.step[a] > 0 ? 1 : 0) + s.step[a], Vf) : kInf;
  bool on_plane[3];
  int plane[3];

  // The DDA. Every event steps at least one axis by one voxel, so 3V events end any walk.
  float t_last = s.t_enter;  // points are recorded only after t_enter (and once per t)
  for (int event = 0; event < 3 * V + 3; ++event) {
    const float t = std::min(t_next[0], std::min(t_next[1], t_next[2]));
    if (!(t <= s.t_exit) || t == kInf) break;  // beyond tmax / the box, or no axis moves
    const bool occupied_before = occupied_now;
    bool inside = true;
    for (int a = 0; a < 3; ++a) {
      on_plane[a] = t_next[a] == t;
      const int up = s.step[a] > 0 ? 1 : 0;
      plane[a] = cell[a] + up;
      if (on_plane[a]) {
        cell[a] += s.step[a];
        inside = inside && cell[a] >= 0 && cell[a] < V;
        t_next[a] = t_after[a];  // plane_t(s.o, s.d, a, cell[a] + up, Vf)
        t_after[a] = plane_t(s.o, s.d, a, cell[a] + up + s.step[a], Vf);
      }
    }
    occupied_now = inside && grid.occupied(cell[0], cell[1], cell[2]);
    if ((occupied_before || occupied_now) && t > t_last) {
      if (!push_point(walk, H, s, t, on_plane, plane, Vf)) break;
      t_last = t;
    }
    if (!inside) break;
  }
  return walk.count;
}

#if defined(__AVX512F__)
namespace {

// The largest V whose planes the lanes' event log holds (a plane n + 1 <= V + 2 in 9 bits); a larger
// grid is walked one ray at a time.
constexpr uint32_t kMaxLaneResolution = 509;

// n / V for the planes n = -1 .. V + 1 a step can reach, as plane_t computes it, 16 lanes at a time.
// For V <= 32 the planes a lane still inside the grid can reach next, n = 0 .. V, come from two
// registers (n = 0 .. 31; n = 32 only as V / V = 1; a lane leaving the grid ends, whatever its
// value); otherwise from the table (index n + 1). Nothing is allocated: walks run inside parallel
// regions, where a failed allocation could not reach the caller.
struct PlaneValues {
  float table[kMaxLaneResolution + 3];
  bool in_registers;
  __m512 low, high;
  explicit PlaneValues(int V) : in_registers(V <= 32) {
    for (int n = -1; n <= V + 1; ++n) table[n + 1] = static_cast<float>(n) / static_cast<float>(V);
    alignas(64) float first[32] = {};
    for (int n = 0; n < std::min(V + 1, 32); ++n) first[n] = table[n + 1];
    low = _mm512_load_ps(first);
    high = _mm512_load_ps(first + 16);
  }
  // The planes n of the lanes in `wanted` (others: any value).
  __m512 operator()(__m512i n, __mmask16 wanted) const {
    if (!in_registers)
      return _mm512_mask_i32gather_ps(_mm512_setzero_ps(), wanted, _mm512_add_epi32(n, _mm512_set1_epi32(1)),
                                      table, 4);
    return _mm512_mask_mov_ps(_mm512_permutex2var_ps(low, n, high), _mm512_cmpeq_epi32_mask(n, _mm512_set1_epi32(32)),
                              _mm512_set1_ps(1.0f));
  }
};

// start_walk for up to 16 rays at once, one per lane, with the same operations on the same floats
// (std::min(x, y) is vminps(y, x) and std::max(x, y) vmaxps(y, x); the start point's product and
// sum fused as GCC fuses start_walk's): starts[k] = start_walk's WalkStart of rays[k] for the lanes
// of the mask returned, where start_walk returns true.
__mmask16 start_walks(const VoxelGrid& grid, const PlaneValues& plane_of, const Ray* rays, int n, WalkStart* starts) {
  constexpr int L = 16;
  constexpr __mmask16 all = 0xFFFF;
  const int V = static_cast<int>(grid.resolution);
  const float Vf = static_cast<float>(V);
  alignas(64) float in[8][L];  // origin, direction, tmin, tmax of each lane's ray
  for (int k = 0; k < L; ++k) {
    const Ray& ray = rays[k < n ? k : 0];
    for (int a = 0; a < 3; ++a) {
      in[a][k] = ray.origin[a];
      in[3 + a][k] = ray.direction[a];
    }
    in[6][k] = ray.tmin;
    in[7][k] = ray.tmax;
  }
  const glm::vec3 extent = grid.bounds.extent();
  const __m512 zero = _mm512_setzero_ps(), unit = _mm512_set1_ps(1.0f), inf = _mm512_set1_ps(kInf);
  const __m512 tmin = _mm512_load_ps(in[6]), tmax = _mm512_load_ps(in[7]);
  __mmask16 ok = __mmask16((1u << n) - 1u);
  __m512 o[3], d[3];
  __mmask16 moves[3];
  __m512 t_near = _mm512_set1_ps(-kInf), t_far = inf;
  for (int a = 0; a < 3; ++a) {
    const __m512 e = _mm512_set1_ps(extent[a]);
    o[a] = _mm512_div_ps(_mm512_sub_ps(_mm512_load_ps(in[a]), _mm512_set1_ps(grid.bounds.lo[a])), e);
    d[a] = _mm512_div_ps(_mm512_load_ps(in[3 + a]), e);
    // Not finite: NaN, +inf, -inf.
    ok &= __mmask16(~(_mm512_fpclass_ps_mask(o[a], 0x99) | _mm512_fpclass_ps_mask(d[a], 0x99)));
  }
  for (int a = 0; a < 3; ++a) {
    moves[a] = _mm512_cmp_ps_mask(d[a], zero, _CMP_NEQ_UQ);
    const __m512 t0 = _mm512_div_ps(_mm512_sub_ps(zero, o[a]), d[a]), t1 = _mm512_div_ps(_mm512_sub_ps(unit, o[a]), d[a]);
    const __m512 nearer = _mm512_maskz_min_ps(all, t1, t0), farther = _mm512_maskz_max_ps(all, t1, t0);
    t_near = _mm512_mask_max_ps(t_near, moves[a], nearer, t_near);
    t_far = _mm512_mask_min_ps(t_far, moves[a], farther, t_far);
    ok &= __mmask16(moves[a] | (_mm512_cmp_ps_mask(o[a], zero, _CMP_GE_OQ) & _mm512_cmp_ps_mask(o[a], unit, _CMP_LE_OQ)));
  }
  const __m512 t_enter = _mm512_maskz_max_ps(all, t_near, tmin), t_exit = _mm512_maskz_min_ps(all, t_far, tmax);
  ok &= __mmask16(_mm512_cmp_ps_mask(t_enter, t_exit, _CMP_LE_OQ) & ~_mm512_fpclass_ps_mask(t_enter, 0x99));
  const __mmask16 from_outside = _mm512_cmp_ps_mask(t_near, tmin, _CMP_GE_OQ);
  alignas(64) float f_out[8][L];
  alignas(64) int32_t i_out[6][L];
  const __m512i v_count = _mm512_set1_epi32(V), one = _mm512_set1_epi32(1);
  for (int a = 0; a < 3; ++a) {
    const __m512 coord = _mm512_mask_mov_ps(o[a], moves[a], _mm512_fmadd_ps(t_enter, d[a], o[a]));
    const __m512 below = _mm512_maskz_roundscale_ps(all, _mm512_mul_ps(coord, _mm512_set1_ps(Vf)), _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
    __m512i c = _mm512_maskz_cvttps_epi32(all, _mm512_maskz_min_ps(all, _mm512_set1_ps(Vf - 1.0f), _mm512_maskz_max_ps(all, below, zero)));
    const __mmask16 ahead_up = _mm512_cmp_ps_mask(d[a], zero, _CMP_GT_OQ);
    const __m512i st = _mm512_mask_mov_epi32(_mm512_set1_epi32(-1), ahead_up, one);
    const __m512i up = _mm512_maskz_mov_epi32(ahead_up, one), down = _mm512_sub_epi32(one, up);
    auto plane_t = [&](__m512i plane, __mmask16 wanted) {
      return _mm512_div_ps(_mm512_sub_ps(plane_of(plane, wanted), o[a]), d[a]);
    };
    // The corrections of start_walk, the first before the second.
    __m512i moved = _mm512_add_epi32(c, st);
    __mmask16 fix = moves[a] & _mm512_cmplt_epu32_mask(moved, v_count);
    fix &= _mm512_cmp_ps_mask(plane_t(_mm512_add_epi32(c, up), fix), t_enter, _CMP_LE_OQ);
    c = _mm512_mask_mov_epi32(c, fix, moved);
    moved = _mm512_sub_epi32(c, st);
    fix = moves[a] & _mm512_cmplt_epu32_mask(moved, v_count);
    fix &= _mm512_cmp_ps_mask(plane_t(_mm512_add_epi32(c, down), fix), t_enter, _CMP_GT_OQ);
    c = _mm512_mask_mov_epi32(c, fix, moved);
    _mm512_store_ps(f_out[a], _mm512_mask_mov_ps(inf, moves[a], plane_t(_mm512_add_epi32(c, up), moves[a])));
    _mm512_store_ps(f_out[3 + a], _mm512_mask_mov_ps(_mm512_set1_ps(-kInf), moves[a], plane_t(_mm512_add_epi32(c, down), moves[a])));
    _mm512_store_si512(i_out[a], c);
    _mm512_store_si512(i_out[3 + a], _mm512_maskz_mov_epi32(moves[a], st));
    _mm512_store_ps(in[a], o[a]);
    _mm512_store_ps(in[3 + a], d[a]);
  }
  _mm512_store_ps(f_out[6], t_enter);
  _mm512_store_ps(f_out[7], t_exit);
  alignas(64) float near_out[L];
  _mm512_store_ps(near_out, t_near);
  for (int k = 0; k < n; ++k) {
    if (!((ok >> k) & 1)) continue;
    WalkStart& s = starts[k];
    for (int a = 0; a < 3; ++a) {
      s.o[a] = in[a][k];
      s.d[a] = in[3 + a][k];
      s.t_ahead[a] = f_out[a][k];
      s.t_behind[a] = f_out[3 + a][k];
      s.cell[a] = i_out[a][k];
      s.step[a] = i_out[3 + a][k];
    }
    s.t_near = near_out[k];
    s.t_enter = f_out[6][k];
    s.t_exit = f_out[7][k];
    s.from_outside = ((from_outside >> k) & 1) != 0;
  }
  return ok;
}

// walk_rays in the 16 lanes of AVX-512 registers: each lane runs walk_ray's DDA for one ray, event
// by event, with the same operations on the same floats (the crossing (n/V - o) / d, the minimum of
// the three axes' next crossings in walk_ray's order, the same comparisons), so a lane's walk is
// walk_ray's bit for bit. Walks start 16 at a time (start_walks), their AABB entries through the
// scalar code (enter_walk); the events at which a lane records a point go into a log, without a
// branch, and are replayed through push_point (so the points are the scalar code's too) before
// lanes whose walks ended take the next rays, which happens once kRefill lanes are idle.
void walk_rays_avx512(const VoxelGrid& grid, const Ray* rays, size_t count, uint32_t H, RayWalk* walks) {
  constexpr int L = 16, kRefill = 3, kLog = 256;
  const int V = static_cast<int>(grid.resolution);
  const float Vf = static_cast<float>(V);
  const PlaneValues plane_of(V);

  // The lanes' walks, one ray per lane.
  alignas(64) float o[3][L], d[3][L], t_next[3][L], t_exit[L], t_last[L];
  alignas(64) int32_t cell[3][L], step[3][L], up[3][L], events[L], points[L];
  WalkStart start[L];
  size_t ray_of[L];
  __mmask16 live = 0, occupied = 0;
  // The log of recorded events: the lane, t, the planes before the step (each + 1 in 9 bits) and the
  // axes that stepped (bits 27-29); room for one more event's 16 lanes at any time.
  alignas(64) int32_t log_lane[kLog + L], log_info[kLog + L];
  alignas(64) float log_t[kLog + L];
  int logged = 0;
  auto replay = [&] {
    for (int e = 0; e < logged; ++e) {
      const int lane = log_lane[e];
      const uint32_t info = uint32_t(log_info[e]);
      const bool on_plane[3] = {(info >> 27 & 1u) != 0, (info >> 28 & 1u) != 0, (info >> 29 & 1u) != 0};
      const int plane[3] = {int(info & 0x1FFu) - 1, int(info >> 9 & 0x1FFu) - 1, int(info >> 18 & 0x1FFu) - 1};
      push_point(walks[ray_of[lane]], H, start[lane], log_t[e], on_plane, plane, Vf);
    }
    logged = 0;
  };
  // Puts the next ray whose walk has a DDA to run into `lane`; false when none is left. Rays are
  // started 16 at a time (start_walks) into `staged`.
  WalkStart staged[L];
  __mmask16 staged_ok = 0;
  size_t staged_first = 0, next = 0;  // the first ray staged, the first not staged yet
  int staged_count = 0, staged_next = 0;
  auto load = [&](int lane) {
    for (;;) {
      if (staged_next == staged_count) {
        if (next == count) return false;
        staged_first = next;
        staged_count = int(std::min<size_t>(L, count - next));
        staged_next = 0;
        next += size_t(staged_count);
        staged_ok = start_walks(grid, plane_of, rays + staged_first, staged_count, staged);
      }
      const int k = staged_next++;
      const size_t i = staged_first + size_t(k);
      clear_walk(walks[i]);
      if (!((staged_ok >> k) & 1)) continue;
      const WalkStart& s = start[lane] = staged[k];
      bool occupied_now = false;
      if (!enter_walk(grid, H, walks[i], s, occupied_now)) continue;
      for (int a = 0; a < 3; ++a) {
        o[a][lane] = s.o[a];
        d[a][lane] = s.d[a];
        t_next[a][lane] = s.t_ahead[a];
        cell[a][lane] = s.cell[a];
        step[a][lane] = s.step[a];
        up[a][lane] = s.step[a] > 0 ? 1 : 0;
      }
      t_exit[lane] = s.t_exit;
      t_last[lane] = s.t_enter;
      events[lane] = 0;
      points[lane] = int32_t(walks[i].count);
      ray_of[lane] = i;
      occupied = __mmask16((occupied & ~(1u << lane)) | (unsigned(occupied_now) << lane));
      return true;
    }
  };

  constexpr __mmask16 all = 0xFFFF;
  const __m512 inf = _mm512_set1_ps(kInf);
  const __m512i v_count = _mm512_set1_epi32(V), one = _mm512_set1_epi32(1), h = _mm512_set1_epi32(int32_t(H));
  const __m512i max_events = _mm512_set1_epi32(3 * V + 3);
  const __m512i lane_index = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  const int* bits = reinterpret_cast<const int*>(grid.bits.data());
  for (;;) {
    const __mmask16 idle = __mmask16(~live);
    if (live == 0 || ((next < count || staged_next < staged_count) && __builtin_popcount(idle) >= kRefill)) {
      replay();
      for (__mmask16 free_lanes = idle; free_lanes; free_lanes = __mmask16(free_lanes & (free_lanes - 1))) {
        const int lane = __builtin_ctz(free_lanes);
        if (load(lane)) live = __mmask16(live | (1u << lane));
      }
      if (live == 0) break;
    }
    __m512 tn[3];
    __m512i c[3];
    for (int a = 0; a < 3; ++a) {
      tn[a] = _mm512_load_ps(t_next[a]);
      c[a] = _mm512_load_si512(cell[a]);
    }
    // std::min(t0, std::min(t1, t2)): min(x, y) is (y < x) ? y : x, vminps(y, x). (The zero-masked
    // forms with every lane set: GCC 12's unmasked ones warn of their undefined pass-through.)
    const __m512 t = _mm512_maskz_min_ps(all, _mm512_maskz_min_ps(all, tn[2], tn[1]), tn[0]);
    const __m512i ev = _mm512_load_si512(events);
    const __mmask16 go = live & _mm512_cmp_ps_mask(t, _mm512_load_ps(t_exit), _CMP_LE_OQ) &
                         _mm512_cmp_ps_mask(t, inf, _CMP_NEQ_OQ) & _mm512_cmplt_epi32_mask(ev, max_events);
    __mmask16 inside = go, on[3];
    __m512 numerator[3];
    __m512i info = _mm512_setzero_si512();
    for (int a = 0; a < 3; ++a) {
      on[a] = go & _mm512_cmp_ps_mask(tn[a], t, _CMP_EQ_OQ);
      const __m512i u = _mm512_load_si512(up[a]);
      const __m512i plane = _mm512_add_epi32(_mm512_add_epi32(c[a], u), one);  // plane + 1 >= 0
      info = _mm512_or_si512(info, _mm512_maskz_slli_epi32(all, plane, unsigned(9 * a)));
      info = _mm512_mask_or_epi32(info, on[a], info, _mm512_set1_epi32(1 << (27 + a)));
      c[a] = _mm512_mask_add_epi32(c[a], on[a], c[a], _mm512_load_si512(step[a]));
      inside &= _mm512_cmplt_epu32_mask(c[a], v_count);
      numerator[a] = _mm512_sub_ps(plane_of(_mm512_add_epi32(c[a], u), on[a]), _mm512_load_ps(o[a]));
      _mm512_store_si512(cell[a], c[a]);
    }
    // The next crossing of each axis that stepped, (n/V - o) / d: one division for a lane's lowest
    // such axis, a second pass only where a lane stepped several axes at once (an edge or a corner).
    const __mmask16 first1 = on[1] & ~on[0], first2 = on[2] & ~(on[0] | on[1]);
    const __m512 quotient = _mm512_div_ps(
        _mm512_mask_mov_ps(_mm512_mask_mov_ps(numerator[0], first1, numerator[1]), first2, numerator[2]),
        _mm512_mask_mov_ps(_mm512_mask_mov_ps(_mm512_load_ps(d[0]), first1, _mm512_load_ps(d[1])), first2,
                           _mm512_load_ps(d[2])));
    tn[0] = _mm512_mask_mov_ps(tn[0], on[0], quotient);
    tn[1] = _mm512_mask_mov_ps(tn[1], first1, quotient);
    tn[2] = _mm512_mask_mov_ps(tn[2], first2, quotient);
    const __mmask16 more1 = on[1] & on[0], more2 = on[2] & (on[0] | on[1]);
    if (more1 | more2) {
      tn[1] = _mm512_mask_div_ps(tn[1], more1, numerator[1], _mm512_load_ps(d[1]));
      tn[2] = _mm512_mask_div_ps(tn[2], more2, numerator[2], _mm512_load_ps(d[2]));
    }
    for (int a = 0; a < 3; ++a) _mm512_store_ps(t_next[a], tn[a]);
    // The voxel entered: voxel index i + V (j + V k), bit (index & 31) of word index >> 5.
    const __m512i index =
        _mm512_add_epi32(c[0], _mm512_mullo_epi32(v_count, _mm512_add_epi32(c[1], _mm512_mullo_epi32(v_count, c[2]))));
    const __m512i word =
        _mm512_mask_i32gather_epi32(_mm512_setzero_si512(), inside, _mm512_maskz_srli_epi32(all, index, 5), bits, 4);
    const __m512i bit = _mm512_maskz_srlv_epi32(all, word, _mm512_and_si512(index, _mm512_set1_epi32(31)));
    const __mmask16 occupied_now = inside & _mm512_test_epi32_mask(bit, one);
    const __m512 last = _mm512_load_ps(t_last);
    const __mmask16 record = go & (occupied | occupied_now) & _mm512_cmp_ps_mask(t, last, _CMP_GT_OQ);
    occupied = occupied_now;
    _mm512_store_si512(events, _mm512_mask_add_epi32(ev, go, ev, one));
    _mm512_store_ps(t_last, _mm512_mask_mov_ps(last, record, t));
    // The log; a record beyond the H-th point is the one that sets `truncated` and ends the walk.
    _mm512_storeu_si512(log_lane + logged, _mm512_maskz_compress_epi32(record, lane_index));
    _mm512_storeu_ps(log_t + logged, _mm512_maskz_compress_ps(record, t));
    _mm512_storeu_si512(log_info + logged, _mm512_maskz_compress_epi32(record, info));
    logged += __builtin_popcount(record);
    const __m512i recorded = _mm512_load_si512(points);
    const __mmask16 full = record & _mm512_cmpge_epi32_mask(recorded, h);
    _mm512_store_si512(points, _mm512_mask_add_epi32(recorded, record, recorded, one));
    live = __mmask16(live & go & inside & ~full);
    if (logged > kLog - L) replay();
  }
}

}  // namespace
#endif

void walk_rays(const VoxelGrid& grid, const Ray* rays, size_t count, uint32_t max_points, RayWalk* walks) {
#if defined(__AVX512F__)
  if (walkable(grid) && grid.resolution <= kMaxLaneResolution) {
    walk_rays_avx512(grid, rays, count, std::min(max_points, LSNIF_MAX_POINTS), walks);
    return;
  }
#endif
  for (size_t i = 0; i < count; ++i) walk_ray(grid, rays[i], max_points, walks[i]);
}

// Contract: the voxel-only baseline of ray_walk.h. hit = walk.count > 0; t = walk.t[0], or
// walk.t_enter when the ray starts strictly inside the box (t_near < tmin) in an occupied voxel;
// the normal is the unit axis of walk.axis[0], signed to face the ray (dot(normal, direction) < 0).
// `walk` must be walk_ray(grid, ray, ...).
BaselineHit voxel_baseline(const VoxelGrid& grid, const Ray& ray, const RayWalk& walk) {
  BaselineHit hit;
  if (walk.count == 0) return hit;
  hit.hit = true;
  hit.t = walk.t[0];
  WalkStart s;
  if (start_walk(grid, ray, s) && !s.from_outside && grid.occupied(s.cell[0], s.cell[1], s.cell[2]))
    hit.t = walk.t_enter;
  const int a = walk.axis[0];
  hit.normal[a] = ray.direction[a] > 0.0f ? -1.0f : 1.0f;
  return hit;
}

}  // namespace lsnif
