// lsnif_walk.glsl -- the LSNIF ray walk on the device: a line-by-line copy of walk_ray in
// src/lsnif/core/ray_walk.cpp (read its file comment: it is the specification). Same float formulas in the
// same order, fixed-size arrays of LSNIF_MAX_POINTS, rolled loops. The walk is kept in the private
// global `lsnif_walk` (no copies of its arrays between functions).
#ifndef LSNIF_WALK_GLSL
#define LSNIF_WALK_GLSL

#include "lsnif/shaders/lsnif_model.glsl"

#define LSNIF_INF uintBitsToFloat(0x7f800000u)

struct LsnifWalk {
  uint count;      // boundary points recorded (<= H)
  bool truncated;  // more boundary points lay beyond the H-th
  bool hits_aabb;  // the clipped interval is non-empty
  float t_enter;   // clipped interval (object-space ray parameter)
  float t_exit;
  float t[LSNIF_MAX_POINTS];  // ray parameter of each boundary point, non-decreasing
  vec3 p[LSNIF_MAX_POINTS];   // unit-cube position of each boundary point
  uint axis[LSNIF_MAX_POINTS];  // axis of the voxel face plane the point lies on
};

LsnifWalk lsnif_walk;

// WalkStart of ray_walk.cpp.
struct LsnifWalkStart {
  vec3 o, d;  // the ray in the grid's unit cube
  float t_near, t_enter, t_exit;
  bool from_outside;
  ivec3 cell;  // voxel just after t_enter
  ivec3 step;  // +1 / -1 along the direction, 0 for an axis that never steps
  vec3 t_ahead, t_behind;
};

float lsnif_plane_t(vec3 o, vec3 d, int a, int n, float Vf) { return (float(n) / Vf - o[a]) / d[a]; }

bool lsnif_finite3(vec3 v) { return !any(isinf(v)) && !any(isnan(v)); }

// start_walk: clips the ray to the box and finds the start voxel; false when the interval is empty.
bool lsnif_start_walk(LsnifModel m, vec3 origin, vec3 direction, float tmin, float tmax,
                      out LsnifWalkStart s) {
  const int V = int(m.h.voxel_resolution);
  const float Vf = float(m.h.voxel_resolution);
  const vec3 lo = lsnif_bounds_lo(m), extent = lsnif_bounds_hi(m) - lo;
  s.o = (origin - lo) / extent;
  s.d = direction / extent;
  s.t_near = 0.0;
  s.t_enter = 0.0;
  s.t_exit = 0.0;
  s.from_outside = false;
  s.cell = ivec3(0);
  s.step = ivec3(0);
  s.t_ahead = vec3(LSNIF_INF);
  s.t_behind = vec3(-LSNIF_INF);
  if (!lsnif_finite3(s.o) || !lsnif_finite3(s.d)) return false;

  // Slab test in the unit cube.
  float t_near = -LSNIF_INF, t_far = LSNIF_INF;
  for (int a = 0; a < 3; ++a) {
    if (s.d[a] != 0.0) {
      const float t0 = lsnif_plane_t(s.o, s.d, a, 0, Vf), t1 = lsnif_plane_t(s.o, s.d, a, V, Vf);
      t_near = max(t_near, min(t0, t1));
      t_far = min(t_far, max(t0, t1));
    } else if (!(s.o[a] >= 0.0 && s.o[a] <= 1.0)) {
      return false;  // parallel to this slab and outside it
    }
  }
  s.t_near = t_near;
  s.t_enter = max(tmin, t_near);
  s.t_exit = min(tmax, t_far);
  if (!(s.t_enter <= s.t_exit) || isinf(s.t_enter) || isnan(s.t_enter)) return false;
  s.from_outside = t_near >= tmin;

  // Start voxel: floor guess at t_enter, then agree with the crossing times.
  const vec3 p = s.o + s.t_enter * s.d;
  for (int a = 0; a < 3; ++a) {
    const float coord = s.d[a] != 0.0 ? p[a] : s.o[a];
    int c = int(clamp(floor(coord * Vf), 0.0, Vf - 1.0));
    if (s.d[a] != 0.0) {
      const int st = s.d[a] > 0.0 ? 1 : -1;
      const int up = st > 0 ? 1 : 0;  // face ahead of voxel c is plane c + up, behind c + 1 - up
      if (c + st >= 0 && c + st < V && lsnif_plane_t(s.o, s.d, a, c + up, Vf) <= s.t_enter) c += st;
      if (c - st >= 0 && c - st < V && lsnif_plane_t(s.o, s.d, a, c + 1 - up, Vf) > s.t_enter) c -= st;
      s.step[a] = st;
      s.t_ahead[a] = lsnif_plane_t(s.o, s.d, a, c + up, Vf);
      s.t_behind[a] = lsnif_plane_t(s.o, s.d, a, c + 1 - up, Vf);
    }
    s.cell[a] = c;
  }
  return true;
}

