// LSNIF objects as procedural AABB geometry traced by a real Vulkan ray-tracing pipeline
// (src/lsnif/shaders/lsnif.rint + tests/gpu/rt_conformance.{rgen,rmiss,rchit}, lavapipe on machines without
// a GPU) against the CPU reference intersector (src/lsnif/core/intersector.cpp), ray by ray: tiny models of
// both hit parametrizations (test_models.h) as in gpu_reference_test, one instance (identity,
// then rotated / non-uniformly scaled / translated), two instances of one model in one TLAS (the
// closer one must be reported, with its instance id), and shadow rays (TerminateOnFirstHit |
// SkipClosestHitShader) whose visibility must match; and a mixed TLAS (an LSNIF instance beside a
// triangle BLAS of the elephant mesh, a triangle hit group at SBT offset 1) whose closest hits and
// shadow visibility must match the closer of the CPU reference and a brute-force triangle test. The validation layer must
// report nothing.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <random>
#include <vector>

#include "lsnif/core/intersector.h"
#include "lsnif/import/mesh.h"
#include "lsnif/core/ray_walk.h"
#include "lsnif/testing/test_support.h"
#include "lsnif/testing/test_models.h"
#include "lsnif/train/trainer.h"
#include "lsnif/vulkan/plugin_device.h"
#include "lsnif/vulkan/raytracing.h"
#include "lsnif/testing/gpu_test_support.h"
#include "lsnif/testing/test_plugin.h"

