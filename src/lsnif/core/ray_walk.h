// ray_walk.h -- the LSNIF ray walk (paper 3.1): clip a ray to the object AABB, step through the
// voxels with a 3D DDA, and collect, front to back, the points where the ray crosses a boundary
// of an occupied voxel. These boundary points are the network's input (after encoding).
//
// Definition (the CPU reference; src/lsnif/shaders/lsnif_walk.glsl follows it line by line):
//  * Everything happens in the grid's unit cube (VoxelGrid::to_unit); t is the ray's own parameter
//    (unchanged by the affine map), so t values are object-space ray parameters.
//  * [t_enter, t_exit] = [max(tmin, t_near), min(tmax, t_far)] of the ray/AABB slab test; empty ->
//    no points.
//  * The ray is in voxel floor(p*V) (clamped to [0, V-1]) at t_enter, where p is taken just after
//    t_enter; the DDA then steps one voxel face at a time.
//  * A crossing at parameter t between the voxel before (a) and after (b) is a boundary point when
//    a or b is occupied. Leaving the grid means b is "outside" (empty). The AABB entry at t_near is a
//    crossing (from outside) only when t_near >= tmin (origin outside or on the box); an origin
//    strictly inside produces no point at t_enter. A crossing beyond tmax is not reached.
//  * Several faces crossed at the same t (an edge or a corner) give one point; it is a boundary
//    point if the voxel before or the voxel after it along the ray is occupied (voxels that only
//    share that edge or corner are never entered and do not count); its axis is the lowest axis
//    among the planes through it.
//  * Points are recorded until H (max_points) are found; `truncated` tells whether more existed.
//  * p[j] lies exactly on the plane of axis[j]: its axis[j] coordinate is the plane's value n/V.
#pragma once
#include <cstddef>
#include <cstdint>
#include <limits>

#include "lsnif/host_device.h"
#include "lsnif/core/geometry.h"
#include "lsnif/core/voxel_grid.h"

namespace lsnif {

struct RayWalk {
  uint32_t count = 0;       // boundary points recorded (<= max_points)
  bool truncated = false;   // more boundary points lay beyond the H-th
  bool hits_aabb = false;   // the clipped interval is non-empty
  float t_enter = 0.0f;     // start of the clipped interval (object-space ray parameter)
  float t_exit = 0.0f;      // end of the clipped interval
  float t[LSNIF_MAX_POINTS];         // ray parameter of each boundary point, non-decreasing
  glm::vec3 p[LSNIF_MAX_POINTS];     // unit-cube position of each boundary point
  uint8_t axis[LSNIF_MAX_POINTS];    // axis (0,1,2) of the voxel face plane the point lies on
};

// Walks `ray` (object space) through `grid`. Returns the number of boundary points (walk.count).
uint32_t walk_ray(const VoxelGrid& grid, const Ray& ray, uint32_t max_points, RayWalk& walk);

// walks[i] = walk_ray(grid, rays[i], max_points) for i < count, the same walks bit for bit; in
// builds with AVX-512 and for V <= 509, 16 rays at a time in the lanes of its registers (one thread;
// callers split the rays among threads).
void walk_rays(const VoxelGrid& grid, const Ray* rays, size_t count, uint32_t max_points, RayWalk* walks);

// A ray without a walk (its origin is not finite): for the slots of a walk_rays batch that hold no ray.
inline const Ray kNoWalkRay{glm::vec3(std::numeric_limits<float>::quiet_NaN()), glm::vec3(0.0f), 0.0f, 0.0f};

// Voxel-only baseline at a walk: hit = at least one boundary point; t = the first point (entry into
// the first occupied voxel, or t_enter if the ray starts inside an occupied voxel); normal = the
// face normal of that point's plane facing the ray (object space, normalized).
struct BaselineHit {
  bool hit = false;
  float t = 0.0f;
  glm::vec3 normal{0.0f};
};
BaselineHit voxel_baseline(const VoxelGrid& grid, const Ray& ray, const RayWalk& walk);

}  // namespace lsnif
