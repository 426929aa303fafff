// gpu_test_support.h -- what the GPU tests (gpu_reference_test, rt_conformance_test) share: tiny
// training settings, instances (A, A^-1 as src/lsnif/core/intersector.cpp computes it, T), the generator
// of world-space test rays of four kinds and the brute-force truth of triangle hits. Header-only;
// include inside no namespace.
#pragma once
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <random>
#include <vector>

#include <glm/glm.hpp>

#include "lsnif/core/head.h"
#include "lsnif/core/intersector.h"
#include "lsnif/core/model.h"
#include "lsnif/import/mesh.h"
#include "lsnif/testing/test_models.h"
#include "lsnif/testing/test_support.h"
#include "lsnif/train/trainer.h"

namespace lsnif::gputest {

inline double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

inline TrainSettings tiny_settings(HitParam param) {
  TrainSettings s = test::tiny_train_settings();
  s.config.hit_param = param;
  s.steps = 200;
  s.seed = 7;
  return s;
}

// The GPU tests' model with uv cells: test::layout_sphere (a textured sphere whose layout has seams
// and a mirrored half) trained tiny with texture coordinates (one name: one model prepared for the
// GPU check).
inline Status uv_sphere_model(Model& model) {
  TrainSettings s = tiny_settings(HitParam::VoxelSegments);
  s.steps = 120;
  s.texture_coordinates = kTextureCoordinatesAuto;
  return test::tiny_model("uv_sphere", test::layout_sphere(24, 48), s, model);
}

struct Instance {
  glm::mat3 A, A_inv;  // A_inv as src/lsnif/core/intersector.cpp computes it
  glm::vec3 T;
};
inline Instance instance_of(const Transform3x4& xf) {
  Instance in;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) in.A[c][r] = xf.m[r][c];
    in.T[r] = xf.m[r][3];
  }
  in.A_inv = glm::inverse(in.A);
  return in;
}

// A direction uniform on the unit sphere (rejection sampling in the unit ball, away from 0).
inline glm::vec3 random_unit_vector(std::mt19937& rng) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (;;) {
    const glm::vec3 v(2 * u(rng) - 1, 2 * u(rng) - 1, 2 * u(rng) - 1);
    const float l = glm::length(v);
    if (l > 0.05f && l <= 1.0f) return v / l;
  }
}

enum RayKind { kOutside, kInside, kInOccupied, kAnywhere, kKinds };
inline const char* kKindNames[kKinds] = {"from outside through the AABB", "from inside the AABB",
                                  "from inside occupied voxels", "anywhere (many miss the AABB)"};

// Object-space rays of every kind (round robin), 15% with a finite tmax that cuts some hits, 10%
// with a raised tmin, unnormalized directions; appended in world space of instance `in`.
inline void make_world_rays(const Model& model, const Instance& in, size_t count, uint32_t seed, std::vector<Ray>& rays,
                     std::vector<int>& kinds) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const Aabb& b = model.bounds();
  const glm::vec3 ext = b.extent();
  const float diag = b.diagonal();
  const uint32_t V = model.voxels.resolution;
  std::vector<glm::uvec3> occupied;
  for (uint32_t k = 0; k < V; ++k)
    for (uint32_t j = 0; j < V; ++j)
      for (uint32_t i = 0; i < V; ++i)
        if (model.voxels.occupied(int(i), int(j), int(k))) occupied.emplace_back(i, j, k);
  auto unit_vector = [&] { return random_unit_vector(rng); };
  auto in_box = [&] { return b.lo + ext * glm::vec3(u(rng), u(rng), u(rng)); };
  for (size_t i = 0; i < count; ++i) {
    const int kind = int(i % kKinds);
    Ray r;
    switch (kind) {
      case kOutside:
        r.origin = b.center() + diag * (0.8f + 0.7f * u(rng)) * unit_vector();
        r.direction = in_box() - r.origin;
        break;
      case kInside:
        r.origin = in_box();
        r.direction = unit_vector();
        break;
      case kInOccupied: {
        const glm::uvec3 v = occupied[size_t(u(rng) * float(occupied.size())) % occupied.size()];
        r.origin = b.lo + ext * (glm::vec3(v) + glm::vec3(u(rng), u(rng), u(rng))) / float(V);
        r.direction = unit_vector();
        break;
      }
      default:
        r.origin = b.center() + 1.5f * ext * glm::vec3(2 * u(rng) - 1, 2 * u(rng) - 1, 2 * u(rng) - 1);
        r.direction = unit_vector();
        break;
    }
    r.direction *= 0.5f + u(rng);
    const float span = diag / glm::length(r.direction);
    const float pick = u(rng);
    if (pick < 0.15f) {
      r.tmax = 2.0f * span * u(rng);
    } else if (pick < 0.25f) {
      r.tmin = 0.5f * span * u(rng);
    }
    Ray w = r;
    w.origin = in.A * r.origin + in.T;
    w.direction = in.A * r.direction;
    rays.push_back(w);
    kinds.push_back(kind);
  }
}