namespace lsnif {
namespace {

using namespace gputest;

const std::string kElephant = test::data_dir() + "/meshes/elephant.off";
// The test's shaders (rt_conformance.*, rt_mixed_triangle.rchit), compiled at build time.
#include "rt_conformance_rchit_spirv.h"
#include "rt_conformance_rgen_spirv.h"
#include "rt_conformance_rmiss_spirv.h"
#include "rt_mixed_triangle_rchit_spirv.h"

// The push constant block of rt_conformance_common.glsl.
using RtPush = RtConformancePush;

// The pipeline's shaders, with the triangle hit group when `mixed`.
vk::RtShaders rt_shaders(bool mixed) {
  vk::RtShaders s;
  s.raygen = spirv(rt_conformance_rgen_spirv, sizeof rt_conformance_rgen_spirv);
  s.miss = spirv(rt_conformance_rmiss_spirv, sizeof rt_conformance_rmiss_spirv);
  s.closest_hit = spirv(rt_conformance_rchit_spirv, sizeof rt_conformance_rchit_spirv);
  s.intersection = TestPlugin::intersection_shader();
  if (mixed) s.triangle_closest_hit = spirv(rt_mixed_triangle_rchit_spirv, sizeof rt_mixed_triangle_rchit_spirv);
  return s;
}
static_assert(sizeof(LsnifHitAttributes) <= 32, "maxRayHitAttributeSize on lavapipe");
constexpr uint32_t kModeClosest = 0, kModeShadow = 1;

// Identity shifted by `offset` (world units).
Transform3x4 translated(glm::vec3 offset) {
  Transform3x4 xf;
  for (int r = 0; r < 3; ++r) xf.m[r][3] = offset[r];
  return xf;
}

// Boundary points of the walk of world ray `w` through instance `in`, from the object-space ray
// computed in float (as the CPU reference does) or in double (another rounding of the same ray).
uint32_t walk_points(const Model& model, const Instance& in, const Ray& w, bool in_double) {
  Ray o;
  if (in_double) {
    const glm::dmat3 A_inv = glm::inverse(glm::dmat3(in.A));
    o.origin = glm::vec3(A_inv * (glm::dvec3(w.origin) - glm::dvec3(in.T)));
    o.direction = glm::vec3(A_inv * glm::dvec3(w.direction));
  } else {
    o.origin = in.A_inv * (w.origin - in.T);
    o.direction = in.A_inv * w.direction;
  }
  o.tmin = w.tmin;
  o.tmax = std::numeric_limits<float>::infinity();
  RayWalk walk;
  walk_ray(model.voxels, o, model.config.max_points, walk);
  return walk.count;
}

struct Comparison {
  size_t rays = 0, cpu_hits = 0, gpu_hits = 0, hit_agree = 0, walk_mismatch = 0;
  size_t flips_threshold = 0, flips_interval = 0, flips_walk = 0, flips_facing = 0, flips_other = 0;
  size_t both_hit = 0, material_mismatch = 0, instance_mismatch = 0, instance_ties = 0;
  size_t hits_per_kind[kKinds] = {}, gpu_hits_per_instance[2] = {};
  size_t closest_hit_ran = 0;  // results written by the closest-hit shader (instance != ~0u)
  // Hit kinds (bit 15 of instance) against the facing of the reported normal: back-facing hits seen,
  // and kinds that disagree where |dot(normal, direction)| > kFacingEps.
  size_t back_facing = 0, facing_mismatch = 0;
  double leaving_tmin_rel_err_max = 0;  // lsnif_leaving_tmin (closest hit) vs leaving_tmin (CPU)
  double t_err_max = 0, t_err_sum = 0, normal_deg_max = 0, normal_deg_sum = 0, albedo_max = 0;
  bool surface_channels = false;  // the model's: every hit's surface word is learned, else 0
  SurfaceAgreement surface;       // the closest-hit shader's decode of the attributes, where both hit
  // Texture coordinates where both hit (the attributes carry 16 fractional bits): hits reporting one
  // on both sides, on one side only, and those further apart than the packing's half step.
  size_t uv_both = 0, uv_one_side = 0, uv_apart = 0;
  double uv_err_max = 0;
};

// Flip explanations, as in gpu_reference_test: a logit within kLogitEps of 0 (on either side), a t
// within kIntervalEps diagonals of tmin or tmax, or a walk that is not robust (the GPU reported
// other boundary points, or float and double object-space rays walk differently).
constexpr double kLogitEps = 1e-3;
constexpr double kIntervalEps = 1e-4;
// Normals within this cosine of perpendicular to the ray may round to either facing.
constexpr double kFacingEps = 1e-4;
// With a culling flag, a flip is also explained when the hitting side's normal lies within this
// cosine of perpendicular to the ray: the GPU's normal differs from the CPU's by up to ~0.4 deg
// (expect_agreement's bounds), so such a hit may face either way on the two sides (sin 0.5 deg).
constexpr double kCullFacingEps = 8.7e-3;

double logit_of(float occlusion) {
  const double p = std::clamp(double(occlusion), 1e-30, 1.0 - 1e-16);
  return std::log(p / (1.0 - p));
}

// Compares GPU results with the CPU reference for rays traced through a TLAS of the instances
// `xfs` (all of `model`): the expected hit is the closest accepted CPU hit over the instances.
// Shadow mode compares only hit / miss.
Comparison compare(const Model& model, const std::vector<Transform3x4>& xfs, const std::vector<Ray>& world,
                   const std::vector<int>& kinds, const std::vector<std::vector<LsnifHit>>& cpu,
                   const std::vector<LsnifReferenceHit>& gpu, uint32_t mode, uint32_t ray_flags) {
  Comparison c;
  c.rays = world.size();
  c.surface_channels = model.config.surface_channels != 0;
  const float scale = model.config.emission_scale;
  // The attributes carry the emission as RGBE: half a step of the shared exponent (<= 2^-8 of the
  // largest channel), on top of the sigmoid's difference bounded as the albedo's, times the scale.
  const auto emission_tolerance = [scale](float largest) {
    return std::ldexp(largest, -8) + 2e-4f * scale;
  };
  const double diag = double(model.bounds().diagonal());
  std::vector<Instance> ins;
  for (const Transform3x4& xf : xfs) ins.push_back(instance_of(xf));
  for (size_t i = 0; i < world.size(); ++i) {
    const Ray& w = world[i];
    const LsnifReferenceHit& g = gpu[i];
    // Expected: the closest accepted hit.
    int best = -1;
    for (size_t k = 0; k < xfs.size(); ++k)
      if (cpu[k][i].hit && (best < 0 || cpu[k][i].t < cpu[size_t(best)][i].t)) best = int(k);
    const bool cpu_hit = best >= 0;
    const bool gpu_hit = g.hit != 0;
    c.cpu_hits += cpu_hit;
    c.gpu_hits += gpu_hit;
    c.closest_hit_ran += g.instance != 0xffffffffu;
    const uint32_t gpu_instance = g.instance & 0x7fffu;
    if (gpu_hit && mode == kModeClosest && gpu_instance < 2) ++c.gpu_hits_per_instance[gpu_instance];
    if (gpu_hit && mode == kModeClosest && gpu_instance < xfs.size() &&
        g.points != walk_points(model, ins[gpu_instance], w, false))
      ++c.walk_mismatch;
    if (cpu_hit == gpu_hit) {
      ++c.hit_agree;
    } else {
      bool threshold = gpu_hit && mode == kModeClosest && std::fabs(double(g.occlusion_logit)) < kLogitEps;
      bool interval = false, walk = false, facing = false;
      const bool culling = (ray_flags & (LSNIF_RAY_FLAG_CULL_BACK_FACING | LSNIF_RAY_FLAG_CULL_FRONT_FACING)) != 0;
      const auto near_perpendicular = [&](const glm::vec3& n) {
        return culling && std::fabs(double(glm::dot(glm::normalize(n), glm::normalize(w.direction)))) < kCullFacingEps;
      };
      if (gpu_hit) facing |= near_perpendicular(glm::vec3(g.normal_x, g.normal_y, g.normal_z));
      if (cpu_hit) facing |= near_perpendicular(cpu[size_t(best)][i].normal);
      for (size_t k = 0; k < xfs.size(); ++k) {
        const LsnifHit& h = cpu[k][i];
        const double span = diag / double(glm::length(ins[k].A_inv * w.direction));
        const uint32_t points = walk_points(model, ins[k], w, false);
        walk |= points != walk_points(model, ins[k], w, true);
        if (gpu_hit && mode == kModeClosest && gpu_instance == k) walk |= g.points != points;
        if (points == 0) continue;
        threshold |= std::fabs(logit_of(h.occlusion)) < kLogitEps;
        for (const double t : {double(h.t), gpu_hit && gpu_instance == k ? double(g.t) : double(h.t)})
          interval |= std::fabs(t - double(w.tmin)) < kIntervalEps * span ||
                      std::fabs(t - double(w.tmax)) < kIntervalEps * span;
      }
      if (walk) ++c.flips_walk;
      else if (threshold) ++c.flips_threshold;
      else if (interval) ++c.flips_interval;
      else if (facing) ++c.flips_facing;
      else {
        ++c.flips_other;
        if (c.flips_other <= 5)
          std::printf("unexplained flip: ray %zu cpu hit %d (instance %d) | gpu hit %u logit %.6g t %.7g\n", i,
                      int(cpu_hit), best, g.hit, double(g.occlusion_logit), double(g.t));
      }
    }
    if (!(cpu_hit && gpu_hit) || mode != kModeClosest) continue;
    // The closest of two instances: when both predicted t lie within kIntervalEps diagonals of each
    // other, either instance may be reported (the driver keeps the first it finds among equals).
    size_t ref = size_t(best);
    if (gpu_instance != ref) {
      const double span = diag / double(glm::length(ins[ref].A_inv * w.direction));
      if (gpu_instance < xfs.size() && cpu[gpu_instance][i].hit &&
          std::fabs(double(cpu[gpu_instance][i].t) - double(cpu[ref][i].t)) < kIntervalEps * span) {
        ++c.instance_ties;
        ref = gpu_instance;
      } else {
        ++c.instance_mismatch;
        continue;
      }
    }
    const LsnifHit& h = cpu[ref][i];
    const double leaving = double(leaving_tmin(model, xfs[ref], w.direction));
    c.leaving_tmin_rel_err_max =
        std::max(c.leaving_tmin_rel_err_max, std::fabs(double(g.leaving_tmin) - leaving) / leaving);
    ++c.both_hit;
    ++c.hits_per_kind[kinds[i]];
    const double span = diag / double(glm::length(ins[ref].A_inv * w.direction));
    const double t_err = std::fabs(double(g.t) - double(h.t)) / span;
    c.t_err_max = std::max(c.t_err_max, t_err);
    c.t_err_sum += t_err;
    const glm::dvec3 gn(g.normal_x, g.normal_y, g.normal_z), hn(h.normal);
    const double deg = std::acos(std::clamp(glm::dot(gn, hn), -1.0, 1.0)) * 180.0 / M_PI;
    c.normal_deg_max = std::max(c.normal_deg_max, deg);
    c.normal_deg_sum += deg;
    // The hit kind says the facing of the predicted normal: dot(A^-T n, d) has the sign of the
    // object-space dot(n, A^-1 d) the intersection shader tests.
    const uint32_t hit_kind = (g.instance >> 15) & 1u;
    const double facing = glm::dot(gn, glm::dvec3(glm::normalize(w.direction)));
    c.back_facing += hit_kind == LSNIF_HIT_KIND_BACK_FACING;
    if (std::fabs(facing) > kFacingEps)
      c.facing_mismatch += hit_kind != (facing < 0.0 ? LSNIF_HIT_KIND_FRONT_FACING : LSNIF_HIT_KIND_BACK_FACING);
    c.material_mismatch += g.material != h.material;
    if (h.reports_uv != (g.reports_uv != 0)) {
      ++c.uv_one_side;
    } else if (h.reports_uv) {
      // The attributes hold the coordinate, not the albedo and channels (the application's textures do).
      ++c.uv_both;
      const glm::dvec2 d = glm::abs(glm::dvec2(g.uv_u, g.uv_v) - glm::dvec2(h.uv));
      c.uv_err_max = std::max(c.uv_err_max, std::max(d.x, d.y));
      c.uv_apart += std::max(d.x, d.y) > 0.5 / 65536.0 + 1e-6;
      continue;
    }
    const glm::vec3 ga(g.albedo_x, g.albedo_y, g.albedo_z);
    for (int k = 0; k < 3; ++k) c.albedo_max = std::max(c.albedo_max, double(std::fabs(ga[k] - h.albedo[k])));
    add_surface(c.surface, g.surface, glm::vec3(g.emission_r, g.emission_g, g.emission_b), h, scale,
                emission_tolerance);
  }
  return c;
}

void print(const char* name, const Comparison& c) {
  std::printf(
      "%s: %zu rays, cpu hits %zu, gpu hits %zu, hit agreement %.4f%% (flips: %zu threshold, %zu interval, "
      "%zu walk, %zu facing, %zu other), gpu walk mismatches %zu, gpu hits per instance %zu/%zu\n"
      "  both hit %zu (per kind %zu/%zu/%zu/%zu): t error / diagonal max %.3g mean %.3g, normal angle max "
      "%.3g deg mean %.3g deg, albedo max %.3g, material mismatches %zu, instance mismatches %zu (ties %zu), "
      "leaving tmin relative error max %.3g, back-facing hits %zu, hit kinds against the normal's facing "
      "%zu wrong\n"
      "  surface channels: %zu of %zu hits learned, %zu words bit-identical, %zu beyond one unorm8 step, "
      "emission max error / scale %.3g\n"
      "  texture coordinates: %zu hits on both sides, %zu on one side, %zu apart beyond the packing, max %.3g\n",
      name, c.rays, c.cpu_hits, c.gpu_hits, 100.0 * double(c.hit_agree) / double(c.rays), c.flips_threshold,
      c.flips_interval, c.flips_walk, c.flips_facing, c.flips_other, c.walk_mismatch, c.gpu_hits_per_instance[0],
      c.gpu_hits_per_instance[1], c.both_hit, c.hits_per_kind[0], c.hits_per_kind[1], c.hits_per_kind[2],
      c.hits_per_kind[3], c.t_err_max, c.both_hit ? c.t_err_sum / double(c.both_hit) : 0.0, c.normal_deg_max,
      c.both_hit ? c.normal_deg_sum / double(c.both_hit) : 0.0, c.albedo_max, c.material_mismatch,
      c.instance_mismatch, c.instance_ties, c.leaving_tmin_rel_err_max, c.back_facing, c.facing_mismatch,
      c.surface.learned, c.surface.hits, c.surface.exact, c.surface.step_mismatch, c.surface.emission_max,
      c.uv_both, c.uv_one_side, c.uv_apart, c.uv_err_max);
}

class RtConformance : public ::testing::Test {
 protected:
  // Model table entries; the third is the voxel-segments model with 8-bit grid features, the fourth
  // the voxel-segments model with surface channels (random surface rows: with_surface_channels).
  static constexpr uint32_t kAabbIndex = 0, kSegmentIndex = 1, kEightBitIndex = 2, kSurfaceIndex = 3, kUvIndex = 4,
                            kModels = 5;

