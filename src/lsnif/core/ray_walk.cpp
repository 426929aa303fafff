// ray_walk.cpp -- the LSNIF ray walk (paper 3.1): AABB clipping and a 3D DDA through the voxel
// grid, collecting the points where the ray crosses a face of an occupied voxel. This is the CPU
// reference; src/lsnif/shaders/lsnif_walk.glsl copies it line by line, hence float math only, rolled loops with
// fixed bounds, no recursion and few branches.
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

}  // namespace

// Contract: fills `walk` for `ray` (object space) against `grid` as defined in ray_walk.h and the
// file comment above; returns walk.count. A grid without voxels (resolution 0 or too few bits) or a
// non-finite ray gives hits_aabb = false and no points. max_points is clamped to LSNIF_MAX_POINTS.
uint32_t walk_ray(const VoxelGrid& grid, const Ray& ray, uint32_t max_points, RayWalk& walk) {
  walk.count = 0;
  walk.truncated = false;
  walk.hits_aabb = false;
  walk.t_enter = 0.0f;
  walk.t_exit = 0.0f;
  const int V = static_cast<int>(grid.resolution);
  if (V < 1 || uint64_t(grid.bits.size()) * 32u < uint64_t(V) * uint64_t(V) * uint64_t(V)) return 0;
  const uint32_t H = std::min(max_points, LSNIF_MAX_POINTS);
  const float Vf = static_cast<float>(V);

  WalkStart s;
  if (!start_walk(grid, ray, s)) return 0;
  walk.hits_aabb = true;
  walk.t_enter = s.t_enter;
  walk.t_exit = s.t_exit;

  int cell[3] = {s.cell[0], s.cell[1], s.cell[2]};
  float t_next[3] = {s.t_ahead[0], s.t_ahead[1], s.t_ahead[2]};
  // The crossing of the plane after each axis's next one, found one step ahead: the division is
  // then off the chain from one event to the next (the same values, computed earlier).
  float t_after[3];
  for (int a = 0; a < 3; ++a)
    t_after[a] = s.step[a] != 0 ? plane_t(s.o, s.d, a, cell[a] + (s.step[a] > 0 ? 1 : 0) + s.step[a], Vf) : kInf;
  bool occupied_now = grid.occupied(cell[0], cell[1], cell[2]);
  bool on_plane[3];
  int plane[3];

  // The AABB entry: a crossing from outside into the start voxel. The planes through the entry
  // point are the start voxel's faces behind it at t_enter and, for a ray that only grazes the box,
  // faces ahead of it at t_enter (the walk leaves again at once; that crossing merges with this one).
  if (s.from_outside && occupied_now) {
    for (int a = 0; a < 3; ++a) {
      const int up = s.step[a] > 0 ? 1 : 0;
      on_plane[a] = s.t_behind[a] == s.t_enter || s.t_ahead[a] == s.t_enter;
      plane[a] = s.t_behind[a] == s.t_enter ? cell[a] + 1 - up : cell[a] + up;
    }
    if (!push_point(walk, H, s, s.t_enter, on_plane, plane, Vf)) return walk.count;
  }

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
