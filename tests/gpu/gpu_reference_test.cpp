// The device LSNIF math (src/lsnif/shaders/lsnif_*.glsl, run as tests/gpu/lsnif_reference.comp through Vulkan
// compute, lavapipe on machines without a GPU) against the CPU reference intersector
// (src/lsnif/core/intersector.cpp), ray by ray, on tiny models trained in-process for both hit
// parametrizations and with hash tables of different sizes per level, and on a random model with
// odd layer sizes, with an identity and a
// rotated/non-uniformly scaled/translated instance. Also checks the GPU block packing
// (src/lsnif/plugin/gpu_model.cpp) value by value, and that the validation layer reported nothing.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <random>
#include <vector>

#include "lsnif/testing/gpu_model.h"
#include "lsnif/core/grid_usage.h"
#include "lsnif/testing/test_support.h"
#include "lsnif/core/half.h"
#include "lsnif/core/intersector.h"
#include "lsnif/import/mesh.h"
#include "lsnif/core/network.h"
#include "lsnif/core/ray_walk.h"
#include "lsnif/testing/test_models.h"
#include "lsnif/train/trainer.h"
#include "lsnif_reference_comp_spirv.h"
#include "lsnif/vulkan/context.h"
#include "lsnif/testing/vk_dispatch.h"
#include "lsnif/testing/gpu_test_support.h"