  static void SetUpTestSuite() {
    vk_status_ = vk_.init(/*ray_tracing=*/true, test::test_validation(), test::test_device());
    if (vk_status_) vk_status_ = tracer_.init();
    if (vk_status_) {
      std::printf("Vulkan device: %s (shaderGroupHandleSize %u, shaderGroupBaseAlignment %u, "
                  "maxRayHitAttributeSize %u)\n",
                  vk_.device_name().c_str(), tracer_.handle_size(), tracer_.base_alignment(),
                  tracer_.max_hit_attribute_size());
      if (tracer_.max_hit_attribute_size() < sizeof(LsnifHitAttributes))
        vk_status_ = Status::error("maxRayHitAttributeSize %u < %zu bytes of LsnifHitAttributes",
                                   tracer_.max_hit_attribute_size(), sizeof(LsnifHitAttributes));
    }
    if (vk_status_)
      vk_status_ = tracer_.create_pipeline(rt_shaders(false), sizeof(RtPush), pipeline_);
    if (vk_status_) std::printf("vkCreateRayTracingPipelinesKHR %.3f s\n", pipeline_.create_seconds);
    if (vk_status_)
      vk_status_ = tracer_.create_pipeline(rt_shaders(true), sizeof(RtPush), mixed_pipeline_);

    if (!std::filesystem::exists(kElephant)) {
      train_status_ = Status::error("%s missing: run scripts/setup.sh", kElephant.c_str());
      return;
    }
    Mesh& mesh = mesh_;
    if (!load_mesh(kElephant, mesh)) {
      train_status_ = Status::error("cannot load %s", kElephant.c_str());
      return;
    }
    const auto t0 = std::chrono::steady_clock::now();
    train_status_ = test::tiny_model("elephant.aabb", mesh, tiny_settings(HitParam::AabbInterval), models_[kAabbIndex]);
    if (train_status_) train_status_ = test::tiny_model("elephant.segments", mesh, tiny_settings(HitParam::VoxelSegments), models_[kSegmentIndex]);
    std::printf("trained 2 tiny models in %.2f s\n", seconds_since(t0));
    models_[kEightBitIndex] = models_[kSegmentIndex];
    models_[kEightBitIndex].config.grid_bits = 8;
    models_[kEightBitIndex].quantize();
    models_[kSurfaceIndex] = with_surface_channels(models_[kSegmentIndex], 40.0f, 21);
    if (train_status_) train_status_ = uv_sphere_model(models_[kUvIndex]);
    if (!train_status_ || !vk_status_) return;

    // Through the plugin, on the Vulkan context's device: model blocks and one AABB BLAS per model, and
    // the model table (custom index -> model address).
    train_status_ = plugin_.init(vk_);
    for (uint32_t m = 0; m < kModels && train_status_; ++m) train_status_ = plugin_.upload(models_[m], handles_[m]);
    std::vector<uint64_t> addresses;
    if (train_status_) train_status_ = plugin_.model_table({handles_[0], handles_[1], handles_[2], handles_[3], handles_[4]}, addresses);
    if (train_status_) train_status_ = vk_.create_buffer(addresses.size() * sizeof(uint64_t), table_);
    if (train_status_) std::memcpy(table_.mapped, addresses.data(), addresses.size() * sizeof(uint64_t));
  }

  static void TearDownTestSuite() {
    for (uint32_t m = 0; m < kModels; ++m) plugin_.release(handles_[m]);
    plugin_.destroy();
    vk_.destroy_buffer(table_);
    tracer_.destroy(pipeline_);
    tracer_.destroy(mixed_pipeline_);
  }

