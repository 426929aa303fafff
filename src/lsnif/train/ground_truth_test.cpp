// ground_truth_test.cpp -- Embree closest hits against a brute-force double-precision
// Moller-Trumbore loop over every triangle, plus the hit attributes and the error paths.
#include "lsnif/train/ground_truth.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "lsnif/core/rng.h"

namespace lsnif {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// Moller-Trumbore in double. Barycentrics >= -eps are accepted (eps > 0 widens the triangle).
bool moller_trumbore(const Ray& ray, const Mesh& mesh, uint32_t tri, double eps, double& t, double& u,
                     double& v) {
  const glm::uvec3 idx = mesh.triangles[tri];
  const glm::dvec3 p0(mesh.positions[idx.x]), p1(mesh.positions[idx.y]), p2(mesh.positions[idx.z]);
  const glm::dvec3 o(ray.origin), d(ray.direction);
  const glm::dvec3 e1 = p1 - p0, e2 = p2 - p0;
  const glm::dvec3 pv = glm::cross(d, e2);
  const double det = glm::dot(e1, pv);
  if (det == 0.0) return false;
  const double inv = 1.0 / det;
  const glm::dvec3 tv = o - p0;
  u = glm::dot(tv, pv) * inv;
  if (u < -eps || u > 1.0 + eps) return false;
  const glm::dvec3 qv = glm::cross(tv, e1);
  v = glm::dot(d, qv) * inv;
  if (v < -eps || u + v > 1.0 + eps) return false;
  t = glm::dot(e2, qv) * inv;
  return true;
}

struct BruteHit {
  bool hit = false;
  double t = 0.0, u = 0.0, v = 0.0;
  uint32_t triangle = 0;
  double margin = 0.0;  // smallest barycentric coordinate: near 0 means near an edge
};

BruteHit brute_force(const Mesh& mesh, const Ray& ray) {
  BruteHit best;
  best.t = std::numeric_limits<double>::infinity();
  for (uint32_t i = 0; i < uint32_t(mesh.triangles.size()); ++i) {
    double t, u, v;
    if (!moller_trumbore(ray, mesh, i, 0.0, t, u, v)) continue;
    if (t < double(ray.tmin) || t > double(ray.tmax) || t >= best.t) continue;
    best = {true, t, u, v, i, std::min(std::min(u, v), 1.0 - u - v)};
  }
  return best;
}

glm::vec3 face_normal(const Mesh& mesh, uint32_t tri) {
  const glm::uvec3 idx = mesh.triangles[tri];
  const glm::dvec3 p0(mesh.positions[idx.x]), p1(mesh.positions[idx.y]), p2(mesh.positions[idx.z]);
  return glm::vec3(glm::normalize(glm::cross(p1 - p0, p2 - p0)));
}

// Icosahedron subdivided `levels` times, projected on the unit sphere, wound counter-clockwise seen
// from outside; per-vertex normals (radial), colors and three materials.
Mesh make_icosphere(int levels) {
  const float g = 1.6180339887f;
  Mesh m;
  m.positions = {{-1, g, 0}, {1, g, 0}, {-1, -g, 0}, {1, -g, 0}, {0, -1, g}, {0, 1, g},
                 {0, -1, -g}, {0, 1, -g}, {g, 0, -1}, {g, 0, 1}, {-g, 0, -1}, {-g, 0, 1}};
  for (auto& p : m.positions) p = glm::normalize(p);
  m.triangles = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                 {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                 {3, 8, 9},  {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (int l = 0; l < levels; ++l) {
    std::vector<glm::uvec3> next;
    for (const glm::uvec3& t : m.triangles) {
      uint32_t mid[3];
      for (int e = 0; e < 3; ++e) {
        m.positions.push_back(glm::normalize(m.positions[t[e]] + m.positions[t[(e + 1) % 3]]));
        mid[e] = uint32_t(m.positions.size() - 1);  // duplicated midpoints: a soup is fine here
      }
      next.push_back({t.x, mid[0], mid[2]});
      next.push_back({t.y, mid[1], mid[0]});
      next.push_back({t.z, mid[2], mid[1]});
      next.push_back({mid[0], mid[1], mid[2]});
    }
    m.triangles = next;
  }
  for (const glm::vec3& p : m.positions) {
    m.normals.push_back(p);
    m.colors.push_back(0.5f * (p + 1.0f));
    // Longitude and latitude: a layout with one seam meridian (a soup: each corner its own uv).
    m.uvs.push_back({std::atan2(p.z, p.x) / 6.2831853f + 0.5f, std::asin(std::clamp(p.y, -1.0f, 1.0f)) / 3.1415927f + 0.5f});
  }
  m.materials = {{"red", {1.0f, 0.2f, 0.2f}, -1}, {"green", {0.2f, 1.0f, 0.2f}, -1},
                 {"blue", {0.2f, 0.2f, 1.0f}, -1}};
  for (size_t i = 0; i < m.triangles.size(); ++i) m.triangle_material.push_back(uint32_t(i % 3));
  return m;
}

// Overlapping random triangles in [-1, 1]^3 (no normals given: flat shading normals).
Mesh make_random_soup(uint32_t count) {
  Mesh m;
  for (uint32_t i = 0; i < count; ++i) {
    Rng rng(11, 0, i);
    const glm::vec3 c(rng.next_float() * 2 - 1, rng.next_float() * 2 - 1, rng.next_float() * 2 - 1);
    for (int k = 0; k < 3; ++k)
      m.positions.push_back(c + 0.4f * glm::vec3(rng.next_float() - 0.5f, rng.next_float() - 0.5f,
                                                  rng.next_float() - 0.5f));
    m.triangles.push_back({3 * i, 3 * i + 1, 3 * i + 2});
    m.triangle_material.push_back(0);
  }
  m.materials = {{"grey", {0.5f, 0.5f, 0.5f}, -1}};
  return m;
}

// Random ray: origin in the box [-r, r]^3, uniform direction scaled by a random length, and for a
// fifth of the rays a random finite [tmin, tmax].
Ray random_ray(uint64_t index, float r) {
  Rng rng(5, 1, index);
  Ray ray;
  ray.origin = r * glm::vec3(2 * rng.next_float() - 1, 2 * rng.next_float() - 1, 2 * rng.next_float() - 1);
  ray.direction = (0.5f + rng.next_float()) * sample_uniform_sphere(rng.next_float(), rng.next_float());
  if (rng.next_float() < 0.2f) {
    ray.tmin = rng.next_float();
    ray.tmax = ray.tmin + 3.0f * rng.next_float();
  }
  return ray;
}

// Compares Embree with brute force on `rays`; hit/miss or triangle disagreements are allowed only
// where the ray passes within a hair of an edge (counted in `ambiguous`).
void compare_with_brute_force(const Mesh& mesh, const GroundTruth& truth, const std::vector<Ray>& rays,
                              int& hits, int& ambiguous) {
  hits = 0;
  ambiguous = 0;
  for (size_t r = 0; r < rays.size(); ++r) {
    const Ray& ray = rays[r];
    const BruteHit bf = brute_force(mesh, ray);
    const ReferenceHit e = truth.trace(ray);
    SCOPED_TRACE("ray " + std::to_string(r));
    double te = 0, ue = 0, ve = 0;
    // Embree's triangle hit by the ray when widened by 1e-5 (an edge grazer), at Embree's t?
    const bool near_embree_triangle =
        e.hit && e.triangle < mesh.triangles.size() &&
        moller_trumbore(ray, mesh, e.triangle, 1e-5, te, ue, ve) &&
        std::abs(te - double(e.t)) <= 1e-4 * std::abs(te) + 1e-6;
    if (bf.hit != e.hit) {
      const bool near_range_end =
          bf.hit ? (std::abs(bf.t - double(ray.tmin)) < 1e-5 || std::abs(bf.t - double(ray.tmax)) < 1e-5)
                 : (std::abs(double(e.t) - double(ray.tmin)) < 1e-5 ||
                    std::abs(double(e.t) - double(ray.tmax)) < 1e-5);
      const bool grazing = bf.hit ? bf.margin < 1e-5 : near_embree_triangle;
      EXPECT_TRUE(grazing || near_range_end) << "hit/miss disagree: brute " << bf.hit << " embree " << e.hit;
      ++ambiguous;
      continue;
    }
    if (!bf.hit) continue;
    ++hits;
    const double tol = 1e-4 * std::abs(bf.t) + 1e-6;
    EXPECT_NEAR(double(e.t), bf.t, tol);
    if (e.triangle != bf.triangle) {
      EXPECT_TRUE(near_embree_triangle && std::abs(te - bf.t) <= tol)
          << "triangle " << e.triangle << " vs brute force " << bf.triangle;
      ++ambiguous;
      continue;
    }
    // Attributes at the brute-force barycentrics (same convention as Embree's u, v).
    const glm::vec3 sn = mesh.shading_normal(e.triangle, float(bf.u), float(bf.v));
    const glm::vec3 al = mesh.albedo(e.triangle, float(bf.u), float(bf.v));
    EXPECT_NEAR(glm::length(e.normal), 1.0f, 1e-4f);
    EXPECT_NEAR(glm::distance(e.normal, sn), 0.0f, 2e-3f);
    EXPECT_NEAR(glm::distance(e.albedo, al), 0.0f, 2e-3f);
    EXPECT_NEAR(glm::distance(e.geometric_normal, face_normal(mesh, e.triangle)), 0.0f, 1e-5f);
    EXPECT_EQ(e.material, mesh.triangle_material[e.triangle]);
    // The uv: the corners' uvs at the brute-force barycentrics, in double.
    if (!mesh.uvs.empty()) {
      const glm::uvec3 c = mesh.triangles[e.triangle];
      const glm::dvec2 uv = (1.0 - bf.u - bf.v) * glm::dvec2(mesh.uvs[c.x]) + bf.u * glm::dvec2(mesh.uvs[c.y]) +
                            bf.v * glm::dvec2(mesh.uvs[c.z]);
      EXPECT_NEAR(glm::distance(glm::dvec2(e.uv), uv), 0.0, 1e-4);
    } else {
      EXPECT_EQ(e.uv, glm::vec2(0.0f));
    }
  }
}

TEST(GroundTruth, IcosphereMatchesBruteForce) {
  const Mesh mesh = make_icosphere(3);  // 1280 triangles
  GroundTruth truth;
  const Status st = truth.build(mesh);
  ASSERT_TRUE(st.is_ok()) << st.message();
  std::vector<Ray> rays;
  for (uint64_t i = 0; i < 4000; ++i) rays.push_back(random_ray(i, 1.0f));
  int hits = 0, ambiguous = 0;
  compare_with_brute_force(mesh, truth, rays, hits, ambiguous);
  EXPECT_GT(hits, 2000);
  EXPECT_LE(ambiguous, 8);
  // Geometric normals point outward (the sphere is wound counter-clockwise from outside) whatever
  // side the ray comes from.
  int inside = 0;
  for (const Ray& ray : rays) {
    const ReferenceHit h = truth.trace(ray);
    if (!h.hit) continue;
    const glm::vec3 p = ray.origin + h.t * ray.direction;
    EXPECT_GT(glm::dot(h.geometric_normal, p), 0.9f);
    EXPECT_GT(glm::dot(h.normal, p), 0.98f);
    inside += glm::dot(h.geometric_normal, ray.direction) > 0.0f;
  }
  EXPECT_GT(inside, 1500);  // plenty of back-face hits from origins inside the sphere
}

TEST(GroundTruth, RandomSoupMatchesBruteForce) {
  const Mesh mesh = make_random_soup(300);
  GroundTruth truth;
  const Status st = truth.build(mesh);
  ASSERT_TRUE(st.is_ok()) << st.message();
  std::vector<Ray> rays;
  for (uint64_t i = 0; i < 5000; ++i) rays.push_back(random_ray(100000 + i, 1.5f));
  int hits = 0, ambiguous = 0;
  compare_with_brute_force(mesh, truth, rays, hits, ambiguous);
  EXPECT_GT(hits, 600);
  EXPECT_LE(ambiguous, 10);
}

TEST(GroundTruth, BunnyMatchesBruteForce) {
  Mesh mesh;
  const Status load = load_mesh(std::string(LSNIF_DATA_DIR) + "/meshes/bunny00.off", mesh);
  ASSERT_TRUE(load.is_ok()) << load.message();
  GroundTruth truth;
  const Status st = truth.build(mesh);
  ASSERT_TRUE(st.is_ok()) << st.message();
  const Aabb box = mesh.bounds();
  const glm::vec3 c = box.center();
  const float radius = box.diagonal();
  std::vector<Ray> rays;
  for (uint64_t i = 0; i < 250; ++i) {
    Rng rng(9, 2, i);
    Ray ray;
    // Half from a sphere around the bunny toward a point of its box, half from inside its box.
    const glm::vec3 in_box = box.lo + glm::vec3(rng.next_float(), rng.next_float(), rng.next_float()) * box.extent();
    if (i % 2 == 0) {
      ray.origin = c + radius * sample_uniform_sphere(rng.next_float(), rng.next_float());
      ray.direction = glm::normalize(in_box - ray.origin);
    } else {
      ray.origin = in_box;
      ray.direction = sample_uniform_sphere(rng.next_float(), rng.next_float());
    }
    rays.push_back(ray);
  }
  int hits = 0, ambiguous = 0;
  compare_with_brute_force(mesh, truth, rays, hits, ambiguous);
  EXPECT_GT(hits, 100);
  EXPECT_LE(ambiguous, 2);
}

TEST(GroundTruth, ParallelTracesMatchSerial) {
  const Mesh mesh = make_icosphere(2);
  GroundTruth truth;
  ASSERT_TRUE(truth.build(mesh).is_ok());
  const int n = 4000;
  std::vector<ReferenceHit> serial(n), parallel(n);
  for (int i = 0; i < n; ++i) serial[size_t(i)] = truth.trace(random_ray(uint64_t(i), 1.5f));
#pragma omp parallel for num_threads(2)
  for (int i = 0; i < n; ++i) parallel[size_t(i)] = truth.trace(random_ray(uint64_t(i), 1.5f));
  for (size_t i = 0; i < size_t(n); ++i) {
    ASSERT_EQ(serial[i].hit, parallel[i].hit) << i;
    EXPECT_EQ(serial[i].t, parallel[i].t) << i;
    EXPECT_EQ(serial[i].triangle, parallel[i].triangle) << i;
  }
}

// One triangle in the z = 0 plane, counter-clockwise seen from +z.
Mesh make_unit_triangle() {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  m.triangles = {{0, 1, 2}};
  m.triangle_material = {0};
  m.materials = {{"white", {1.0f, 1.0f, 1.0f}, -1}};
  return m;
}

TEST(GroundTruth, SingleTriangleAnalytic) {
  const Mesh mesh = make_unit_triangle();
  GroundTruth truth;
  ASSERT_TRUE(truth.build(mesh).is_ok());
  Ray down;
  down.origin = {0.25f, 0.25f, 2.0f};
  down.direction = {0.0f, 0.0f, -1.0f};
  ReferenceHit h = truth.trace(down);
  ASSERT_TRUE(h.hit);
  EXPECT_FLOAT_EQ(h.t, 2.0f);
  EXPECT_EQ(h.triangle, 0u);
  EXPECT_EQ(h.geometric_normal, glm::vec3(0, 0, 1));
  // From below: the normal is still the wound one, not flipped toward the ray.
  Ray up = down;
  up.origin.z = -3.0f;
  up.direction = {0.0f, 0.0f, 2.0f};  // not normalized: t in units of the direction
  h = truth.trace(up);
  ASSERT_TRUE(h.hit);
  EXPECT_FLOAT_EQ(h.t, 1.5f);
  EXPECT_EQ(h.geometric_normal, glm::vec3(0, 0, 1));
  // Range limits.
  Ray short_ray = down;
  short_ray.tmax = 1.9f;
  EXPECT_FALSE(truth.trace(short_ray).hit);
  Ray late_ray = down;
  late_ray.tmin = 2.1f;
  EXPECT_FALSE(truth.trace(late_ray).hit);
  Ray exact_range = down;
  exact_range.tmin = 1.5f;
  exact_range.tmax = 2.5f;
  EXPECT_TRUE(truth.trace(exact_range).hit);
  Ray outside = down;
  outside.origin = {0.75f, 0.75f, 2.0f};
  EXPECT_FALSE(truth.trace(outside).hit);
}

TEST(GroundTruth, InvalidRaysMiss) {
  const Mesh mesh = make_unit_triangle();
  GroundTruth truth;
  ASSERT_TRUE(truth.build(mesh).is_ok());
  Ray good;
  good.origin = {0.25f, 0.25f, 2.0f};
  good.direction = {0.0f, 0.0f, -1.0f};
  ASSERT_TRUE(truth.trace(good).hit);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  Ray r = good;
  r.origin.x = nan;
  EXPECT_FALSE(truth.trace(r).hit);
  r = good;
  r.direction.z = -kInf;
  EXPECT_FALSE(truth.trace(r).hit);
  r = good;
  r.direction = glm::vec3(0.0f);
  EXPECT_FALSE(truth.trace(r).hit);
  r = good;
  r.tmax = nan;
  EXPECT_FALSE(truth.trace(r).hit);
  r = good;
  r.tmin = 3.0f;
  r.tmax = 1.0f;
  EXPECT_FALSE(truth.trace(r).hit);
}

TEST(GroundTruth, BuildErrors) {
  GroundTruth truth;
  Ray ray;
  ray.origin = {0.25f, 0.25f, 2.0f};
  ray.direction = {0.0f, 0.0f, -1.0f};
  EXPECT_FALSE(truth.trace(ray).hit);  // not built: a miss, not a crash

  Mesh empty;
  Status st = truth.build(empty);
  EXPECT_FALSE(st.is_ok());
  EXPECT_NE(st.message().find("no triangles"), std::string::npos) << st.message();

  Mesh nan_vertex = make_unit_triangle();
  nan_vertex.positions[1].y = std::numeric_limits<float>::quiet_NaN();
  st = truth.build(nan_vertex);
  EXPECT_FALSE(st.is_ok());
  EXPECT_NE(st.message().find("position 1"), std::string::npos) << st.message();
  EXPECT_FALSE(truth.trace(ray).hit);

  Mesh bad_index = make_unit_triangle();
  bad_index.triangles[0].z = 7;
  st = truth.build(bad_index);
  EXPECT_FALSE(st.is_ok());
  EXPECT_NE(st.message().find("vertex 7"), std::string::npos) << st.message();

  Mesh bad_material = make_unit_triangle();
  bad_material.triangle_material[0] = 3;
  st = truth.build(bad_material);
  EXPECT_FALSE(st.is_ok());
  EXPECT_NE(st.message().find("material 3"), std::string::npos) << st.message();

  Mesh missing_materials = make_unit_triangle();
  missing_materials.triangle_material.clear();
  EXPECT_FALSE(truth.build(missing_materials).is_ok());
  EXPECT_FALSE(truth.trace(ray).hit);

  // A failed build leaves the object usable: a later good build works.
  const Mesh good = make_unit_triangle();
  ASSERT_TRUE(truth.build(good).is_ok());
  EXPECT_TRUE(truth.trace(ray).hit);
}

// A unit quad in z = 0 (uv = xy) over an opaque one in z = -1. The front quad's base colour
// texture is an N x N checkerboard of alpha 255 (even cells) and `hole_alpha` (odd cells).
Mesh checkerboard_over_backing(AlphaMode mode, float cutoff, uint8_t hole_alpha, float factor_alpha) {
  constexpr uint32_t N = 4;
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, -1}, {1, 0, -1}, {1, 1, -1}, {0, 1, -1}};
  m.normals.assign(8, glm::vec3(0, 0, 1));
  for (const glm::vec3& p : m.positions) m.uvs.emplace_back(p.x, p.y);
  m.triangles = {{0, 1, 2}, {0, 2, 3}, {4, 5, 6}, {4, 6, 7}};
  m.triangle_material = {0, 0, 1, 1};
  Material cut;
  cut.name = "cut";
  cut.base_color_texture = 0;
  cut.alpha_mode = mode;
  cut.alpha_cutoff = cutoff;
  cut.alpha = factor_alpha;
  Material backing;
  backing.name = "backing";
  backing.alpha_mode = mode;  // no texture: alpha 1, always surface
  m.materials = {cut, backing};
  Texture t;
  t.width = t.height = N;
  // Row y of the texture is read at v = (y + 0.5) / N (top row first, uv as given).
  for (uint32_t y = 0; y < N; ++y)
    for (uint32_t x = 0; x < N; ++x) t.rgba.insert(t.rgba.end(), {200, 100, 50, (x + y) % 2 ? hole_alpha : uint8_t(255)});
  m.textures = {t};
  return m;
}

// Rays straight down through every cell centre: the alpha test decides, cell by cell, between the
// front quad and the backing behind it, as the checkerboard says (the texture is read at texel
// centres, where bilinear filtering returns the texel itself).
void expect_cells(const Mesh& mesh, float alpha_times_factor_hole, bool holes_expected) {
  GroundTruth truth;
  ASSERT_TRUE(truth.build(mesh));
  for (uint32_t y = 0; y < 4; ++y)
    for (uint32_t x = 0; x < 4; ++x) {
      Ray r;
      r.origin = {(float(x) + 0.5f) / 4.0f, (float(y) + 0.5f) / 4.0f, 1.0f};
      r.direction = {0, 0, -1};
      const ReferenceHit h = truth.trace(r);
      ASSERT_TRUE(h.hit);
      const bool hole = (x + y) % 2 == 1 && holes_expected;
      EXPECT_FLOAT_EQ(h.t, hole ? 2.0f : 1.0f) << "cell " << x << "," << y << " alpha " << alpha_times_factor_hole;
      EXPECT_EQ(h.material, hole ? 1u : 0u);
    }
}

TEST(GroundTruth, CutoutsAreAlphaTested) {
  // MASK at its cutoff: a hole of alpha 0 is seen through; factor alpha multiplies the texture.
  expect_cells(checkerboard_over_backing(AlphaMode::Mask, 0.5f, 0, 1.0f), 0.0f, true);
  expect_cells(checkerboard_over_backing(AlphaMode::Mask, 0.3f, 102, 1.0f), 0.4f, false);  // 0.4 >= 0.3
  expect_cells(checkerboard_over_backing(AlphaMode::Mask, 0.5f, 102, 1.0f), 0.4f, true);   // 0.4 < 0.5
  // The opaque cells fail too when the factor brings them under the cutoff: everything is a hole
  // but the backing.
  {
    GroundTruth truth;
    const Mesh m = checkerboard_over_backing(AlphaMode::Mask, 0.5f, 255, 0.25f);
    ASSERT_TRUE(truth.build(m));
    Ray r;
    r.origin = {0.125f, 0.125f, 1.0f};
    r.direction = {0, 0, -1};
    EXPECT_EQ(truth.trace(r).material, 1u);
  }
  // BLEND is a cut-out at 0.5 whatever alphaCutoff says; OPAQUE ignores alpha.
  expect_cells(checkerboard_over_backing(AlphaMode::Blend, 0.1f, 102, 1.0f), 0.4f, true);
  expect_cells(checkerboard_over_backing(AlphaMode::Blend, 0.9f, 153, 1.0f), 0.6f, false);
  expect_cells(checkerboard_over_backing(AlphaMode::Opaque, 0.5f, 0, 1.0f), 0.0f, false);
  // Mesh::opaque_at, the test itself, agrees at the cell centres (barycentrics of triangle 0:
  // p = (1-u-v) p0 + u p1 + v p2 with p0 (0,0), p1 (1,0), p2 (1,1): x = u + v, y = v).
  const Mesh m = checkerboard_over_backing(AlphaMode::Mask, 0.5f, 0, 1.0f);
  EXPECT_TRUE(m.opaque_at(0, 0.125f - 0.125f, 0.125f));  // cell (0, 0)
  EXPECT_FALSE(m.opaque_at(0, 0.375f - 0.125f, 0.125f));  // cell (1, 0)
  EXPECT_TRUE(m.has_cutouts());
  EXPECT_FALSE(make_unit_triangle().has_cutouts());
}

// The packet form traces as one ray at a time does, every field of every hit, on the bunny (rays
// from around it and from inside its box), with invalid rays mixed in and batches that do not fill
// the last packet, and on the checkerboard of cut-outs (the alpha test's filter on 16 rays at once).
void expect_same_hits(const GroundTruth& truth, const std::vector<Ray>& rays) {
  for (const size_t n : {size_t(0), size_t(1), size_t(15), size_t(16), size_t(17), rays.size()}) {
    if (n > rays.size()) continue;
    std::vector<ReferenceHit> packed(n);
    truth.trace(rays.data(), n, packed.data());
    for (size_t i = 0; i < n; ++i) {
      const ReferenceHit one = truth.trace(rays[i]);
      const ReferenceHit& h = packed[i];
      ASSERT_EQ(h.hit, one.hit) << "ray " << i << " of " << n;
      EXPECT_EQ(h.t, one.t) << i;
      EXPECT_EQ(h.triangle, one.triangle) << i;
      EXPECT_EQ(h.material, one.material) << i;
      EXPECT_EQ(h.normal, one.normal) << i;
      EXPECT_EQ(h.geometric_normal, one.geometric_normal) << i;
      EXPECT_EQ(h.albedo, one.albedo) << i;
      EXPECT_EQ(h.uv, one.uv) << i;
    }
  }
}

TEST(GroundTruth, PacketsTraceAsOneRayAtATime) {
  Mesh mesh;
  const Status load = load_mesh(std::string(LSNIF_DATA_DIR) + "/meshes/bunny00.off", mesh);
  ASSERT_TRUE(load.is_ok()) << load.message();
  GroundTruth truth;
  ASSERT_TRUE(truth.build(mesh).is_ok());
  const Aabb box = mesh.bounds();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::vector<Ray> rays;
  int hits = 0;
  for (uint64_t i = 0; i < 3000; ++i) {
    Rng rng(11, 4, i);
    Ray ray;
    const glm::vec3 in_box = box.lo + glm::vec3(rng.next_float(), rng.next_float(), rng.next_float()) * box.extent();
    ray.origin = i % 2 ? in_box : box.center() + box.diagonal() * sample_uniform_sphere(rng.next_float(), rng.next_float());
    ray.direction = i % 2 ? sample_uniform_sphere(rng.next_float(), rng.next_float()) : in_box - ray.origin;
    switch (i % 23) {  // invalid or limited rays among the others
      case 3: ray.origin.y = nan; break;
      case 7: ray.direction = glm::vec3(0.0f); break;
      case 11: ray.tmax = nan; break;
      case 13: ray.tmin = 2.0f; ray.tmax = 1.0f; break;
      case 17: ray.tmin = -1.0f; ray.tmax = 0.5f; break;
      case 19: ray.direction.x = kInf; break;
      default: break;
    }
    hits += truth.trace(ray).hit;
    rays.push_back(ray);
  }
  EXPECT_GT(hits, 1000);
  expect_same_hits(truth, rays);
  // Before a successful build every ray misses, in packets too.
  GroundTruth unbuilt;
  std::vector<ReferenceHit> none(20);
  unbuilt.trace(rays.data(), none.size(), none.data());
  for (const ReferenceHit& h : none) EXPECT_FALSE(h.hit);

  GroundTruth cutouts;
  const Mesh board = checkerboard_over_backing(AlphaMode::Mask, 0.5f, 0, 1.0f);
  ASSERT_TRUE(cutouts.build(board).is_ok());
  std::vector<Ray> down;
  for (uint32_t k = 0; k < 40; ++k) {
    Ray r;
    r.origin = {(float(k % 8) + 0.5f) / 8.0f, (float(k / 8 % 4) + 0.5f) / 4.0f, 1.0f};
    r.direction = {0, 0, -1};
    down.push_back(r);
  }
  expect_same_hits(cutouts, down);
}

}  // namespace
}  // namespace lsnif
