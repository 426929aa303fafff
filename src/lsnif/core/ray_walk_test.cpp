// ray_walk_test.cpp -- walk_ray and voxel_baseline against hand-computed cases and an independent
// brute force: all plane crossings of every axis in [t_enter, t_exit], sorted and merged by t, each
// classified by the voxels before and after it, found by counting the planes already crossed.
#include "lsnif/core/ray_walk.h"
#include "lsnif/testing/off_reader.h"
#include "lsnif/train/voxelizer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace lsnif {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

VoxelGrid empty_grid(uint32_t V, glm::vec3 lo, glm::vec3 hi) {
  VoxelGrid g;
  g.resolution = V;
  g.bounds.lo = lo;
  g.bounds.hi = hi;
  g.bits.assign((V * V * V + 31) / 32, 0u);
  return g;
}

Ray make_ray(glm::vec3 o, glm::vec3 d, float tmin = 0.0f, float tmax = kInf) {
  Ray r;
  r.origin = o;
  r.direction = d;
  r.tmin = tmin;
  r.tmax = tmax;
  return r;
}

// ---------------------------------------------------------------------------------------------
// Brute-force reference.

struct RefPoint {
  float t;
  glm::vec3 p;
  int axis;
};

struct RefWalk {
  bool hits = false;
  float t_enter = 0.0f, t_exit = 0.0f;
  bool from_outside = false;
  bool starts_occupied = false;       // the voxel at t_enter is occupied (origin inside the box)
  std::vector<RefPoint> points;       // every boundary point (no H limit)
  int geometry_mismatches = 0;        // self-check of the plane counting against positions
};

RefWalk reference_walk(const VoxelGrid& g, const Ray& ray) {
  RefWalk r;
  const int V = int(g.resolution);
  const float Vf = float(V);
  const glm::vec3 o = g.to_unit(ray.origin), d = g.direction_to_unit(ray.direction);
  auto plane_t = [&](int a, int n) { return (float(n) / Vf - o[a]) / d[a]; };

  float t_near = -kInf, t_far = kInf;
  for (int a = 0; a < 3; ++a) {
    if (d[a] != 0.0f) {
      t_near = std::max(t_near, std::min(plane_t(a, 0), plane_t(a, V)));
      t_far = std::min(t_far, std::max(plane_t(a, 0), plane_t(a, V)));
    } else if (o[a] < 0.0f || o[a] > 1.0f) {
      return r;
    }
  }
  r.t_enter = std::max(ray.tmin, t_near);
  r.t_exit = std::min(ray.tmax, t_far);
  if (!(r.t_enter <= r.t_exit)) return r;
  r.hits = true;
  r.from_outside = t_near >= ray.tmin;

  // The voxel just after parameter tau: on each moving axis, the planes 1..V-1 with t <= tau are
  // behind the ray. Returns whether that point is still inside the box (cell is clamped anyway).
  auto voxel_after = [&](float tau, int cell[3]) {
    bool inside = true;
    for (int a = 0; a < 3; ++a) {
      if (d[a] == 0.0f) {
        cell[a] = std::clamp(int(std::floor(o[a] * Vf)), 0, V - 1);
        continue;
      }
      int crossed = 0;
      for (int n = 1; n < V; ++n) crossed += plane_t(a, n) <= tau;
      cell[a] = d[a] > 0.0f ? crossed : V - 1 - crossed;
      inside = inside && (d[a] > 0.0f ? plane_t(a, V) : plane_t(a, 0)) > tau;
    }
    return inside;
  };
  // Independent self-check: the voxel of the midpoint of an interval, on the axes where that
  // midpoint is not within rounding distance of a plane.
  auto check_geometry = [&](float t0, float t1, const int cell[3]) {
    const float tm = 0.5f * (t0 + t1);
    glm::vec3 q = (o + tm * d) * Vf;
    for (int a = 0; a < 3; ++a) {
      float error = 8.0f * std::numeric_limits<float>::epsilon() * Vf * (std::abs(o[a]) + std::abs(tm * d[a]));
      if (d[a] != 0.0f && std::abs(q[a] - std::round(q[a])) > 1e-3f + error && int(std::floor(q[a])) != cell[a])
        ++r.geometry_mismatches;
    }
  };

  struct Crossing {
    float t;
    int axis, plane;
  };
  std::vector<Crossing> crossings;
  for (int a = 0; a < 3; ++a)
    if (d[a] != 0.0f)
      for (int n = 0; n <= V; ++n) {
        float t = plane_t(a, n);
        if (t >= r.t_enter && t <= r.t_exit) crossings.push_back({t, a, n});
      }
  std::sort(crossings.begin(), crossings.end(),
            [](const Crossing& x, const Crossing& y) { return x.t < y.t || (x.t == y.t && x.axis < y.axis); });

  auto push = [&](const Crossing& c) {  // c: the first (lowest-axis) crossing of its group
    glm::vec3 p = o + c.t * d;
    p[c.axis] = float(c.plane) / Vf;
    r.points.push_back({c.t, p, c.axis});
  };

  int cell[3];
  bool inside = voxel_after(r.t_enter, cell);
  bool occupied_before;
  size_t i = 0;
  if (r.from_outside) {
    // The entry group at t_enter: from outside into the start voxel (the clamped one even when the
    // ray only grazes the box and leaves at the same t).
    occupied_before = g.occupied(cell[0], cell[1], cell[2]);
    if (occupied_before) push(crossings[0]);
  } else {
    occupied_before = inside && g.occupied(cell[0], cell[1], cell[2]);
    r.starts_occupied = occupied_before;
  }
  while (i < crossings.size() && crossings[i].t == r.t_enter) ++i;  // nothing else at t_enter
  float t_prev = r.t_enter;
  while (i < crossings.size() && inside) {
    const Crossing first = crossings[i];
    while (i < crossings.size() && crossings[i].t == first.t) ++i;
    check_geometry(t_prev, first.t, cell);
    inside = voxel_after(first.t, cell);
    bool occupied_after = inside && g.occupied(cell[0], cell[1], cell[2]);
    if (occupied_before || occupied_after) push(first);
    occupied_before = occupied_after;
    t_prev = first.t;
  }
  return r;
}