  // Traces `world` through a TLAS of instances `xfs` of model `index` (custom index = index) in
  // `mode` with `ray_flags`, runs the CPU reference per instance and compares. The TLAS is built
  // here, or is `prebuilt` (whose instances must be `xfs`).
  static Comparison run(uint32_t index, const std::vector<Transform3x4>& xfs, const std::vector<Ray>& world,
                        const std::vector<int>& kinds, uint32_t mode, const char* name, uint32_t ray_flags = 0,
                        const vk::AccelerationStructure* prebuilt = nullptr) {
    const Model& model = models_[index];
    const size_t count = world.size();
    std::vector<std::vector<LsnifHit>> cpu(xfs.size(), std::vector<LsnifHit>(count));
    auto t0 = std::chrono::steady_clock::now();
    for (size_t k = 0; k < xfs.size(); ++k) {
      const Status s = intersect(model, xfs[k], world.data(), count, cpu[k].data(), ray_flags);
      EXPECT_TRUE(s) << s.message();
    }
    const double cpu_seconds = seconds_since(t0);

    std::vector<VkAccelerationStructureInstanceKHR> instances(xfs.size());
    Status s = Status::ok();
    for (size_t k = 0; k < xfs.size() && s; ++k) s = plugin_.make_instance(handles_[index], xfs[k], index, 0xFF, 0, instances[k]);
    vk::AccelerationStructure tlas;
    vk::Buffer ray_buf, hit_buf;
    std::vector<LsnifReferenceHit> gpu(count);
    double gpu_seconds = 0;
    if (s && !prebuilt) s = tracer_.build_tlas(instances, tlas);
    if (s) s = vk_.create_buffer(count * sizeof(LsnifReferenceRay), ray_buf);
    if (s) s = vk_.create_buffer(count * sizeof(LsnifReferenceHit), hit_buf);
    if (s) {
      auto* rays = static_cast<LsnifReferenceRay*>(ray_buf.mapped);
      for (size_t i = 0; i < count; ++i) {
        const Ray& r = world[i];
        rays[i] = {r.origin.x, r.origin.y, r.origin.z, r.tmin, r.direction.x, r.direction.y, r.direction.z, r.tmax};
      }
      RtPush push;
      push.model_table = table_.address;
      push.model_count = kModels;
      push.rays = ray_buf.address;
      push.hits = hit_buf.address;
      push.ray_count = uint32_t(count);
      push.mode = mode;
      push.ray_flags = ray_flags;
      t0 = std::chrono::steady_clock::now();
      s = tracer_.trace(pipeline_, prebuilt ? *prebuilt : tlas, &push, uint32_t(count));
      gpu_seconds = seconds_since(t0);
      const auto* hits = static_cast<const LsnifReferenceHit*>(hit_buf.mapped);
      if (s) gpu.assign(hits, hits + count);
    }
    EXPECT_TRUE(s) << s.message();
    vk_.destroy_buffer(ray_buf);
    vk_.destroy_buffer(hit_buf);
    tracer_.destroy(tlas);

    const Comparison c = compare(model, xfs, world, kinds, cpu, gpu, mode, ray_flags);
    std::printf("[%s] trace %.3f s (%.0f rays/s, includes the first-use compile), CPU reference %.3f s\n", name,
                gpu_seconds, double(count) / gpu_seconds, cpu_seconds);
    print(name, c);
    return c;
  }

  static Comparison run_single(uint32_t index, const Transform3x4& xf, size_t count, uint32_t seed, uint32_t mode,
                               const char* name) {
    std::vector<Ray> world;
    std::vector<int> kinds;
    make_world_rays(models_[index], instance_of(xf), count, seed, world, kinds);
    return run(index, {xf}, world, kinds, mode, name);
  }

  // Agreement bounds: those of gpu_reference_test (same shared GLSL, same fp16 parameters in fp32;
  // the object-space ray now comes from the driver's gl_ObjectRay*EXT instead of the host's A^-1,
  // a difference of a few ulps that the hash grid amplifies to ~1e-5 in the features: measured
  // maxima ~1e-5 diagonals in t and mostly < 0.1 deg in the normal, but 0.40 deg on one ray of 1,202
  // of a model trained with another gradient summation order: the maximum depends on the model's
  // steepest point, the mean (< 0.01 deg) does not; the mean t error, ~1e-6 diagonals, reached
  // 2.07e-6 on the rays leaving the surface of a model trained with AVX-512 GEMMs), plus the unorm8
  // packing of the hit attributes' albedo (<= 1/510 = 2e-3). Formula, layout or attribute-packing errors give errors of percent and
  // degrees on most hits, which the mean bounds catch. The surface channels: the learned flag on every hit of a model with them
  // (the word 0 without), each unorm8 within one step of the CPU's, the emission within RGBE's step.
  static void expect_agreement(const Comparison& c, uint32_t mode) {
    EXPECT_GE(double(c.hit_agree), 0.999 * double(c.rays));
    EXPECT_EQ(c.flips_other, 0u);
    if (mode == kModeShadow) {
      EXPECT_EQ(c.closest_hit_ran, 0u);  // gl_RayFlagsSkipClosestHitShaderEXT honoured
      return;
    }
    EXPECT_EQ(c.closest_hit_ran, c.gpu_hits);
    EXPECT_LE(double(c.walk_mismatch), 5e-4 * double(c.rays));
    EXPECT_EQ(c.instance_mismatch, 0u);
    EXPECT_LT(c.t_err_max, 2e-4);
    EXPECT_LT(c.both_hit ? c.t_err_sum / double(c.both_hit) : 0.0, 4e-6);
    EXPECT_LT(c.normal_deg_max, 1.0);
    EXPECT_LT(c.both_hit ? c.normal_deg_sum / double(c.both_hit) : 0.0, 0.03);
    EXPECT_LT(c.albedo_max, 0.5 / 255.0 + 1e-4);
    EXPECT_EQ(c.material_mismatch, 0u);
    EXPECT_LT(c.leaving_tmin_rel_err_max, 1e-5);
    EXPECT_EQ(c.facing_mismatch, 0u);
    expect_surface_agreement(c.surface, c.surface_channels);
  }

  void SetUp() override {
    ASSERT_TRUE(vk_status_) << "no usable Vulkan ray-tracing device: " << vk_status_.message();
    ASSERT_TRUE(train_status_) << train_status_.message();
  }
  void TearDown() override {
    EXPECT_EQ(vk_.validation_errors(), 0u) << vk_.validation_log();
    EXPECT_EQ(vk_.validation_warnings(), 0u) << vk_.validation_log();
  }