// The closest triangle of `mesh` that `ray` hits with t in [tmin, tmax]: every triangle tested in
// double precision (Moller-Trumbore, both facings), the independent truth of the triangle hits of
// the mixed-TLAS tests.
struct TriangleHit {
  bool hit = false;
  float t = 0.0f;
  uint32_t triangle = 0;
};
inline TriangleHit closest_triangle_hit(const Mesh& mesh, const Ray& ray) {
  const glm::dvec3 o(ray.origin), d(ray.direction);
  TriangleHit best;
  double best_t = double(ray.tmax);
  for (size_t i = 0; i < mesh.triangles.size(); ++i) {
    const glm::uvec3& tri = mesh.triangles[i];
    const glm::dvec3 p0(mesh.positions[tri.x]), e1 = glm::dvec3(mesh.positions[tri.y]) - p0,
        e2 = glm::dvec3(mesh.positions[tri.z]) - p0;
    const glm::dvec3 pv = glm::cross(d, e2);
    const double det = glm::dot(e1, pv);
    if (det == 0.0) continue;
    const double inv = 1.0 / det;
    const glm::dvec3 tv = o - p0;
    const double u = glm::dot(tv, pv) * inv;
    if (u < 0.0 || u > 1.0) continue;
    const glm::dvec3 qv = glm::cross(tv, e1);
    const double v = glm::dot(d, qv) * inv;
    if (v < 0.0 || u + v > 1.0) continue;
    const double t = glm::dot(e2, qv) * inv;
    if (t < double(ray.tmin) || t > best_t) continue;
    best_t = t;
    best.hit = true;
    best.t = float(t);
    best.triangle = uint32_t(i);
  }
  return best;
}

// `model` with surface channels (config.surface_channels = 1, the emission scale `emission_scale`)
// whose LSNIF_OUT_SURFACE_COUNT extra output rows have random weights and biases (fp16 after
// quantize): no training, but the other outputs, hence the hits, stay the model's. Weights of the
// scale of a Kaiming initialisation plus biases in [-1, 1] spread the raw outputs over the sigmoid's
// range, so the decoded channels and the emission's RGBE exponents vary from hit to hit.
inline Model with_surface_channels(const Model& model, float emission_scale, uint32_t seed) {
  Model m = model;
  m.config.surface_channels = 1;
  m.config.emission_scale = emission_scale;
  const LayerView old_out = mlp_layers(model.config).back();
  const LayerView out = mlp_layers(m.config).back();
  m.mlp.resize(size_t(m.config.mlp_parameter_count()));
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  const float a = std::sqrt(6.0f / float(out.in));
  for (uint32_t r = 0; r < out.out; ++r) {
    const bool kept = r < old_out.out;
    for (uint32_t i = 0; i < out.in; ++i)
      m.mlp[out.weight_offset + size_t(r) * out.in + i] =
          kept ? model.mlp[old_out.weight_offset + size_t(r) * old_out.in + i] : a * u(rng);
    m.mlp[out.bias_offset + r] = kept ? model.mlp[old_out.bias_offset + r] : u(rng);
  }
  m.quantize();
  return m;
}

// Agreement of a device's surface channels with the CPU reference's, over the hits both report.
struct SurfaceAgreement {
  size_t hits = 0, learned = 0;
  size_t flag_mismatch = 0;    // the learned flag (byte 3) differs
  size_t step_mismatch = 0;    // a channel's unorm8 differs by more than one step
  size_t exact = 0;            // the packed word equals pack_surface of the CPU's channels
  double emission_max = 0.0;   // max |device - CPU| / emission scale over the channels
  double emission_excess = 0.0;  // max of |device - CPU| less the tolerance given (<= 0: within)
};

// Adds one hit: `surface` the device's packed word, `emission` its emission, `h` the CPU reference
// hit, `scale` the model's emission scale; `tolerance(c)` the allowed |device - CPU| of a channel
// whose CPU value is the largest channel `c` of the colour.
template <typename Tolerance>
void add_surface(SurfaceAgreement& a, uint32_t surface, glm::vec3 emission, const LsnifHit& h, float scale,
                 Tolerance tolerance) {
  Prediction p;
  p.surface_learned = h.surface_learned;
  p.metallic = h.metallic;
  p.roughness = h.roughness;
  p.ambient_occlusion = h.ambient_occlusion;
  const uint32_t want = pack_surface(p);
  ++a.hits;
  a.learned += h.surface_learned;
  a.exact += surface == want;
  a.flag_mismatch += (surface >> 24) != (want >> 24);
  bool step = false;
  for (int k = 0; k < 3; ++k) {
    const int got = int((surface >> (8 * k)) & 0xffu), expect = int((want >> (8 * k)) & 0xffu);
    step |= std::abs(got - expect) > 1;
  }
  a.step_mismatch += step;
  const float largest = std::max({h.emission.r, h.emission.g, h.emission.b});
  for (int k = 0; k < 3; ++k) {
    const double err = std::fabs(double(emission[k]) - double(h.emission[k]));
    if (scale > 0.0f) a.emission_max = std::max(a.emission_max, err / double(scale));
    a.emission_excess = std::max(a.emission_excess, err - double(tolerance(largest)));
  }
}

// What the surface tests expect of every hit (the tolerance passed to add_surface decides emission).
inline void expect_surface_agreement(const SurfaceAgreement& a, bool learned) {
  EXPECT_EQ(a.learned, learned ? a.hits : 0u);
  EXPECT_EQ(a.flag_mismatch, 0u);
  EXPECT_EQ(a.step_mismatch, 0u);
  EXPECT_LE(a.emission_excess, 0.0) << "emission beyond tolerance";
  // A one-step difference happens only where the CPU's and the device's sigmoid straddle a rounding
  // boundary of unorm8 (~1e-4 of 1/255 apart): nearly every word is bit-identical.
  EXPECT_GE(double(a.exact), 0.99 * double(a.hits));
}

}  // namespace lsnif::gputest