namespace lsnif {
namespace {

using namespace gputest;

const std::string kElephant = test::data_dir() + "/meshes/elephant.off";

// The push constant block of lsnif_reference.comp (std430: 128 bytes).
struct Push {
  uint64_t model = 0, rays = 0, hits = 0;
  uint32_t ray_count = 0, pad = 0;
  float object_to_world[3][4] = {};
  float world_to_object[3][4] = {};
};
static_assert(sizeof(Push) == 128, "push constant layout");

// A model with random (fp16) parameters and odd sizes everywhere: input 3*1*3 = 9, W = 5, output 10.
Model random_odd_model() {
  Model m;
  Config& c = m.config;
  c.voxel_resolution = 5;
  c.max_points = 3;
  c.grid_levels = 1;
  c.grid_resolution[0] = 15;
  c.grid_resolution[1] = 0;
  set_table_log2(c, 5);
  c.features = 3;
  c.hidden_width = 5;
  c.hidden_layers = 3;
  c.material_count = 2;
  c.hit_param = HitParam::VoxelSegments;
  c.leaky_slope = 0.05f;
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  m.voxels.resolution = c.voxel_resolution;
  m.voxels.bounds.lo = glm::vec3(-1.0f, 0.5f, 2.0f);
  m.voxels.bounds.hi = glm::vec3(2.0f, 1.5f, 4.0f);
  m.voxels.bits.assign(size_t((c.voxel_count() + 31) / 32), 0u);
  for (uint32_t k = 0; k < 5; ++k)
    for (uint32_t j = 0; j < 5; ++j)
      for (uint32_t i = 0; i < 5; ++i)
        if (u(rng) > 0.4f) m.voxels.set(i, j, k);
  m.materials.resize(c.material_count);
  m.grid.resize(size_t(c.grid_parameter_count()));
  for (float& v : m.grid) v = u(rng);
  m.mlp.resize(size_t(c.mlp_parameter_count()));
  mlp_init_kaiming(c, 5, m.mlp.data());
  for (const LayerView& v : mlp_layers(c))
    for (uint32_t i = 0; i < v.out; ++i) m.mlp[v.bias_offset + i] = 0.3f * u(rng);
  m.quantize();
  return m;
}

// random_odd_model with its level indexed (R = 15 over V = 5) and the table's random values redrawn.
Model random_odd_indexed_model() {
  Model m = random_odd_model();
  const bool indexed[LSNIF_MAX_LEVELS] = {true};
  const Status s = index_grid_levels(m.voxels, indexed, m.config, m.grid_index);
  EXPECT_TRUE(s) << s.message();
  std::mt19937 rng(12);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  m.grid.resize(size_t(m.config.grid_parameter_count()));
  for (float& v : m.grid) v = u(rng);
  m.quantize();
  return m;
}

// Object-to-world of the transformed instance: rotation * non-uniform scale, then translation.
Transform3x4 skewed_instance() { return test::skewed_instance(); }

struct Comparison {
  size_t rays = 0, walk_mismatch = 0, cpu_hits = 0, gpu_hits = 0, hit_agree = 0;
  size_t flips_threshold = 0, flips_interval = 0, flips_walk = 0, flips_other = 0;
  size_t both_hit = 0, material_mismatch = 0, hits_per_kind[kKinds] = {};
  double t_err_max = 0, t_err_sum = 0, normal_deg_max = 0, normal_deg_sum = 0, albedo_max = 0;
  double occlusion_max = 0;  // |sigmoid(gpu logit) - cpu occlusion| where both walks match
  bool surface_channels = false;  // the model's: every hit's surface word is learned, else 0
  SurfaceAgreement surface;       // where both hit
  // Texture coordinates where both hit: hits reporting one on both sides, on one side only, and
  // those whose coordinates differ by more than 1e-4.
  size_t uv_both = 0, uv_one_side = 0, uv_apart = 0;
  double uv_err_max = 0;
};

// A flip (hit on one side only) is "threshold" when the occlusion logit is within kLogitEps of 0,
// "interval" when t is within kIntervalEps (of the ray's diagonal span) of tmin or tmax, "walk"
// when the walks differ (a ray grazing a voxel face or edge: the object-space ray differs in the last
// bit between the compilers' float contraction choices).
constexpr float kLogitEps = 1e-3f;
constexpr double kIntervalEps = 1e-4;

Comparison compare(const Model& model, const Instance& in, const std::vector<Ray>& world,
                   const std::vector<int>& kinds, const std::vector<LsnifHit>& cpu,
                   const std::vector<LsnifReferenceHit>& gpu) {
  Comparison c;
  c.rays = world.size();
  c.surface_channels = model.config.surface_channels != 0;
  const float scale = model.config.emission_scale;
  // The emission is fp32 here (no RGBE): the sigmoid's difference between the two sides, bounded as
  // the albedo's, times the scale.
  const auto emission_tolerance = [scale](float) { return 1e-4f * scale; };
  const float diag = model.bounds().diagonal();
  for (size_t i = 0; i < world.size(); ++i) {
    Ray o;
    o.origin = in.A_inv * (world[i].origin - in.T);
    o.direction = in.A_inv * world[i].direction;
    o.tmin = world[i].tmin;
    o.tmax = std::numeric_limits<float>::infinity();
    RayWalk walk;
    walk_ray(model.voxels, o, model.config.max_points, walk);
    const double span = double(diag) / double(glm::length(o.direction));  // t units per diagonal
    const LsnifHit& h = cpu[i];
    const LsnifReferenceHit& g = gpu[i];
    const bool walk_same = walk.count == g.points;
    c.walk_mismatch += !walk_same;
    c.cpu_hits += h.hit;
    c.gpu_hits += g.hit != 0;
    if (walk_same && walk.count > 0) {
      const double occ = 1.0 / (1.0 + std::exp(-double(g.occlusion_logit)));
      c.occlusion_max = std::max(c.occlusion_max, std::fabs(occ - double(h.occlusion)));
    }
    if (h.hit == (g.hit != 0)) {
      ++c.hit_agree;
    } else if (!walk_same) {
      ++c.flips_walk;
    } else if (std::fabs(g.occlusion_logit) < kLogitEps) {
      ++c.flips_threshold;
    } else if (std::fabs(double(g.t) - double(world[i].tmin)) < kIntervalEps * span ||
               std::fabs(double(g.t) - double(world[i].tmax)) < kIntervalEps * span) {
      ++c.flips_interval;
    } else {
      ++c.flips_other;
      if (c.flips_other <= 5)
        std::printf("unexplained flip: ray %zu cpu hit %d occ %.6f t %.7g | gpu hit %u logit %.6g t %.7g\n", i,
                    int(h.hit), double(h.occlusion), double(h.t), g.hit, double(g.occlusion_logit),
                    double(g.t));
    }
    if (!(h.hit && g.hit && walk_same)) continue;
    ++c.both_hit;
    ++c.hits_per_kind[kinds[i]];
    const double t_err = std::fabs(double(g.t) - double(h.t)) / span;
    c.t_err_max = std::max(c.t_err_max, t_err);
    c.t_err_sum += t_err;
    const glm::dvec3 gn(g.normal_x, g.normal_y, g.normal_z), hn(h.normal);
    const double cosang = std::clamp(glm::dot(gn, hn), -1.0, 1.0);
    const double deg = std::acos(cosang) * 180.0 / M_PI;
    c.normal_deg_max = std::max(c.normal_deg_max, deg);
    c.normal_deg_sum += deg;
    const glm::vec3 ga(g.albedo_x, g.albedo_y, g.albedo_z);
    for (int k = 0; k < 3; ++k) c.albedo_max = std::max(c.albedo_max, double(std::fabs(ga[k] - h.albedo[k])));
    c.material_mismatch += g.material != h.material;
    add_surface(c.surface, g.surface, glm::vec3(g.emission_r, g.emission_g, g.emission_b), h, scale,
                emission_tolerance);
    if (h.reports_uv != (g.reports_uv != 0)) {
      ++c.uv_one_side;
    } else if (h.reports_uv) {
      ++c.uv_both;
      const double err = glm::length(glm::dvec2(g.uv_u, g.uv_v) - glm::dvec2(h.uv));
      c.uv_err_max = std::max(c.uv_err_max, err);
      c.uv_apart += err > 1e-4;
    }
  }
  return c;
}

void print(const char* name, const Comparison& c) {
  std::printf(
      "%s: %zu rays, cpu hits %zu, gpu hits %zu, hit agreement %.4f%% (flips: %zu threshold, %zu interval, "
      "%zu walk, %zu other), walk mismatches %zu\n"
      "  both hit %zu (per kind %zu/%zu/%zu/%zu): t error / diagonal max %.3g mean %.3g, normal angle max "
      "%.3g deg mean %.3g deg, albedo max %.3g, material mismatches %zu, occlusion max diff %.3g\n"
      "  surface channels: %zu of %zu hits learned, %zu words bit-identical, %zu beyond one unorm8 step, "
      "emission max error / scale %.3g\n"
      "  texture coordinates: %zu hits on both sides, %zu on one side, %zu apart by > 1e-4, max difference %.3g\n",
      name, c.rays, c.cpu_hits, c.gpu_hits, 100.0 * double(c.hit_agree) / double(c.rays), c.flips_threshold,
      c.flips_interval, c.flips_walk, c.flips_other, c.walk_mismatch, c.both_hit, c.hits_per_kind[0],
      c.hits_per_kind[1], c.hits_per_kind[2], c.hits_per_kind[3], c.t_err_max,
      c.both_hit ? c.t_err_sum / double(c.both_hit) : 0.0, c.normal_deg_max,
      c.both_hit ? c.normal_deg_sum / double(c.both_hit) : 0.0, c.albedo_max, c.material_mismatch,
      c.occlusion_max, c.surface.learned, c.surface.hits, c.surface.exact, c.surface.step_mismatch,
      c.surface.emission_max, c.uv_both, c.uv_one_side, c.uv_apart, c.uv_err_max);
}

constexpr size_t kRaysPerInstance = 5000;  // x 2 instances x 2 models = 20k trained-model rays

class GpuReference : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    vk_status_ = vk_.init(/*ray_tracing=*/false, test::test_validation(), test::test_device());
    if (vk_status_) {
      std::printf("Vulkan device: %s\n", vk_.device_name().c_str());
      vk_status_ = vk_.create_pipeline(vk::Spirv{lsnif_reference_comp_spirv, sizeof lsnif_reference_comp_spirv}, sizeof(Push), pipeline_);
      // lavapipe compiles the shader with LLVM at the first dispatch (unless MESA_SHADER_CACHE_DIR
      // has it): an empty dispatch (ray_count 0, no memory touched) measures that alone.
      const auto t1 = std::chrono::steady_clock::now();
      Push empty;
      if (vk_status_) vk_status_ = gputest::dispatch(vk_, pipeline_, &empty, 1);
      std::printf("lsnif_reference.comp: vkCreateComputePipelines %.3f s, first (empty) dispatch %.3f s\n",
                  pipeline_.create_seconds, seconds_since(t1));
    }
    if (!std::filesystem::exists(kElephant)) {
      train_status_ = Status::error("%s missing: run scripts/setup.sh", kElephant.c_str());
      return;
    }
    Mesh mesh;
    if (!load_mesh(kElephant, mesh)) {
      train_status_ = Status::error("cannot load %s", kElephant.c_str());
      return;
    }
    const auto t0 = std::chrono::steady_clock::now();
    train_status_ = test::tiny_model("elephant.aabb", mesh, tiny_settings(HitParam::AabbInterval), aabb_model_);
    if (train_status_) train_status_ = test::tiny_model("elephant.segments", mesh, tiny_settings(HitParam::VoxelSegments), segment_model_);
    if (train_status_) train_status_ = test::tiny_model("elephant.unequal_tables", mesh, unequal_tables_settings(), unequal_model_);
    if (train_status_) train_status_ = test::tiny_model("elephant.indexed_level", mesh, indexed_level_settings(), indexed_model_);
    std::printf("trained 4 tiny models in %.2f s\n", seconds_since(t0));
  }
  static void TearDownTestSuite() { vk_.destroy_pipeline(pipeline_); }

