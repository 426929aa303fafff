// voxelizer_test.cpp -- the SAT triangle/box test and the voxelizer against an independent exact
// method: Sutherland-Hodgman clipping of the triangle by the six box planes (in double), which is
// non-empty exactly when the triangle meets the closed box. Near-touching configurations are either
// excluded (an epsilon band, decided by clipping against a slightly shrunk and a slightly grown box)
// or built on a dyadic lattice, where touching is exact in float and separation is far above eps.
#include "lsnif/testing/off_reader.h"
#include "lsnif/train/voxelizer.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <string>
#include <vector>

namespace lsnif {
namespace {

using dvec3 = glm::dvec3;

// True when the triangle (a, b, c) clipped to the closed box [lo, hi] is non-empty.
bool clipped_nonempty(const dvec3& a, const dvec3& b, const dvec3& c, const dvec3& lo, const dvec3& hi) {
  std::vector<dvec3> poly = {a, b, c}, out;
  for (int axis = 0; axis < 3; ++axis) {
    for (int side = 0; side < 2; ++side) {
      const double plane = side == 0 ? lo[axis] : hi[axis];
      auto inside = [&](const dvec3& p) { return side == 0 ? p[axis] - plane : plane - p[axis]; };
      out.clear();
      for (size_t i = 0; i < poly.size(); ++i) {
        const dvec3& cur = poly[i];
        const dvec3& prev = poly[(i + poly.size() - 1) % poly.size()];
        double dc = inside(cur), dp = inside(prev);
        if ((dc >= 0.0) != (dp >= 0.0)) {
          dvec3 x = prev + (cur - prev) * (dp / (dp - dc));
          x[axis] = plane;
          out.push_back(x);
        }
        if (dc >= 0.0) out.push_back(cur);
      }
      poly.swap(out);
      if (poly.empty()) return false;
    }
  }
  return true;
}

enum class Truth { Separate, Overlap, Ambiguous };

// Exact answer outside an eps band: overlap if the triangle meets the box shrunk by eps, separate if
// it misses the box grown by eps; otherwise the configuration is within eps of touching. A negative
// eps decides everything by the box grown by |eps| (never ambiguous).
Truth clip_truth(const dvec3& a, const dvec3& b, const dvec3& c, const dvec3& lo, const dvec3& hi,
                 double eps) {
  dvec3 mn = glm::min(a, glm::min(b, c)), mx = glm::max(a, glm::max(b, c));
  for (int k = 0; k < 3; ++k)
    if (mn[k] > hi[k] + std::abs(eps) || mx[k] < lo[k] - std::abs(eps)) return Truth::Separate;
  if (clipped_nonempty(a, b, c, lo + eps, hi - eps)) return Truth::Overlap;
  if (!clipped_nonempty(a, b, c, lo - eps, hi + eps)) return Truth::Separate;
  return Truth::Ambiguous;
}

TEST(ClippingReference, HandCases) {
  const dvec3 lo(0.0), hi(1.0);
  // Triangle crossing the box, far outside, touching a corner with a vertex, edge through an edge.
  EXPECT_TRUE(clipped_nonempty({-1, 0.5, 0.5}, {2, 0.5, 0.5}, {0.5, 2, 0.5}, lo, hi));
  EXPECT_FALSE(clipped_nonempty({2, 2, 2}, {3, 2, 2}, {2, 3, 2}, lo, hi));
  EXPECT_TRUE(clipped_nonempty({1, 1, 1}, {2, 1, 1}, {1, 2, 2}, lo, hi));
  EXPECT_TRUE(clipped_nonempty({2, 0, 0.5}, {0, 2, 0.5}, {2, 2, 0.5}, lo, hi));
  EXPECT_FALSE(clipped_nonempty({2.01, 0, 0.5}, {0, 2.01, 0.5}, {2, 2, 0.5}, lo, hi));
}

TEST(TriangleBoxOverlap, HandCases) {
  const glm::vec3 c(0.5f), h(0.5f);  // the box [0,1]^3
  // A big triangle whose plane x + y = 2 touches only the box edge x = y = 1.
  EXPECT_TRUE(triangle_box_overlap(c, h, {2, 0, -5}, {0, 2, -5}, {1, 1, 5}));
  EXPECT_FALSE(triangle_box_overlap(c, h, {2.01f, 0, -5}, {0, 2.01f, -5}, {1.005f, 1.005f, 5}));
  // A vertex exactly on the corner (1,1,1), the rest outside.
  EXPECT_TRUE(triangle_box_overlap(c, h, {1, 1, 1}, {3, 1, 1}, {1, 3, 2}));
  // Edges crossing the box although no vertex is inside and the vertices' boxes straddle it.
  EXPECT_TRUE(triangle_box_overlap(c, h, {-1, 0.5f, -1}, {2, 0.5f, -1}, {0.5f, 0.5f, 3}));
  // In the plane z = 0.5 near the box edge x = y = 1: the bounding boxes overlap and the plane cuts
  // the box, only the edge axis (1,1,0) (hypotenuse x cross z) separates at x + y = 2.1 > 2.
  EXPECT_FALSE(triangle_box_overlap(c, h, {1.5f, 0.6f, 0.5f}, {0.6f, 1.5f, 0.5f}, {1.5f, 1.5f, 0.5f}));
  EXPECT_TRUE(triangle_box_overlap(c, h, {1.5f, 0.5f, 0.5f}, {0.5f, 1.5f, 0.5f}, {1.5f, 1.5f, 0.5f}));
  EXPECT_TRUE(triangle_box_overlap(c, h, {1.4f, 0.5f, 0.5f}, {0.5f, 1.4f, 0.5f}, {1.5f, 1.5f, 0.5f}));
  // Degenerate triangles: a segment through the box, a segment beside it, a point on a face.
  EXPECT_TRUE(triangle_box_overlap(c, h, {-1, -1, -1}, {2, 2, 2}, {0.5f, 0.5f, 0.5f}));
  EXPECT_FALSE(triangle_box_overlap(c, h, {-1, 2, 0.5f}, {2, 5, 0.5f}, {0.5f, 3.5f, 0.5f}));
  EXPECT_TRUE(triangle_box_overlap(c, h, {1, 0.3f, 0.3f}, {1, 0.3f, 0.3f}, {1, 0.3f, 0.3f}));
  EXPECT_FALSE(triangle_box_overlap(c, h, {1.01f, 0.3f, 0.3f}, {1.01f, 0.3f, 0.3f}, {1.01f, 0.3f, 0.3f}));
}

TEST(TriangleBoxOverlap, MatchesClippingOnRandomTriangles) {
  std::mt19937 rng(12345);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  int overlap = 0, separate = 0, ambiguous = 0, mismatches = 0;
  const int n = 60000;
  for (int it = 0; it < n; ++it) {
    glm::vec3 center(4 * u(rng) - 2, 4 * u(rng) - 2, 4 * u(rng) - 2);
    glm::vec3 half(0.05f + u(rng), 0.05f + u(rng), 0.05f + u(rng));
    float size = it % 3 == 0 ? 0.2f : (it % 3 == 1 ? 1.0f : 4.0f);  // small, medium, large
    glm::vec3 base = center + half * glm::vec3(4 * u(rng) - 2, 4 * u(rng) - 2, 4 * u(rng) - 2);
    glm::vec3 v[3];
    for (auto& x : v) x = base + size * glm::vec3(2 * u(rng) - 1, 2 * u(rng) - 1, 2 * u(rng) - 1);
    Truth truth = clip_truth(v[0], v[1], v[2], dvec3(center - half), dvec3(center + half), 1e-4);
    if (truth == Truth::Ambiguous) {
      ++ambiguous;
      continue;
    }
    bool got = triangle_box_overlap(center, half, v[0], v[1], v[2]);
    (truth == Truth::Overlap ? overlap : separate)++;
    if (got != (truth == Truth::Overlap) && ++mismatches <= 5)
      ADD_FAILURE() << "triangle " << it << " expected " << (truth == Truth::Overlap) << " got " << got;
  }
  EXPECT_EQ(mismatches, 0);
  EXPECT_GT(overlap, n / 10);
  EXPECT_GT(separate, n / 10);
  EXPECT_LT(ambiguous, n / 200);
}

// Vertices on a 1/4 lattice around the box [0,1]^3 (and dyadic boxes): every float operation of the
// SAT test is exact, so touching configurations are decided exactly; a separated lattice triangle
// is at least ~1e-4 away, so clipping against the box grown by 1e-7 is the exact truth.
TEST(TriangleBoxOverlap, MatchesClippingOnLatticeTrianglesIncludingTouching) {
  std::mt19937 rng(777);
  std::uniform_int_distribution<int> coord(-6, 10);  // x/4 in [-1.5, 2.5]
  int overlap = 0, touching = 0, mismatches = 0;
  const int n = 60000;
  for (int it = 0; it < n; ++it) {
    glm::vec3 lo(0.0f), hi(1.0f);
    if (it % 2) {  // other dyadic boxes
      lo = glm::vec3(float(coord(rng) % 3) * 0.25f, float(coord(rng) % 3) * 0.25f, 0.0f);
      hi = lo + glm::vec3(0.5f, 1.0f, 1.25f);
    }
    glm::vec3 v[3];
    for (auto& x : v) x = 0.25f * glm::vec3(float(coord(rng)), float(coord(rng)), float(coord(rng)));
    if (it % 10 == 0) v[2] = v[1];                        // segments
    if (it % 10 == 1) v[2] = 2.0f * v[1] - v[0];          // collinear
    dvec3 dlo(lo), dhi(hi);
    bool truth = clipped_nonempty(v[0], v[1], v[2], dlo - 1e-7, dhi + 1e-7);
    bool strictly = clipped_nonempty(v[0], v[1], v[2], dlo + 1e-7, dhi - 1e-7);
    overlap += truth;
    touching += truth && !strictly;
    bool got = triangle_box_overlap(0.5f * (lo + hi), 0.5f * (hi - lo), v[0], v[1], v[2]);
    if (got != truth && ++mismatches <= 5)
      ADD_FAILURE() << "lattice triangle " << it << " expected " << truth << " got " << got;
  }
  EXPECT_EQ(mismatches, 0);
  EXPECT_GT(overlap, n / 10);
  EXPECT_GT(touching, n / 100) << "the lattice must produce touching-only cases";
}

VoxelGrid brute_force_voxels(const std::vector<glm::vec3>& positions,
                             const std::vector<glm::uvec3>& triangles, uint32_t V, const Aabb& bounds,
                             double eps, int* ambiguous, std::vector<uint8_t>* ambiguous_mask) {
  VoxelGrid g;
  g.resolution = V;
  g.bounds = bounds;
  g.bits.assign((V * V * V + 31) / 32, 0u);
  ambiguous_mask->assign(size_t(V) * V * V, 0);
  std::vector<dvec3> grid_pos;  // the mapping of the spec: unit cube (VoxelGrid::to_unit) times V
  for (const auto& p : positions) grid_pos.push_back(dvec3(g.to_unit(p) * float(V)));
  for (uint32_t k = 0; k < V; ++k)
    for (uint32_t j = 0; j < V; ++j)
      for (uint32_t i = 0; i < V; ++i) {
        dvec3 lo(i, j, k), hi = lo + 1.0;
        bool any = false, unsure = false;
        for (const auto& t : triangles) {
          Truth r = clip_truth(grid_pos[t.x], grid_pos[t.y], grid_pos[t.z], lo, hi, eps);
          any = any || r == Truth::Overlap;
          unsure = unsure || r == Truth::Ambiguous;
        }
        if (any) g.set(i, j, k);
        if (!any && unsure) {
          ++*ambiguous;
          (*ambiguous_mask)[i + V * (j + V * k)] = 1;
        }
      }
  return g;
}

TEST(Voxelize, MatchesBruteForceOnRandomMeshes) {
  std::mt19937 rng(2024);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const uint32_t resolutions[] = {1, 8, 11, 16};
  for (uint32_t V : resolutions) {
    for (int mesh_id = 0; mesh_id < 3; ++mesh_id) {
      Aabb bounds;
      bounds.lo = glm::vec3(-3 * u(rng), -3 * u(rng), -3 * u(rng));
      bounds.hi = bounds.lo + glm::vec3(0.5f + 3 * u(rng), 0.5f + 3 * u(rng), 0.5f + 3 * u(rng));
      Mesh mesh;
      for (int t = 0; t < 40; ++t) {
        float size = t % 4 == 0 ? 0.8f : (t % 4 == 1 ? 0.2f : 0.05f);
        // Centres slightly beyond the bounds too, so clipping at the grid border is exercised.
        glm::vec3 center = bounds.lo + bounds.extent() * glm::vec3(1.2f * u(rng) - 0.1f, 1.2f * u(rng) - 0.1f,
                                                                   1.2f * u(rng) - 0.1f);
        uint32_t base = uint32_t(mesh.positions.size());
        for (int v = 0; v < 3; ++v)
          mesh.positions.push_back(center + size * bounds.extent() *
                                                glm::vec3(2 * u(rng) - 1, 2 * u(rng) - 1, 2 * u(rng) - 1));
        mesh.triangles.push_back({base, base + 1, base + 2});
      }
      VoxelGrid got = voxelize(mesh, V, bounds);
      ASSERT_EQ(got.resolution, V);
      int ambiguous = 0;
      std::vector<uint8_t> unsure;
      VoxelGrid want = brute_force_voxels(mesh.positions, mesh.triangles, V, bounds, 1e-4, &ambiguous, &unsure);
      EXPECT_LT(ambiguous, int(V * V * V) / 100 + 1);
      int mismatches = 0;
      uint32_t want_count = 0;
      for (int k = 0; k < int(V); ++k)
        for (int j = 0; j < int(V); ++j)
          for (int i = 0; i < int(V); ++i) {
            want_count += want.occupied(i, j, k);
            if (unsure[size_t(i) + V * (j + V * size_t(k))]) continue;
            if (got.occupied(i, j, k) != want.occupied(i, j, k) && ++mismatches <= 5)
              ADD_FAILURE() << "V=" << V << " mesh " << mesh_id << " voxel (" << i << "," << j << "," << k
                            << ") expected " << want.occupied(i, j, k);
          }
      EXPECT_EQ(mismatches, 0);
      EXPECT_GT(want_count, 0u);
      if (ambiguous == 0) {
        EXPECT_EQ(got.count_occupied(), want_count);
      }
    }
  }
}

// Dyadic bounds and vertices on a quarter-voxel lattice: voxel faces, edges and corners are hit
// exactly, so every touching voxel must be marked (closed boxes) and nothing else.
TEST(Voxelize, MatchesBruteForceOnLatticeMeshWithTouching) {
  const uint32_t V = 8;
  Aabb bounds;
  bounds.lo = glm::vec3(-1.0f, 0.5f, -2.0f);
  bounds.hi = bounds.lo + glm::vec3(2.0f, 4.0f, 1.0f);
  std::mt19937 rng(99);
  std::uniform_int_distribution<int> q(-2, 4 * int(V) + 2);  // grid coordinate q/4, partly outside
  Mesh mesh;
  for (int t = 0; t < 60; ++t) {
    int c[3] = {q(rng), q(rng), q(rng)};
    uint32_t base = uint32_t(mesh.positions.size());
    for (int v = 0; v < 3; ++v) {
      glm::vec3 g;
      for (int a = 0; a < 3; ++a) {
        int offset = std::uniform_int_distribution<int>(-6, 6)(rng);
        if (t % 3 == 0) offset = (offset / 4) * 4;  // whole-voxel steps: vertices on lattice planes
        g[a] = 0.25f * float(t % 3 == 0 ? (c[a] / 4) * 4 + offset : c[a] + offset);
      }
      mesh.positions.push_back(bounds.lo + bounds.extent() * (g / float(V)));
    }
    mesh.triangles.push_back({base, base + 1, base + 2});
  }
  VoxelGrid got = voxelize(mesh, V, bounds);
  int ambiguous = 0;
  std::vector<uint8_t> unsure;
  VoxelGrid want_strict = brute_force_voxels(mesh.positions, mesh.triangles, V, bounds, -1e-7, &ambiguous,
                                             &unsure);  // a negative eps = closed box grown by 1e-7
  EXPECT_EQ(ambiguous, 0);
  VoxelGrid interior = brute_force_voxels(mesh.positions, mesh.triangles, V, bounds, 1e-7, &ambiguous, &unsure);
  EXPECT_EQ(got.bits, want_strict.bits);
  EXPECT_GT(want_strict.count_occupied(), interior.count_occupied())
      << "the lattice mesh must have voxels that are only touched";
}

TEST(Voxelize, LargeResolutionQuadHasAnalyticCount) {
  // The square z = 0.5, x, y in [0.25, 0.75] in the unit box at V = 256 lies on plane 128: it
  // touches layers 127 and 128, and voxels 63..192 along x and y (closed boxes): 2 * 130^2 voxels.
  Mesh mesh;
  mesh.positions = {{0.25f, 0.25f, 0.5f}, {0.75f, 0.25f, 0.5f}, {0.75f, 0.75f, 0.5f}, {0.25f, 0.75f, 0.5f}};
  mesh.triangles = {{0, 1, 2}, {0, 2, 3}};
  Aabb bounds;
  bounds.lo = glm::vec3(0.0f);
  bounds.hi = glm::vec3(1.0f);
  VoxelGrid g = voxelize(mesh, 256, bounds);
  ASSERT_EQ(g.resolution, 256u);
  EXPECT_EQ(g.count_occupied(), 2u * 130u * 130u);
  EXPECT_TRUE(g.occupied(63, 63, 127));
  EXPECT_TRUE(g.occupied(192, 192, 128));
  EXPECT_FALSE(g.occupied(62, 100, 127));
  EXPECT_FALSE(g.occupied(193, 100, 128));
  EXPECT_FALSE(g.occupied(100, 100, 126));
  EXPECT_FALSE(g.occupied(100, 100, 129));
}

TEST(Voxelize, InvalidInputs) {
  Mesh mesh;
  mesh.positions = {{0.1f, 0.1f, 0.1f}, {0.9f, 0.1f, 0.1f}, {0.1f, 0.9f, 0.1f}, {5, 5, 5}, {6, 5, 5}, {5, 6, 5}};
  mesh.triangles = {{0, 1, 2}, {0, 1, 99}, {3, 4, 5}};  // valid, bad index (skipped), outside bounds
  Aabb bounds;
  bounds.lo = glm::vec3(0.0f);
  bounds.hi = glm::vec3(1.0f);
  EXPECT_EQ(voxelize(mesh, 0, bounds).resolution, 0u);
  EXPECT_EQ(voxelize(mesh, 257, bounds).resolution, 0u);
  EXPECT_TRUE(voxelize(mesh, 257, bounds).bits.empty());
  Aabb flat = bounds;
  flat.hi.z = 0.0f;
  EXPECT_EQ(voxelize(mesh, 8, flat).resolution, 0u);
  EXPECT_EQ(voxelize(mesh, 8, Aabb()).resolution, 0u);
  VoxelGrid g = voxelize(mesh, 10, bounds);
  ASSERT_EQ(g.resolution, 10u);
  // Only the first triangle counts. It lies on grid plane z = 1 (touching layers 0 and 1) and
  // covers x + y <= 10 from (1, 1): its corner vertex (1,1,1) also touches voxel (0,0,0).
  uint32_t count = 0;
  for (int k = 0; k < 10; ++k)
    for (int j = 0; j < 10; ++j)
      for (int i = 0; i < 10; ++i) count += g.occupied(i, j, k);
  EXPECT_EQ(count, g.count_occupied());
  EXPECT_TRUE(g.occupied(0, 0, 0));
  EXPECT_TRUE(g.occupied(5, 3, 0));
  EXPECT_TRUE(g.occupied(5, 3, 1));
  EXPECT_FALSE(g.occupied(5, 3, 2));
  EXPECT_FALSE(g.occupied(9, 9, 1));
  EXPECT_FALSE(g.occupied(9, 9, 5));
  mesh.triangles = {{3, 4, 5}};
  EXPECT_EQ(voxelize(mesh, 10, bounds).count_occupied(), 0u);
}

using test::read_off;  // lsnif/testing/off_reader.h

TEST(Voxelize, BunnyAt32) {
  Mesh mesh;
  ASSERT_TRUE(read_off(std::string(LSNIF_DATA_DIR) + "/meshes/bunny00.off", mesh));
  ASSERT_GT(mesh.triangles.size(), 70000u);
  Aabb box;
  for (const auto& p : mesh.positions) box.grow(p);
  Aabb bounds = pad_aabb(box);

  VoxelGrid g;
  double best_ms = 1e30;
  for (int rep = 0; rep < 5; ++rep) {
    auto t0 = std::chrono::steady_clock::now();
    g = voxelize(mesh, 32, bounds);
    best_ms = std::min(best_ms, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  std::printf("[ timing ] voxelize bunny00 (%zu triangles) at V=32: %.2f ms (best of 5, %d threads), %u voxels\n",
              mesh.triangles.size(), best_ms, omp_get_max_threads(), g.count_occupied());
  ASSERT_EQ(g.resolution, 32u);
  EXPECT_GT(g.count_occupied(), 0u);
  EXPECT_LT(g.count_occupied(), 32u * 32u * 32u / 2u);
  // Every vertex lies in (the closed box of) the voxel floor(unit * V).
  for (const auto& t : mesh.triangles)
    for (int v = 0; v < 3; ++v) {
      glm::vec3 q = glm::floor(g.to_unit(mesh.positions[t[v]]) * 32.0f);
      ASSERT_TRUE(g.occupied(int(q.x), int(q.y), int(q.z))) << "vertex " << t[v];
    }
  // Deterministic whatever the thread count.
  int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  VoxelGrid serial = voxelize(mesh, 32, bounds);
  omp_set_num_threads(threads);
  EXPECT_EQ(serial.bits, g.bits);

  // Sampled voxels (occupied and empty) against the brute force over all triangles.
  std::vector<dvec3> gp;
  for (const auto& p : mesh.positions) gp.push_back(dvec3(g.to_unit(p) * 32.0f));
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> cell(0, 31);
  int checked_occupied = 0, checked_empty = 0;
  while (checked_occupied < 60 || checked_empty < 60) {
    int i = cell(rng), j = cell(rng), k = cell(rng);
    bool occ = g.occupied(i, j, k);
    if ((occ && checked_occupied >= 60) || (!occ && checked_empty >= 60)) continue;
    bool near_surface = g.occupied(i - 1, j, k) || g.occupied(i + 1, j, k) || g.occupied(i, j - 1, k) ||
                        g.occupied(i, j + 1, k) || g.occupied(i, j, k - 1) || g.occupied(i, j, k + 1);
    if (!occ && !near_surface) continue;  // empty voxels next to the surface are the informative ones
    dvec3 lo(i, j, k), hi = lo + 1.0;
    bool any = false, unsure = false;
    for (const auto& t : mesh.triangles) {
      Truth r = clip_truth(gp[t.x], gp[t.y], gp[t.z], lo, hi, 1e-5);
      any = any || r == Truth::Overlap;
      unsure = unsure || r == Truth::Ambiguous;
    }
    if (!any && unsure) continue;
    EXPECT_EQ(occ, any) << "bunny voxel (" << i << "," << j << "," << k << ")";
    (occ ? checked_occupied : checked_empty)++;
  }
}

}  // namespace
}  // namespace lsnif

namespace lsnif {
namespace {

// Cut-out triangles with opaque_cells_only: every voxel that holds a point of a triangle where
// Mesh::opaque_at holds (dense random samples, the truth the trainer's ground truth uses) is
// marked; the marked voxels are a subset of the plain voxelization's and strictly fewer for a
// texture with large holes; a cut-out whose factor alpha is below its cutoff (no texture) marks
// nothing; opaque materials, and opaque_cells_only false, give the plain voxelization.
TEST(Voxelize, CutoutsMarkOnlyTheVoxelsOfTheirOpaqueParts) {
  std::mt19937 rng(77);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  Mesh mesh;
  // An 8 x 8 alpha texture of random 2 x 2 blocks, half of them holes.
  Texture t;
  t.width = t.height = 8;
  t.rgba.assign(8 * 8 * 4, 255);
  for (uint32_t by = 0; by < 4; ++by)
    for (uint32_t bx = 0; bx < 4; ++bx) {
      const uint8_t a = u(rng) < 0.5f ? 0 : 255;
      for (uint32_t y = 2 * by; y < 2 * by + 2; ++y)
        for (uint32_t x = 2 * bx; x < 2 * bx + 2; ++x) t.rgba[(y * 8 + x) * 4 + 3] = a;
    }
  mesh.textures = {t};
  Material mask, blend, faint, opaque;
  mask.base_color_texture = blend.base_color_texture = 0;
  mask.alpha_mode = AlphaMode::Mask;
  mask.alpha_cutoff = 0.3f;
  mask.uv_transform[kSlotBaseColor] = UvTransform(1.5f, 0.2f, -0.1f, 1.25f, 0.3f, -0.6f);
  blend.alpha_mode = AlphaMode::Blend;
  faint.alpha_mode = AlphaMode::Mask;
  faint.alpha = 0.2f;  // below the cutoff everywhere: all hole
  mesh.materials = {mask, blend, faint, opaque};
  for (int tri = 0; tri < 60; ++tri) {
    const glm::vec3 c(0.1f + 0.8f * u(rng), 0.1f + 0.8f * u(rng), 0.1f + 0.8f * u(rng));
    const uint32_t base = uint32_t(mesh.positions.size());
    const glm::vec2 uv0(3.0f * u(rng) - 1.0f, 3.0f * u(rng) - 1.0f);  // beyond [0, 1]: wrapping
    for (int v = 0; v < 3; ++v) {
      mesh.positions.push_back(c + 0.3f * glm::vec3(2 * u(rng) - 1, 2 * u(rng) - 1, 2 * u(rng) - 1));
      mesh.uvs.push_back(uv0 + 0.4f * glm::vec2(u(rng), u(rng)));
    }
    mesh.triangles.push_back({base, base + 1, base + 2});
    mesh.triangle_material.push_back(tri < 25 ? 0 : tri < 50 ? 1 : 2);
  }
  Aabb bounds;
  bounds.lo = glm::vec3(-0.25f);
  bounds.hi = glm::vec3(1.25f);
  const uint32_t V = 16;
  const VoxelGrid all = voxelize(mesh, V, bounds);
  const VoxelGrid cut = voxelize(mesh, V, bounds, /*opaque_cells_only=*/true);
  ASSERT_EQ(cut.resolution, V);
  uint32_t samples_opaque = 0;
  for (uint32_t tri = 0; tri < mesh.triangles.size(); ++tri)
    for (int s = 0; s < 4000; ++s) {
      float a = u(rng), b = u(rng);
      if (a + b > 1.0f) a = 1.0f - a, b = 1.0f - b;
      if (!mesh.opaque_at(tri, a, b)) continue;
      const glm::uvec3 idx = mesh.triangles[tri];
      const glm::vec3 p = (1.0f - a - b) * mesh.positions[idx.x] + a * mesh.positions[idx.y] + b * mesh.positions[idx.z];
      const glm::vec3 q = glm::floor(cut.to_unit(p) * float(V));
      ++samples_opaque;
      ASSERT_TRUE(cut.occupied(int(q.x), int(q.y), int(q.z))) << "triangle " << tri << " at (" << a << ", " << b << ")";
    }
  EXPECT_GT(samples_opaque, 20000u);
  for (size_t w = 0; w < cut.bits.size(); ++w) EXPECT_EQ(cut.bits[w] & ~all.bits[w], 0u) << "word " << w;
  EXPECT_LT(cut.count_occupied(), all.count_occupied() * 19 / 20) << "half the texture is holes";
  std::printf("[ cut-out ] %u voxels of the opaque parts, %u of the whole triangles\n", cut.count_occupied(),
              all.count_occupied());

  Mesh faint_only = mesh;
  faint_only.triangle_material.assign(mesh.triangles.size(), 2);
  EXPECT_EQ(voxelize(faint_only, V, bounds, true).count_occupied(), 0u);
  Mesh opaque_only = mesh;
  opaque_only.triangle_material.assign(mesh.triangles.size(), 3);
  EXPECT_EQ(voxelize(opaque_only, V, bounds, true).bits, voxelize(opaque_only, V, bounds).bits);
  EXPECT_EQ(voxelize(mesh, V, bounds, false).bits, all.bits);
}

}  // namespace
}  // namespace lsnif