  static vk::Context vk_;
  static vk::RayTracer tracer_;
  static vk::RtPipeline pipeline_, mixed_pipeline_;
  static Mesh mesh_;
  static Status vk_status_, train_status_;
  static Model models_[kModels];
  static TestPlugin plugin_;
  static LsnifModel handles_[kModels];
  static vk::Buffer table_;
};
vk::Context RtConformance::vk_;
vk::RayTracer RtConformance::tracer_(RtConformance::vk_);
vk::RtPipeline RtConformance::pipeline_, RtConformance::mixed_pipeline_;
Mesh RtConformance::mesh_;
Status RtConformance::vk_status_, RtConformance::train_status_;
Model RtConformance::models_[RtConformance::kModels];
TestPlugin RtConformance::plugin_;
LsnifModel RtConformance::handles_[RtConformance::kModels];
vk::Buffer RtConformance::table_;

constexpr size_t kRays = 5000;  // per model and instance: 20k rays for the single-instance tests

TEST_F(RtConformance, IdentityInstanceMatchesCpu) {
  const Comparison a = run_single(kAabbIndex, Transform3x4(), kRays, 1, kModeClosest, "AABB interval, identity");
  const Comparison b = run_single(kSegmentIndex, Transform3x4(), kRays, 3, kModeClosest, "voxel segments, identity");
  for (const Comparison* c : {&a, &b}) {
    expect_agreement(*c, kModeClosest);
    EXPECT_GT(c->cpu_hits, kRays / 5);  // not vacuous
    EXPECT_EQ(c->gpu_hits_per_instance[0], c->gpu_hits);
    for (size_t k = 0; k < kKinds; ++k) EXPECT_GT(c->hits_per_kind[k], 20u) << kKindNames[k];
  }
}

TEST_F(RtConformance, SkewedInstanceMatchesCpu) {
  const Comparison a =
      run_single(kAabbIndex, test::skewed_instance(), kRays, 2, kModeClosest, "AABB interval, skewed instance");
  const Comparison b =
      run_single(kSegmentIndex, test::skewed_instance(), kRays, 4, kModeClosest, "voxel segments, skewed instance");
  for (const Comparison* c : {&a, &b}) {
    expect_agreement(*c, kModeClosest);
    EXPECT_GT(c->cpu_hits, kRays / 5);
    for (size_t k = 0; k < kKinds; ++k) EXPECT_GT(c->hits_per_kind[k], 20u) << kKindNames[k];
  }
}

// 8-bit grid features (int8 codes times a per-level scale, lsnif_grid_value in the shader): the same
// agreement with the CPU reference, whose grid holds the same code * scale products.
TEST_F(RtConformance, EightBitGridModelMatchesCpu) {
  const Comparison a =
      run_single(kEightBitIndex, Transform3x4(), kRays, 12, kModeClosest, "8-bit grid, voxel segments, identity");
  const Comparison b = run_single(kEightBitIndex, test::skewed_instance(), kRays, 13, kModeClosest,
                                  "8-bit grid, voxel segments, skewed instance");
  for (const Comparison* c : {&a, &b}) {
    expect_agreement(*c, kModeClosest);
    EXPECT_GT(c->cpu_hits, kRays / 5);
    for (size_t k = 0; k < kKinds; ++k) EXPECT_GT(c->hits_per_kind[k], 20u) << kKindNames[k];
  }
}

// Surface channels: the intersection shader packs the model's metallic, roughness, ambient occlusion
// (unorm8) and emission (RGBE, up to 40 here) into the hit attributes, the closest-hit shader decodes
// them with lsnif_hit.glsl: the CPU reference's channels per ray, on both instances.
TEST_F(RtConformance, SurfaceChannelsReachTheClosestHitShader) {
  const Comparison a =
      run_single(kSurfaceIndex, Transform3x4(), kRays, 14, kModeClosest, "surface channels, identity");
  const Comparison b =
      run_single(kSurfaceIndex, test::skewed_instance(), kRays, 15, kModeClosest, "surface channels, skewed instance");
  for (const Comparison* c : {&a, &b}) {
    expect_agreement(*c, kModeClosest);
    EXPECT_GT(c->cpu_hits, kRays / 5);
    EXPECT_EQ(c->surface.learned, c->both_hit);
    EXPECT_GT(c->surface.emission_max, 0.0) << "not vacuous: the closest-hit shader decodes emission";
  }
}

// Texture coordinates: the intersection shader reads a hit's coordinate from the uv cells and packs
// it into the attributes (LSNIF_HIT_UV_BIT), the closest-hit shader decodes it with lsnif_hit.glsl:
// the CPU reference's per ray, to the packing's 16 fractional bits, on both instances, of a model of a
// sphere whose layout has seams and a mirrored half (test::layout_sphere).
TEST_F(RtConformance, TextureCoordinatesReachTheClosestHitShader) {
  const Comparison a = run_single(kUvIndex, Transform3x4(), kRays, 16, kModeClosest, "uv cells, identity");
  const Comparison b = run_single(kUvIndex, test::skewed_instance(), kRays, 17, kModeClosest, "uv cells, skewed instance");
  for (const Comparison* c : {&a, &b}) {
    expect_agreement(*c, kModeClosest);
    EXPECT_GT(c->uv_both, c->both_hit / 2) << "not vacuous: most hits report a texture coordinate";
    EXPECT_LE(double(c->uv_one_side), 2e-3 * double(c->both_hit));
    EXPECT_LE(double(c->uv_apart), 5e-3 * double(c->both_hit));
  }
}

// Two instances of one model in one TLAS: the skewed one and an identity one shifted by 40% of the
// model's extent along x (their boxes overlap, so many rays cross both and the closer must win).
// Rays are aimed at either instance (half each).
std::vector<Transform3x4> two_instances(const Model& model) {
  return {test::skewed_instance(), translated(glm::vec3(0.4f * model.bounds().extent().x, 0.0f, 0.0f) +
                                              test::skewed_translation())};
}

TEST_F(RtConformance, TwoInstancesReportTheCloserHit) {
  const Model& model = models_[kSegmentIndex];
  const std::vector<Transform3x4> xfs = two_instances(model);
  std::vector<Ray> world;
  std::vector<int> kinds;
  make_world_rays(model, instance_of(xfs[0]), kRays / 2, 5, world, kinds);
  make_world_rays(model, instance_of(xfs[1]), kRays / 2, 6, world, kinds);
  const Comparison c = run(kSegmentIndex, xfs, world, kinds, kModeClosest, "voxel segments, two instances");
  expect_agreement(c, kModeClosest);
  EXPECT_GT(c.cpu_hits, kRays / 5);
  EXPECT_GT(c.gpu_hits_per_instance[0], kRays / 20);
  EXPECT_GT(c.gpu_hits_per_instance[1], kRays / 20);
  EXPECT_EQ(c.gpu_hits_per_instance[0] + c.gpu_hits_per_instance[1], c.gpu_hits);
  // Rays crossing both instances where the CPU says the far-away instance's hit is not the closest:
  // the count of rays both instances hit must be substantial for this test to mean something.
  std::vector<LsnifHit> h0(world.size()), h1(world.size());
  ASSERT_TRUE(intersect(model, xfs[0], world.data(), world.size(), h0.data()));
  ASSERT_TRUE(intersect(model, xfs[1], world.data(), world.size(), h1.data()));
  size_t both = 0;
  for (size_t i = 0; i < world.size(); ++i) both += h0[i].hit && h1[i].hit;
  std::printf("rays that hit both instances on the CPU: %zu\n", both);
  EXPECT_GT(both, kRays / 50);
}

TEST_F(RtConformance, ShadowRaysMatchCpuVisibility) {
  const Comparison a =
      run_single(kAabbIndex, test::skewed_instance(), kRays, 7, kModeShadow, "AABB interval, shadow rays");
  const Model& model = models_[kSegmentIndex];
  const std::vector<Transform3x4> xfs = two_instances(model);
  std::vector<Ray> world;
  std::vector<int> kinds;
  make_world_rays(model, instance_of(xfs[0]), kRays / 2, 8, world, kinds);
  make_world_rays(model, instance_of(xfs[1]), kRays / 2, 9, world, kinds);
  const Comparison b = run(kSegmentIndex, xfs, world, kinds, kModeShadow, "voxel segments, two instances, shadow");
  for (const Comparison* c : {&a, &b}) {
    expect_agreement(*c, kModeShadow);
    EXPECT_GT(c->cpu_hits, kRays / 5);
    EXPECT_LT(c->cpu_hits, kRays - kRays / 5);
  }
}

// Moving instances: a TLAS of two instances of one model built once with ALLOW_UPDATE, then per
// frame the plugin makes new instance records for moved transforms (rotation about a tilted axis,
// non-uniform scale, translation along a path) and the TLAS is refitted in place (update) on
// frames 1-4 and rebuilt from scratch on frame 5; the models and BLASes stay untouched. Each frame,
// rays aimed at the instances' current placement must match the CPU reference at the current
// transforms, and enough of them must hit differently than at the previous frame's transforms (the
// motion is visible, so a stale TLAS would fail).
Transform3x4 moving_instance(const Model& model, int frame, int which) {
  const float angle = 0.35f * float(frame) + 1.3f * float(which);
  const glm::vec3 axis = glm::normalize(glm::vec3(0.3f, 1.0f, 0.2f * float(which + 1)));
  const float c = std::cos(angle), s = std::sin(angle);
  const glm::mat3 K(0, axis.z, -axis.y, -axis.z, 0, axis.x, axis.y, -axis.x, 0);  // cross-product matrix
  const glm::mat3 R = glm::mat3(1.0f) + s * K + (1 - c) * K * K;
  const glm::mat3 A = R * glm::mat3(glm::vec3(1.0f + 0.1f * float(frame), 0, 0), glm::vec3(0, 0.8f, 0),
                                    glm::vec3(0, 0, 1.2f));
  const Aabb& b = model.bounds();
  const glm::vec3 T = -A * b.center() + b.diagonal() * glm::vec3(0.15f * float(frame) + 0.6f * float(which),
                                                                 0.05f * float(frame), -0.1f * float(which));
  Transform3x4 xf;
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) xf.m[r][k] = A[k][r];
    xf.m[r][3] = T[r];
  }
  return xf;
}

