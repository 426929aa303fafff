// ray_sampler_test.cpp -- the training/evaluation ray sampler (paper 5.2) on the Stanford bunny:
// determinism across thread counts, exact counts, sample validity, the geometry of both ray kinds
// (outer origins on the sphere, surface origins at the offset from the mesh), the cosine-weighted
// warp and the surface/outer split.
#include "lsnif/train/ray_sampler.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <utility>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "lsnif/core/rng.h"
#include "lsnif/train/voxelizer.h"

namespace lsnif {
namespace {

constexpr uint32_t kResolution = 32;  // V
constexpr uint32_t kMaxPoints = 18;   // H

struct Scene {
  Mesh mesh;
  GroundTruth truth;
  VoxelGrid grid;
};

// The bunny with its ground truth and its V=32 voxel grid, loaded once for all tests.
class RaySamplerTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    scene_ = new Scene;
    const Status load = load_mesh(std::string(LSNIF_DATA_DIR) + "/meshes/bunny00.off", scene_->mesh);
    ASSERT_TRUE(load.is_ok()) << load.message();
    const Status build = scene_->truth.build(scene_->mesh);
    ASSERT_TRUE(build.is_ok()) << build.message();
    scene_->grid = voxelize(scene_->mesh, kResolution, pad_aabb(scene_->mesh.bounds()));
    ASSERT_GT(scene_->grid.count_occupied(), 0u);
    ready_ = true;
  }
  static void TearDownTestSuite() {
    delete scene_;
    scene_ = nullptr;
  }
  void SetUp() override { ASSERT_TRUE(ready_) << "loading, tracing or voxelizing bunny00.off failed"; }
  void TearDown() override { omp_set_num_threads(2); }
  // A sampler of the bunny with `settings`.
  static RaySampler sampler_of(const SamplerSettings& settings) {
    return RaySampler(scene_->mesh, scene_->truth, scene_->grid, kMaxPoints, settings);
  }
  static Scene* scene_;
  static bool ready_;
};
Scene* RaySamplerTest::scene_ = nullptr;
bool RaySamplerTest::ready_ = false;

void expect_same_walk(const RayWalk& a, const RayWalk& b, size_t i) {
  ASSERT_EQ(a.count, b.count) << "sample " << i;
  EXPECT_EQ(a.truncated, b.truncated) << "sample " << i;
  EXPECT_EQ(a.t_enter, b.t_enter) << "sample " << i;
  EXPECT_EQ(a.t_exit, b.t_exit) << "sample " << i;
  for (uint32_t k = 0; k < a.count; ++k) {
    EXPECT_EQ(a.t[k], b.t[k]) << "sample " << i << " point " << k;
    EXPECT_EQ(a.p[k], b.p[k]) << "sample " << i << " point " << k;
    EXPECT_EQ(a.axis[k], b.axis[k]) << "sample " << i << " point " << k;
  }
}

void expect_same_hit(const ReferenceHit& a, const ReferenceHit& b, size_t i) {
  ASSERT_EQ(a.hit, b.hit) << "sample " << i;
  EXPECT_EQ(a.t, b.t) << "sample " << i;
  EXPECT_EQ(a.triangle, b.triangle) << "sample " << i;
  EXPECT_EQ(a.material, b.material) << "sample " << i;
  EXPECT_EQ(a.normal, b.normal) << "sample " << i;
  EXPECT_EQ(a.geometric_normal, b.geometric_normal) << "sample " << i;
  EXPECT_EQ(a.albedo, b.albedo) << "sample " << i;
}

// Exact equality of two generated sets (the first `n` of each).
void expect_identical(const std::vector<Sample>& a, const std::vector<RayWalk>& wa,
                      const std::vector<Sample>& b, const std::vector<RayWalk>& wb, size_t n) {
  ASSERT_GE(a.size(), n);
  ASSERT_GE(b.size(), n);
  for (size_t i = 0; i < n; ++i) {
    ASSERT_EQ(a[i].ray.origin, b[i].ray.origin) << "sample " << i;
    ASSERT_EQ(a[i].ray.direction, b[i].ray.direction) << "sample " << i;
    ASSERT_EQ(a[i].from_surface, b[i].from_surface) << "sample " << i;
    expect_same_hit(a[i].reference, b[i].reference, i);
    expect_same_walk(wa[i], wb[i], i);
  }
}

TEST_F(RaySamplerTest, DeterministicWhateverTheThreadCount) {
  const RaySampler sampler(scene_->mesh, scene_->truth, scene_->grid, kMaxPoints);
  std::vector<Sample> s1, s2, prefix;
  std::vector<RayWalk> w1, w2, wprefix;
  omp_set_num_threads(1);
  sampler.generate(42, 3, 3000, s1, w1);
  omp_set_num_threads(2);
  sampler.generate(42, 3, 3000, s2, w2);
  ASSERT_EQ(s1.size(), 3000u);
  ASSERT_EQ(s2.size(), 3000u);
  expect_identical(s1, w1, s2, w2, 3000);
  // Samples are kept in candidate order: a smaller request is a prefix of a larger one.
  sampler.generate(42, 3, 100, prefix, wprefix);
  ASSERT_EQ(prefix.size(), 100u);
  expect_identical(prefix, wprefix, s1, w1, 100);
}