std::string describe(const VoxelGrid& g, const Ray& ray, uint32_t H) {
  std::ostringstream s;
  s.precision(9);
  s << "V=" << g.resolution << " bounds=(" << g.bounds.lo.x << "," << g.bounds.lo.y << "," << g.bounds.lo.z
    << ")-(" << g.bounds.hi.x << "," << g.bounds.hi.y << "," << g.bounds.hi.z << ") o=(" << ray.origin.x << ","
    << ray.origin.y << "," << ray.origin.z << ") d=(" << ray.direction.x << "," << ray.direction.y << ","
    << ray.direction.z << ") tmin=" << ray.tmin << " tmax=" << ray.tmax << " H=" << H;
  return s.str();
}

// Compares walk_ray with the reference; returns false (and reports) on the first difference.
bool matches_reference(const VoxelGrid& g, const Ray& ray, uint32_t H) {
  RayWalk w;
  uint32_t n = walk_ray(g, ray, H, w);
  RefWalk r = reference_walk(g, ray);
  std::ostringstream err;
  const size_t want = std::min<size_t>(H, r.points.size());
  if (n != w.count) err << "returned " << n << " != count " << w.count << "; ";
  if (w.hits_aabb != r.hits) err << "hits_aabb " << w.hits_aabb << " want " << r.hits << "; ";
  if (r.hits && (w.t_enter != r.t_enter || w.t_exit != r.t_exit))
    err << "interval [" << w.t_enter << "," << w.t_exit << "] want [" << r.t_enter << "," << r.t_exit << "]; ";
  if (w.count != want) err << "count " << w.count << " want " << want << " (of " << r.points.size() << "); ";
  if (w.truncated != (r.points.size() > H)) err << "truncated " << w.truncated << "; ";
  if (r.geometry_mismatches) err << "reference self-check failed; ";
  // o_u + t * d_u carries an absolute error of a few ulps of its terms: far origins widen p's tolerance.
  const glm::vec3 o = g.to_unit(ray.origin), d = g.direction_to_unit(ray.direction);
  for (size_t j = 0; j < std::min<size_t>(want, w.count); ++j) {
    const RefPoint& q = r.points[j];
    float tol = 1e-5f * std::max(1.0f, std::abs(q.t));
    auto max_abs = [](glm::vec3 v) { return std::max(std::abs(v.x), std::max(std::abs(v.y), std::abs(v.z))); };
    float magnitude = max_abs(o) + std::abs(q.t) * max_abs(d);
    float tol_p = 1e-5f + 8.0f * std::numeric_limits<float>::epsilon() * magnitude;
    if (!(std::abs(w.t[j] - q.t) <= tol)) err << "t[" << j << "]=" << w.t[j] << " want " << q.t << "; ";
    if (w.axis[j] != q.axis) err << "axis[" << j << "]=" << int(w.axis[j]) << " want " << q.axis << "; ";
    if (w.p[j][q.axis] != q.p[q.axis]) err << "p[" << j << "] not on plane " << q.p[q.axis] << "; ";
    for (int a = 0; a < 3; ++a)
      if (!(std::abs(w.p[j][a] - q.p[a]) <= tol_p))
        err << "p[" << j << "][" << a << "]=" << w.p[j][a] << " want " << q.p[a] << "; ";
    if (j > 0 && w.t[j] < w.t[j - 1]) err << "t decreasing at " << j << "; ";
  }
  if (err.str().empty()) return true;
  ADD_FAILURE() << describe(g, ray, H) << ": " << err.str();
  return false;
}

// ---------------------------------------------------------------------------------------------
// Hand cases. V = 4 over [0,4]^3: voxel (i,j,k) is the unit box at (i,j,k), unit coordinate = x/4.

class HandCase : public ::testing::Test {
 protected:
  VoxelGrid g = empty_grid(4, glm::vec3(0.0f), glm::vec3(4.0f));
};