  // Runs `world` rays through the GPU and the CPU reference for one instance and compares.
  static Comparison run(const Model& model, const Transform3x4& xf, size_t count, uint32_t seed,
                        const char* name) {
    const Instance in = instance_of(xf);
    std::vector<int> kinds;
    std::vector<Ray> world;
    make_world_rays(model, in, count, seed, world, kinds);
    std::vector<LsnifHit> cpu(count);
    auto t0 = std::chrono::steady_clock::now();
    Status s = intersect(model, xf, world.data(), count, cpu.data());
    EXPECT_TRUE(s) << s.message();
    const double cpu_seconds = seconds_since(t0);

    std::vector<uint32_t> words;
    s = pack_gpu_model(model, words);
    EXPECT_TRUE(s) << s.message();
    vk::Buffer model_buf, ray_buf, hit_buf;
    EXPECT_TRUE(vk_.create_buffer(words.size() * 4, model_buf));
    EXPECT_TRUE(vk_.create_buffer(count * sizeof(LsnifReferenceRay), ray_buf));
    EXPECT_TRUE(vk_.create_buffer(count * sizeof(LsnifReferenceHit), hit_buf));
    std::memcpy(model_buf.mapped, words.data(), words.size() * 4);
    auto* rays = static_cast<LsnifReferenceRay*>(ray_buf.mapped);
    for (size_t i = 0; i < count; ++i) {
      const Ray& r = world[i];
      rays[i] = {r.origin.x, r.origin.y, r.origin.z, r.tmin, r.direction.x, r.direction.y, r.direction.z, r.tmax};
    }
    Push push;
    push.model = model_buf.address;
    push.rays = ray_buf.address;
    push.hits = hit_buf.address;
    push.ray_count = uint32_t(count);
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) push.object_to_world[r][c] = xf.m[r][c];
      for (int c = 0; c < 3; ++c) push.world_to_object[r][c] = in.A_inv[c][r];
    }
    t0 = std::chrono::steady_clock::now();
    s = gputest::dispatch(vk_, pipeline_, &push, uint32_t((count + 63) / 64));
    EXPECT_TRUE(s) << s.message();
    const double gpu_seconds = seconds_since(t0);
    const auto* hits = static_cast<const LsnifReferenceHit*>(hit_buf.mapped);
    const std::vector<LsnifReferenceHit> gpu(hits, hits + count);
    vk_.destroy_buffer(model_buf);
    vk_.destroy_buffer(ray_buf);
    vk_.destroy_buffer(hit_buf);

    const Comparison c = compare(model, in, world, kinds, cpu, gpu);
    std::printf("[%s] GPU %.3f s (%.0f rays/s), CPU reference %.3f s\n", name, gpu_seconds,
                double(count) / gpu_seconds, cpu_seconds);
    print(name, c);
    return c;
  }

  // Agreement bounds (justified below).
  static void expect_agreement(const Comparison& c) {
    // Hits: >= 99.9% agree; every flip must be explained (threshold / interval / walk), and those
    // are rare: a logit within 1e-3 of 0, or t within 1e-4 diagonals of tmin/tmax, or a walk that
    // differs (< 0.05% of the rays).
    EXPECT_GE(double(c.hit_agree), 0.999 * double(c.rays));
    EXPECT_EQ(c.flips_other, 0u);
    EXPECT_LE(double(c.walk_mismatch), 5e-4 * double(c.rays));
    // Both sides use the same fp16 parameters in fp32; differences come from the summation order,
    // exp rounding and, through an instance, the last bit of the object-space ray (A^-1 (o - T)
    // with or without fused multiply-adds). The hash grid's slope (R = 64 cells per unit, features
    // of order 1) amplifies a 1e-7 position change to ~1e-5 in the features, so measured maxima
    // are ~1e-5 diagonals in t and ~0.03 deg in the normal (means 100x lower); the bounds leave
    // ~10x for other ray sets and drivers while still catching any formula or layout error (those
    // give errors of percent and degrees).
    EXPECT_LT(c.t_err_max, 2e-4);
    EXPECT_LT(c.both_hit ? c.t_err_sum / double(c.both_hit) : 0.0, 2e-6);
    EXPECT_LT(c.normal_deg_max, 0.3);
    EXPECT_LT(c.both_hit ? c.normal_deg_sum / double(c.both_hit) : 0.0, 0.03);
    EXPECT_LT(c.albedo_max, 1e-4);
    EXPECT_LT(c.occlusion_max, 5e-4);
    EXPECT_EQ(c.material_mismatch, 0u);
    // Surface channels: the learned flag on every hit of a model with them (and the word 0 without),
    // each unorm8 within one step of pack_surface of the CPU's sigmoids, the emission within the
    // albedo's bound times the emission scale.
    expect_surface_agreement(c.surface, c.surface_channels);
  }

  // Two comparisons of a trained model: each within the bounds, not vacuous (hits of every kind).
  static void expect_trained_agreement(const Comparison& a, const Comparison& b) {
    for (const Comparison* c : {&a, &b}) {
      expect_agreement(*c);
      EXPECT_GT(c->cpu_hits, kRaysPerInstance / 5);  // the comparison is not vacuous
      for (size_t k = 0; k < kKinds; ++k) EXPECT_GT(c->hits_per_kind[k], 20u) << kKindNames[k];
    }
  }

  void SetUp() override {
    ASSERT_TRUE(vk_status_) << "no usable Vulkan device: " << vk_status_.message();
  }
  void TearDown() override {
    EXPECT_EQ(vk_.validation_errors(), 0u) << vk_.validation_log();
    EXPECT_EQ(vk_.validation_warnings(), 0u) << vk_.validation_log();
  }

  static vk::Context vk_;
  static vk::Pipeline pipeline_;
  static Status vk_status_, train_status_;
  static Model aabb_model_, segment_model_, unequal_model_, indexed_model_;

  // tiny_settings with level 0's table (R = 32) 2^10 entries and level 1's (R = 64) 2^14.
  static TrainSettings unequal_tables_settings() {
    TrainSettings s = tiny_settings(HitParam::VoxelSegments);
    const uint32_t sizes[2] = {10, 14};
    set_table_log2(s.config, sizes, 2);
    return s;
  }
  // tiny_settings with level 0 indexed (its perfect hash built from the voxels), level 1 hashed.
  static TrainSettings indexed_level_settings() {
    TrainSettings s = tiny_settings(HitParam::VoxelSegments);
    s.indexed[0] = true;
    return s;
  }
};
vk::Context GpuReference::vk_;
vk::Pipeline GpuReference::pipeline_;
Status GpuReference::vk_status_, GpuReference::train_status_;
Model GpuReference::aabb_model_, GpuReference::segment_model_, GpuReference::unequal_model_,
    GpuReference::indexed_model_;