TEST_F(RaySamplerTest, SeedsAndStreamsDiffer) {
  const RaySampler sampler(scene_->mesh, scene_->truth, scene_->grid, kMaxPoints);
  std::vector<Sample> a, b, c;
  std::vector<RayWalk> wa, wb, wc;
  sampler.generate(1, 0, 500, a, wa);
  sampler.generate(2, 0, 500, b, wb);
  sampler.generate(1, 1, 500, c, wc);
  int same_seed = 0, same_stream = 0;
  for (size_t i = 0; i < 500; ++i) {
    same_seed += a[i].ray.origin == b[i].ray.origin || a[i].ray.direction == b[i].ray.direction;
    same_stream += a[i].ray.origin == c[i].ray.origin || a[i].ray.direction == c[i].ray.direction;
  }
  EXPECT_EQ(same_seed, 0);
  EXPECT_EQ(same_stream, 0);
}

TEST_F(RaySamplerTest, ExactCountOfValidSamples) {
  const RaySampler sampler(scene_->mesh, scene_->truth, scene_->grid, kMaxPoints);
  const glm::vec3 centre = scene_->grid.bounds.center();
  const float radius = 0.5f * scene_->grid.bounds.diagonal();
  std::vector<Sample> samples;
  std::vector<RayWalk> walks;
  for (size_t count : {size_t(0), size_t(1), size_t(20000)}) {
    sampler.generate(7, 0, count, samples, walks);
    ASSERT_EQ(samples.size(), count);
    ASSERT_EQ(walks.size(), count);
  }
  size_t surface = 0, hits = 0;
  for (size_t i = 0; i < samples.size(); ++i) {
    const Sample& s = samples[i];
    ASSERT_GT(walks[i].count, 0u) << "sample " << i;
    EXPECT_LE(walks[i].count, kMaxPoints);
    EXPECT_NEAR(glm::length(s.ray.direction), 1.0f, 1e-5f) << "sample " << i;
    EXPECT_EQ(s.ray.tmin, 0.0f);
    EXPECT_EQ(s.ray.tmax, std::numeric_limits<float>::infinity());
    // The stored walk and reference are what walk_ray and a fresh trace give.
    RayWalk again;
    walk_ray(scene_->grid, s.ray, kMaxPoints, again);
    expect_same_walk(walks[i], again, i);
    expect_same_hit(s.reference, scene_->truth.trace(s.ray), i);
    if (s.from_surface) {
      ++surface;
    } else {
      // Outer rays start on the sphere and head into the hemisphere facing its centre.
      EXPECT_NEAR(glm::distance(s.ray.origin, centre), radius, 1e-5f * radius) << "sample " << i;
      EXPECT_GT(glm::dot(s.ray.direction, centre - s.ray.origin), 0.0f) << "sample " << i;
    }
    hits += s.reference.hit;
  }
  EXPECT_GT(surface, 10000u);
  EXPECT_GT(samples.size() - surface, 3000u);
  EXPECT_GT(hits, 3000u);
}

// The paper's rays of the first kind drawn independently of the sampler: a uniform point on the
// sphere, a cosine-weighted direction toward its centre.
Ray sphere_line(Rng& rng, const glm::vec3& centre, float radius) {
  const float u1 = rng.next_float(), u2 = rng.next_float(), u3 = rng.next_float(), u4 = rng.next_float();
  const glm::vec3 outward = sample_uniform_sphere(u1, u2);
  Ray ray;
  ray.origin = centre + radius * outward;
  ray.direction = sample_cosine_hemisphere(-outward, u3, u4);
  return ray;
}

// The sampler's body holds the mesh and every occupied voxel, lies in the grid's bounds and is
// tighter than their bounding box; the share of the sphere's lines that cross it is its area (the
// sum of its boundary triangles') over the sphere's (Cauchy-Crofton): counted by brute force over
// 400,000 of the paper's rays with the body's own slab test.
TEST_F(RaySamplerTest, LineBodyShareIsTheCountedShareOfSphereLines) {
  const RaySampler sampler(scene_->mesh, scene_->truth, scene_->grid, kMaxPoints);
  const LineBody& body = sampler.line_body();
  ASSERT_TRUE(body.valid());
  const float tolerance = 1e-6f * scene_->grid.bounds.diagonal();
  for (const glm::vec3& p : scene_->mesh.positions) ASSERT_TRUE(body.contains(p, tolerance)) << p.x << " " << p.y << " " << p.z;
  const uint32_t V = scene_->grid.resolution;
  const glm::vec3 cell = scene_->grid.bounds.extent() / float(V);
  Aabb voxels;
  for (uint32_t k = 0; k < V; ++k)
    for (uint32_t j = 0; j < V; ++j)
      for (uint32_t i = 0; i < V; ++i)
        if (scene_->grid.occupied(int(i), int(j), int(k)))
          for (uint32_t c = 0; c < 8; ++c) {
            const glm::vec3 corner =
                scene_->grid.bounds.lo + glm::vec3(i + (c & 1), j + ((c >> 1) & 1), k + (c >> 2)) * cell;
            ASSERT_TRUE(body.contains(corner, tolerance)) << i << " " << j << " " << k;
            voxels.grow(corner);
          }
  for (int a = 0; a < 3; ++a) {
    EXPECT_GE(body.bounds.lo[a], scene_->grid.bounds.lo[a]);
    EXPECT_LE(body.bounds.hi[a], scene_->grid.bounds.hi[a]);
  }
  for (const glm::vec3& p : body.corners) EXPECT_TRUE(body.contains(p, tolerance)) << p.x << " " << p.y << " " << p.z;
  // Tighter than the box around the occupied voxels (whose area the body's would equal were the
  // diagonal planes no cut).
  const glm::dvec3 e(voxels.extent());
  const double box_area = 2.0 * (e.x * e.y + e.y * e.z + e.z * e.x);
  EXPECT_LT(body.area, 0.95 * box_area);
  const glm::vec3 centre = scene_->grid.bounds.center();
  const float radius = 0.5f * scene_->grid.bounds.diagonal();
  const int n = 400000;
  int crossing = 0;
  for (int i = 0; i < n; ++i) {
    Rng rng(5, 9, uint64_t(i));
    Ray ray = sphere_line(rng, centre, radius);
    ray.tmin = 0.0f;
    ray.tmax = std::numeric_limits<float>::infinity();
    crossing += body.crossed_by(ray);
  }
  const double p = sampler.line_body_share();
  EXPECT_GT(p, 0.1);
  EXPECT_LT(p, 1.0);
  EXPECT_NEAR(double(crossing) / n, p, 4.5 * std::sqrt(p * (1 - p) / n));
  std::printf("[ info     ] body area %.4f = %.3f of the voxels' box; share of sphere lines %.4f, counted %.4f\n",
              body.area, body.area / box_area, p, double(crossing) / n);
}