TEST_F(HandCase, SingleVoxelAlongXGivesEntryAndExitFaces) {
  g.set(1, 1, 1);
  RayWalk w;
  ASSERT_EQ(walk_ray(g, make_ray({-1, 1.5f, 1.5f}, {1, 0, 0}), 18, w), 2u);
  EXPECT_TRUE(w.hits_aabb);
  EXPECT_FALSE(w.truncated);
  EXPECT_EQ(w.t_enter, 1.0f);
  EXPECT_EQ(w.t_exit, 5.0f);
  EXPECT_EQ(w.t[0], 2.0f);
  EXPECT_EQ(w.t[1], 3.0f);
  EXPECT_EQ(w.p[0], glm::vec3(0.25f, 0.375f, 0.375f));
  EXPECT_EQ(w.p[1], glm::vec3(0.5f, 0.375f, 0.375f));
  EXPECT_EQ(w.axis[0], 0);
  EXPECT_EQ(w.axis[1], 0);
  // t is the ray's own parameter: a direction twice as long halves it.
  ASSERT_EQ(walk_ray(g, make_ray({-1, 1.5f, 1.5f}, {2, 0, 0}), 18, w), 2u);
  EXPECT_EQ(w.t[0], 1.0f);
  EXPECT_EQ(w.t[1], 1.5f);
  // The same voxel along -z.
  ASSERT_EQ(walk_ray(g, make_ray({1.5f, 1.5f, 9}, {0, 0, -1}), 18, w), 2u);
  EXPECT_EQ(w.t[0], 7.0f);
  EXPECT_EQ(w.t[1], 8.0f);
  EXPECT_EQ(w.axis[0], 2);
  EXPECT_EQ(w.p[0], glm::vec3(0.375f, 0.375f, 0.5f));
}

TEST_F(HandCase, TwoAdjacentVoxelsGiveThreePointsAndTruncation) {
  g.set(1, 1, 1);
  g.set(2, 1, 1);
  Ray ray = make_ray({-1, 1.5f, 1.5f}, {1, 0, 0});
  RayWalk w;
  ASSERT_EQ(walk_ray(g, ray, 18, w), 3u);
  EXPECT_EQ(w.t[0], 2.0f);
  EXPECT_EQ(w.t[1], 3.0f);
  EXPECT_EQ(w.t[2], 4.0f);
  EXPECT_FALSE(w.truncated);
  EXPECT_EQ(walk_ray(g, ray, 3, w), 3u);
  EXPECT_FALSE(w.truncated);
  EXPECT_EQ(walk_ray(g, ray, 2, w), 2u);
  EXPECT_TRUE(w.truncated);
  EXPECT_EQ(w.t[1], 3.0f);
  EXPECT_EQ(walk_ray(g, ray, 0, w), 0u);
  EXPECT_TRUE(w.truncated);
  EXPECT_EQ(walk_ray(g, ray, 1000, w), 3u);  // clamped to LSNIF_MAX_POINTS
}

TEST_F(HandCase, OriginExactlyOnAVoxelFace) {
  g.set(1, 1, 1);
  RayWalk w;
  // On the face x = 2 going -x: the start voxel is the lower one, (1,1,1), occupied; no point at
  // t = 0 (origin strictly inside the box), one where the ray leaves it at x = 1.
  ASSERT_EQ(walk_ray(g, make_ray({2, 1.5f, 1.5f}, {-1, 0, 0}), 18, w), 1u);
  EXPECT_EQ(w.t[0], 1.0f);
  EXPECT_EQ(w.p[0].x, 0.25f);
  BaselineHit b = voxel_baseline(g, make_ray({2, 1.5f, 1.5f}, {-1, 0, 0}), w);
  EXPECT_TRUE(b.hit);
  EXPECT_EQ(b.t, 0.0f);  // starts inside an occupied voxel
  EXPECT_EQ(b.normal, glm::vec3(1, 0, 0));
  // Going +x it starts in (2,1,1), empty, and never touches (1,1,1).
  EXPECT_EQ(walk_ray(g, make_ray({2, 1.5f, 1.5f}, {1, 0, 0}), 18, w), 0u);
  EXPECT_TRUE(w.hits_aabb);
  // With (2,1,1) occupied instead, +x gives only its far face.
  VoxelGrid h = empty_grid(4, glm::vec3(0.0f), glm::vec3(4.0f));
  h.set(2, 1, 1);
  ASSERT_EQ(walk_ray(h, make_ray({2, 1.5f, 1.5f}, {1, 0, 0}), 18, w), 1u);
  EXPECT_EQ(w.t[0], 1.0f);
  EXPECT_EQ(walk_ray(h, make_ray({2, 1.5f, 1.5f}, {-1, 0, 0}), 18, w), 0u);
}

TEST_F(HandCase, OriginOnTheAabbBoundary) {
  g.set(0, 1, 1);
  RayWalk w;
  // Entering: the entry at t = 0 is a crossing from outside.
  ASSERT_EQ(walk_ray(g, make_ray({0, 1.5f, 1.5f}, {1, 0, 0}), 18, w), 2u);
  EXPECT_EQ(w.t[0], 0.0f);
  EXPECT_EQ(w.p[0].x, 0.0f);
  EXPECT_EQ(w.t[1], 1.0f);
  BaselineHit b = voxel_baseline(g, make_ray({0, 1.5f, 1.5f}, {1, 0, 0}), w);
  EXPECT_EQ(b.t, 0.0f);
  EXPECT_EQ(b.normal, glm::vec3(-1, 0, 0));
  // Leaving: the interval is the single point t = 0 and nothing is recorded.
  EXPECT_EQ(walk_ray(g, make_ray({0, 1.5f, 1.5f}, {-1, 0, 0}), 18, w), 0u);
  EXPECT_TRUE(w.hits_aabb);
  EXPECT_EQ(w.t_enter, 0.0f);
  EXPECT_EQ(w.t_exit, 0.0f);
}