TEST_F(RtConformance, MovingInstancesFollowTlasUpdates) {
  const Model& model = models_[kSegmentIndex];
  std::vector<Transform3x4> xfs = {moving_instance(model, 0, 0), moving_instance(model, 0, 1)};
  std::vector<VkAccelerationStructureInstanceKHR> records(2);
  for (int k = 0; k < 2; ++k)
    ASSERT_TRUE(plugin_.make_instance(handles_[kSegmentIndex], xfs[size_t(k)], kSegmentIndex, 0xFF, 0, records[size_t(k)]));
  vk::AccelerationStructure tlas;
  ASSERT_TRUE(tracer_.build_tlas(records, tlas, /*allow_update=*/true));
  const VkDeviceAddress blas_before = plugin_.properties(handles_[kSegmentIndex]).blasAddress;
  for (int frame = 1; frame <= 5; ++frame) {
    const std::vector<Transform3x4> previous = xfs;
    xfs = {moving_instance(model, frame, 0), moving_instance(model, frame, 1)};
    for (int k = 0; k < 2; ++k)
      ASSERT_TRUE(plugin_.make_instance(handles_[kSegmentIndex], xfs[size_t(k)], kSegmentIndex, 0xFF, 0, records[size_t(k)]));
    if (frame < 5) {
      ASSERT_TRUE(tracer_.update_tlas(records, tlas));
    } else {
      tracer_.destroy(tlas);
      ASSERT_TRUE(tracer_.build_tlas(records, tlas, true));
    }
    std::vector<Ray> world;
    std::vector<int> kinds;
    make_world_rays(model, instance_of(xfs[0]), kRays / 4, uint32_t(40 + frame), world, kinds);
    make_world_rays(model, instance_of(xfs[1]), kRays / 4, uint32_t(60 + frame), world, kinds);
    char name[64];
    std::snprintf(name, sizeof(name), "moving instances, frame %d (%s)", frame, frame < 5 ? "update" : "rebuild");
    const Comparison c = run(kSegmentIndex, xfs, world, kinds, kModeClosest, name, 0, &tlas);
    expect_agreement(c, kModeClosest);
    EXPECT_GT(c.gpu_hits_per_instance[0], kRays / 40);
    EXPECT_GT(c.gpu_hits_per_instance[1], kRays / 40);
    // The same rays against the previous frame's placement: many answers differ.
    size_t changed = 0;
    std::vector<LsnifHit> now0(world.size()), now1(world.size()), old0(world.size()), old1(world.size());
    ASSERT_TRUE(intersect(model, xfs[0], world.data(), world.size(), now0.data()));
    ASSERT_TRUE(intersect(model, xfs[1], world.data(), world.size(), now1.data()));
    ASSERT_TRUE(intersect(model, previous[0], world.data(), world.size(), old0.data()));
    ASSERT_TRUE(intersect(model, previous[1], world.data(), world.size(), old1.data()));
    for (size_t i = 0; i < world.size(); ++i) changed += (now0[i].hit || now1[i].hit) != (old0[i].hit || old1[i].hit);
    std::printf("frame %d: %zu of %zu rays hit differently at the previous frame's transforms\n", frame, changed,
                world.size());
    EXPECT_GT(changed, world.size() / 20);
  }
  EXPECT_EQ(plugin_.properties(handles_[kSegmentIndex]).blasAddress, blas_before);  // models untouched
  tracer_.destroy(tlas);
  vk::AccelerationStructure plain;
  ASSERT_TRUE(tracer_.build_tlas(records, plain));
  EXPECT_FALSE(tracer_.update_tlas(records, plain));  // not built for updates: a clear error
  records.pop_back();
  tracer_.destroy(plain);
}

