// geometry.h -- small geometric types shared by every host module: rays, boxes, the object's
// padded AABB and its mapping to the unit cube in which voxels and the hash grid live.
#pragma once
#include <glm/glm.hpp>

#include <cmath>
#include <limits>

namespace lsnif {

struct Ray {
  glm::vec3 origin{0.0f};
  glm::vec3 direction{0.0f, 0.0f, 1.0f};  // need not be normalized; t is measured in its units
  float tmin = 0.0f;
  float tmax = std::numeric_limits<float>::infinity();
};

struct Aabb {
  glm::vec3 lo{std::numeric_limits<float>::infinity()};
  glm::vec3 hi{-std::numeric_limits<float>::infinity()};
  void grow(const glm::vec3& p) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  bool valid() const { return lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z; }
  glm::vec3 extent() const { return hi - lo; }
  glm::vec3 center() const { return 0.5f * (lo + hi); }
  float diagonal() const { return glm::length(hi - lo); }
};

// Pads a mesh's bounding box so no triangle lies on the voxel grid's outer boundary (LSNIF
// "object AABB"): every side grows by `fraction` of the diagonal. A flat box (a planar mesh) still
// gets a non-zero extent on every axis.
inline Aabb pad_aabb(const Aabb& box, float fraction = 0.01f) {
  float pad = fraction * box.diagonal();
  if (!(pad > 0.0f)) pad = 1e-3f;
  Aabb out;
  out.lo = box.lo - glm::vec3(pad);
  out.hi = box.hi + glm::vec3(pad);
  return out;
}

// Slab test. Returns false when the ray misses the box within [ray.tmin, ray.tmax]; otherwise
// t_near/t_far are the parametric entry and exit (t_near may be < ray.tmin when the origin is
// inside). Axis-parallel directions (a zero component) are handled: the slab is either always or
// never satisfied. entry_axis receives the axis of the face through which the ray enters (-1 if
// the origin is inside the box on every axis, i.e. t_near = -inf).
inline bool intersect_aabb(const Aabb& box, const Ray& ray, float& t_near, float& t_far,
                           int* entry_axis = nullptr) {
  float tn = -std::numeric_limits<float>::infinity();
  float tf = std::numeric_limits<float>::infinity();
  int axis = -1;
  for (int a = 0; a < 3; ++a) {
    float o = ray.origin[a], d = ray.direction[a];
    if (d == 0.0f) {
      if (o < box.lo[a] || o > box.hi[a]) return false;
      continue;
    }
    float inv = 1.0f / d;
    float t0 = (box.lo[a] - o) * inv, t1 = (box.hi[a] - o) * inv;
    if (t0 > t1) std::swap(t0, t1);
    if (t0 > tn) {
      tn = t0;
      axis = a;
    }
    tf = std::min(tf, t1);
  }
  if (entry_axis) *entry_axis = axis;
  t_near = tn;
  t_far = tf;
  return tn <= tf && tf >= ray.tmin && tn <= ray.tmax;
}

}  // namespace lsnif