TEST_F(GpuReference, AabbIntervalModelMatchesCpu) {
  ASSERT_TRUE(train_status_) << train_status_.message();
  const Comparison a = run(aabb_model_, Transform3x4(), kRaysPerInstance, 1, "AABB interval, identity");
  const Comparison b = run(aabb_model_, skewed_instance(), kRaysPerInstance, 2, "AABB interval, skewed instance");
  expect_trained_agreement(a, b);
}

TEST_F(GpuReference, VoxelSegmentsModelMatchesCpu) {
  ASSERT_TRUE(train_status_) << train_status_.message();
  const Comparison a = run(segment_model_, Transform3x4(), kRaysPerInstance, 3, "voxel segments, identity");
  const Comparison b = run(segment_model_, skewed_instance(), kRaysPerInstance, 4, "voxel segments, skewed instance");
  expect_trained_agreement(a, b);
}

// Surface channels (metallic, roughness, ambient occlusion, emission) after the material logits:
// the voxel-segments model with random surface rows (with_surface_channels: the hits stay the
// trained model's), emission up to 40, on both instances; RandomOddSizedModelMatchesCpu adds them
// to the odd-sized model (after its 2 material logits: outputs 10 to 15).
TEST_F(GpuReference, SurfaceChannelsModelMatchesCpu) {
  ASSERT_TRUE(train_status_) << train_status_.message();
  const Model model = with_surface_channels(segment_model_, 40.0f, 21);
  ASSERT_EQ(model.config.output_dim(), segment_model_.config.output_dim() + LSNIF_OUT_SURFACE_COUNT);
  const Comparison a = run(model, Transform3x4(), kRaysPerInstance, 12, "surface channels, identity");
  const Comparison b = run(model, skewed_instance(), kRaysPerInstance, 13, "surface channels, skewed instance");
  expect_trained_agreement(a, b);
  for (const Comparison* c : {&a, &b}) {
    EXPECT_EQ(c->surface.learned, c->both_hit);
    EXPECT_GT(c->surface.emission_max, 0.0) << "not vacuous: the GPU reports emission";
  }
  // The packed words vary: the random rows are not saturated.
  std::vector<LsnifHit> cpu(2000);
  const Instance in = instance_of(Transform3x4());
  std::vector<int> kinds;
  std::vector<Ray> world;
  make_world_rays(model, in, cpu.size(), 14, world, kinds);
  ASSERT_TRUE(intersect(model, Transform3x4(), world.data(), world.size(), cpu.data()));
  float lo = 1.0f, hi = 0.0f, emission_hi = 0.0f;
  for (const LsnifHit& h : cpu) {
    if (!h.hit) continue;
    lo = std::min({lo, h.metallic, h.roughness, h.ambient_occlusion});
    hi = std::max({hi, h.metallic, h.roughness, h.ambient_occlusion});
    emission_hi = std::max({emission_hi, h.emission.r, h.emission.g, h.emission.b});
  }
  EXPECT_LT(lo, 0.2f);
  EXPECT_GT(hi, 0.8f);
  EXPECT_GT(emission_hi, 20.0f);
}