// Two-sample chi-square statistic of histograms a and b (bins with no count in either skipped);
// `dof` receives the degrees of freedom.
double two_sample_chi2(const std::vector<double>& a, const std::vector<double>& b, int& dof) {
  double na = 0, nb = 0;
  for (size_t i = 0; i < a.size(); ++i) { na += a[i]; nb += b[i]; }
  const double ka = std::sqrt(nb / na), kb = std::sqrt(na / nb);
  double chi2 = 0;
  dof = -1;
  for (size_t i = 0; i < a.size(); ++i) {
    if (a[i] + b[i] == 0) continue;
    chi2 += (ka * a[i] - kb * b[i]) * (ka * a[i] - kb * b[i]) / (a[i] + b[i]);
    ++dof;
  }
  return chi2;
}

// Histogram of one kind of ray: direction octant (8) x hit (2) x where it starts: the octant about
// `centre` (8), or for outer rays with an `entry_box`, the face of the box they enter (6).
std::vector<double> ray_histogram(const std::vector<Sample>& samples, bool surface, const glm::vec3& centre,
                                  const Aabb* entry_box = nullptr) {
  std::vector<double> h(128, 0.0);
  for (const Sample& x : samples) {
    if (x.from_surface != surface) continue;
    const glm::vec3 o = x.ray.origin - centre, d = x.ray.direction;
    int where = (o.x > 0) + 2 * (o.y > 0) + 4 * (o.z > 0);
    if (!surface && entry_box) {
      float t_enter = -std::numeric_limits<float>::infinity();
      for (int ax = 0; ax < 3; ++ax) {
        const float t = ((d[ax] > 0 ? entry_box->lo[ax] : entry_box->hi[ax]) - x.ray.origin[ax]) / d[ax];
        if (t > t_enter) {
          t_enter = t;
          where = 2 * ax + (d[ax] < 0);
        }
      }
    }
    const int bin = where + 8 * ((d.x > 0) + 2 * (d.y > 0) + 4 * (d.z > 0)) + 64 * int(x.reference.hit);
    h[size_t(bin)] += 1;
  }
  return h;
}

// n samples from each of two samplers (seeds `seed` and seed + 1).
void generate_both(const RaySampler& x, const RaySampler& y, uint64_t seed, size_t n, std::vector<Sample>& a,
                   std::vector<Sample>& b) {
  std::vector<RayWalk> wa, wb;
  x.generate(seed, 0, n, a, wa);
  y.generate(seed + 1, 0, n, b, wb);
  ASSERT_EQ(a.size(), n);
  ASSERT_EQ(b.size(), n);
}

// Histograms a and b of one kind of ray come from the same law: their two-sample chi-square, over
// `inflation` (b's counts vary up to that many times as much as independent rays'), below
// Wilson-Hilferty's quantile at p = 1e-4.
void expect_same_histograms(const std::vector<double>& a, const std::vector<double>& b, double inflation,
                            const char* what) {
  SCOPED_TRACE(what);
  int dof = 0;
  const double chi2 = two_sample_chi2(a, b, dof) / inflation;
  ASSERT_GT(dof, 20);
  const double q = 2.0 / (9.0 * dof), limit = dof * std::pow(1.0 - q + 3.719 * std::sqrt(q), 3.0);
  EXPECT_LT(chi2, limit) << dof << " degrees of freedom";
  std::printf("[ info     ] %s: chi-square %.1f, %d degrees of freedom (limit %.1f)\n", what, chi2, dof, limit);
}

// The shares of surface rays in a and b (as many each) agree within 4.5 standard errors of their
// difference (b's variance up to `inflation` times a binomial's); returns them.
std::pair<double, double> expect_same_surface_share(const std::vector<Sample>& a, const std::vector<Sample>& b,
                                                    double inflation) {
  double sa = 0, sb = 0;
  for (const Sample& x : a) sa += x.from_surface;
  for (const Sample& x : b) sb += x.from_surface;
  const double n = double(a.size());
  sa /= n;
  sb /= n;
  const double pooled = 0.5 * (sa + sb);
  EXPECT_NEAR(sa, sb, 4.5 * std::sqrt((1.0 + inflation) * pooled * (1 - pooled) / n));
  return {sa, sb};
}