TEST_F(HandCase, MissesAndClipping) {
  g.set(1, 1, 1);
  RayWalk w;
  EXPECT_EQ(walk_ray(g, make_ray({-1, 5, 1.5f}, {1, 0, 0}), 18, w), 0u);
  EXPECT_FALSE(w.hits_aabb);
  EXPECT_EQ(walk_ray(g, make_ray({-1, 1.5f, 1.5f}, {-1, 0, 0}), 18, w), 0u);  // box behind
  EXPECT_FALSE(w.hits_aabb);
  EXPECT_EQ(walk_ray(g, make_ray({-1, 1.5f, 1.5f}, {1, 0, 0}, 0.0f, 0.5f), 18, w), 0u);  // tmax short
  EXPECT_FALSE(w.hits_aabb);
  EXPECT_EQ(walk_ray(g, make_ray({-1, 1.5f, 1.5f}, {0, 0, 0}), 18, w), 0u);  // no direction
  EXPECT_FALSE(w.hits_aabb);
  // tmax between the two faces: only the entry face; exactly on the exit face: both.
  ASSERT_EQ(walk_ray(g, make_ray({-1, 1.5f, 1.5f}, {1, 0, 0}, 0.0f, 2.5f), 18, w), 1u);
  EXPECT_EQ(w.t_exit, 2.5f);
  EXPECT_EQ(walk_ray(g, make_ray({-1, 1.5f, 1.5f}, {1, 0, 0}, 0.0f, 3.0f), 18, w), 2u);
  // tmin inside the occupied voxel: no point at t_enter, the exit face only.
  Ray inside = make_ray({-1, 1.5f, 1.5f}, {1, 0, 0}, 2.5f);
  ASSERT_EQ(walk_ray(g, inside, 18, w), 1u);
  EXPECT_EQ(w.t_enter, 2.5f);
  EXPECT_EQ(w.t[0], 3.0f);
  BaselineHit b = voxel_baseline(g, inside, w);
  EXPECT_TRUE(b.hit);
  EXPECT_EQ(b.t, 2.5f);
}

TEST_F(HandCase, CornersAndEdgesGiveOnePoint) {
  RayWalk w;
  Ray diagonal = make_ray({-1, -1, -1}, {1, 1, 1});  // through the lattice corners at t = 1..5
  g.set(1, 1, 1);
  ASSERT_EQ(walk_ray(g, diagonal, 18, w), 2u);
  EXPECT_EQ(w.t[0], 2.0f);
  EXPECT_EQ(w.t[1], 3.0f);
  EXPECT_EQ(w.p[0], glm::vec3(0.25f));
  EXPECT_EQ(w.axis[0], 0);
  // A voxel that the ray touches only at its corner (1,1,1) is not entered.
  VoxelGrid h = empty_grid(4, glm::vec3(0.0f), glm::vec3(4.0f));
  h.set(1, 1, 0);
  EXPECT_EQ(walk_ray(h, diagonal, 18, w), 0u);
  // Entering through the box corner into an occupied voxel.
  h.set(0, 0, 0);
  ASSERT_EQ(walk_ray(h, diagonal, 18, w), 2u);
  EXPECT_EQ(w.t[0], 1.0f);
  EXPECT_EQ(w.p[0], glm::vec3(0.0f));
  EXPECT_EQ(w.t[1], 2.0f);
  // Through the edge x = 2, y = 1 in the plane z = 1.5: (1,0,1) -> (2,1,1) directly.
  VoxelGrid e = empty_grid(4, glm::vec3(0.0f), glm::vec3(4.0f));
  e.set(2, 0, 1);  // shares only the edge with the path
  e.set(1, 1, 1);  // shares only the edge with the path
  EXPECT_EQ(walk_ray(e, make_ray({0, -1, 1.5f}, {1, 1, 0}), 18, w), 0u);
  e.set(2, 1, 1);
  ASSERT_EQ(walk_ray(e, make_ray({0, -1, 1.5f}, {1, 1, 0}), 18, w), 2u);
  EXPECT_EQ(w.t[0], 2.0f);
  EXPECT_EQ(w.p[0], glm::vec3(0.5f, 0.25f, 0.375f));
  EXPECT_EQ(w.axis[0], 0);
  EXPECT_EQ(w.t[1], 3.0f);  // the next lattice edge (3, 2): leaving (2,1,1)
}

TEST_F(HandCase, RayGrazingTheBoxEdge) {
  // Touches the box only at its edge x = 4, y = 0 (t = 1): one point if that voxel is occupied.
  Ray ray = make_ray({3, -1, 1.5f}, {1, 1, 0});
  RayWalk w;
  EXPECT_EQ(walk_ray(g, ray, 18, w), 0u);
  EXPECT_TRUE(w.hits_aabb);
  g.set(3, 0, 1);
  ASSERT_EQ(walk_ray(g, ray, 18, w), 1u);
  EXPECT_EQ(w.t[0], 1.0f);
  EXPECT_EQ(w.axis[0], 0);
  EXPECT_EQ(w.p[0], glm::vec3(1.0f, 0.0f, 0.375f));
}

TEST_F(HandCase, RayLyingInAVoxelPlaneUsesTheUpperVoxels) {
  // y = 2 exactly with no y motion: the walk uses floor(2) = row 2.
  RayWalk w;
  g.set(1, 1, 1);
  EXPECT_EQ(walk_ray(g, make_ray({-1, 2, 1.5f}, {1, 0, 0}), 18, w), 0u);
  g.set(1, 2, 1);
  EXPECT_EQ(walk_ray(g, make_ray({-1, 2, 1.5f}, {1, 0, 0}), 18, w), 2u);
}