// Uv cells: a model of test::layout_sphere (a textured sphere whose layout has seams and a mirrored
// half) reports texture coordinates on its hits; the device's lookup (lsnif_uv_cells.glsl) gives the
// CPU's (UvCells::lookup) on both instances. A hit point differing in its last bits can tip the
// choice between two pieces whose scores tie, or the cut between a ray meeting a plane and a
// projection onto it: rare, and bounded.
TEST_F(GpuReference, UvCellsModelMatchesCpu) {
  Model model;
  const Status trained = uv_sphere_model(model);
  ASSERT_TRUE(trained) << trained.message();
  ASSERT_EQ(model.config.uv_materials, 1u);
  const Comparison a = run(model, Transform3x4(), kRaysPerInstance, 31, "uv cells, identity");
  const Comparison b = run(model, skewed_instance(), kRaysPerInstance, 32, "uv cells, skewed instance");
  for (const Comparison* c : {&a, &b}) {
    EXPECT_GE(double(c->hit_agree), 0.999 * double(c->rays));
    EXPECT_GT(c->uv_both, c->both_hit / 2) << "not vacuous: most hits report a texture coordinate";
    EXPECT_LE(double(c->uv_one_side), 2e-3 * double(c->both_hit));
    EXPECT_LE(double(c->uv_apart), 5e-3 * double(c->both_hit));
  }
}

// 8-bit grid features: the trained models' grids as int8 codes times a per-level scale. The
// shader's lsnif_grid_value decodes them to exactly Model::grid (code * scale in fp32 on both
// sides), so the agreement bounds are those of fp16 grids.
Model with_8bit_grid(Model m) {
  m.config.grid_bits = 8;
  m.quantize();
  return m;
}

TEST_F(GpuReference, EightBitGridModelsMatchCpu) {
  ASSERT_TRUE(train_status_) << train_status_.message();
  const Model aabb = with_8bit_grid(aabb_model_), segments = with_8bit_grid(segment_model_);
  const Comparison a = run(aabb, skewed_instance(), kRaysPerInstance, 6, "8-bit grid, AABB interval, skewed instance");
  const Comparison b = run(segments, Transform3x4(), kRaysPerInstance, 7, "8-bit grid, voxel segments, identity");
  expect_trained_agreement(a, b);
}

// Level 0's table smaller than level 1's: the levels' tables one after another (level 1 starting at
// entry 2^10), each hashed into its own size; fp16 and 8-bit features.
TEST_F(GpuReference, TablesOfDifferentSizesPerLevelMatchCpu) {
  ASSERT_TRUE(train_status_) << train_status_.message();
  ASSERT_EQ(unequal_model_.config.table_log2[0], 10u);
  ASSERT_EQ(unequal_model_.config.table_log2[1], 14u);
  const Comparison a = run(unequal_model_, skewed_instance(), kRaysPerInstance, 8,
                           "tables 2^10 + 2^14, voxel segments, skewed instance");
  const Comparison b = run(with_8bit_grid(unequal_model_), Transform3x4(), kRaysPerInstance, 9,
                           "tables 2^10 + 2^14, 8-bit grid, identity");
  expect_trained_agreement(a, b);
}

// Level 0 indexed: its entries through the perfect hash (lsnif_perfect_hash.glsl against
// src/lsnif/core/perfect_hash.h), level 1's table after level 0's index_slots entries, the displacements in
// the block's index section; fp16 and 8-bit features.
TEST_F(GpuReference, IndexedLevelModelMatchesCpu) {
  ASSERT_TRUE(train_status_) << train_status_.message();
  const Config& c = indexed_model_.config;
  ASSERT_TRUE(c.indexed(0));
  ASSERT_FALSE(c.indexed(1));
  ASSERT_EQ(indexed_model_.grid_index.size(), c.index_buckets[0]);
  const Comparison a = run(indexed_model_, skewed_instance(), kRaysPerInstance, 10,
                           "level 0 indexed, voxel segments, skewed instance");
  const Comparison b = run(with_8bit_grid(indexed_model_), Transform3x4(), kRaysPerInstance, 11,
                           "level 0 indexed, 8-bit grid, identity");
  expect_trained_agreement(a, b);
}