// Drawing the first kind's rays through the body keeps what the sampler returns: the same mix of
// surface and outer rays, and each kind's rays with the same law (histograms of where they start
// and where they head, and whether they hit, against the paper's whole-sphere sampler), while the
// body is drawn far fewer candidates for.
TEST_F(RaySamplerTest, LinesThroughTheBodyKeepTheSampledRays) {
  SamplerSettings body_settings, sphere_settings;
  body_settings.surface_rays = sphere_settings.surface_rays = 1;  // independent rays (the test below: more)
  sphere_settings.lines_through_body = false;
  const RaySampler body_sampler(scene_->mesh, scene_->truth, scene_->grid, kMaxPoints, body_settings);
  const RaySampler sphere_sampler(scene_->mesh, scene_->truth, scene_->grid, kMaxPoints, sphere_settings);
  EXPECT_FALSE(sphere_sampler.line_body().valid());
  EXPECT_EQ(sphere_sampler.surface_share(), 0.5);
  EXPECT_GT(body_sampler.surface_share(), 0.5);
  std::vector<Sample> a, b;
  ASSERT_NO_FATAL_FAILURE(generate_both(body_sampler, sphere_sampler, 11, 60000, a, b));
  const glm::vec3 centre = scene_->grid.bounds.center();
  // Outer rays by the face of the body's bounding box they enter, surface rays by where they start.
  const Aabb box = body_sampler.line_body().bounds;
  expect_same_histograms(ray_histogram(a, false, centre, &box), ray_histogram(b, false, centre, &box), 1.0,
                         "outer rays");
  expect_same_histograms(ray_histogram(a, true, centre), ray_histogram(b, true, centre), 1.0, "surface rays");
  // The mix: both shares of surface rays agree.
  const auto [sa, sb] = expect_same_surface_share(a, b, 1.0);
  std::printf("[ info     ] body share %.3f, surface candidates %.3f; kept surface rays %.4f (body) and %.4f (sphere)\n",
              body_sampler.line_body_share(), body_sampler.surface_share(), sa, sb);
}

// Several surface rays from each found point (--surface-rays): they come in runs of that many with
// one origin and their own directions, and the sampler returns the same mix of surface and outer
// rays and each kind's rays with the same law as with one ray per point. The rays of a run share
// their origin, so a histogram's counts vary up to k times as much as independent rays': the
// surface rays' chi-square is divided by k (a bound of that inflation).
TEST_F(RaySamplerTest, SeveralSurfaceRaysPerFoundPointKeepTheSampledRays) {
  SamplerSettings one, several;
  one.surface_rays = 1;
  several.surface_rays = 3;
  const RaySampler one_sampler = sampler_of(one), several_sampler = sampler_of(several);
  EXPECT_LT(several_sampler.surface_share(), one_sampler.surface_share());
  const size_t n = 60000;
  std::vector<Sample> a, b;
  ASSERT_NO_FATAL_FAILURE(generate_both(one_sampler, several_sampler, 21, n, a, b));
  // Runs: a surface ray's origin is its run's; a run holds at most 3 rays, all surface rays, and
  // every direction of a run differs. (A ray whose walk crosses no occupied voxel is dropped, so a
  // run may be shorter; the last run may be cut by the count.)
  size_t runs = 0, in_runs = 0;
  for (size_t i = 0; i < n;) {
    size_t j = i + 1;
    while (j < n && b[j].from_surface && b[i].from_surface && b[j].ray.origin == b[i].ray.origin) ++j;
    if (b[i].from_surface) {
      ASSERT_LE(j - i, 3u) << i;
      for (size_t x = i; x < j; ++x)
        for (size_t y = x + 1; y < j; ++y) EXPECT_NE(b[x].ray.direction, b[y].ray.direction) << x << " " << y;
      ++runs;
      in_runs += j - i;
    }
    i = j;
  }
  std::printf("[ info     ] %zu surface rays in %zu runs (%.2f a found point)\n", in_runs, runs,
              double(in_runs) / double(runs));
  EXPECT_GT(double(in_runs) / double(runs), 2.5);  // a surface ray's walk almost always crosses a voxel
  const glm::vec3 centre = scene_->grid.bounds.center();
  expect_same_histograms(ray_histogram(a, false, centre), ray_histogram(b, false, centre), 1.0, "outer rays");
  expect_same_histograms(ray_histogram(a, true, centre), ray_histogram(b, true, centre), 3.0, "surface rays (over 3)");
  // The mix (runs inflate the variance of the share by at most 3).
  const auto [sa, sb] = expect_same_surface_share(a, b, 3.0);
  std::printf("[ info     ] kept surface rays %.4f (one a point) and %.4f (three)\n", sa, sb);
}