// The self-intersection rule (host_device.h): rays leaving LSNIF hits of the skewed instance start
// at the predicted hit point with tmin = leaving_tmin and CullBackFacingTriangles (then, for the
// flag's twin, CullFrontFacingTriangles); directions cosine-distributed about the predicted world
// normal, as a renderer would draw them. The GPU must agree with the CPU reference under the same
// flags, and the flags must change results (not vacuous).
TEST_F(RtConformance, RaysLeavingTheSurfaceFollowTheRule) {
  const Model& model = models_[kSegmentIndex];
  const Transform3x4 xf = test::skewed_instance();
  std::vector<Ray> primary, secondary;
  std::vector<int> kinds, secondary_kinds;
  make_world_rays(model, instance_of(xf), 4 * kRays, 11, primary, kinds);
  std::vector<LsnifHit> hits(primary.size());
  ASSERT_TRUE(intersect(model, xf, primary.data(), primary.size(), hits.data()));
  std::mt19937 rng(12);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (size_t i = 0; i < primary.size() && secondary.size() < kRays; ++i) {
    if (kinds[i] != kOutside || !hits[i].hit) continue;
    const glm::vec3 n = hits[i].normal;
    const glm::vec3 a = std::fabs(n.x) > 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0);
    const glm::vec3 t = glm::normalize(glm::cross(a, n)), b = glm::cross(n, t);
    const float u1 = u(rng), phi = 6.2831853f * u(rng);
    Ray r;
    r.origin = primary[i].origin + hits[i].t * primary[i].direction;
    r.direction = std::sqrt(u1) * (std::cos(phi) * t + std::sin(phi) * b) + std::sqrt(1.0f - u1) * n;
    r.tmin = leaving_tmin(model, xf, r.direction);
    ASSERT_GT(r.tmin, 0.0f);
    secondary.push_back(r);
    secondary_kinds.push_back(kInOccupied);
  }
  ASSERT_GT(secondary.size(), kRays / 4);
  std::vector<LsnifHit> plain(secondary.size()), back(secondary.size()), front(secondary.size());
  ASSERT_TRUE(intersect(model, xf, secondary.data(), secondary.size(), plain.data()));
  ASSERT_TRUE(intersect(model, xf, secondary.data(), secondary.size(), back.data(), LSNIF_RAY_FLAG_CULL_BACK_FACING));
  ASSERT_TRUE(intersect(model, xf, secondary.data(), secondary.size(), front.data(), LSNIF_RAY_FLAG_CULL_FRONT_FACING));
  size_t n_plain = 0, n_back = 0, n_front = 0;
  for (size_t i = 0; i < secondary.size(); ++i) {
    n_plain += plain[i].hit;
    n_back += back[i].hit;
    n_front += front[i].hit;
    // Culling removes hits by the facing of the predicted normal, never adds or moves one.
    if (back[i].hit) {
      EXPECT_TRUE(plain[i].hit && plain[i].t == back[i].t && glm::dot(back[i].normal, secondary[i].direction) <= 0);
    }
    if (front[i].hit) {
      EXPECT_TRUE(plain[i].hit && plain[i].t == front[i].t && glm::dot(front[i].normal, secondary[i].direction) >= 0);
    }
  }
  std::printf("leaving rays: %zu, CPU hits without culling %zu, culling back faces %zu, front faces %zu\n",
              secondary.size(), n_plain, n_back, n_front);
  EXPECT_LT(n_back, n_plain);
  EXPECT_LT(n_front, n_plain);
  EXPECT_EQ(n_back + n_front, n_plain);  // no predicted normal is exactly tangent here
  const Comparison cb = run(kSegmentIndex, {xf}, secondary, secondary_kinds, kModeClosest,
                            "leaving rays, cull back-facing", LSNIF_RAY_FLAG_CULL_BACK_FACING);
  const Comparison cf = run(kSegmentIndex, {xf}, secondary, secondary_kinds, kModeClosest,
                            "leaving rays, cull front-facing", LSNIF_RAY_FLAG_CULL_FRONT_FACING);
  for (const Comparison* c : {&cb, &cf}) expect_agreement(*c, kModeClosest);
  EXPECT_EQ(cb.cpu_hits, n_back);
  EXPECT_EQ(cf.cpu_hits, n_front);
}

// A mixed TLAS: the voxel-segments model as an identity LSNIF instance (custom index 1, hit group 0)
// beside a triangle instance of the elephant mesh (rotated 90 degrees about y, scaled 0.8, shifted
// by 55% of the model's x extent so the boxes overlap; custom index kTriangleIndex, hit group 1).
// Truth per ray: the closer of lsnif::intersect and the closest triangle of the mesh moved to world
// space, every triangle tested (closest_triangle_hit). Rays from every direction around the pair and from inside their boxes.
constexpr uint32_t kTriangleIndex = 5;

struct MixedComparison {
  size_t rays = 0, cpu_hits = 0, gpu_hits = 0, hit_agree = 0, kind_mismatch = 0, ties = 0;
  size_t lsnif_closest = 0, triangle_closest = 0, both_kinds_hit = 0, closest_hit_ran = 0;
  size_t lsnif_compared = 0, triangle_compared = 0, triangle_index_mismatch = 0;
  double lsnif_t_err_max = 0, lsnif_normal_deg_max = 0, triangle_t_err_max = 0;
};