// push_point: appends a boundary point at t lying on the planes on_plane[a] (value plane[a] / V).
// False when H points are already recorded (sets truncated).
bool lsnif_push_point(uint H, vec3 o, vec3 d, float t, bvec3 on_plane, ivec3 plane, float Vf) {
  if (lsnif_walk.count >= H) {
    lsnif_walk.truncated = true;
    return false;
  }
  vec3 p = clamp(o + t * d, vec3(0.0), vec3(1.0));
  int axis = 3;
  for (int a = 2; a >= 0; --a) {
    if (on_plane[a]) {
      p[a] = float(plane[a]) / Vf;
      axis = a;
    }
  }
  lsnif_walk.t[lsnif_walk.count] = t;
  lsnif_walk.p[lsnif_walk.count] = p;
  lsnif_walk.axis[lsnif_walk.count] = axis == 3 ? 0u : uint(axis);
  ++lsnif_walk.count;
  return true;
}

// walk_ray: fills lsnif_walk for the object-space ray; returns lsnif_walk.count.
uint lsnif_walk_ray(LsnifModel m, vec3 origin, vec3 direction, float tmin, float tmax) {
  lsnif_walk.count = 0u;
  lsnif_walk.truncated = false;
  lsnif_walk.hits_aabb = false;
  lsnif_walk.t_enter = 0.0;
  lsnif_walk.t_exit = 0.0;
  const int V = int(m.h.voxel_resolution);
  if (V < 1) return 0u;
  const uint H = min(m.h.max_points, LSNIF_MAX_POINTS);
  const float Vf = float(V);

  LsnifWalkStart s;
  if (!lsnif_start_walk(m, origin, direction, tmin, tmax, s)) return 0u;
  lsnif_walk.hits_aabb = true;
  lsnif_walk.t_enter = s.t_enter;
  lsnif_walk.t_exit = s.t_exit;

  ivec3 cell = s.cell;
  vec3 t_next = s.t_ahead;
  bool occupied_now = lsnif_occupied(m, cell[0], cell[1], cell[2]);
  bvec3 on_plane;
  ivec3 plane;

  // The AABB entry: a crossing from outside into the start voxel.
  if (s.from_outside && occupied_now) {
    for (int a = 0; a < 3; ++a) {
      const int up = s.step[a] > 0 ? 1 : 0;
      on_plane[a] = s.t_behind[a] == s.t_enter || s.t_ahead[a] == s.t_enter;
      plane[a] = s.t_behind[a] == s.t_enter ? cell[a] + 1 - up : cell[a] + up;
    }
    if (!lsnif_push_point(H, s.o, s.d, s.t_enter, on_plane, plane, Vf)) return lsnif_walk.count;
  }

  // The DDA. Every event steps at least one axis by one voxel, so 3V events end any walk.
  float t_last = s.t_enter;
  for (int event = 0; event < 3 * V + 3; ++event) {
    const float t = min(t_next[0], min(t_next[1], t_next[2]));
    if (!(t <= s.t_exit) || t == LSNIF_INF) break;
    const bool occupied_before = occupied_now;
    bool inside = true;
    for (int a = 0; a < 3; ++a) {
      on_plane[a] = t_next[a] == t;
      const int up = s.step[a] > 0 ? 1 : 0;
      plane[a] = cell[a] + up;
      if (on_plane[a]) {
        cell[a] += s.step[a];
        inside = inside && cell[a] >= 0 && cell[a] < V;
        t_next[a] = lsnif_plane_t(s.o, s.d, a, cell[a] + up, Vf);
      }
    }
    occupied_now = inside && lsnif_occupied(m, cell[0], cell[1], cell[2]);
    if ((occupied_before || occupied_now) && t > t_last) {
      if (!lsnif_push_point(H, s.o, s.d, t, on_plane, plane, Vf)) break;
      t_last = t;
    }
    if (!inside) break;
  }
  return lsnif_walk.count;
}

#endif