// Surface points taken from earlier outer candidates' reference hits (the default) keep what the
// sampler returns: the same mix and each kind's rays with the same law (histograms, as above) as
// when every surface candidate casts its own finding ray. And the points are so taken: a run of
// surface rays that starts a push-off from an outer sample's hit comes after that sample, and no
// hit serves two runs; most outer hits serve one.
TEST_F(RaySamplerTest, SurfacePointsFromOuterHitsKeepTheSampledRays) {
  SamplerSettings reuse, own;
  own.surface_points_from_outer_hits = false;
  ASSERT_TRUE(reuse.surface_points_from_outer_hits);
  const uint32_t k = reuse.surface_rays;
  const RaySampler reuse_sampler = sampler_of(reuse), own_sampler = sampler_of(own);
  EXPECT_EQ(reuse_sampler.surface_share(), own_sampler.surface_share());
  const size_t n = 60000;
  std::vector<Sample> a, b;
  ASSERT_NO_FATAL_FAILURE(generate_both(own_sampler, reuse_sampler, 31, n, a, b));
  const glm::vec3 centre = scene_->grid.bounds.center();
  const Aabb box = own_sampler.line_body().bounds;
  expect_same_histograms(ray_histogram(a, false, centre, &box), ray_histogram(b, false, centre, &box), 1.0,
                         "outer rays");
  // A run's rays vary together (up to k times a histogram's variance), as in the test above.
  expect_same_histograms(ray_histogram(a, true, centre), ray_histogram(b, true, centre), double(k),
                         "surface rays (over k)");
  const auto [sa, sb] = expect_same_surface_share(a, b, double(k));
  // Where each outer sample's hit would start a surface ray (the offset along the face normal
  // turned toward the ray), matched against the runs' origins within a hair (the sampler's
  // arithmetic may be contracted otherwise than this test's), by x through a sorted list.
  const float offset = reuse.surface_offset * scene_->grid.bounds.diagonal();
  const float hair = 1e-5f * scene_->grid.bounds.diagonal();
  std::vector<std::pair<glm::vec3, size_t>> starts;  // (origin, outer sample), by x
  for (size_t i = 0; i < n; ++i)
    if (!b[i].from_surface && b[i].reference.hit) {
      const SurfacePoint at = SurfacePoint::of(b[i].ray, b[i].reference);
      starts.push_back({at.point + offset * at.normal, i});
    }
  std::sort(starts.begin(), starts.end(), [](const auto& x, const auto& y) { return x.first.x < y.first.x; });
  std::vector<int> served(n, 0);
  size_t runs = 0, from_outer = 0;
  for (size_t i = 0; i < n; ++i) {
    if (!b[i].from_surface || (i > 0 && b[i - 1].from_surface && b[i - 1].ray.origin == b[i].ray.origin)) continue;
    ++runs;
    const glm::vec3 o = b[i].ray.origin;
    auto it = std::lower_bound(starts.begin(), starts.end(), o.x - hair,
                               [](const auto& x, float v) { return x.first.x < v; });
    for (; it != starts.end() && it->first.x <= o.x + hair; ++it)
      if (glm::distance(it->first, o) <= hair) {
        EXPECT_LT(it->second, i) << "the run at " << i << " starts at a later sample's hit";
        EXPECT_EQ(++served[it->second], 1) << "outer sample " << it->second << " serves two runs";
        ++from_outer;
        break;
      }
  }
  const size_t outer_hits = starts.size();
  std::printf("[ info     ] surface rays %.4f (own finding rays) and %.4f; %zu of %zu runs from %zu outer hits\n",
              sa, sb, from_outer, runs, outer_hits);
  EXPECT_GT(double(from_outer), 0.9 * double(outer_hits));
  EXPECT_LT(from_outer, runs);  // the others find their own points
}

// A sphere that does not contain the body (--sphere-scale below 1): the rays are drawn on the
// whole sphere, the surface share is the setting's (its odds over the surface rays per point).
TEST_F(RaySamplerTest, SmallSphereDrawsOnTheWholeSphere) {
  SamplerSettings settings;
  settings.sphere_scale = 0.6f;
  const RaySampler sampler(scene_->mesh, scene_->truth, scene_->grid, kMaxPoints, settings);
  EXPECT_FALSE(sampler.line_body().valid());
  const double f = settings.surface_fraction, k = settings.surface_rays;
  EXPECT_NEAR(sampler.surface_share(), f / (f + (1.0 - f) * k), 1e-12);
  settings.surface_rays = 1;
  EXPECT_EQ(RaySampler(scene_->mesh, scene_->truth, scene_->grid, kMaxPoints, settings).surface_share(), f);
  std::vector<Sample> samples;
  std::vector<RayWalk> walks;
  sampler.generate(3, 0, 2000, samples, walks);
  ASSERT_EQ(samples.size(), 2000u);
  const glm::vec3 centre = scene_->grid.bounds.center();
  const float radius = settings.sphere_scale * 0.5f * scene_->grid.bounds.diagonal();
  for (const Sample& s : samples) {
    if (s.from_surface) continue;
    ASSERT_NEAR(glm::distance(s.ray.origin, centre), radius, 1e-5f * radius);
  }
}