TEST(Baseline, HandCases) {
  // Non-cubic box: V = 4 over [0,4] x [0,8] x [0,2]; voxel (1,1,1) = [1,2] x [2,4] x [0.5,1].
  VoxelGrid g = empty_grid(4, glm::vec3(0.0f), glm::vec3(4.0f, 8.0f, 2.0f));
  g.set(1, 1, 1);
  RayWalk w;
  Ray from_right = make_ray({6, 3, 0.75f}, {-2, 0, 0});
  walk_ray(g, from_right, 18, w);
  BaselineHit b = voxel_baseline(g, from_right, w);
  EXPECT_TRUE(b.hit);
  EXPECT_EQ(b.t, 2.0f);
  EXPECT_EQ(b.normal, glm::vec3(1, 0, 0));
  Ray from_below = make_ray({1.5f, -4, 0.75f}, {0, 1, 0});
  walk_ray(g, from_below, 18, w);
  b = voxel_baseline(g, from_below, w);
  EXPECT_EQ(b.t, 6.0f);
  EXPECT_EQ(b.normal, glm::vec3(0, -1, 0));
  Ray inside = make_ray({1.5f, 3, 0.75f}, {0, 0, -1});
  walk_ray(g, inside, 18, w);
  b = voxel_baseline(g, inside, w);
  EXPECT_TRUE(b.hit);
  EXPECT_EQ(b.t, 0.0f);
  EXPECT_EQ(b.normal, glm::vec3(0, 0, 1));  // axis of the first point (z), facing the ray
  Ray miss = make_ray({6, 7, 0.75f}, {-1, 0, 0});
  walk_ray(g, miss, 18, w);
  EXPECT_FALSE(voxel_baseline(g, miss, w).hit);
}

// ---------------------------------------------------------------------------------------------
// Random grids and rays against the reference.

struct RandomGrid {
  VoxelGrid grid;
  bool dyadic;  // bounds and V such that lattice points map exactly into the unit cube
  std::vector<glm::ivec3> occupied;
};

RandomGrid random_grid(std::mt19937& rng, uint32_t V, bool dyadic) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  RandomGrid r;
  r.dyadic = dyadic;
  glm::vec3 lo, extent;
  for (int a = 0; a < 3; ++a) {
    if (dyadic) {
      lo[a] = float(int(u(rng) * 33.0f) - 16) / 8.0f;
      extent[a] = std::ldexp(1.0f, int(u(rng) * 5.0f) - 2);  // 1/4 .. 4
    } else {
      lo[a] = 10.0f * u(rng) - 5.0f;
      extent[a] = 0.1f + 5.0f * u(rng);
    }
  }
  r.grid = empty_grid(V, lo, lo + extent);
  for (uint32_t k = 0; k < V; ++k)
    for (uint32_t j = 0; j < V; ++j)
      for (uint32_t i = 0; i < V; ++i)
        if (u(rng) < 0.2f) {
          r.grid.set(i, j, k);
          r.occupied.push_back(glm::ivec3(i, j, k));
        }
  return r;
}

glm::vec3 random_unit_vector(std::mt19937& rng) {
  std::normal_distribution<float> n(0.0f, 1.0f);
  glm::vec3 v(n(rng), n(rng), n(rng));
  float len = glm::length(v);
  return len > 1e-6f ? v / len : glm::vec3(0, 0, 1);
}

// One random ray of category `kind` (see the switch), in object space.
Ray random_ray(std::mt19937& rng, const RandomGrid& rg, int kind) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const VoxelGrid& g = rg.grid;
  const float Vf = float(g.resolution);
  auto from_unit = [&](glm::vec3 q) { return g.bounds.lo + q * g.bounds.extent(); };
  auto in_box = [&] { return from_unit(glm::vec3(u(rng), u(rng), u(rng))); };
  const float scale = std::exp2(4.0f * u(rng) - 2.0f);  // directions need not be normalized
  const glm::vec3 center = g.bounds.center();
  const float R = g.bounds.diagonal() * (0.75f + 2.0f * u(rng));
  Ray ray;
  switch (kind) {
    case 0: {  // from outside towards a point of the box
      ray.origin = center + R * random_unit_vector(rng);
      ray.direction = (in_box() - ray.origin) * scale;
      break;
    }
    case 1: {  // from outside in a random direction (mostly misses)
      ray.origin = center + R * random_unit_vector(rng);
      ray.direction = random_unit_vector(rng) * scale;
      break;
    }
    case 2: {  // from inside
      ray.origin = in_box();
      ray.direction = random_unit_vector(rng) * scale;
      break;
    }
    case 3: {  // from inside an occupied voxel
      glm::ivec3 c = rg.occupied.empty() ? glm::ivec3(0) : rg.occupied[rng() % rg.occupied.size()];
      ray.origin = from_unit((glm::vec3(c) + glm::vec3(u(rng), u(rng), u(rng))) / Vf);
      ray.direction = random_unit_vector(rng) * scale;
      break;
    }
    case 4: {  // axis-parallel in one or two axes, through a point of the box, from inside or out
      glm::vec3 target = in_box();
      ray.direction = random_unit_vector(rng) * scale;
      int zero_a = int(rng() % 3);
      ray.direction[zero_a] = 0.0f;
      if (u(rng) < 0.5f) ray.direction[(zero_a + 1) % 3] = 0.0f;
      ray.origin = target - ray.direction * (3.0f * u(rng) * g.bounds.diagonal() / glm::length(ray.direction));
      break;
    }
    case 5: {  // tmin > 0 and a finite tmax
      ray.origin = u(rng) < 0.5f ? center + R * random_unit_vector(rng) : in_box();
      glm::vec3 target = in_box();
      ray.direction = (target - ray.origin) * scale;
      ray.tmin = (1.2f * u(rng)) / scale;
      ray.tmax = ray.tmin + (0.8f * u(rng)) / scale;
      break;
    }
    case 6:
    case 7: {
      if (!rg.dyadic) return random_ray(rng, rg, kind - 6);
      // Lattice rays: origin on the quarter-voxel lattice (on faces, edges, corners, the box
      // boundary, inside or outside), direction with small integer unit-space components, so the
      // crossing times are exact and ties at edges and corners are exact.
      const int V = int(g.resolution);
      glm::vec3 q;
      for (int a = 0; a < 3; ++a) {
        int m = int(rng() % uint32_t(6 * V + 1)) - V;  // quarter steps over [-V/4, 5V/4] voxels
        if (kind == 7) m = (m / 4) * 4;                // whole voxels: on lattice planes
        q[a] = float(m) / (4.0f * Vf);
      }
      if (kind == 7 && u(rng) < 0.5f) q = glm::clamp(q, 0.0f, 1.0f);  // inside or on the boundary
      glm::vec3 du;
      do {
        du = glm::vec3(float(int(rng() % 5) - 2), float(int(rng() % 5) - 2), float(int(rng() % 5) - 2));
      } while (du == glm::vec3(0.0f));
      ray.origin = from_unit(q);
      ray.direction = du * g.bounds.extent() * 0.5f;
      if (u(rng) < 0.2f) ray.tmin = 0.25f * float(rng() % 5);
      if (u(rng) < 0.2f) ray.tmax = ray.tmin + 0.25f * float(rng() % 9);
      break;
    }
  }
  return ray;
}