TEST_F(RtConformance, MixedTlasWithTrianglesMatchesCpuAndBruteForce) {
  const Model& model = models_[kSegmentIndex];
  const Aabb& b = model.bounds();
  const glm::vec3 ext = b.extent();
  const float diag = b.diagonal();
  // Triangle instance: world = M p + T with M = 0.8 * rotation about y by 90 degrees.
  const glm::mat3 M = 0.8f * glm::mat3(glm::vec3(0, 0, -1), glm::vec3(0, 1, 0), glm::vec3(1, 0, 0));
  const glm::vec3 T = b.center() + glm::vec3(0.55f * ext.x, 0, 0) - M * mesh_.bounds().center();
  Mesh world_mesh = mesh_;
  for (glm::vec3& p : world_mesh.positions) p = M * p + T;

  std::vector<float> positions;
  std::vector<uint32_t> indices;
  for (const glm::vec3& p : mesh_.positions) positions.insert(positions.end(), {p.x, p.y, p.z});
  for (const glm::uvec3& t : mesh_.triangles) indices.insert(indices.end(), {t.x, t.y, t.z});
  vk::AccelerationStructure tri_blas, tlas;
  ASSERT_TRUE(tracer_.build_triangle_blas(positions, indices, tri_blas));
  std::vector<VkAccelerationStructureInstanceKHR> records(2);
  ASSERT_TRUE(plugin_.make_instance(handles_[kSegmentIndex], Transform3x4(), kSegmentIndex, 0xFF, 0, records[0]));
  VkAccelerationStructureInstanceKHR& tri = records[1];
  tri = VkAccelerationStructureInstanceKHR{};
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) tri.transform.matrix[r][c] = M[c][r];
    tri.transform.matrix[r][3] = T[r];
  }
  tri.instanceCustomIndex = kTriangleIndex;
  tri.mask = 0xFF;
  tri.instanceShaderBindingTableRecordOffset = mixed_pipeline_.triangle_sbt_offset & 0xffffffu;
  tri.accelerationStructureReference = tri_blas.address;
  ASSERT_TRUE(tracer_.build_tlas(records, tlas));

  Aabb scene = world_mesh.bounds();
  scene.lo = glm::min(scene.lo, b.lo);
  scene.hi = glm::max(scene.hi, b.hi);
  const glm::vec3 center = scene.center(), sext = scene.extent();
  const float sdiag = scene.diagonal();
  std::mt19937 rng(21);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  auto unit_vector = [&] { return random_unit_vector(rng); };
  constexpr size_t kMixedRays = 6000;
  for (const uint32_t mode : {kModeClosest, kModeShadow}) {
    std::vector<Ray> world(kMixedRays);
    for (size_t i = 0; i < kMixedRays; ++i) {
      Ray& r = world[i];
      if (i % 3 == 2) {  // from inside the pair's box, any direction
        r.origin = scene.lo + sext * glm::vec3(u(rng), u(rng), u(rng));
        r.direction = (0.5f + u(rng)) * unit_vector();
      } else {  // from a sphere around the pair towards a point of its box (or of the LSNIF box)
        r.origin = center + sdiag * (0.8f + 0.7f * u(rng)) * unit_vector();
        const glm::vec3 target = i % 3 == 0 ? scene.lo + sext * glm::vec3(u(rng), u(rng), u(rng))
                                            : b.lo + ext * glm::vec3(u(rng), u(rng), u(rng));
        r.direction = target - r.origin;
      }
      // Shadow rays end before, in or behind the objects: from outside at 0.6..1.4 of the way to
      // the target, from inside after 5%..55% of the pair's diagonal.
      if (mode == kModeShadow)
        r.tmax = i % 3 == 2 ? (0.05f + 0.5f * u(rng)) * sdiag / glm::length(r.direction) : 0.6f + 0.8f * u(rng);
    }
    std::vector<LsnifHit> lsnif_hits(kMixedRays);
    ASSERT_TRUE(intersect(model, Transform3x4(), world.data(), kMixedRays, lsnif_hits.data()));

    vk::Buffer ray_buf, hit_buf;
    ASSERT_TRUE(vk_.create_buffer(kMixedRays * sizeof(LsnifReferenceRay), ray_buf));
    ASSERT_TRUE(vk_.create_buffer(kMixedRays * sizeof(LsnifReferenceHit), hit_buf));
    auto* rays = static_cast<LsnifReferenceRay*>(ray_buf.mapped);
    for (size_t i = 0; i < kMixedRays; ++i) {
      const Ray& r = world[i];
      rays[i] = {r.origin.x, r.origin.y, r.origin.z, r.tmin, r.direction.x, r.direction.y, r.direction.z, r.tmax};
    }
    RtPush push;
    push.model_table = table_.address;
    push.model_count = kModels;
    push.rays = ray_buf.address;
    push.hits = hit_buf.address;
    push.ray_count = uint32_t(kMixedRays);
    push.mode = mode;
    const auto t0 = std::chrono::steady_clock::now();
    const Status s = tracer_.trace(mixed_pipeline_, tlas, &push, uint32_t(kMixedRays));
    const double gpu_seconds = seconds_since(t0);
    EXPECT_TRUE(s) << s.message();
    const auto* hits = static_cast<const LsnifReferenceHit*>(hit_buf.mapped);
    std::vector<LsnifReferenceHit> gpu(hits, hits + kMixedRays);
    vk_.destroy_buffer(ray_buf);
    vk_.destroy_buffer(hit_buf);

    MixedComparison c;
    c.rays = kMixedRays;
    for (size_t i = 0; i < kMixedRays; ++i) {
      const LsnifHit& l = lsnif_hits[i];
      const TriangleHit e = closest_triangle_hit(world_mesh, world[i]);
      const LsnifReferenceHit& g = gpu[i];
      const bool cpu_hit = l.hit || e.hit;
      const bool lsnif_first = l.hit && (!e.hit || l.t < e.t);
      c.cpu_hits += cpu_hit;
      c.gpu_hits += g.hit != 0;
      c.closest_hit_ran += g.instance != 0xffffffffu;
      c.both_kinds_hit += l.hit && e.hit;
      if (g.hit != 0 && cpu_hit) ++c.hit_agree;
      else if (g.hit == 0 && !cpu_hit) ++c.hit_agree;
      if (mode != kModeClosest || !cpu_hit || !g.hit) continue;
      lsnif_first ? ++c.lsnif_closest : ++c.triangle_closest;
      const bool gpu_triangle = (g.instance >> 16) == kTriangleIndex;
      const double span = double(diag) / double(glm::length(world[i].direction));
      if (gpu_triangle == lsnif_first) {
        // Either kind may be reported when both hits lie within kIntervalEps diagonals.
        if (l.hit && e.hit && std::fabs(double(l.t) - double(e.t)) < kIntervalEps * span) ++c.ties;
        else ++c.kind_mismatch;
        continue;
      }
      if (gpu_triangle) {
        ++c.triangle_compared;
        c.triangle_t_err_max = std::max(c.triangle_t_err_max, std::fabs(double(g.t) - double(e.t)) / span);
        c.triangle_index_mismatch += g.material != e.triangle;
      } else {
        ++c.lsnif_compared;
        EXPECT_EQ(g.instance >> 16, kSegmentIndex);
        c.lsnif_t_err_max = std::max(c.lsnif_t_err_max, std::fabs(double(g.t) - double(l.t)) / span);
        const glm::dvec3 gn(g.normal_x, g.normal_y, g.normal_z), hn(l.normal);
        c.lsnif_normal_deg_max =
            std::max(c.lsnif_normal_deg_max, std::acos(std::clamp(glm::dot(gn, hn), -1.0, 1.0)) * 180.0 / M_PI);
      }
    }
    std::printf("[mixed TLAS, %s] trace %.3f s: %zu rays, cpu hits %zu, gpu hits %zu, hit agreement %.4f%%, "
                "closest LSNIF %zu / triangles %zu, both kinds hit %zu, kind mismatches %zu (ties %zu); LSNIF: %zu "
                "compared, t error / diagonal max %.3g, normal max %.3g deg; triangles: %zu compared, t error / "
                "diagonal max %.3g, triangle index mismatches %zu\n",
                mode == kModeClosest ? "closest" : "shadow", gpu_seconds, c.rays, c.cpu_hits, c.gpu_hits,
                100.0 * double(c.hit_agree) / double(c.rays), c.lsnif_closest, c.triangle_closest, c.both_kinds_hit,
                c.kind_mismatch, c.ties, c.lsnif_compared, c.lsnif_t_err_max, c.lsnif_normal_deg_max,
                c.triangle_compared, c.triangle_t_err_max, c.triangle_index_mismatch);
    EXPECT_GE(double(c.hit_agree), 0.999 * double(c.rays));
    if (mode == kModeShadow) {
      EXPECT_EQ(c.closest_hit_ran, 0u);
      EXPECT_GT(c.cpu_hits, kMixedRays / 5);
      EXPECT_LT(c.cpu_hits, kMixedRays - kMixedRays / 5);
      continue;
    }
    EXPECT_EQ(c.closest_hit_ran, c.gpu_hits);
    EXPECT_GT(c.both_kinds_hit, kMixedRays / 50);  // rays that must pick the closer kind
    EXPECT_LE(double(c.kind_mismatch), 1e-3 * double(c.rays));
    EXPECT_GT(c.lsnif_closest, kMixedRays / 20);
    EXPECT_GT(c.triangle_closest, kMixedRays / 20);
    EXPECT_LT(c.lsnif_t_err_max, 2e-4);
    EXPECT_LT(c.lsnif_normal_deg_max, 0.3);
    EXPECT_LT(c.triangle_t_err_max, 1e-5);
    EXPECT_LE(double(c.triangle_index_mismatch), 1e-3 * double(c.triangle_compared));
  }
  tracer_.destroy(tlas);
  tracer_.destroy(tri_blas);
}

// The zero-message assertions mean something only if this device's messenger counts errors.
TEST_F(RtConformance, ValidationMessengerCountsErrors) {
  if (!test::test_validation()) GTEST_SKIP() << "needs the validation layer (LSNIF_TEST_VALIDATION=0)";
  const uint32_t before = vk_.validation_errors();
  VkBufferCreateInfo bci{};
  bci.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
  bci.size = 64;
  bci.usage = 0;
  std::printf("(one validation error is expected next)\n");
  std::fflush(stdout);
  VkBuffer buffer = VK_NULL_HANDLE;
  vkCreateBuffer(vk_.device(), &bci, nullptr, &buffer);
  if (buffer) vkDestroyBuffer(vk_.device(), buffer, nullptr);
  EXPECT_GT(vk_.validation_errors(), before);
  vk_.reset_validation_counts();
}

}  // namespace
}  // namespace lsnif