// Closest point of triangle (a, b, c) to p (Ericson, Real-Time Collision Detection 5.1.5); `interior`
// tells whether it lies strictly inside the face rather than on an edge or a vertex.
glm::dvec3 closest_point_on_triangle(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b,
                                     const glm::dvec3& c, bool& interior) {
  interior = false;
  const glm::dvec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const glm::dvec3 bp = p - b;
  const double d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + (d1 / (d1 - d3)) * ab;
  const glm::dvec3 cp = p - c;
  const double d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + (d2 / (d2 - d6)) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  interior = true;
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

TEST_F(RaySamplerTest, SurfaceOriginsSitAtTheOffsetWithCosineDirections) {
  const Mesh& mesh = scene_->mesh;
  SamplerSettings settings;
  settings.surface_fraction = 1.0f;
  const RaySampler sampler(mesh, scene_->truth, scene_->grid, kMaxPoints, settings);
  std::vector<Sample> samples;
  std::vector<RayWalk> walks;
  sampler.generate(99, 0, 500, samples, walks);
  ASSERT_EQ(samples.size(), 500u);
  const double offset = double(settings.surface_offset) * double(scene_->grid.bounds.diagonal());

  std::vector<Aabb> boxes(mesh.triangles.size());
  for (size_t t = 0; t < mesh.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) boxes[t].grow(mesh.positions[mesh.triangles[t][k]]);

  double cos_sum = 0.0;
  int cos_count = 0, at_offset = 0, surface = 0;
  for (size_t i = 0; i < samples.size(); ++i) {
    const Sample& s = samples[i];
    if (!s.from_surface) continue;  // an outer fallback (all finding rays missed): rare
    ++surface;
    // Brute-force closest triangle to the origin.
    const glm::dvec3 o(s.ray.origin);
    double best = std::numeric_limits<double>::infinity();
    uint32_t best_tri = 0;
    bool best_interior = false;
    for (uint32_t t = 0; t < uint32_t(mesh.triangles.size()); ++t) {
      const glm::dvec3 q = glm::clamp(o, glm::dvec3(boxes[t].lo), glm::dvec3(boxes[t].hi));
      if (glm::distance(q, o) >= best) continue;
      const glm::uvec3 tri = mesh.triangles[t];
      bool interior = false;
      const glm::dvec3 c = closest_point_on_triangle(o, glm::dvec3(mesh.positions[tri.x]),
                                                     glm::dvec3(mesh.positions[tri.y]),
                                                     glm::dvec3(mesh.positions[tri.z]), interior);
      const double d = glm::distance(c, o);
      if (d < best) {
        best = d;
        best_tri = t;
        best_interior = interior;
      }
    }
    EXPECT_LE(best, 1.02 * offset) << "sample " << i;
    if (best < 0.98 * offset || !best_interior) continue;  // near a crease or an edge: normal ambiguous
    ++at_offset;
    // The origin lies on the front of the face it was pushed off; the direction is cosine-weighted
    // about that side's normal.
    const glm::uvec3 tri = mesh.triangles[best_tri];
    const glm::dvec3 p0(mesh.positions[tri.x]), p1(mesh.positions[tri.y]), p2(mesh.positions[tri.z]);
    glm::dvec3 n = glm::normalize(glm::cross(p1 - p0, p2 - p0));
    if (glm::dot(o - p0, n) < 0) n = -n;
    const double cos_theta = glm::dot(glm::dvec3(s.ray.direction), n);
    EXPECT_GT(cos_theta, 0.0) << "sample " << i;
    cos_sum += cos_theta;
    ++cos_count;
  }
  EXPECT_GT(surface, 490);
  EXPECT_GT(at_offset, 400);
  // E[cos] = 2/3 for a cosine-weighted hemisphere; sd of cos is sqrt(1/18), 4 standard errors.
  const double mean = cos_sum / cos_count;
  EXPECT_NEAR(mean, 2.0 / 3.0, 4.0 * std::sqrt(1.0 / 18.0 / cos_count));
}

// Octahedron subdivided `levels` times onto the unit sphere; `outward` picks the winding (face
// normals out of or into the sphere).
Mesh make_octasphere(int levels, bool outward) {
  Mesh m;
  for (int sx = -1; sx <= 1; sx += 2)
    for (int sy = -1; sy <= 1; sy += 2)
      for (int sz = -1; sz <= 1; sz += 2) {
        const uint32_t base = uint32_t(m.positions.size());
        m.positions.push_back({float(sx), 0, 0});
        m.positions.push_back({0, float(sy), 0});
        m.positions.push_back({0, 0, float(sz)});
        m.triangles.push_back({base, base + 1, base + 2});
      }
  for (int l = 0; l < levels; ++l) {
    std::vector<glm::uvec3> next;
    for (const glm::uvec3& t : m.triangles) {
      uint32_t mid[3];
      for (int e = 0; e < 3; ++e) {
        m.positions.push_back(glm::normalize(m.positions[t[e]] + m.positions[t[(e + 1) % 3]]));
        mid[e] = uint32_t(m.positions.size() - 1);
      }
      next.push_back({t.x, mid[0], mid[2]});
      next.push_back({t.y, mid[1], mid[0]});
      next.push_back({t.z, mid[2], mid[1]});
      next.push_back({mid[0], mid[1], mid[2]});
    }
    m.triangles = next;
  }
  for (glm::uvec3& t : m.triangles) {
    const glm::vec3 a = m.positions[t.x], b = m.positions[t.y], c = m.positions[t.z];
    const bool is_outward = glm::dot(glm::cross(b - a, c - a), a + b + c) > 0.0f;
    if (is_outward != outward) std::swap(t.y, t.z);
  }
  for (const glm::vec3& p : m.positions) m.normals.push_back(outward ? p : -p);
  m.triangle_material.assign(m.triangles.size(), 0);
  m.materials = {{"white", glm::vec3(1.0f), -1}};
  return m;
}

// Surface origins lie on the side the finding ray came from (outside the sphere), whatever the
// winding: the face normal is flipped toward the finding ray before the push-off.
TEST(RaySampler, SurfaceOriginsOnTheFindingRaySide) {
  for (bool outward : {true, false}) {
    SCOPED_TRACE(outward ? "outward winding" : "inward winding");
    const Mesh mesh = make_octasphere(3, outward);
    GroundTruth truth;
    ASSERT_TRUE(truth.build(mesh).is_ok());
    const VoxelGrid grid = voxelize(mesh, 16, pad_aabb(mesh.bounds()));
    SamplerSettings settings;
    settings.surface_fraction = 1.0f;
    std::vector<Sample> samples;
    std::vector<RayWalk> walks;
    RaySampler(mesh, truth, grid, kMaxPoints, settings).generate(4, 0, 400, samples, walks);
    ASSERT_EQ(samples.size(), 400u);
    const float offset = settings.surface_offset * grid.bounds.diagonal();
    for (size_t i = 0; i < samples.size(); ++i) {
      ASSERT_TRUE(samples[i].from_surface) << "sample " << i;  // finding rays aimed at a sphere
      // Back toward the centre the surface is a push-off away (from inside it would be ~2 away).
      Ray back;
      back.origin = samples[i].ray.origin;
      back.direction = -glm::normalize(back.origin);
      const ReferenceHit h = truth.trace(back);
      ASSERT_TRUE(h.hit) << "sample " << i;
      EXPECT_LT(h.t, 1.5f * offset) << "sample " << i;
      EXPECT_GT(h.t, 0.5f * offset) << "sample " << i;
    }
  }
}

TEST(SamplingWarps, CosineHemisphereMomentsAndHistogram) {
  const glm::vec3 axes[] = {{0, 0, 1}, {0, 0, -1}, {1, 0, 0}, glm::normalize(glm::vec3(0.3f, -0.5f, 0.8f)),
                            glm::normalize(glm::vec3(-1e-4f, 2e-4f, -1.0f))};
  const int n = 100000;
  for (const glm::vec3& axis : axes) {
    glm::vec3 t, b;
    orthonormal_basis(axis, t, b);
    EXPECT_NEAR(glm::dot(t, axis), 0.0f, 1e-6f);
    EXPECT_NEAR(glm::dot(b, axis), 0.0f, 1e-6f);
    EXPECT_NEAR(glm::dot(t, b), 0.0f, 1e-6f);
    double sum_cos = 0.0, sum_cos2 = 0.0, sum_t = 0.0, sum_b = 0.0;
    int bins[10] = {};
    for (int i = 0; i < n; ++i) {
      Rng rng(3, 4, uint64_t(i));
      const float u1 = rng.next_float(), u2 = rng.next_float();
      const glm::vec3 d = sample_cosine_hemisphere(axis, u1, u2);
      ASSERT_NEAR(glm::length(d), 1.0f, 1e-5f);
      const double c = double(glm::dot(d, axis));
      ASSERT_GE(c, -1e-6);
      sum_cos += c;
      sum_cos2 += c * c;
      sum_t += double(glm::dot(d, t));
      sum_b += double(glm::dot(d, b));
      // cos^2(theta) is uniform on [0, 1] for a cosine-weighted hemisphere.
      ++bins[std::min(9, int(c * c * 10.0))];
    }
    EXPECT_NEAR(sum_cos / n, 2.0 / 3.0, 4.0 * std::sqrt(1.0 / 18.0 / n));
    EXPECT_NEAR(sum_cos2 / n, 0.5, 0.005);
    EXPECT_NEAR(sum_t / n, 0.0, 0.006);
    EXPECT_NEAR(sum_b / n, 0.0, 0.006);
    double chi2 = 0.0;
    for (int k = 0; k < 10; ++k) chi2 += (bins[k] - n / 10.0) * (bins[k] - n / 10.0) / (n / 10.0);
    EXPECT_LT(chi2, 33.7);  // chi-square, 9 degrees of freedom, p = 1e-4
  }
}

TEST(SamplingWarps, UniformSphereMoments) {
  const int n = 100000;
  glm::dvec3 mean(0.0), mean_sq(0.0);
  for (int i = 0; i < n; ++i) {
    Rng rng(8, 0, uint64_t(i));
    const float u1 = rng.next_float(), u2 = rng.next_float();
    const glm::dvec3 d(sample_uniform_sphere(u1, u2));
    ASSERT_NEAR(glm::length(d), 1.0, 1e-5);
    mean += d / double(n);
    mean_sq += d * d / double(n);
  }
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(mean[k], 0.0, 0.008);         // sd 1/sqrt(3n)
    EXPECT_NEAR(mean_sq[k], 1.0 / 3.0, 0.006);
  }
}