TEST(RayWalk, MatchesBruteForceOnRandomGridsAndRays) {
  std::mt19937 rng(31337);
  const uint32_t any_V[] = {1, 2, 3, 4, 5, 7, 8, 13, 16, 32};
  const uint32_t dyadic_V[] = {1, 2, 4, 8, 16, 32};
  const uint32_t Hs[] = {0, 1, 2, 3, 4, 8, 18, 32};
  int rays = 0, failures = 0, points = 0, truncated = 0, hits = 0, ties = 0;
  for (int grid_id = 0; grid_id < 48 && failures < 10; ++grid_id) {
    bool dyadic = grid_id % 2 == 1;
    uint32_t V = dyadic ? dyadic_V[(grid_id / 2) % 6] : any_V[(grid_id / 2) % 10];
    RandomGrid rg = random_grid(rng, V, dyadic);
    for (int it = 0; it < 500 && failures < 10; ++it) {
      Ray ray = random_ray(rng, rg, it % 8);
      uint32_t H = Hs[rng() % 8];
      if (!matches_reference(rg.grid, ray, H)) ++failures;
      ++rays;
      RayWalk w;
      walk_ray(rg.grid, ray, H, w);
      points += int(w.count);
      truncated += w.truncated;
      hits += w.hits_aabb;
      for (uint32_t j = 0; j < w.count; ++j) {  // points lying on more than one plane
        glm::vec3 s = w.p[j] * float(V);
        ties += (s.x == std::floor(s.x)) + (s.y == std::floor(s.y)) + (s.z == std::floor(s.z)) > 1;
      }
    }
  }
  EXPECT_EQ(failures, 0);
  std::printf("[ info   ] %d rays: %d hit the box, %d points, %d truncated, %d points on edges/corners\n", rays,
              hits, points, truncated, ties);
  EXPECT_GT(hits, rays / 2);
  EXPECT_GT(truncated, rays / 20);
  EXPECT_GT(ties, 100);
}

// walk_rays against walk_ray, every field bit for bit, on the random grids and rays above (lattice
// rays with their ties, rays along axes, tmin/tmax, every H) in batches of every size from none to
// more than a register's 16 lanes many times over; the walks start out filled with garbage.
bool same_walk(const RayWalk& a, const RayWalk& b) {
  if (a.count != b.count || a.truncated != b.truncated || a.hits_aabb != b.hits_aabb) return false;
  if (std::memcmp(&a.t_enter, &b.t_enter, sizeof(float)) != 0 || std::memcmp(&a.t_exit, &b.t_exit, sizeof(float)) != 0)
    return false;
  return std::memcmp(a.t, b.t, a.count * sizeof(float)) == 0 && std::memcmp(a.p, b.p, a.count * sizeof(glm::vec3)) == 0 &&
         std::memcmp(a.axis, b.axis, a.count) == 0;
}