// Random fp16 weights and odd sizes (input 9, width 5, 3 hidden layers, 2 materials, V = 5, R = 15):
// exercises the half-pair padding of every row and bias, the ping-pong between layers and the
// material argmax. Random logits are larger than trained ones, hence the same relative bounds.
TEST_F(GpuReference, RandomOddSizedModelMatchesCpu) {
  for (const uint32_t variant : {16u, 8u, 0u}) {  // 0: fp16, the level indexed
    const uint32_t grid_bits = variant ? variant : 16u;
    SCOPED_TRACE(variant);
    Model model = variant ? random_odd_model() : random_odd_indexed_model();
    model.config.grid_bits = grid_bits;
    model.quantize();
    // Calibrate the occlusion bias on the CPU so that about half of the rays crossing an occupied
    // voxel are predicted hits (random weights alone put nearly all logits on one side).
    const Instance in = instance_of(skewed_instance());
    std::vector<int> kinds;
    std::vector<Ray> world;
    make_world_rays(model, in, 4000, 5, world, kinds);
    std::vector<LsnifHit> cpu(world.size());
    ASSERT_TRUE(intersect(model, skewed_instance(), world.data(), world.size(), cpu.data()));
    std::vector<float> logits;
    for (const LsnifHit& h : cpu)
      if (h.occlusion > 0.0f && h.occlusion < 1.0f) logits.push_back(std::log(h.occlusion / (1.0f - h.occlusion)));
    ASSERT_GT(logits.size(), 1000u);
    std::nth_element(logits.begin(), logits.begin() + long(logits.size() / 2), logits.end());
    model.mlp[mlp_layers(model.config).back().bias_offset + LSNIF_OUT_OCCLUSION] -= logits[logits.size() / 2];
    model.quantize();
    const char* name = variant == 8u   ? "random odd-sized 8-bit model"
                       : variant == 0u ? "random odd-sized indexed model, skewed instance"
                                       : "random odd-sized model, skewed instance";
    const Comparison c = run(model, skewed_instance(), 4000, 5, name);
    expect_agreement(c);
    EXPECT_GT(c.cpu_hits, 400u);
    EXPECT_LT(c.cpu_hits, 3600u);
    // The same model with surface channels after its 2 material logits (outputs 10 to 15).
    const Comparison s = run(with_surface_channels(model, 3.0f, 15 + variant), skewed_instance(), 4000, 5,
                             "the same with surface channels");
    expect_agreement(s);
    EXPECT_EQ(s.surface.learned, s.both_hit);
    EXPECT_GT(s.both_hit, 400u);
  }
}