TEST(SamplingWarps, RngDependsOnlyOnTheTriple) {
  Rng a(1, 2, 3), b(1, 2, 3), c(1, 2, 4), d(1, 3, 3), e(2, 2, 3);
  const uint64_t x = a.next_u64();
  EXPECT_EQ(x, b.next_u64());
  EXPECT_NE(x, c.next_u64());
  EXPECT_NE(x, d.next_u64());
  EXPECT_NE(x, e.next_u64());
  // Floats lie in [0, 1) with a uniform mean.
  Rng f(0, 0, 0);
  double sum = 0.0;
  for (int i = 0; i < 100000; ++i) {
    const float u = f.next_float();
    ASSERT_GE(u, 0.0f);
    ASSERT_LT(u, 1.0f);
    sum += double(u);
  }
  EXPECT_NEAR(sum / 100000.0, 0.5, 0.004);
}

// With every voxel occupied, a surface ray (origin inside the box) is always kept and an outer ray
// is kept exactly when it meets the box, so the kept split follows from the candidate split.
TEST_F(RaySamplerTest, SurfaceFractionMatchesTheCandidateSplit) {
  VoxelGrid full;
  full.resolution = 8;
  full.bounds = scene_->grid.bounds;
  full.bits.assign(512 / 32, 0xFFFFFFFFu);
  const float s = 0.5f;
  SamplerSettings settings;
  settings.surface_fraction = s;
  const RaySampler sampler(scene_->mesh, scene_->truth, full, kMaxPoints, settings);
  std::vector<Sample> samples;
  std::vector<RayWalk> walks;
  const size_t count = 20000;
  sampler.generate(5, 0, count, samples, walks);
  ASSERT_EQ(samples.size(), count);
  size_t surface = 0;
  for (const Sample& x : samples) surface += x.from_surface;

  // Independent estimates: the share of outer rays meeting the box (keep rate) and of finding
  // rays missing the mesh (a surface candidate falls back to an outer ray after 16 misses).
  const glm::vec3 centre = full.bounds.center();
  const float radius = 0.5f * full.bounds.diagonal();
  const int n = 20000;
  int meets = 0, misses = 0;
  for (int i = 0; i < n; ++i) {
    Rng rng(77, 0, uint64_t(i));
    const float u1 = rng.next_float(), u2 = rng.next_float(), u3 = rng.next_float(), u4 = rng.next_float();
    // Uniform point on the sphere; cosine-weighted direction toward the centre by Malley's method.
    const float z = 1.0f - 2.0f * u1, r = std::sqrt(std::max(0.0f, 1.0f - z * z)), phi = 6.2831853f * u2;
    const glm::vec3 out(r * std::cos(phi), r * std::sin(phi), z);
    const glm::vec3 w = -out;
    const glm::vec3 helper = std::abs(w.x) < 0.5f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
    const glm::vec3 tu = glm::normalize(glm::cross(helper, w)), tv = glm::cross(w, tu);
    const float rr = std::sqrt(u3), ph = 6.2831853f * u4;
    Ray ray;
    ray.origin = centre + radius * out;
    ray.direction = rr * std::cos(ph) * tu + rr * std::sin(ph) * tv + std::sqrt(1.0f - u3) * w;
    float tn, tf;
    meets += intersect_aabb(full.bounds, ray, tn, tf);
    misses += !scene_->truth.trace(ray).hit;
  }
  const double keep_outer = double(meets) / n;
  const double fallback = std::pow(double(misses) / n, 16.0);
  const double surface_kept = s * (1.0 - fallback);
  const double expected = surface_kept / (surface_kept + (1.0 - surface_kept) * keep_outer);
  const double measured = double(surface) / double(count);
  EXPECT_GT(keep_outer, 0.2);
  EXPECT_LT(keep_outer, 0.95);
  // Binomial sd of the measured share is about 0.0035; the estimates add a little more.
  EXPECT_NEAR(measured, expected, 0.02) << "keep_outer " << keep_outer << " fallback " << fallback;
}