TEST(RayWalk, WalkRaysIsWalkRayBitForBit) {
  std::mt19937 rng(5151);
  const uint32_t any_V[] = {1, 2, 3, 5, 7, 13, 32, 64};
  const uint32_t dyadic_V[] = {1, 2, 4, 8, 16, 32};
  const uint32_t Hs[] = {0, 1, 2, 3, 5, 18, 32};
  const size_t batches[] = {0, 1, 5, 16, 17, 40, 333, 2000};
  size_t rays_walked = 0, points = 0, ties = 0;
  for (int grid_id = 0; grid_id < 28; ++grid_id) {
    const bool dyadic = grid_id % 2 == 1;
    const uint32_t V = dyadic ? dyadic_V[(grid_id / 2) % 6] : any_V[(grid_id / 2) % 8];
    const RandomGrid rg = random_grid(rng, V, dyadic);
    for (const size_t n : batches) {
      const uint32_t H = Hs[rng() % 7];
      std::vector<Ray> rays(n);
      for (size_t i = 0; i < n; ++i) rays[i] = random_ray(rng, rg, int(i % 8));
      std::vector<RayWalk> batch(n), single(n);
      for (RayWalk& w : batch) std::memset(static_cast<void*>(&w), 0xA5, sizeof(RayWalk));
      walk_rays(rg.grid, rays.data(), n, H, batch.data());
      for (size_t i = 0; i < n; ++i) {
        walk_ray(rg.grid, rays[i], H, single[i]);
        ASSERT_TRUE(same_walk(batch[i], single[i])) << "ray " << i << " of " << n << ": " << describe(rg.grid, rays[i], H)
                                                   << " walk_rays: " << batch[i].count << " points, walk_ray: " << single[i].count;
        points += single[i].count;
        for (uint32_t j = 0; j < single[i].count; ++j) {
          const glm::vec3 q = single[i].p[j] * float(V);
          ties += (q.x == std::floor(q.x)) + (q.y == std::floor(q.y)) + (q.z == std::floor(q.z)) > 1;
        }
      }
      rays_walked += n;
    }
  }
  // The largest grids: points on the far planes (n = V), whose index the lanes' log keeps in 9 bits.
  for (const uint32_t V : {256u, 509u}) {
    VoxelGrid big = empty_grid(V, glm::vec3(0.0f), glm::vec3(1.0f));
    std::vector<Ray> rays;
    for (uint32_t i = 0; i < 40; ++i) {
      const uint32_t a = V - 1 - i % 3, b = (i * 37u) % V, c = (i * 101u) % V;
      big.set(a, b, c);  // near the high x face; rays through it along x, then along y and z
      big.set(b, a, c);
      big.set(c, b, a);
      const glm::vec3 centres[3] = {glm::vec3(float(a), float(b), float(c)), glm::vec3(float(b), float(a), float(c)),
                                    glm::vec3(float(c), float(b), float(a))};
      for (int axis = 0; axis < 3; ++axis) {
        const glm::vec3 p = (centres[axis] + 0.5f) / float(V);
        glm::vec3 d(0.0f);
        d[axis] = 1.0f;
        rays.push_back(make_ray(p - 2.0f * d, d));
        rays.push_back(make_ray(p - 2.0f * d + glm::vec3(0.0f, 0.1f, 0.2f) / float(V), d + glm::vec3(0.01f, 0.02f, 0.03f)));
      }
    }
    std::vector<RayWalk> batch(rays.size()), single(rays.size());
    walk_rays(big, rays.data(), rays.size(), 18, batch.data());
    size_t far = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
      walk_ray(big, rays[i], 18, single[i]);
      ASSERT_TRUE(same_walk(batch[i], single[i])) << "V=" << V << " ray " << i;
      for (uint32_t j = 0; j < single[i].count; ++j) far += glm::any(glm::equal(single[i].p[j], glm::vec3(1.0f)));
    }
    EXPECT_GT(far, 40u) << "V=" << V;  // exits through the far planes were recorded
  }
  // A grid without voxels: every walk empty, as walk_ray's.
  VoxelGrid none;
  std::vector<Ray> rays(20, make_ray({-1, 0.5f, 0.5f}, {1, 0, 0}));
  std::vector<RayWalk> walks(20);
  for (RayWalk& w : walks) std::memset(static_cast<void*>(&w), 0xA5, sizeof(RayWalk));
  walk_rays(none, rays.data(), rays.size(), 18, walks.data());
  for (const RayWalk& w : walks) EXPECT_TRUE(w.count == 0 && !w.hits_aabb && !w.truncated);
  std::printf("[ info   ] %zu rays, %zu points, %zu on edges/corners\n", rays_walked, points, ties);
  EXPECT_GT(points, rays_walked / 2);
  EXPECT_GT(ties, 100u);
}

// Starts within a few ulps of a voxel plane (at the origin or at tmin) and far-away origins: the
// floor guess of the start voxel is then often on the wrong side of the plane and must be
// corrected to agree with the crossing times.
TEST(RayWalk, StartVoxelNearPlanesAndFarOrigins) {
  std::mt19937 rng(2718);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const uint32_t Vs[] = {3, 5, 7, 13, 24, 32, 64};
  int failures = 0;
  for (uint32_t V : Vs) {
    RandomGrid rg = random_grid(rng, V, false);
    const VoxelGrid& g = rg.grid;
    std::vector<Ray> rays;
    for (int it = 0; it < 1500 && failures < 10; ++it) {
      Ray ray;
      ray.direction = random_unit_vector(rng) * std::exp2(4.0f * u(rng) - 2.0f);
      if (it % 3 == 2) {  // far away, aimed at the box
        glm::vec3 target = g.bounds.lo + g.bounds.extent() * glm::vec3(u(rng), u(rng), u(rng));
        ray.origin = target - ray.direction * (g.bounds.diagonal() * std::exp2(4.0f + 6.0f * u(rng)) /
                                               glm::length(ray.direction));
      } else {
        glm::vec3 q(u(rng), u(rng), u(rng));
        int a = int(rng() % 3), n = 1 + int(rng() % (V - 1));
        q[a] = float(n) / float(V);
        for (int k = int(rng() % 7) - 3; k != 0; k += k > 0 ? -1 : 1)
          q[a] = std::nextafter(q[a], k > 0 ? 2.0f : -1.0f);
        glm::vec3 start = g.bounds.lo + q * g.bounds.extent();
        if (it % 3 == 0) {
          ray.origin = start;
        } else {  // reach the near-plane point at tmin instead
          ray.tmin = 0.5f + u(rng);
          ray.origin = start - ray.tmin * ray.direction;
        }
      }
      if (!matches_reference(g, ray, 32)) ++failures;
      rays.push_back(ray);
    }
    // walk_rays starts these walks as walk_ray does, bit for bit.
    std::vector<RayWalk> batch(rays.size()), single(rays.size());
    walk_rays(g, rays.data(), rays.size(), 32, batch.data());
    for (size_t i = 0; i < rays.size(); ++i) {
      walk_ray(g, rays[i], 32, single[i]);
      ASSERT_TRUE(same_walk(batch[i], single[i])) << describe(g, rays[i], 32);
    }
  }
  EXPECT_EQ(failures, 0);
}