// The zero-message assertions above mean something only if the messenger sees errors: provoke one
// (a buffer without usage bits, VUID-VkBufferCreateInfo-usage-requiredbitmask) and see it counted.
TEST_F(GpuReference, ValidationMessengerCountsErrors) {
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

TEST(GpuModelPacking, EveryValueAtItsDocumentedPlace) {
  const Model model = random_odd_model();
  std::vector<uint32_t> words;
  ASSERT_TRUE(pack_gpu_model(model, words));
  const LsnifGpuModelHeader h = gpu_block_header(words);
  EXPECT_EQ(h.magic, LSNIF_GPU_MAGIC);
  EXPECT_EQ(h.version, LSNIF_GPU_VERSION);
  EXPECT_EQ(h.total_words, words.size());
  EXPECT_EQ(h.voxel_resolution, 5u);
  EXPECT_EQ(h.max_points, 3u);
  EXPECT_EQ(h.grid_resolution0, 15u);
  EXPECT_EQ(h.table_log2, 5u);  // M_0 = 5 in the low byte, no other level
  EXPECT_EQ(h.hidden_layers, 3u);
  EXPECT_EQ(h.material_count, 2u);
  EXPECT_EQ(h.hit_param, LSNIF_HIT_PARAM_VOXEL_SEGMENTS);
  EXPECT_EQ(h.leaky_slope, 0.05f);
  EXPECT_EQ(h.bounds_lo_y, 0.5f);
  EXPECT_EQ(h.bounds_hi_z, 4.0f);
  EXPECT_EQ(h.voxel_offset, LSNIF_GPU_HEADER_WORDS);
  EXPECT_EQ(h.grid_bits, 16u);
  EXPECT_EQ(h.grid_scale0, 0.0f);
  EXPECT_EQ(h.index_offset, 0u);  // no indexed level, no index section
  EXPECT_EQ(h.index_slots0 | h.index_buckets0, 0u);
  EXPECT_EQ(h.surface_channels, 0u);
  EXPECT_EQ(h.emission_scale, 0.0f);
  EXPECT_EQ(h.uv_materials_lo | h.uv_materials_hi, 0u);
  EXPECT_EQ(h.uv_cells | h.uv_rank_offset | h.uv_record_offset | h.uv_map_offset, 0u);
  auto half_at = [&](uint32_t base, uint64_t e) {
    return half_to_float(uint16_t(words[base + (e >> 1)] >> ((e & 1u) * 16u)));
  };
  for (uint32_t k = 0; k < 5; ++k)
    for (uint32_t j = 0; j < 5; ++j)
      for (uint32_t i = 0; i < 5; ++i) {
        const uint32_t idx = i + 5 * (j + 5 * k);
        EXPECT_EQ(((words[h.voxel_offset + idx / 32] >> (idx % 32)) & 1u) != 0,
                  model.voxels.occupied(int(i), int(j), int(k)));
      }
  for (size_t e = 0; e < model.grid.size(); ++e) ASSERT_EQ(half_at(h.grid_offset, e), model.grid[e]) << e;
  const std::vector<LayerView> views = mlp_layers(model.config);
  const std::vector<GpuLayerLayout> layers = gpu_layer_layout(model.config);
  ASSERT_EQ(layers.size(), 4u);
  EXPECT_EQ(layers[0].in, 9u);
  EXPECT_EQ(layers[0].row_words, 5u);
  EXPECT_EQ(layers[3].out, 10u);
  EXPECT_EQ(layers[3].blocks, 2u);
  EXPECT_EQ(h.mlp_offset % 8, 0u);  // 32-byte loads
  // Independent of weight_word_of: row r, input i of block b = r / 8 sits in word
  // ((b * P + i / 2) * 8 + r % 8), half i % 2; padded rows and the pad half are zero; the bias of
  // block b is 8 words at bias_word + 8 b, 4 words of fp16 pairs then 4 zero words.
  uint32_t expect_word = 0;
  for (size_t l = 0; l < layers.size(); ++l) {
    const GpuLayerLayout& g = layers[l];
    EXPECT_EQ(g.weight_word, expect_word);
    EXPECT_EQ(g.weight_word % 8, 0u);
    const uint32_t P = (g.in + 1) / 2;
    for (uint32_t r = 0; r < g.blocks * 8; ++r) {
      for (uint32_t i = 0; i < 2 * P; ++i) {
        const uint32_t word = h.mlp_offset + g.weight_word + ((r / 8) * P + i / 2) * 8 + r % 8;
        const float expect = r < g.out && i < g.in ? model.mlp[views[l].weight_offset + size_t(r) * g.in + i] : 0.0f;
        ASSERT_EQ(half_at(word, i % 2), expect) << l << " " << r << " " << i;
      }
      const float bias = r < g.out ? model.mlp[views[l].bias_offset + r] : 0.0f;
      ASSERT_EQ(half_at(h.mlp_offset + g.bias_word + (r / 8) * 8, r % 8), bias);
      if (r % 8 == 0) {
        for (uint32_t k = 4; k < 8; ++k) EXPECT_EQ(words[h.mlp_offset + g.bias_word + r + k], 0u);  // pad words
      }
    }
    EXPECT_EQ(g.bias_word, g.weight_word + g.blocks * 8 * P);
    expect_word = g.bias_word + g.blocks * 8;
    EXPECT_EQ(g.end_word, expect_word);
  }
  EXPECT_EQ(h.mlp_offset + expect_word, h.total_words);
}

// Surface channels: the header's flag and emission scale, the output layer LSNIF_OUT_SURFACE_COUNT
// rows taller (16 = two blocks of 8 for the odd-sized model), the rest of the block unchanged in
// layout.
TEST(GpuModelPacking, SurfaceChannelsInTheHeaderAndTheOutputLayer) {
  const Model plain = random_odd_model();
  const Model model = gputest::with_surface_channels(plain, 3.5f, 3);
  std::vector<uint32_t> words;
  const Status packed = pack_gpu_model(model, words);
  ASSERT_TRUE(packed) << packed.message();
  ASSERT_TRUE(check_gpu_block_header(words));
  const LsnifGpuModelHeader h = gpu_block_header(words);
  EXPECT_EQ(h.surface_channels, 1u);
  EXPECT_EQ(h.emission_scale, 3.5f);
  EXPECT_EQ(h.uv_materials_lo | h.uv_materials_hi, 0u);
  EXPECT_EQ(h.uv_cells | h.uv_rank_offset | h.uv_record_offset | h.uv_map_offset, 0u);
  const std::vector<GpuLayerLayout> layers = gpu_layer_layout(model.config);
  ASSERT_EQ(layers.size(), 4u);
  EXPECT_EQ(layers[3].out, 10u + LSNIF_OUT_SURFACE_COUNT);
  EXPECT_EQ(layers[3].blocks, 2u);
  // The output rows the plain model has are its own, the surface rows follow them.
  const LayerView with = mlp_layers(model.config).back(), without = mlp_layers(plain.config).back();
  for (uint32_t r = 0; r < without.out; ++r) {
    EXPECT_EQ(model.mlp[with.bias_offset + r], plain.mlp[without.bias_offset + r]) << r;
    for (uint32_t i = 0; i < with.in; ++i)
      ASSERT_EQ(model.mlp[with.weight_offset + size_t(r) * with.in + i],
                plain.mlp[without.weight_offset + size_t(r) * without.in + i]);
  }
}

// 8-bit grid features: four two's complement codes per word (element e in byte e & 3 of word
// e >> 2), the level scales in the header, the MLP still 32-byte aligned after the grid.
TEST(GpuModelPacking, EightBitGridCodesFourPerWord) {
  const Model model = with_8bit_grid(random_odd_model());
  std::vector<uint32_t> words;
  ASSERT_TRUE(pack_gpu_model(model, words));
  const LsnifGpuModelHeader h = gpu_block_header(words);
  EXPECT_EQ(h.grid_bits, 8u);
  const float scales[4] = {h.grid_scale0, h.grid_scale1, h.grid_scale2, h.grid_scale3};
  const Config& c = model.config;
  for (uint32_t l = 0; l < 4; ++l) EXPECT_EQ(scales[l], l < c.grid_levels ? model.grid_scales[l] : 0.0f) << l;
  EXPECT_EQ(h.index_offset, 0u);
  const uint64_t count = c.grid_parameter_count();
  EXPECT_EQ(h.mlp_offset - h.grid_offset, ((count + 3) / 4 + 7) / 8 * 8);
  for (uint64_t e = 0; e < count; ++e) {
    const int8_t code = int8_t(uint8_t(words[h.grid_offset + e / 4] >> (8 * (e % 4))));
    ASSERT_EQ(code, model.grid_code(e)) << e;
    ASSERT_EQ(float(code) * scales[c.level_of_entry(e / c.features)], model.grid[e]) << e;
  }
  for (uint64_t b = count; b < 4 * uint64_t(h.mlp_offset - h.grid_offset); ++b)
    ASSERT_EQ((words[h.grid_offset + b / 4] >> (8 * (b % 4))) & 0xffu, 0u) << "pad byte " << b;
  // The MLP section is that of the fp16 model, moved.
  std::vector<uint32_t> wide;
  Model fp16 = model;
  fp16.config.grid_bits = 16;
  fp16.quantize();
  ASSERT_TRUE(pack_gpu_model(fp16, wide));
  const LsnifGpuModelHeader hw = gpu_block_header(wide);
  ASSERT_EQ(wide.size() - hw.mlp_offset, words.size() - h.mlp_offset);
  EXPECT_TRUE(std::equal(words.begin() + h.mlp_offset, words.end(), wide.begin() + hw.mlp_offset));
  EXPECT_LT(words.size(), wide.size());
  // An 8-bit model whose grid is not code * scale is refused.
  Model off = model;
  off.grid[1] += off.grid_scales[0] * 0.25f;
  EXPECT_FALSE(pack_gpu_model(off, words));
}

// Tables of different sizes: the header holds M_l byte by byte, the levels' values one after another
// (level l from element F * (2^M_0 + ... + 2^M_{l-1})), each level's codes times its own scale.
TEST(GpuModelPacking, TablesOfDifferentSizesPerLevel) {
  Model model = random_odd_model();
  Config& c = model.config;
  c.grid_levels = 3;
  c.grid_resolution[1] = 30;
  c.grid_resolution[2] = 45;
  const uint32_t sizes[3] = {6, 4, 9};
  set_table_log2(c, sizes, 3);
  c.grid_bits = 8;
  c.max_points = 1;  // input 1 * 3 * 3 = 9, the MLP as before
  ASSERT_TRUE(c.validate()) << c.validate().message();
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  model.grid.resize(size_t(c.grid_parameter_count()));
  const size_t first[4] = {0, 64 * 3, (64 + 16) * 3, (64 + 16 + 512) * 3};
  ASSERT_EQ(model.grid.size(), first[3]);
  for (uint32_t l = 0; l < 3; ++l)
    for (size_t e = first[l]; e < first[l + 1]; ++e) model.grid[e] = u(rng) * float(1u << (4 * l));  // own ranges
  model.quantize();
  std::vector<uint32_t> words;
  ASSERT_TRUE(pack_gpu_model(model, words));
  const LsnifGpuModelHeader h = gpu_block_header(words);
  EXPECT_EQ(h.table_log2, 6u | 4u << 8 | 9u << 16);
  for (uint32_t l = 0; l < 3; ++l) EXPECT_EQ(LSNIF_GPU_TABLE_LOG2(h.table_log2, l), sizes[l]);
  const float scales[3] = {h.grid_scale0, h.grid_scale1, h.grid_scale2};
  for (uint32_t l = 0; l < 3; ++l) {
    EXPECT_EQ(scales[l], model.grid_scales[l]);
    for (size_t e = first[l]; e < first[l + 1]; ++e) {
      const int8_t code = int8_t(uint8_t(words[h.grid_offset + e / 4] >> (8 * (e % 4))));
      ASSERT_EQ(float(code) * scales[l], model.grid[e]) << "level " << l << " element " << e;
    }
  }
  EXPECT_EQ(h.mlp_offset - h.grid_offset, ((first[3] + 3) / 4 + 7) / 8 * 8);
}

// An indexed level: its slots and buckets in the header, the displacements two per word in the
// index section between the grid and the MLP (each 8-word aligned), the grid as long as the slots.
TEST(GpuModelPacking, IndexedLevelDisplacementsTwoPerWord) {
  const Model model = random_odd_indexed_model();
  const Config& c = model.config;
  ASSERT_TRUE(c.indexed(0));
  std::vector<uint32_t> words;
  ASSERT_TRUE(pack_gpu_model(model, words));
  const LsnifGpuModelHeader h = gpu_block_header(words);
  EXPECT_EQ(h.index_slots0, c.index_slots[0]);
  EXPECT_EQ(h.index_buckets0, c.index_buckets[0]);
  EXPECT_EQ(h.index_slots1 | h.index_buckets1 | h.index_slots2 | h.index_buckets2, 0u);
  EXPECT_EQ(model.grid.size(), size_t(c.index_slots[0]) * c.features);
  EXPECT_EQ(h.index_offset, h.grid_offset + ((model.grid.size() + 1) / 2 + 7) / 8 * 8);  // fp16 pairs
  EXPECT_EQ(h.index_offset % 8, 0u);
  EXPECT_EQ(h.mlp_offset, h.index_offset + ((model.grid_index.size() + 1) / 2 + 7) / 8 * 8);
  for (size_t i = 0; i < model.grid_index.size(); ++i)
    ASSERT_EQ(uint16_t(words[h.index_offset + i / 2] >> (16 * (i % 2))), model.grid_index[i]) << i;
  for (size_t i = model.grid_index.size(); i < 2 * size_t(h.mlp_offset - h.index_offset); ++i)
    ASSERT_EQ(uint16_t(words[h.index_offset + i / 2] >> (16 * (i % 2))), 0u) << "pad " << i;
}

TEST(GpuModelPacking, RejectsUnquantizedAndInconsistentModels) {
  Model model = random_odd_model();
  model.mlp[7] = 0.1f;  // not an fp16 value
  std::vector<uint32_t> words(3, 1u);
  Status s = pack_gpu_model(model, words);
  EXPECT_FALSE(s);
  EXPECT_NE(s.message().find("not an fp16 value"), std::string::npos) << s.message();
  EXPECT_TRUE(words.empty());
  model = random_odd_model();
  model.grid.pop_back();
  s = pack_gpu_model(model, words);
  EXPECT_FALSE(s);
  EXPECT_NE(s.message().find("hash grid"), std::string::npos) << s.message();
}

}  // namespace
}  // namespace lsnif