TEST_F(RaySamplerTest, ExtremeSurfaceFractions) {
  std::vector<Sample> samples;
  std::vector<RayWalk> walks;
  SamplerSettings outer_only;
  outer_only.surface_fraction = 0.0f;
  RaySampler(scene_->mesh, scene_->truth, scene_->grid, kMaxPoints, outer_only).generate(3, 0, 2000, samples, walks);
  ASSERT_EQ(samples.size(), 2000u);
  for (const Sample& s : samples) EXPECT_FALSE(s.from_surface);
  SamplerSettings surface_only;
  surface_only.surface_fraction = 1.0f;
  RaySampler(scene_->mesh, scene_->truth, scene_->grid, kMaxPoints, surface_only).generate(3, 0, 2000, samples, walks);
  ASSERT_EQ(samples.size(), 2000u);
  size_t surface = 0;
  for (const Sample& s : samples) surface += s.from_surface;
  EXPECT_GT(surface, 1980u);
}

TEST(RaySampler, TerminatesWhenNothingCanBeKeptOrFound) {
  // A triangle far outside a fully occupied grid: finding rays never hit it, so surface candidates
  // fall back to outer rays, and the request is still met.
  Mesh far;
  far.positions = {{100, 100, 100}, {101, 100, 100}, {100, 101, 100}};
  far.triangles = {{0, 1, 2}};
  far.triangle_material = {0};
  far.materials = {{"white", glm::vec3(1.0f), -1}};
  GroundTruth truth;
  ASSERT_TRUE(truth.build(far).is_ok());
  VoxelGrid grid;
  grid.resolution = 4;
  grid.bounds.lo = glm::vec3(-1.0f);
  grid.bounds.hi = glm::vec3(1.0f);
  grid.bits.assign(2, 0xFFFFFFFFu);
  SamplerSettings settings;
  settings.surface_fraction = 1.0f;
  std::vector<Sample> samples;
  std::vector<RayWalk> walks;
  RaySampler(far, truth, grid, kMaxPoints, settings).generate(1, 0, 300, samples, walks);
  ASSERT_EQ(samples.size(), 300u);
  for (const Sample& s : samples) {
    EXPECT_FALSE(s.from_surface);
    EXPECT_FALSE(s.reference.hit);
  }
  // An empty grid keeps nothing, and H = 0 records no point: both return no samples at once.
  VoxelGrid empty = grid;
  std::fill(empty.bits.begin(), empty.bits.end(), 0u);
  RaySampler(far, truth, empty, kMaxPoints, settings).generate(1, 0, 300, samples, walks);
  EXPECT_TRUE(samples.empty());
  EXPECT_TRUE(walks.empty());
  RaySampler(far, truth, grid, 0, settings).generate(1, 0, 300, samples, walks);
  EXPECT_TRUE(samples.empty());
}

TEST_F(RaySamplerTest, Throughput) {
  const RaySampler sampler(scene_->mesh, scene_->truth, scene_->grid, kMaxPoints);
  std::vector<Sample> samples;
  std::vector<RayWalk> walks;
  omp_set_num_threads(2);
  const auto start = std::chrono::steady_clock::now();
  sampler.generate(123, 0, 50000, samples, walks);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_EQ(samples.size(), 50000u);
  std::printf("[ info     ] bunny V=%u H=%u, 2 threads: %.0f kept samples/s\n", kResolution, kMaxPoints,
              double(samples.size()) / seconds);
}

}  // namespace
}  // namespace lsnif