// The baseline against its definition on random rays, and geometrically: before its t the ray
// passes through empty voxels only; its normal faces the ray.
TEST(Baseline, MatchesDefinitionOnRandomRays) {
  std::mt19937 rng(4242);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  int hits = 0, inside_hits = 0;
  for (int grid_id = 0; grid_id < 8; ++grid_id) {
    RandomGrid rg = random_grid(rng, 4u + uint32_t(grid_id) * 4u, false);
    const VoxelGrid& g = rg.grid;
    const float Vf = float(g.resolution);
    for (int it = 0; it < 500; ++it) {
      Ray ray = random_ray(rng, rg, it % 6);
      RayWalk w;
      walk_ray(g, ray, 18, w);
      BaselineHit b = voxel_baseline(g, ray, w);
      RefWalk r = reference_walk(g, ray);
      ASSERT_EQ(b.hit, !r.points.empty()) << describe(g, ray, 18);
      if (!b.hit) continue;
      ++hits;
      inside_hits += r.starts_occupied;
      EXPECT_EQ(b.t, r.starts_occupied ? r.t_enter : r.points[0].t) << describe(g, ray, 18);
      EXPECT_FLOAT_EQ(glm::length(b.normal), 1.0f);
      EXPECT_LT(glm::dot(b.normal, ray.direction), 0.0f) << describe(g, ray, 18);
      if (r.starts_occupied) continue;
      glm::vec3 o = g.to_unit(ray.origin), d = g.direction_to_unit(ray.direction);
      for (int s = 1; s < 16; ++s) {
        float t = w.t_enter + (b.t - w.t_enter) * float(s) / 16.0f;
        glm::vec3 q = (o + t * d) * Vf;
        glm::vec3 f = q - glm::floor(q);
        if (glm::any(glm::lessThan(glm::min(f, 1.0f - f), glm::vec3(1e-3f)))) continue;  // near a face
        EXPECT_FALSE(g.occupied(int(q.x), int(q.y), int(q.z))) << describe(g, ray, 18) << " at t=" << t;
      }
    }
  }
  EXPECT_GT(hits, 1000);
  EXPECT_GT(inside_hits, 50);
}

// ---------------------------------------------------------------------------------------------
// Throughput on the bunny (reported, not asserted).

using test::read_off;  // lsnif/testing/off_reader.h

TEST(RayWalk, BunnyThroughputAndConsistency) {
  Mesh mesh;
  ASSERT_TRUE(read_off(std::string(LSNIF_DATA_DIR) + "/meshes/bunny00.off", mesh));
  Aabb box;
  for (const auto& p : mesh.positions) box.grow(p);
  VoxelGrid g = voxelize(mesh, 32, pad_aabb(box));
  ASSERT_EQ(g.resolution, 32u);
  std::mt19937 rng(8);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<Ray> rays(400000);
  for (auto& r : rays) {
    r.origin = g.bounds.center() + g.bounds.diagonal() * random_unit_vector(rng);
    glm::vec3 target = g.bounds.lo + g.bounds.extent() * glm::vec3(u(rng), u(rng), u(rng));
    r.direction = glm::normalize(target - r.origin);
  }
  RayWalk w;
  uint64_t total_points = 0, with_points = 0;
  auto t0 = std::chrono::steady_clock::now();
  for (const auto& r : rays) {
    total_points += walk_ray(g, r, 18, w);
    with_points += w.count > 0;
  }
  double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("[ timing ] walk_ray bunny V=32 H=18: %.2f Mrays/s single thread (%.2f points/ray, %.0f%% with points)\n",
              double(rays.size()) / seconds * 1e-6, double(total_points) / double(rays.size()),
              100.0 * double(with_points) / double(rays.size()));
  EXPECT_GT(with_points, rays.size() / 10);
  std::vector<RayWalk> walks(rays.size());
  t0 = std::chrono::steady_clock::now();
  walk_rays(g, rays.data(), rays.size(), 18, walks.data());
  const double batch_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("[ timing ] walk_rays: %.2f Mrays/s single thread, %.2fx walk_ray's\n",
              double(rays.size()) / batch_seconds * 1e-6, seconds / batch_seconds);
  uint64_t batch_points = 0;
  for (const RayWalk& bw : walks) batch_points += bw.count;
  EXPECT_EQ(batch_points, total_points);
  // A sample of these rays against the reference too (real occupancy rather than random).
  for (size_t i = 0; i < 2000; ++i) ASSERT_TRUE(matches_reference(g, rays[i], 18));
}

}  // namespace
}  // namespace lsnif
