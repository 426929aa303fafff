// lsnifCmdQuery (src/lsnif/lsnif.h): world-space rays against a TLAS of triangle and LSNIF
// instances, on the Vulkan context's device (LSNIF_TEST_DEVICE, default lavapipe; validation on), against two
// independent truths: a ray-tracing pipeline over the same TLAS (the plugin's intersection shader
// with the instance-table lookup, a triangle hit group) and the CPU reference (src/lsnif/core/intersector.h).
//  - a mixed TLAS (a triangle instance, three LSNIF instances of two models, one with hash tables of
//    different sizes per level: rotation, non-uniform scale, translation), closest-hit rays with and
//    without culling, any-hit rays;
//  - rays leaving an LSNIF surface by the self-intersection rule;
//  - many models in one batch (a table of ten entries with holes);
//  - an empty batch, a batch in which no ray reaches an LSNIF object;
//  - candidate overflow: every ray whose answer could be wrong is marked incomplete and counted;
//  - equal t resolved to the lower instance index; batches of more than one chunk;
//  - the two broad phases (a ray-tracing pipeline, ray queries) agreeing hit for hit; the automatic
//    choice, the forced ones and what a context whose enabled features lack them reports;
//  - the argument errors.
// Compiled into plugin_test.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "lsnif/testing/gpu_test_support.h"
#include "lsnif/core/intersector.h"
#include <volk.h>  // before lsnif.h, which then uses volk's Vulkan declarations
#include "lsnif/lsnif.hpp"

#include "lsnif/import/mesh.h"
#include "lsnif/vulkan/plugin_device.h"
#include "lsnif/testing/test_plugin.h"
#include "lsnif/testing/test_support.h"
#include "lsnif/testing/test_models.h"
#include "lsnif/train/trainer.h"
#include "lsnif/vulkan/raytracing.h"

namespace lsnif {
namespace {

using namespace gputest;

#include "rt_conformance_rchit_spirv.h"
#include "rt_conformance_rgen_spirv.h"
#include "rt_conformance_rmiss_spirv.h"
#include "rt_mixed_triangle_rchit_spirv.h"

const std::string kMeshA = test::data_dir() + "/meshes/elephant.off";
const std::string kMeshB = test::data_dir() + "/meshes/bunny00.off";
constexpr uint32_t kModeClosest = 0, kModeShadow = 1;  // RT_MODE_* of rt_conformance_common.glsl

std::string last_error() { return lsnifGetLastErrorMessage(); }

// LsnifQueryPipelineCreateInfo keeps the layout it shipped with (the flags are chained through pNext).
static_assert(offsetof(LsnifQueryPipelineCreateInfo, pNext) == 0, "shipped layout");
static_assert(offsetof(LsnifQueryPipelineCreateInfo, pipelineCache) == sizeof(void*), "shipped layout");
static_assert(sizeof(LsnifQueryPipelineCreateInfo) == sizeof(void*) + sizeof(VkPipelineCache), "shipped layout");

// Object to world: rotation by `deg` degrees about `axis`, then scale `s` (per axis, applied first),
// then translation `t`.
Transform3x4 transform(glm::vec3 axis, float deg, glm::vec3 s, glm::vec3 t) {
  const float a = glm::radians(deg);
  const glm::vec3 u = glm::normalize(axis);
  const float c = std::cos(a), si = std::sin(a);
  glm::mat3 R;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      R[j][i] = (i == j ? c : 0.0f) + (1 - c) * u[i] * u[j] + si * (i == 0 ? (j == 1 ? -u.z : j == 2 ? u.y : 0.0f)
                                                                     : i == 1 ? (j == 0 ? u.z : j == 2 ? -u.x : 0.0f)
                                                                              : (j == 0 ? -u.y : j == 1 ? u.x : 0.0f));
  const glm::mat3 A = R * glm::mat3(glm::vec3(s.x, 0, 0), glm::vec3(0, s.y, 0), glm::vec3(0, 0, s.z));
  Transform3x4 xf;
  for (int r = 0; r < 3; ++r) {
    for (int col = 0; col < 3; ++col) xf.m[r][col] = A[col][r];
    xf.m[r][3] = t[r];
  }
  return xf;
}

// The world box of `b` under `xf`.
Aabb world_box(const Aabb& b, const Transform3x4& xf) {
  const Instance in = instance_of(xf);
  Aabb w;
  for (int k = 0; k < 8; ++k) {
    const glm::vec3 p((k & 1) ? b.hi.x : b.lo.x, (k & 2) ? b.hi.y : b.lo.y, (k & 4) ? b.hi.z : b.lo.z);
    const glm::vec3 q = in.A * p + in.T;
    w.lo = glm::min(w.lo, q);
    w.hi = glm::max(w.hi, q);
  }
  return w;
}

// One LSNIF instance of a scene, for the CPU reference.
struct LsnifInstance {
  const Model* model = nullptr;
  Transform3x4 xf;
  uint32_t index = 0;  // in the TLAS
};

// A TLAS, its model table (in a buffer) and what the CPU needs to know of it.
struct Scene {
  std::vector<VkAccelerationStructureInstanceKHR> records;
  std::vector<LsnifModel> table_models;  // table entries (null: holes)
  std::vector<LsnifInstance> lsnif;
  std::vector<Aabb> boxes;  // world box of every instance, in TLAS order
  Aabb bounds;
  vk::Buffer table;
  vk::AccelerationStructure tlas;
};

// Runs `f` when it goes out of scope (releases a scene also when an assertion ends the test).
struct Cleanup {
  std::function<void()> f;
  ~Cleanup() { f(); }
};

class PluginQuery : public ::testing::Test {
 public:
  // The device, models and pipelines the two suites (PluginQuery, PluginQueryPerBroadPhase) share:
  // made by the first suite's SetUpTestSuite, released once after every test
  // (PluginQueryEnvironment), so that the second suite neither trains nor compiles them again.
  static void release_shared() {
    if (!set_up_) return;
    pipeline_.reset();
    ray_query_pipeline_.reset();
    trace_rays_pipeline_.reset();
    plugin_.destroy();
    tracer_.destroy(triangle_blas_);
    tracer_.destroy(rt_pipeline_);
    vk_.destroy_device();
    set_up_ = false;
  }

 protected:
  static void SetUpTestSuite() {
    if (set_up_) return;
    set_up_ = true;
    vk::ContextOptions options;
    options.ray_tracing = true;
    options.validation = test::test_validation();
    options.device = test::test_device();
    status_ = vk_.init(options);  // ray queries and rayTraversalPrimitiveCulling where offered
    if (status_) status_ = tracer_.init();
    if (status_) {
      vk::RtShaders s;
      s.raygen = spirv(rt_conformance_rgen_spirv, sizeof rt_conformance_rgen_spirv);
      s.miss = spirv(rt_conformance_rmiss_spirv, sizeof rt_conformance_rmiss_spirv);
      s.closest_hit = spirv(rt_conformance_rchit_spirv, sizeof rt_conformance_rchit_spirv);
      s.intersection = TestPlugin::intersection_shader(LSNIF_MODEL_LOOKUP_INSTANCE_TABLE);
      s.triangle_closest_hit = spirv(rt_mixed_triangle_rchit_spirv, sizeof rt_mixed_triangle_rchit_spirv);
      status_ = tracer_.create_pipeline(s, sizeof(RtConformancePush), rt_pipeline_);
    }
    for (const std::string* path : {&kMeshA, &kMeshB})
      if (status_ && !std::filesystem::exists(*path))
        status_ = Status::error("%s missing: run scripts/setup.sh", path->c_str());
    Mesh b;
    if (status_) status_ = load_mesh(kMeshA, mesh_);
    if (status_) status_ = load_mesh(kMeshB, b);
    if (status_) status_ = test::tiny_model("elephant.segments", mesh_, tiny_settings(HitParam::VoxelSegments), model_a_);
    // Model b's levels have hash tables of different sizes (2^10 and 2^14 entries): the batched path
    // and the intersection shader decode the per-level layout as the CPU reference does.
    TrainSettings unequal_tables = tiny_settings(HitParam::VoxelSegments);
    const uint32_t table_log2[2] = {10, 14};
    set_table_log2(unequal_tables.config, table_log2, 2);
    if (status_) status_ = test::tiny_model("bunny.tables_10_14", b, unequal_tables, model_b_);
    // Model b also has surface channels (random surface rows, emission up to 8: with_surface_channels),
    // model a none: every query mixes both kinds of results.
    if (status_) model_b_ = with_surface_channels(model_b_, 8.0f, 31);
    if (status_) status_ = plugin_.init(vk_);
    if (status_) status_ = plugin_.upload(model_a_, a_);
    if (status_) status_ = plugin_.upload(model_b_, b_);
    if (status_) {
      // Through lsnif.hpp: the query() helper records with its cmd_query and sizes with query_scratch_size.
      // The automatic broad phase runs every test; the ray-query one is compared with it.
      status_ = TestPlugin::check(pipeline_.create(plugin_.context(), LSNIF_QUERY_PIPELINE_CREATE_TLAS_BIT),
                                  "query pipeline");
    }
    if (status_) {
      LsnifDeviceSupport support{};
      if (lsnifQueryDeviceSupport(vk_.instance(), vk_.physical_device(), vkGetInstanceProcAddr, &support) != LSNIF_SUCCESS)
        status_ = Status::error("lsnifQueryDeviceSupport: %s", last_error().c_str());
      if (!support.rayQuery)
        ray_query_missing_ = "device '" + vk_.device_name() + "' lacks extension VK_KHR_ray_query with feature rayQuery";
      if (!support.rayTraversalPrimitiveCulling)
        trace_rays_missing_ = "device '" + vk_.device_name() + "' lacks feature rayTraversalPrimitiveCulling";
    }
    if (status_ && ray_query_missing_.empty())
      status_ = TestPlugin::check(ray_query_pipeline_.create(plugin_.context(),
                                                             LSNIF_QUERY_PIPELINE_CREATE_TLAS_BIT |
                                                                 LSNIF_QUERY_PIPELINE_CREATE_RAY_QUERY_BROAD_PHASE_BIT),
                                  "query pipeline (ray-query broad phase)");
    if (status_ && trace_rays_missing_.empty())
      status_ = TestPlugin::check(trace_rays_pipeline_.create(plugin_.context(),
                                                              LSNIF_QUERY_PIPELINE_CREATE_TLAS_BIT |
                                                                  LSNIF_QUERY_PIPELINE_CREATE_TRACE_RAYS_BROAD_PHASE_BIT),
                                  "query pipeline (ray-tracing broad phase)");
    if (status_) {
      std::vector<float> positions;
      std::vector<uint32_t> indices;
      for (const glm::vec3& p : mesh_.positions) positions.insert(positions.end(), {p.x, p.y, p.z});
      for (const glm::uvec3& t : mesh_.triangles) indices.insert(indices.end(), {t.x, t.y, t.z});
      status_ = tracer_.build_triangle_blas(positions, indices, triangle_blas_);
    }
  }
  static void TearDownTestSuite() {}  // release_shared, after every suite
  void SetUp() override {
    ASSERT_TRUE(status_) << status_.message();
    vk_.reset_validation_counts();
    current_ = &pipeline_;
  }
  void TearDown() override {
    EXPECT_EQ(vk_.validation_errors(), 0u) << vk_.validation_log();
    EXPECT_EQ(vk_.validation_warnings(), 0u) << vk_.validation_log();
  }

  // Adds an LSNIF instance of `model` (handle `handle`, table entry `entry`).
  static void add_lsnif(Scene& s, const Model& model, LsnifModel handle, uint32_t entry, const Transform3x4& xf) {
    VkAccelerationStructureInstanceKHR rec;
    ASSERT_TRUE(plugin_.make_instance(handle, xf, entry, 0xFF, 0, rec));
    s.lsnif.push_back({&model, xf, uint32_t(s.records.size())});
    s.records.push_back(rec);
    s.boxes.push_back(world_box(model.bounds(), xf));
  }
  // Adds a triangle instance of the first mesh (custom index `entry`, a hole of the table).
  static void add_triangles(Scene& s, uint32_t entry, const Transform3x4& xf) {
    VkAccelerationStructureInstanceKHR rec{};
    std::memcpy(rec.transform.matrix, xf.m, sizeof rec.transform.matrix);
    rec.instanceCustomIndex = entry & 0xffffffu;
    rec.mask = 0xFF;
    rec.instanceShaderBindingTableRecordOffset = rt_pipeline_.triangle_sbt_offset & 0xffffffu;
    rec.accelerationStructureReference = triangle_blas_.address;
    s.records.push_back(rec);
    s.boxes.push_back(world_box(mesh_.bounds(), xf));
  }
  // Builds the TLAS and uploads the table.
  static void finish(Scene& s) {
    for (const Aabb& b : s.boxes) {
      s.bounds.lo = glm::min(s.bounds.lo, b.lo);
      s.bounds.hi = glm::max(s.bounds.hi, b.hi);
    }
    std::vector<uint64_t> table;
    ASSERT_TRUE(plugin_.model_table(s.table_models, table));
    ASSERT_TRUE(vk_.create_buffer(std::max<size_t>(1, table.size()) * sizeof(uint64_t), s.table));
    if (!table.empty()) std::memcpy(s.table.mapped, table.data(), table.size() * sizeof(uint64_t));
    ASSERT_TRUE(tracer_.build_tlas(s.records, s.tlas));
  }
  static void release(Scene& s) {
    vk_.destroy_buffer(s.table);
    tracer_.destroy(s.tlas);
  }

  // The mixed scene: a triangle instance (entry 2, a hole), model A twice (entry 0: rotated about y;
  // rotated about a skew axis with non-uniform scale), model B once (entry 1: non-uniform scale,
  // rotation, translation); the boxes overlap pairwise.
  static void mixed_scene(Scene& s) {
    const Aabb& ba = model_a_.bounds();
    const glm::vec3 ea = ba.extent();
    s.table_models = {a_, b_, nullptr};
    add_lsnif(s, model_a_, a_, 0, transform({0, 1, 0}, 30, glm::vec3(1.0f), glm::vec3(0.0f)));
    add_triangles(s, 2, transform({0, 1, 0}, 90, glm::vec3(0.8f), glm::vec3(0.6f * ea.x, 0, 0) - ba.center()));
    add_lsnif(s, model_b_, b_, 1,
              transform({1, 0, 0}, -20, glm::vec3(1.5f, 0.7f, 1.1f) * (ea.x / model_b_.bounds().extent().x),
                        glm::vec3(-0.5f * ea.x, 0.3f * ea.y, 0.2f * ea.z) - model_b_.bounds().center()));
    add_lsnif(s, model_a_, a_, 0,
              transform({1, 1, 0}, 50, glm::vec3(0.6f, 1.3f, 0.9f), glm::vec3(0.1f * ea.x, -0.5f * ea.y, 0.4f * ea.z)));
    finish(s);
  }

  // Rays at the scene: from a sphere around it towards a point of one instance's box (round robin),
  // from inside an instance's box in any direction, and anywhere; 15% with a finite tmax.
  static std::vector<Ray> rays_at(const Scene& s, size_t count, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    auto unit_vector = [&] { return random_unit_vector(rng); };
    auto in_box = [&](const Aabb& b) { return b.lo + b.extent() * glm::vec3(u(rng), u(rng), u(rng)); };
    const float diag = s.bounds.diagonal();
    std::vector<Ray> rays(count);
    for (size_t i = 0; i < count; ++i) {
      Ray& r = rays[i];
      const Aabb& box = s.boxes[(i / 3) % s.boxes.size()];
      switch (i % 3) {
        case 0:
          r.origin = s.bounds.center() + diag * (0.8f + 0.7f * u(rng)) * unit_vector();
          r.direction = in_box(box) - r.origin;
          break;
        case 1:
          r.origin = in_box(box);
          r.direction = (0.5f + u(rng)) * unit_vector();
          break;
        default:
          r.origin =
              s.bounds.center() + 1.5f * s.bounds.extent() * glm::vec3(2 * u(rng) - 1, 2 * u(rng) - 1, 2 * u(rng) - 1);
          r.direction = (0.5f + u(rng)) * unit_vector();
          break;
      }
      if (u(rng) < 0.15f) r.tmax = 2.0f * diag / glm::length(r.direction) * u(rng);
    }
    return rays;
  }

  // Rays from around the scene towards points near its centre, where the boxes overlap: most cross
  // two or three LSNIF boxes.
  static std::vector<Ray> rays_to_centre(const Scene& s, size_t count, uint32_t seed) {
    std::vector<Ray> rays(count);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    for (Ray& r : rays) {
      glm::vec3 v(u(rng), u(rng), u(rng));
      while (glm::length(v) < 0.1f || glm::length(v) > 1.0f) v = glm::vec3(u(rng), u(rng), u(rng));
      r.origin = s.bounds.center() + 1.2f * s.bounds.diagonal() * glm::normalize(v);
      r.direction = s.bounds.center() + 0.15f * s.bounds.extent() * glm::vec3(u(rng), u(rng), u(rng)) - r.origin;
    }
    return rays;
  }
  // Ray flags: every other ray any-hit.
  static std::vector<uint32_t> every_other_any_hit(size_t count) {
    std::vector<uint32_t> flags(count, 0u);
    for (size_t i = 0; i < flags.size(); i += 2) flags[i] = LSNIF_RAY_FLAG_TERMINATE_ON_FIRST_HIT;
    return flags;
  }

  struct QueryRun {
    std::vector<LsnifQueryResult> results;
    LsnifQueryStatus status{};
  };
  // `rays` with flags[i] (or `flags[0]` for all when it has one entry) through lsnifCmdQuery. The
  // result and status buffers start as 0xFF bytes, so a field left unwritten shows.
  // `models` (when given) replaces the scene's table models as pModels (the device table stays).
  // `stamps` (when given) gets the stage timestamps (LsnifQueryTimestampsInfo chained) as ticks,
  // with their availability: {tick, available} per query. `model_index` (when given) is chained too.
  static QueryRun query(const Scene& s, const std::vector<Ray>& rays, const std::vector<uint32_t>& flags,
                        uint32_t per_ray = 4, const std::vector<LsnifModel>* models = nullptr,
                        std::vector<std::array<uint64_t, 2>>* stamps = nullptr,
                        const plugin::QueryPipeline* pipeline = nullptr,
                        const LsnifQueryModelIndexInfo* model_index = nullptr) {
    QueryRun out;
    if (!pipeline) pipeline = current_;
    if (!models) models = &s.table_models;
    const uint32_t n = uint32_t(rays.size());
    LsnifQueryInfo info{};
    info.rayCount = n;
    info.candidatesPerRay = per_ray;
    info.tlas = s.tlas.address;
    info.cullMask = 0xFF;
    info.modelCount = uint32_t(models->size());
    info.pModels = models->data();
    info.modelTable = s.table.address;
    VkDeviceSize bytes = 0;
    EXPECT_EQ(plugin::query_scratch_size(plugin_.context(), info, bytes), LSNIF_SUCCESS) << last_error();
    vk::Buffer ray_buf, result_buf, status_buf, scratch;
    vk::Timestamps pool;
    Status st = vk_.create_buffer(std::max<size_t>(1, n) * sizeof(LsnifQueryRay), ray_buf);
    if (st) st = vk_.create_buffer(std::max<size_t>(1, n) * sizeof(LsnifQueryResult), result_buf);
    if (st) st = vk_.create_buffer(sizeof(LsnifQueryStatus), status_buf);
    if (st) st = vk_.create_buffer(size_t(bytes) + 16, scratch, VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT);
    if (st) {
      auto* r = static_cast<LsnifQueryRay*>(ray_buf.mapped);
      for (uint32_t i = 0; i < n; ++i) {
        const uint32_t f = flags.size() == 1 ? flags[0] : i < flags.size() ? flags[i] : 0u;
        r[i] = {rays[i].origin.x, rays[i].origin.y, rays[i].origin.z, rays[i].tmin, rays[i].direction.x,
                rays[i].direction.y, rays[i].direction.z, rays[i].tmax, f, 0, 0, 0};
      }
      std::memset(result_buf.mapped, 0xFF, std::max<size_t>(1, n) * sizeof(LsnifQueryResult));
      std::memset(status_buf.mapped, 0xFF, sizeof(LsnifQueryStatus));
      info.rays = ray_buf.address;
      info.results = result_buf.address;
      info.scratchBuffer = scratch.buffer;
      info.scratchOffset = 16;  // not at the buffer's start
      info.scratchSize = bytes;
      info.status = status_buf.address;
      LsnifQueryTimestampsInfo chained{};
      chained.sType = LSNIF_STRUCTURE_TYPE_QUERY_TIMESTAMPS_INFO;
      chained.firstQuery = 1;  // not at the pool's start
      info.pNext = model_index;
      if (stamps) {
        st = vk_.create_timestamps(1 + LSNIF_QUERY_TIMESTAMP_COUNT_FOR_RAYS(uint32_t(n)), pool);
        chained.timestampPool = pool.pool;
        chained.pNext = model_index;
        info.pNext = &chained;
      }
      if (st) st = vk_.submit("lsnifCmdQuery", [&](VkCommandBuffer cmd) {
        if (stamps) vkCmdResetQueryPool(cmd, pool.pool, 0, pool.count);
        EXPECT_EQ(pipeline->cmd_query(cmd, info), LSNIF_SUCCESS) << last_error();
        vk::Context::barrier_compute_to_host(cmd);
      });
    }
    EXPECT_TRUE(st) << st.message();
    if (st) {
      const auto* h = static_cast<const LsnifQueryResult*>(result_buf.mapped);
      out.results.assign(h, h + n);
      std::memcpy(&out.status, status_buf.mapped, sizeof out.status);
    }
    if (st && stamps) {
      // Without WAIT: a timestamp the command failed to write reads as unavailable, not as a hang.
      stamps->assign(LSNIF_QUERY_TIMESTAMP_COUNT_FOR_RAYS(uint32_t(n)), {0, 0});
      const VkResult r = vkGetQueryPoolResults(vk_.device(), pool.pool, 1, uint32_t(stamps->size()),
                                               stamps->size() * sizeof(stamps->front()), stamps->data(),
                                               sizeof(stamps->front()),
                                               VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WITH_AVAILABILITY_BIT);
      EXPECT_TRUE(r == VK_SUCCESS || r == VK_NOT_READY) << "vkGetQueryPoolResults " << int(r);
    }
    vk_.destroy_timestamps(pool);
    for (vk::Buffer* b : {&ray_buf, &result_buf, &status_buf, &scratch}) vk_.destroy_buffer(*b);
    return out;
  }

  // Counts of the rays of `q` marked LSNIF_QUERY_HIT_INCOMPLETE (every other field as for a miss),
  // of the others answered as in `ref` (any-hit rays: a hit or a miss alike; closest: kind, instance
  // and t), each of which must be, and of its LSNIF hits.
  struct Marked {
    size_t incomplete = 0, exact = 0, lsnif = 0;
  };
  static Marked marked_or_exact(const std::vector<uint32_t>& flags, const QueryRun& q, const QueryRun& ref) {
    Marked m;
    EXPECT_EQ(q.results.size(), ref.results.size());
    for (size_t i = 0; i < std::min(q.results.size(), ref.results.size()); ++i) {
      const LsnifQueryResult& r = q.results[i];
      const LsnifQueryResult& f = ref.results[i];
      if (r.kind == LSNIF_QUERY_HIT_INCOMPLETE) {
        ++m.incomplete;
        EXPECT_EQ(r.instance_index, ~0u);
        EXPECT_EQ(r.t, 0.0f);
        continue;
      }
      m.lsnif += r.kind == LSNIF_QUERY_HIT_LSNIF;
      const bool same = (flags[i] & LSNIF_RAY_FLAG_TERMINATE_ON_FIRST_HIT)
                            ? (r.kind == LSNIF_QUERY_HIT_NONE) == (f.kind == LSNIF_QUERY_HIT_NONE)
                            : r.kind == f.kind && r.instance_index == f.instance_index && r.t == f.t;
      m.exact += same;
      EXPECT_TRUE(same) << "ray " << i << " answered wrongly without the mark: kind " << r.kind << " vs " << f.kind;
    }
    return m;
  }

  // The same rays through the ray-tracing pipeline over the scene's TLAS (closest or shadow mode).
  // `table_count` below the table's size hides the LSNIF instances of the entries past it.
  static std::vector<LsnifReferenceHit> trace(const Scene& s, const std::vector<Ray>& rays, uint32_t mode,
                                              uint32_t ray_flags, uint32_t table_count = ~0u) {
    std::vector<LsnifReferenceHit> out;
    RtConformancePush push;
    push.model_table = s.table.address;
    push.model_count = std::min(table_count, uint32_t(s.table_models.size()));
    push.mode = mode;
    push.ray_flags = ray_flags;
    const Status st = trace_reference(vk_, tracer_, rt_pipeline_, s.tlas, push, rays, out);
    EXPECT_TRUE(st) << st.message();
    return out;
  }

  // Agreement of the query with the ray-tracing pipeline (closest mode) on the same rays.
  struct Agreement {
    size_t rays = 0, same_hit = 0, same_instance = 0, both_hit = 0, lsnif = 0, triangles = 0, incomplete = 0;
    double max_dt = 0, max_angle = 0, max_albedo = 0;
    // Surface channels of the LSNIF hits: learned ones, words whose flag differs or a channel by
    // more than one unorm8 step, the largest emission difference beyond the RGBE step of the
    // shader's attributes (<= 0: within).
    size_t surface_learned = 0, surface_mismatch = 0;
    double emission_excess = -1.0;
    // Texture coordinates of the LSNIF hits (models with uv cells): both report one, one side only,
    // apart by more than half a step of the shader's packing (pack_uv), the largest difference.
    size_t uv_both = 0, uv_one_side = 0, uv_apart = 0;
    double uv_max = 0;
  };
  static Agreement compare(const Scene& s, const std::vector<Ray>& rays, const std::vector<LsnifQueryResult>& q,
                           const std::vector<LsnifReferenceHit>& ref) {
    Agreement a;
    a.rays = rays.size();
    EXPECT_EQ(q.size(), rays.size());
    EXPECT_EQ(ref.size(), rays.size());
    if (q.size() != rays.size() || ref.size() != rays.size()) return a;
    const double diag = s.bounds.diagonal();
    for (size_t i = 0; i < rays.size(); ++i) {
      const LsnifQueryResult& r = q[i];
      EXPECT_TRUE(r.kind == LSNIF_QUERY_HIT_NONE || r.kind == LSNIF_QUERY_HIT_LSNIF ||
                  r.kind == LSNIF_QUERY_HIT_TRIANGLE)
          << "ray " << i << " kind " << r.kind;
      a.lsnif += r.kind == LSNIF_QUERY_HIT_LSNIF;
      a.triangles += r.kind == LSNIF_QUERY_HIT_TRIANGLE;
      EXPECT_EQ(r.reserved, 0u) << "ray " << i;
      if (r.kind != LSNIF_QUERY_HIT_LSNIF) {
        EXPECT_EQ(r.reports_uv, 0u) << "ray " << i;
      }
      if (r.reports_uv == 0u) {
        EXPECT_TRUE(r.uv_u == 0.0f && r.uv_v == 0.0f) << "ray " << i;
      }
      const bool hit = r.kind == LSNIF_QUERY_HIT_LSNIF || r.kind == LSNIF_QUERY_HIT_TRIANGLE;
      if (!hit) {
        EXPECT_EQ(r.instance_index, ~0u) << "ray " << i;
        EXPECT_EQ(r.t, 0.0f) << "ray " << i;
        EXPECT_EQ(r.surface, 0u) << "ray " << i;
      }
      a.same_hit += hit == (ref[i].hit != 0);
      if (!hit || !ref[i].hit) continue;
      ++a.both_hit;
      const uint32_t ref_instance = ref[i].instance & 0x7fffu;  // bit 15: the hit kind (rt_conformance.rchit)
      if (r.instance_index != ref_instance) continue;
      ++a.same_instance;
      EXPECT_EQ(r.instance_custom_index, ref[i].instance >> 16) << "ray " << i;
      const double len = double(glm::length(rays[i].direction));
      a.max_dt = std::max(a.max_dt, std::fabs(double(r.t) - double(ref[i].t)) * len / diag);
      if (r.kind == LSNIF_QUERY_HIT_TRIANGLE) {
        EXPECT_EQ(ref[i].points, 0u) << "ray " << i << ": the shader hit an LSNIF object";
        EXPECT_EQ(r.primitive_index, ref[i].material) << "ray " << i;
        EXPECT_NEAR(r.barycentric_u, ref[i].albedo_x, 1e-4) << "ray " << i;
        EXPECT_NEAR(r.barycentric_v, ref[i].albedo_y, 1e-4) << "ray " << i;
        EXPECT_EQ(r.geometry_index, 0u);
        EXPECT_EQ(r.surface, 0u) << "ray " << i << ": a triangle has no learned surface";
        EXPECT_EQ(r.emission_r + r.emission_g + r.emission_b, 0.0f) << "ray " << i;
        continue;
      }
      EXPECT_GT(ref[i].points, 0u) << "ray " << i << ": the shader hit a triangle";
      const glm::vec3 nq(r.normal_x, r.normal_y, r.normal_z), nr(ref[i].normal_x, ref[i].normal_y, ref[i].normal_z);
      a.max_angle = std::max(a.max_angle, double(std::acos(std::clamp(glm::dot(nq, nr), -1.0f, 1.0f))) * 180.0 / M_PI);
      EXPECT_EQ(r.material, ref[i].material) << "ray " << i;
      if ((r.reports_uv != 0u) != (ref[i].reports_uv != 0u)) {
        ++a.uv_one_side;
        continue;
      }
      if (r.reports_uv != 0u) {
        // The shader's attributes hold the coordinate instead of the albedo and surface channels
        // (the application's textures give them); the query reports both.
        ++a.uv_both;
        const double du = std::max(std::fabs(double(r.uv_u) - double(ref[i].uv_u)),
                                   std::fabs(double(r.uv_v) - double(ref[i].uv_v)));
        a.uv_max = std::max(a.uv_max, du);
        a.uv_apart += du > 0.5 / 65536.0 + 1e-6;
        continue;
      }
      a.max_albedo = std::max({a.max_albedo, std::fabs(double(r.albedo_r - ref[i].albedo_x)),
                               std::fabs(double(r.albedo_g - ref[i].albedo_y)),
                               std::fabs(double(r.albedo_b - ref[i].albedo_z))});
      EXPECT_EQ(r.primitive_index, 0u);
      // The same network on both sides: the same packed channels (one step where the two paths'
      // sums straddle a rounding boundary), the shader's emission RGBE-rounded (half a step of the
      // shared exponent, <= 2^-8 of the largest channel).
      a.surface_learned += (r.surface >> 24) == LSNIF_SURFACE_LEARNED;
      bool mismatch = (r.surface >> 24) != (ref[i].surface >> 24);
      for (int k = 0; k < 3; ++k)
        mismatch |= std::abs(int((r.surface >> (8 * k)) & 0xffu) - int((ref[i].surface >> (8 * k)) & 0xffu)) > 1;
      a.surface_mismatch += mismatch;
      const float qe[3] = {r.emission_r, r.emission_g, r.emission_b};
      const float re[3] = {ref[i].emission_r, ref[i].emission_g, ref[i].emission_b};
      const double largest = std::max({qe[0], qe[1], qe[2]});
      for (int k = 0; k < 3; ++k)
        a.emission_excess = std::max(a.emission_excess, std::fabs(double(qe[k]) - double(re[k])) -
                                                            (std::ldexp(largest, -8) * 1.001 + 1e-6));
    }
    return a;
  }
  // The shader is the truth: hit/miss and the instance on >= 99.9% of rays, t within 1e-5 of the
  // scene's diagonal and the normal within 0.05 degrees where both hit the same instance (the same
  // GLSL in fp32 on both sides; fp16 weights are read the same way), albedo to the unorm8 packing
  // of the shader's attributes, the surface channels as compare() says.
  static void expect_agreement(const Agreement& a, const char* what) {
    SCOPED_TRACE(what);
    std::printf("[%s] %zu rays: LSNIF hits %zu, triangle hits %zu; hit/miss agreement %zu, same instance %zu of %zu; "
                "max |dt| / diagonal %.3g, max normal %.3g deg, max albedo %.3g; surface channels learned %zu, "
                "mismatched %zu, emission beyond the RGBE step %.3g; texture coordinates %zu, one side %zu, "
                "apart %zu, max %.3g\n",
                what, a.rays, a.lsnif, a.triangles, a.same_hit, a.same_instance, a.both_hit, a.max_dt, a.max_angle,
                a.max_albedo, a.surface_learned, a.surface_mismatch, a.emission_excess, a.uv_both, a.uv_one_side,
                a.uv_apart, a.uv_max);
    EXPECT_GE(double(a.same_hit), 0.999 * double(a.rays)) << "hit/miss vs the intersection shader";
    EXPECT_GE(double(a.same_instance), 0.999 * double(a.both_hit)) << "closest instance vs the intersection shader";
    EXPECT_LE(a.max_dt, 1e-5) << "largest |t difference| / scene diagonal";
    EXPECT_LE(a.max_angle, 0.05) << "largest world normal difference (degrees)";
    EXPECT_LE(a.max_albedo, 0.5 / 255.0 + 1e-6) << "largest albedo difference";
    EXPECT_EQ(a.surface_mismatch, 0u) << "surface channels vs the intersection shader's attributes";
    EXPECT_LE(a.emission_excess, 0.0) << "emission vs the intersection shader's attributes";
    // The same lookup on both sides; a hit point differing in its last bits can tip a choice
    // between two pieces whose scores tie: rare, and bounded.
    EXPECT_LE(double(a.uv_one_side), 2e-3 * double(a.both_hit)) << "texture coordinate reported on one side only";
    EXPECT_LE(double(a.uv_apart), 5e-3 * double(a.both_hit)) << "texture coordinates vs the intersection shader's";
  }

  // CPU reference of a scene's LSNIF instances alone: the closest accepted hit over them.
  static std::vector<LsnifHit> cpu_lsnif(const Scene& s, const std::vector<Ray>& rays, uint32_t flags,
                                         std::vector<uint32_t>& instance) {
    std::vector<LsnifHit> best(rays.size());
    instance.assign(rays.size(), ~0u);
    for (const LsnifInstance& li : s.lsnif) {
      std::vector<LsnifHit> h(rays.size());
      const Status st = intersect(*li.model, li.xf, rays.data(), rays.size(), h.data(), flags);
      EXPECT_TRUE(st) << st.message();
      for (size_t i = 0; i < rays.size(); ++i)
        if (h[i].hit && (!best[i].hit || h[i].t < best[i].t)) best[i] = h[i], instance[i] = li.index;
    }
    return best;
  }

  static vk::Context vk_;
  static vk::RayTracer tracer_;
  static vk::RtPipeline rt_pipeline_;
  static Status status_;
  static Mesh mesh_;
  static Model model_a_, model_b_;
  static TestPlugin plugin_;
  static LsnifModel a_, b_;
  static plugin::QueryPipeline pipeline_;             // the automatic broad phase
  static plugin::QueryPipeline ray_query_pipeline_;   // the ray-query broad phase, forced
  static plugin::QueryPipeline trace_rays_pipeline_;  // the ray-tracing broad phase, forced
  static const plugin::QueryPipeline* current_;
  static bool set_up_;       // query()'s pipeline: the automatic one, or the
                                                      // test's broad phase (PluginQueryPerBroadPhase)
  static std::string ray_query_missing_, trace_rays_missing_;  // why a broad phase cannot run ("" when it can)
  static vk::AccelerationStructure triangle_blas_;
};
vk::Context PluginQuery::vk_;
vk::RayTracer PluginQuery::tracer_(PluginQuery::vk_);
vk::RtPipeline PluginQuery::rt_pipeline_;
Status PluginQuery::status_;
Mesh PluginQuery::mesh_;
Model PluginQuery::model_a_, PluginQuery::model_b_;
TestPlugin PluginQuery::plugin_;
LsnifModel PluginQuery::a_ = nullptr, PluginQuery::b_ = nullptr;
plugin::QueryPipeline PluginQuery::pipeline_;
plugin::QueryPipeline PluginQuery::ray_query_pipeline_;
plugin::QueryPipeline PluginQuery::trace_rays_pipeline_;
const plugin::QueryPipeline* PluginQuery::current_ = nullptr;
bool PluginQuery::set_up_ = false;

class PluginQueryEnvironment : public ::testing::Environment {
 public:
  void TearDown() override { PluginQuery::release_shared(); }
};
[[maybe_unused]] ::testing::Environment* const kPluginQueryEnvironment =
    ::testing::AddGlobalTestEnvironment(new PluginQueryEnvironment);

// The tests that run once per broad phase: query() (and the tests' own lsnifCmdQuery calls) use
// the broad phase of the parameter. A device lacking what one needs skips it, naming the feature
// (a failure on lavapipe, which has both).
class PluginQueryPerBroadPhase : public PluginQuery, public ::testing::WithParamInterface<LsnifQueryBroadPhase> {
 protected:
  void SetUp() override {
    PluginQuery::SetUp();
    if (HasFatalFailure()) return;
    if (GetParam() == LSNIF_QUERY_BROAD_PHASE_RAY_QUERY) {
      LSNIF_TEST_NEEDS(ray_query_missing_.empty(), vk_.device_name(), "extension VK_KHR_ray_query with feature rayQuery");
      current_ = &ray_query_pipeline_;
    } else {
      LSNIF_TEST_NEEDS(trace_rays_missing_.empty(), vk_.device_name(), "feature rayTraversalPrimitiveCulling");
      current_ = &trace_rays_pipeline_;
    }
  }
};
INSTANTIATE_TEST_SUITE_P(BroadPhase, PluginQueryPerBroadPhase,
                         ::testing::Values(LSNIF_QUERY_BROAD_PHASE_TRACE_RAYS, LSNIF_QUERY_BROAD_PHASE_RAY_QUERY),
                         [](const ::testing::TestParamInfo<LsnifQueryBroadPhase>& param) {
                           return std::string(param.param == LSNIF_QUERY_BROAD_PHASE_RAY_QUERY ? "RayQuery"
                                                                                               : "TraceRays");
                         });
std::string PluginQuery::ray_query_missing_, PluginQuery::trace_rays_missing_;
vk::AccelerationStructure PluginQuery::triangle_blas_;

constexpr size_t kRays = 3000;

// Closest-hit rays with no culling and with back-face culling, then any-hit rays, against the
// intersection shader over the same mixed TLAS.
TEST_P(PluginQueryPerBroadPhase, MixedTlasMatchesTheIntersectionShader) {
  Scene s;
  const Cleanup cleanup{[&] { release(s); }};
  ASSERT_NO_FATAL_FAILURE(mixed_scene(s));
  const std::vector<Ray> rays = rays_at(s, kRays, 3);
  for (const uint32_t flags : {0u, LSNIF_RAY_FLAG_CULL_BACK_FACING}) {
    SCOPED_TRACE(testing::Message() << "ray flags 0x" << std::hex << flags);
    const QueryRun q = query(s, rays, {flags});
    const Agreement a = compare(s, rays, q.results, trace(s, rays, kModeClosest, flags));
    expect_agreement(a, "closest hits");
    EXPECT_GT(a.lsnif, kRays / 10) << "too few LSNIF hits to tell anything";
    EXPECT_GT(a.triangles, kRays / 20) << "too few triangle hits to tell anything";
    EXPECT_EQ(q.status.dropped, 0u);
    EXPECT_EQ(q.status.incomplete_rays, 0u);
    EXPECT_EQ(q.status.unevaluated, 0u);
    EXPECT_EQ(q.status.capacity, 4u * kRays);
    // One candidate per (ray, LSNIF instance) whose model box the ray crosses before its closest
    // triangle (the shader's trace with an empty table sees the triangles only): none beyond it.
    const std::vector<LsnifReferenceHit> triangles_only = trace(s, rays, kModeClosest, flags, 0);
    size_t expected = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
      const float tmax = triangles_only[i].hit ? triangles_only[i].t : rays[i].tmax;
      for (const LsnifInstance& li : s.lsnif) {
        const Instance in = instance_of(li.xf);
        const glm::vec3 o = in.A_inv * (rays[i].origin - in.T), d = in.A_inv * rays[i].direction;
        const Aabb& b = li.model->bounds();
        float t0 = rays[i].tmin, t1 = tmax;
        for (int k = 0; k < 3; ++k) {
          const float lo = (b.lo[k] - o[k]) / d[k], hi = (b.hi[k] - o[k]) / d[k];
          t0 = std::max(t0, std::min(lo, hi));
          t1 = std::min(t1, std::max(lo, hi));
        }
        expected += t0 <= t1;
      }
    }
    EXPECT_NEAR(double(q.status.candidates), double(expected), 0.005 * double(expected))
        << "candidates: one per crossed LSNIF box before the closest triangle";
    EXPECT_GT(q.status.candidates, kRays / 4);
    // Every LSNIF answer agrees with the CPU reference of the LSNIF instances where no triangle is
    // closer (the shader's truth covers the rest).
    std::vector<uint32_t> cpu_instance;
    const std::vector<LsnifHit> cpu = cpu_lsnif(s, rays, flags, cpu_instance);
    size_t compared = 0, agree = 0;
    SurfaceAgreement surface;
    for (size_t i = 0; i < rays.size(); ++i) {
      if (q.results[i].kind == LSNIF_QUERY_HIT_TRIANGLE) continue;
      ++compared;
      const LsnifQueryResult& r = q.results[i];
      const bool hit = r.kind == LSNIF_QUERY_HIT_LSNIF;
      const bool same = hit == cpu[i].hit &&
                        (!hit || (r.instance_index == cpu_instance[i] &&
                                  std::fabs(double(r.t - cpu[i].t)) * double(glm::length(rays[i].direction)) <=
                                      2e-4 * double(s.bounds.diagonal())));
      agree += same;
      if (!same || !hit) continue;
      // The surface channels of the same hit: the CPU's, as gpu_reference_test bounds them (fp32
      // emission: the albedo's bound times the model's scale).
      const Model* model = nullptr;
      for (const LsnifInstance& li : s.lsnif)
        if (li.index == r.instance_index) model = li.model;
      if (!model) continue;
      const float scale = model->config.emission_scale;
      add_surface(surface, r.surface, glm::vec3(r.emission_r, r.emission_g, r.emission_b), cpu[i], scale,
                  [scale](float) { return 1e-4f * scale; });
    }
    EXPECT_GE(double(agree), 0.999 * double(compared)) << "agreement with the CPU reference";
    EXPECT_EQ(surface.flag_mismatch, 0u) << "surface channels learned as the CPU's model says";
    EXPECT_EQ(surface.step_mismatch, 0u);
    EXPECT_LE(surface.emission_excess, 0.0);
    EXPECT_GE(double(surface.exact), 0.99 * double(surface.hits));
    EXPECT_GT(surface.learned, surface.hits / 20) << "not vacuous: model b's hits carry surface channels";
    EXPECT_LT(surface.learned, surface.hits) << "model a's hits carry none";
  }

  // Any-hit rays (15% end early): occluded or not as the shader's shadow rays; an answered hit is a
  // real one (its kind and instance are the shader's closest where that is the only object hit).
  const QueryRun q = query(s, rays, {LSNIF_RAY_FLAG_TERMINATE_ON_FIRST_HIT});
  const std::vector<LsnifReferenceHit> shadow = trace(s, rays, kModeShadow, 0);
  const std::vector<LsnifReferenceHit> closest = trace(s, rays, kModeClosest, 0);
  size_t same = 0, hits = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    const bool hit = q.results[i].kind == LSNIF_QUERY_HIT_LSNIF || q.results[i].kind == LSNIF_QUERY_HIT_TRIANGLE;
    hits += hit;
    same += hit == (shadow[i].hit != 0) && hit == (closest[i].hit != 0);
    if (hit) {
      EXPECT_GE(q.results[i].t, rays[i].tmin);
      EXPECT_LE(q.results[i].t, rays[i].tmax);
    }
  }
  EXPECT_GE(double(same), 0.999 * double(rays.size())) << "any-hit rays: occlusion vs the shader";
  EXPECT_GT(hits, kRays / 5);
}

// The two broad phases (two launches of a ray-tracing pipeline whose intersection shader records
// candidates; two ray queries in a compute shader) give every ray the same answer, field for field,
// and the same status: on the mixed TLAS with every kind of ray flags and on rays leaving the LSNIF
// surfaces. The automatic choice is the ray-tracing one wherever the device offers
// rayTraversalPrimitiveCulling.
TEST_F(PluginQuery, BroadPhasesAgreeHitForHit) {
  EXPECT_EQ(pipeline_.broad_phase(),
            ray_query_missing_.empty() ? LSNIF_QUERY_BROAD_PHASE_RAY_QUERY : LSNIF_QUERY_BROAD_PHASE_TRACE_RAYS)
      << "the automatic choice: ray queries where the device has them";
  LSNIF_TEST_NEEDS(trace_rays_missing_.empty(), vk_.device_name(), "feature rayTraversalPrimitiveCulling");
  LSNIF_TEST_NEEDS(ray_query_missing_.empty(), vk_.device_name(), "extension VK_KHR_ray_query with feature rayQuery");
  ASSERT_EQ(ray_query_pipeline_.broad_phase(), LSNIF_QUERY_BROAD_PHASE_RAY_QUERY);
  ASSERT_EQ(trace_rays_pipeline_.broad_phase(), LSNIF_QUERY_BROAD_PHASE_TRACE_RAYS);
  Scene s;
  const Cleanup cleanup{[&] { release(s); }};
  ASSERT_NO_FATAL_FAILURE(mixed_scene(s));
  std::vector<Ray> rays = rays_at(s, kRays, 5);
  // Rays leaving the surface: from the closest LSNIF hits of the first rays, back towards the origin.
  const QueryRun first = query(s, rays, {0u}, 4, nullptr, nullptr, &trace_rays_pipeline_);
  for (size_t i = 0; i < kRays / 4; ++i) {
    const LsnifQueryResult& h = first.results[i];
    if (h.kind != LSNIF_QUERY_HIT_LSNIF) continue;
    Ray r = rays[i];
    r.origin = rays[i].origin + h.t * rays[i].direction;
    r.direction = -rays[i].direction;
    r.tmin = 1e-3f;
    rays.push_back(r);
  }
  size_t lsnif = 0, triangles = 0;
  for (const uint32_t flags :
       {0u, LSNIF_RAY_FLAG_CULL_BACK_FACING, LSNIF_RAY_FLAG_CULL_FRONT_FACING, LSNIF_RAY_FLAG_TERMINATE_ON_FIRST_HIT,
        LSNIF_RAY_FLAG_TERMINATE_ON_FIRST_HIT | LSNIF_RAY_FLAG_CULL_BACK_FACING}) {
    SCOPED_TRACE(testing::Message() << "ray flags 0x" << std::hex << flags);
    const QueryRun trace_rays = query(s, rays, {flags}, 4, nullptr, nullptr, &trace_rays_pipeline_);
    const QueryRun ray_query = query(s, rays, {flags}, 4, nullptr, nullptr, &ray_query_pipeline_);
    ASSERT_EQ(trace_rays.results.size(), rays.size());
    ASSERT_EQ(ray_query.results.size(), rays.size());
    size_t differ = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
      const bool same = std::memcmp(&trace_rays.results[i], &ray_query.results[i], sizeof(LsnifQueryResult)) == 0;
      differ += !same;
      if (!same && differ <= 3)
        ADD_FAILURE() << "ray " << i << ": kind " << trace_rays.results[i].kind << " t " << trace_rays.results[i].t
                      << " instance " << trace_rays.results[i].instance_index << " (trace rays) vs kind "
                      << ray_query.results[i].kind << " t " << ray_query.results[i].t << " instance "
                      << ray_query.results[i].instance_index << " (ray query)";
      lsnif += trace_rays.results[i].kind == LSNIF_QUERY_HIT_LSNIF;
      triangles += trace_rays.results[i].kind == LSNIF_QUERY_HIT_TRIANGLE;
    }
    EXPECT_EQ(differ, 0u) << "rays answered differently by the two broad phases";
    EXPECT_EQ(trace_rays.status.candidates, ray_query.status.candidates);
    EXPECT_EQ(trace_rays.status.capacity, ray_query.status.capacity);
    EXPECT_EQ(trace_rays.status.dropped, ray_query.status.dropped);
    EXPECT_EQ(trace_rays.status.incomplete_rays, ray_query.status.incomplete_rays);
    EXPECT_EQ(trace_rays.status.unevaluated, ray_query.status.unevaluated);
  }
  EXPECT_GT(lsnif, kRays / 2) << "too few LSNIF hits to tell anything";
  EXPECT_GT(triangles, kRays / 4) << "too few triangle hits to tell anything";
}

// An application that traced its own geometry first passes the distance it found as each ray's
// tmax: the query must then report exactly the hits closer than it (at most tmax, inclusive), each
// the same to the bit as without the limit, and nothing for the others. The limits lie just below,
// at and just above the unlimited answer's t (and anywhere for misses).
TEST_F(PluginQuery, ApplicationTmaxKeepsExactlyTheCloserHits) {
  Scene s;
  const Cleanup cleanup{[&] { release(s); }};
  ASSERT_NO_FATAL_FAILURE(mixed_scene(s));
  std::vector<Ray> rays = rays_at(s, kRays, 11);
  for (Ray& r : rays) r.tmax = std::numeric_limits<float>::infinity();
  const QueryRun unlimited = query(s, rays, {0u});
  ASSERT_EQ(unlimited.results.size(), rays.size());
  ASSERT_EQ(unlimited.status.incomplete_rays, 0u);
  const float factors[] = {0.5f, 0.9999f, 1.0f, 1.0001f, 3.0f};
  std::vector<bool> keeps(rays.size());
  for (size_t i = 0; i < rays.size(); ++i) {
    const LsnifQueryResult& u = unlimited.results[i];
    const bool hit = u.kind == LSNIF_QUERY_HIT_LSNIF || u.kind == LSNIF_QUERY_HIT_TRIANGLE;
    // Exactly at t for LSNIF hits only: a triangle exactly at tmax is the traversal's to decide.
    float f = factors[i % 5];
    if (f == 1.0f && u.kind != LSNIF_QUERY_HIT_LSNIF) f = 1.0001f;
    rays[i].tmax = hit ? u.t * f : s.bounds.diagonal() * float(i % 7) / glm::length(rays[i].direction);
    keeps[i] = hit && u.t <= rays[i].tmax;
  }
  const QueryRun limited = query(s, rays, {0u});
  ASSERT_EQ(limited.results.size(), rays.size());
  size_t kept_lsnif = 0, kept_triangles = 0, dropped = 0, wrong = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    const LsnifQueryResult& u = unlimited.results[i];
    const LsnifQueryResult& l = limited.results[i];
    const bool ok = keeps[i] ? std::memcmp(&u, &l, sizeof u) == 0 : l.kind == LSNIF_QUERY_HIT_NONE;
    if (!ok && ++wrong <= 3)
      ADD_FAILURE() << "ray " << i << " tmax " << rays[i].tmax << ": unlimited kind " << u.kind << " t " << u.t
                    << " instance " << u.instance_index << ", limited kind " << l.kind << " t " << l.t
                    << " instance " << l.instance_index;
    kept_lsnif += keeps[i] && u.kind == LSNIF_QUERY_HIT_LSNIF;
    kept_triangles += keeps[i] && u.kind == LSNIF_QUERY_HIT_TRIANGLE;
    dropped += !keeps[i] && u.kind != LSNIF_QUERY_HIT_NONE;
  }
  EXPECT_EQ(wrong, 0u);
  EXPECT_EQ(limited.status.incomplete_rays, 0u);
  std::printf("[application tmax] %zu rays: kept %zu LSNIF and %zu triangle hits, %zu hits beyond tmax dropped\n",
              rays.size(), kept_lsnif, kept_triangles, dropped);
  EXPECT_GT(kept_lsnif, kRays / 10) << "too few LSNIF hits to tell anything";
  EXPECT_GT(dropped, kRays / 10);
}

// The model-table entry chosen by LsnifQueryModelIndexInfo: the mixed scene again with the custom
// indices moved by a base (and the base given), and with custom indices of the application's own
// (the table then indexed by the TLAS instance index) must answer every ray as the scene numbered
// by the custom index does, reporting each instance's own custom index.
TEST_F(PluginQuery, ModelTableIndexedByABaseOrTheInstanceIndex) {
  Scene reference, based, by_instance;
  const Cleanup cleanup{[&] {
    release(reference);
    release(based);
    release(by_instance);
  }};
  ASSERT_NO_FATAL_FAILURE(mixed_scene(reference));
  // The same instances; only custom indices and tables differ.
  constexpr uint32_t kBase = 1000;
  based.records = by_instance.records = reference.records;
  based.lsnif = by_instance.lsnif = reference.lsnif;
  based.boxes = by_instance.boxes = reference.boxes;
  based.table_models = reference.table_models;
  std::vector<uint32_t> own_index(reference.records.size());
  for (size_t i = 0; i < reference.records.size(); ++i) {
    based.records[i].instanceCustomIndex = (reference.records[i].instanceCustomIndex + kBase) & 0xffffffu;
    own_index[i] = 7000 + 13 * uint32_t(i);
    by_instance.records[i].instanceCustomIndex = own_index[i] & 0xffffffu;
    const uint32_t entry = reference.records[i].instanceCustomIndex;
    by_instance.table_models.push_back(entry < reference.table_models.size() ? reference.table_models[entry] : nullptr);
  }
  ASSERT_NO_FATAL_FAILURE(finish(based));
  ASSERT_NO_FATAL_FAILURE(finish(by_instance));
  const std::vector<Ray> rays = rays_at(reference, kRays, 13);
  const QueryRun want = query(reference, rays, {0u});
  LsnifQueryModelIndexInfo base_info{};
  base_info.sType = LSNIF_STRUCTURE_TYPE_QUERY_MODEL_INDEX_INFO;
  base_info.modelIndex = LSNIF_QUERY_MODEL_INDEX_CUSTOM_INDEX;
  base_info.customIndexBase = kBase;
  LsnifQueryModelIndexInfo instance_info = base_info;
  instance_info.modelIndex = LSNIF_QUERY_MODEL_INDEX_INSTANCE_INDEX;
  instance_info.customIndexBase = 0;
  std::vector<std::array<uint64_t, 2>> stamps;  // chained before the model index
  const QueryRun got_based = query(based, rays, {0u}, 4, nullptr, &stamps, nullptr, &base_info);
  const QueryRun got_by_instance = query(by_instance, rays, {0u}, 4, nullptr, nullptr, nullptr, &instance_info);
  const QueryRun unbased = query(based, rays, {0u});  // the base not given: every LSNIF entry is past the table
  size_t lsnif = 0, wrong = 0, unbased_lsnif = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    LsnifQueryResult expect_based = want.results[i], expect_by_instance = want.results[i];
    const bool hit = want.results[i].kind == LSNIF_QUERY_HIT_LSNIF || want.results[i].kind == LSNIF_QUERY_HIT_TRIANGLE;
    if (hit) {
      expect_based.instance_custom_index += kBase;
      expect_by_instance.instance_custom_index = own_index[want.results[i].instance_index];
    }
    const bool same = std::memcmp(&expect_based, &got_based.results[i], sizeof expect_based) == 0 &&
                      std::memcmp(&expect_by_instance, &got_by_instance.results[i], sizeof expect_by_instance) == 0;
    if (!same && ++wrong <= 3)
      ADD_FAILURE() << "ray " << i << ": kind " << want.results[i].kind << " instance " << want.results[i].instance_index
                    << " t " << want.results[i].t << " | with a base: kind " << got_based.results[i].kind << " custom "
                    << got_based.results[i].instance_custom_index << " | by instance: kind "
                    << got_by_instance.results[i].kind << " custom " << got_by_instance.results[i].instance_custom_index;
    lsnif += want.results[i].kind == LSNIF_QUERY_HIT_LSNIF;
    unbased_lsnif += unbased.results[i].kind == LSNIF_QUERY_HIT_LSNIF;
  }
  EXPECT_EQ(wrong, 0u);
  EXPECT_GT(lsnif, kRays / 10) << "too few LSNIF hits to tell anything";
  EXPECT_EQ(unbased_lsnif, 0u) << "without the base, the moved custom indices name no table entry";
  EXPECT_EQ(got_based.status.candidates, want.status.candidates);
  EXPECT_EQ(got_by_instance.status.candidates, want.status.candidates);
}

// Rays leaving the LSNIF surfaces by the self-intersection rule (origin at the hit, back-face
// culling, tmin = leaving_tmin of the hit's instance) against the shader with the same flags.
TEST_P(PluginQueryPerBroadPhase, RaysLeavingAnLsnifSurfaceMatchTheIntersectionShader) {
  Scene s;
  const Cleanup cleanup{[&] { release(s); }};
  ASSERT_NO_FATAL_FAILURE(mixed_scene(s));
  const std::vector<Ray> primary = rays_at(s, kRays, 7);
  const QueryRun first = query(s, primary, {0u});
  std::mt19937 rng(9);
  std::normal_distribution<float> g(0.0f, 1.0f);
  std::vector<Ray> leaving;
  for (size_t i = 0; i < primary.size(); ++i) {
    const LsnifQueryResult& r = first.results[i];
    if (r.kind != LSNIF_QUERY_HIT_LSNIF) continue;
    const LsnifInstance* li = nullptr;
    for (const LsnifInstance& c : s.lsnif)
      if (c.index == r.instance_index) li = &c;
    ASSERT_NE(li, nullptr);
    Ray l;
    l.origin = primary[i].origin + r.t * primary[i].direction;
    l.direction = glm::normalize(glm::vec3(g(rng), g(rng), g(rng)));
    l.tmin = leaving_tmin(*li->model, li->xf, l.direction);
    leaving.push_back(l);
  }
  ASSERT_GT(leaving.size(), kRays / 10);
  const QueryRun q = query(s, leaving, {LSNIF_RAY_FLAG_CULL_BACK_FACING});
  const Agreement a = compare(s, leaving, q.results, trace(s, leaving, kModeClosest, LSNIF_RAY_FLAG_CULL_BACK_FACING));
  expect_agreement(a, "rays leaving the surface");
  EXPECT_GT(a.lsnif + a.triangles, leaving.size() / 20) << "too few hits to tell anything";
}

// Ten table entries (models A and B uploaded again, alternating, with holes between them), nine
// LSNIF instances in a row of overlapping boxes and one triangle instance: every model is its own
// bucket of the counting sort and its own indirect dispatches.
TEST_P(PluginQueryPerBroadPhase, ManyModelsInOneBatch) {
  std::vector<LsnifModel> extra;
  Scene s;
  const Cleanup cleanup{[&] {
    release(s);
    for (LsnifModel& m : extra) plugin_.release(m);
  }};
  const Aabb& ba = model_a_.bounds();
  const float step = 0.45f * ba.extent().x;
  s.table_models.assign(12, nullptr);
  for (uint32_t k = 0; k < 9; ++k) {
    const bool is_a = k % 2 == 0;
    LsnifModel m = nullptr;
    ASSERT_TRUE(plugin_.upload(is_a ? model_a_ : model_b_, m));
    extra.push_back(m);
    const uint32_t entry = k + (k >= 4 ? 2u : 0u);  // entries 4 and 5 are holes
    s.table_models[entry] = m;
    const Model& model = is_a ? model_a_ : model_b_;
    const float scale = ba.extent().x / model.bounds().extent().x;
    add_lsnif(s, model, m, entry,
              transform({0.3f, 1, 0.1f}, 25.0f * float(k), glm::vec3(scale, scale * (0.8f + 0.05f * float(k)), scale),
                        glm::vec3(step * float(k), 0.1f * ba.extent().y * float(k % 3), 0) -
                            scale * model.bounds().center()));
  }
  add_triangles(
      s, 5, transform({0, 0, 1}, 10, glm::vec3(0.7f), glm::vec3(4.0f * step, -0.6f * ba.extent().y, 0) - ba.center()));
  ASSERT_NO_FATAL_FAILURE(finish(s));
  const std::vector<Ray> rays = rays_at(s, kRays, 11);
  const QueryRun q = query(s, rays, {0u});
  const Agreement a = compare(s, rays, q.results, trace(s, rays, kModeClosest, 0));
  expect_agreement(a, "ten table entries");
  std::vector<size_t> per_instance(s.records.size(), 0);
  for (const LsnifQueryResult& r : q.results)
    if (r.kind == LSNIF_QUERY_HIT_LSNIF) ++per_instance[r.instance_index];
  for (const LsnifInstance& li : s.lsnif) EXPECT_GT(per_instance[li.index], 10u) << "instance " << li.index;
  EXPECT_EQ(q.status.dropped, 0u);
}

// Texture coordinates: two instances of a model with uv cells (gputest::uv_sphere_model; one
// rotated with non-uniform scale) beside a triangle instance. Each LSNIF answer reports the
// coordinate the intersection shader packs into its hit attributes (compare(): within half a step
// of the packing) and the CPU reference's lookup for the same instance (fp32 on both sides).
TEST_P(PluginQueryPerBroadPhase, TexturedInstancesReportTheirTextureCoordinates) {
  Model model;
  const Status trained = uv_sphere_model(model);
  ASSERT_TRUE(trained) << trained.message();
  ASSERT_EQ(model.config.uv_materials, 1u);
  LsnifModel m = nullptr;
  Scene s;
  const Cleanup cleanup{[&] {
    release(s);
    plugin_.release(m);
  }};
  ASSERT_TRUE(plugin_.upload(model, m));
  const glm::vec3 e = model.bounds().extent();
  s.table_models = {m, nullptr};
  add_lsnif(s, model, m, 0, transform({0, 1, 0}, 40, glm::vec3(1.0f), -model.bounds().center()));
  add_lsnif(s, model, m, 0,
            transform({1, 1, 0}, 30, glm::vec3(0.7f, 1.2f, 0.9f), glm::vec3(0.9f * e.x, 0.2f * e.y, 0) - model.bounds().center()));
  const float tri_scale = 0.6f * e.x / mesh_.bounds().extent().x;
  add_triangles(s, 1, transform({0, 0, 1}, 15, glm::vec3(tri_scale), glm::vec3(-0.8f * e.x, 0, 0.3f * e.z) - tri_scale * mesh_.bounds().center()));
  ASSERT_NO_FATAL_FAILURE(finish(s));
  const std::vector<Ray> rays = rays_at(s, kRays, 13);
  const QueryRun q = query(s, rays, {0u});
  const Agreement a = compare(s, rays, q.results, trace(s, rays, kModeClosest, 0));
  expect_agreement(a, "textured instances");
  EXPECT_GT(a.uv_both, a.lsnif / 2) << "not vacuous: most LSNIF hits report a texture coordinate";
  EXPECT_GT(a.triangles, kRays / 50) << "too few triangle hits to tell anything";
  EXPECT_EQ(q.status.incomplete_rays, 0u);
  // Against the CPU reference of the LSNIF instances where no triangle is closer.
  std::vector<uint32_t> cpu_instance;
  const std::vector<LsnifHit> cpu = cpu_lsnif(s, rays, 0, cpu_instance);
  size_t both = 0, one_side = 0, apart = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    const LsnifQueryResult& r = q.results[i];
    if (r.kind != LSNIF_QUERY_HIT_LSNIF || !cpu[i].hit || r.instance_index != cpu_instance[i]) continue;
    if (std::fabs(double(r.t - cpu[i].t)) * double(glm::length(rays[i].direction)) > 2e-4 * double(s.bounds.diagonal()))
      continue;
    if ((r.reports_uv != 0u) != cpu[i].reports_uv) {
      ++one_side;
    } else if (cpu[i].reports_uv) {
      ++both;
      apart += glm::length(glm::dvec2(r.uv_u, r.uv_v) - glm::dvec2(cpu[i].uv)) > 1e-4;
    }
  }
  std::printf("vs the CPU reference: texture coordinates %zu, one side %zu, apart %zu\n", both, one_side, apart);
  EXPECT_GT(both, a.lsnif / 2);
  EXPECT_LE(double(one_side), 2e-3 * double(both));
  EXPECT_LE(double(apart), 5e-3 * double(both));
}

// A row of eight instances of one model, apart, each its own table entry (one run of eight entries:
// one batch), and rays along the row (closest and any-hit): the first round evaluates each ray's
// nearest box, the second leaves out the boxes beyond the hit it found. The answers are the
// intersection shader's and the CPU reference's (the closest hit over every instance); the status's
// culled count lies between a bound computed on the CPU (candidates whose world box starts clearly
// beyond their ray's answer; no walk starts before its box) and the candidates that are not their
// ray's first. Then the device table's entry 3 holds another model: only its candidates are not
// evaluated (the rays crossing box 3), and every ray that does not cross it answers as before.
TEST_P(PluginQueryPerBroadPhase, TheSecondRoundLeavesOutOnlyWhatCannotWin) {
  Scene s;
  const Cleanup cleanup{[&] { release(s); }};
  constexpr uint32_t kRow = 8;
  s.table_models.assign(kRow, a_);
  const Aabb& ba = model_a_.bounds();
  const glm::vec3 e = ba.extent();
  for (uint32_t k = 0; k < kRow; ++k)
    add_lsnif(s, model_a_, a_, k,
              transform({0, 1, 0}, 0, glm::vec3(1.0f), glm::vec3(1.25f * e.x * float(k), 0, 0) - ba.center()));
  ASSERT_NO_FATAL_FAILURE(finish(s));
  std::mt19937 rng(29);
  std::uniform_real_distribution<float> u(-0.45f, 0.45f);
  std::vector<Ray> rays(kRays);
  for (Ray& r : rays) {
    r.origin = glm::vec3(-1.5f * e.x, u(rng) * e.y, u(rng) * e.z);
    r.direction = glm::vec3(1.0f, 0.05f * u(rng), 0.05f * u(rng));
  }
  // The CPU's entry into each world box (slab test), -1 when the ray misses it.
  auto entry = [&](const Ray& r, const Aabb& b) {
    const glm::vec3 a = (b.lo - r.origin) / r.direction, c = (b.hi - r.origin) / r.direction;
    const glm::vec3 lo = glm::min(a, c), hi = glm::max(a, c);
    const float t0 = std::max(std::max(lo.x, lo.y), std::max(lo.z, r.tmin));
    const float t1 = std::min(std::min(hi.x, hi.y), hi.z);
    return t0 <= t1 ? t0 : -1.0f;
  };
  std::vector<uint32_t> cpu_instance;
  const std::vector<LsnifHit> cpu = cpu_lsnif(s, rays, 0, cpu_instance);
  QueryRun closest;
  for (const uint32_t flags : {0u, LSNIF_RAY_FLAG_TERMINATE_ON_FIRST_HIT}) {
    SCOPED_TRACE(flags ? "any-hit rays" : "closest-hit rays");
    const QueryRun q = query(s, rays, {flags}, kRow);
    if (flags == 0) {
      expect_agreement(compare(s, rays, q.results, trace(s, rays, kModeClosest, 0)), "a row of eight");
      size_t same = 0, hits = 0;
      for (size_t i = 0; i < rays.size(); ++i) {
        const bool hit = q.results[i].kind == LSNIF_QUERY_HIT_LSNIF;
        hits += hit;
        same += hit == cpu[i].hit && (!hit || q.results[i].instance_index == cpu_instance[i]);
      }
      EXPECT_GE(double(same), 0.99 * double(rays.size())) << "closest instance vs the CPU reference over every instance";
      EXPECT_GT(hits, rays.size() / 2);
    }
    // The bound: rays answered by their nearest box (the first round's hit), boxes clearly beyond it.
    size_t bound = 0, not_first = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
      const LsnifQueryResult& r = q.results[i];
      std::vector<float> t(s.boxes.size());
      size_t crossed = 0, nearest = 0;
      for (size_t k = 0; k < s.boxes.size(); ++k) {
        t[k] = entry(rays[i], s.boxes[k]);
        if (t[k] < 0.0f) continue;
        if (crossed++ == 0 || t[k] < t[nearest]) nearest = k;
      }
      not_first += crossed > 0 ? crossed - 1 : 0;
      if (r.kind != LSNIF_QUERY_HIT_LSNIF || r.instance_index != s.lsnif[nearest].index) continue;
      for (size_t k = 0; k < s.boxes.size(); ++k) bound += t[k] > r.t + 1e-3f * e.x;
    }
    EXPECT_GT(bound, rays.size()) << "the rays must hit before the end of the row";
    EXPECT_GE(q.status.culled, bound) << "candidates beyond their ray's answer";
    EXPECT_LE(q.status.culled, not_first) << "a ray's first candidate is never culled";
    EXPECT_EQ(q.status.unevaluated, 0u);
    EXPECT_EQ(q.status.incomplete_rays, 0u);
    if (flags == 0) closest = q;
  }

  // Entry 3 of the device's table holds model B while pModels says A.
  Scene other;
  const Cleanup cleanup_other{[&] { release(other); }};
  other.table_models = s.table_models;
  other.table_models[3] = b_;
  for (uint32_t k = 0; k < kRow; ++k) add_lsnif(other, model_a_, a_, k, s.lsnif[k].xf);
  ASSERT_NO_FATAL_FAILURE(finish(other));
  const QueryRun q = query(other, rays, {0u}, kRow, &s.table_models);
  size_t crossing = 0, same = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    if (entry(rays[i], s.boxes[3]) >= 0.0f) {
      ++crossing;
      continue;
    }
    same += std::memcmp(&q.results[i], &closest.results[i], sizeof(LsnifQueryResult)) == 0;
  }
  EXPECT_EQ(same, rays.size() - crossing) << "rays not crossing box 3 answer as with the agreeing table";
  EXPECT_NEAR(double(q.status.unevaluated), double(crossing), 0.005 * double(rays.size()))
      << "the candidates of entry 3 alone are not evaluated";
  EXPECT_GT(crossing, rays.size() / 2);
}

// A capacity of one candidate per ray over rays that cross several LSNIF boxes: candidates are
// dropped, and every ray is either answered exactly as with room for all of its candidates or marked
// LSNIF_QUERY_HIT_INCOMPLETE; the status counts both.
TEST_P(PluginQueryPerBroadPhase, OverflowMarksTheAffectedRays) {
  Scene s;
  const Cleanup cleanup{[&] { release(s); }};
  ASSERT_NO_FATAL_FAILURE(mixed_scene(s));
  const std::vector<Ray> rays = rays_to_centre(s, kRays, 13);
  const std::vector<uint32_t> flags = every_other_any_hit(rays.size());
  const QueryRun full = query(s, rays, flags, 8);
  ASSERT_EQ(full.status.dropped, 0u);
  const QueryRun tight = query(s, rays, flags, 1);
  EXPECT_EQ(tight.status.capacity, uint32_t(rays.size()));
  EXPECT_EQ(tight.status.candidates, full.status.candidates);
  EXPECT_EQ(tight.status.dropped, full.status.candidates - uint32_t(rays.size()));
  ASSERT_GT(tight.status.dropped, 0u) << "the rays must overflow one candidate per ray";
  const auto [incomplete, exact, lsnif] = marked_or_exact(flags, tight, full);
  std::printf(
      "[overflow] %zu rays, %u candidates, capacity %u, dropped %u: %zu incomplete, %zu exact (%zu LSNIF hits)\n",
      rays.size(), tight.status.candidates, tight.status.capacity, tight.status.dropped, incomplete, exact, lsnif);
  EXPECT_EQ(incomplete, tight.status.incomplete_rays);
  EXPECT_GT(incomplete, 0u);
  EXPECT_EQ(incomplete + exact, rays.size());
  EXPECT_GT(lsnif, 0u) << "kept candidates must still answer";
  EXPECT_EQ(tight.status.unevaluated, 0u);
}

// The device's model table disagrees with pModels: entry 0 holds model B's block while pModels[0]
// is A, or holds A's block while pModels[0] is NULL. The candidates of entry 0 are not evaluated
// (the status counts them exactly: all candidates but those of entry 1); every ray one of them could
// have changed is LSNIF_QUERY_HIT_INCOMPLETE, and every other ray is answered as with a table that
// agrees with pModels.
TEST_P(PluginQueryPerBroadPhase, ModelTableDisagreeingWithPModelsMarksTheAffectedRays) {
  Scene s;
  const Cleanup cleanup{[&] { release(s); }};
  ASSERT_NO_FATAL_FAILURE(mixed_scene(s));  // pModels {A, B, NULL}, the table written from them
  const std::vector<Ray> rays = rays_to_centre(s, kRays, 17);
  const std::vector<uint32_t> flags = every_other_any_hit(rays.size());
  auto write_table = [&](const std::vector<LsnifModel>& models) {
    std::vector<uint64_t> table;
    ASSERT_TRUE(plugin_.model_table(models, table));
    std::memcpy(s.table.mapped, table.data(), table.size() * sizeof(uint64_t));
  };
  // The candidates of entry 1 alone (entry 0 a hole on both sides).
  const std::vector<LsnifModel> only_b = {nullptr, b_, nullptr};
  ASSERT_NO_FATAL_FAILURE(write_table(only_b));
  const QueryRun entry1 = query(s, rays, flags, 8, &only_b);
  EXPECT_EQ(entry1.status.unevaluated, 0u);

  struct Case {
    const char* what;
    std::vector<LsnifModel> table, models, agreeing;
  };
  const Case cases[] = {
      {"table B, pModels A", {b_, b_, nullptr}, {a_, b_, nullptr}, {b_, b_, nullptr}},
      {"table A, pModels NULL", {a_, b_, nullptr}, {nullptr, b_, nullptr}, {a_, b_, nullptr}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    ASSERT_NO_FATAL_FAILURE(write_table(c.table));
    const QueryRun agree = query(s, rays, flags, 8, &c.agreeing);
    const QueryRun q = query(s, rays, flags, 8, &c.models);
    ASSERT_EQ(agree.status.dropped, 0u);
    EXPECT_EQ(agree.status.unevaluated, 0u);
    EXPECT_EQ(agree.status.incomplete_rays, 0u);
    EXPECT_EQ(q.status.dropped, 0u);
    EXPECT_EQ(q.status.candidates, agree.status.candidates);
    EXPECT_EQ(q.status.unevaluated, agree.status.candidates - entry1.status.candidates);
    ASSERT_GT(q.status.unevaluated, kRays / 4) << "too few candidates of entry 0 to tell anything";
    const auto [incomplete, exact, lsnif] = marked_or_exact(flags, q, agree);
    for (size_t i = 0; i < rays.size(); ++i)
      EXPECT_NE(q.results[i].instance_custom_index, 0u) << "ray " << i << " answered by an entry not evaluated";
    std::printf("[%s] %zu rays, %u candidates, %u not evaluated: %zu incomplete, %zu exact (%zu LSNIF hits)\n",
                c.what, rays.size(), q.status.candidates, q.status.unevaluated, incomplete, exact, lsnif);
    EXPECT_EQ(incomplete, q.status.incomplete_rays);
    EXPECT_GT(incomplete, rays.size() / 10);
    EXPECT_EQ(incomplete + exact, rays.size());
    EXPECT_GT(lsnif, 0u) << "entry 1 must still answer";
  }
}

// Two instances of the same model at the same place (and a third elsewhere): every hit on them is
// at equal t, and the lower instance index must win, whatever order the traversal and the atomics
// took.
TEST_P(PluginQueryPerBroadPhase, EqualTResolvesToTheLowerInstanceIndex) {
  Scene s;
  const Cleanup cleanup{[&] { release(s); }};
  s.table_models = {nullptr, b_, a_};
  const Transform3x4 xf = transform({0, 1, 1}, 40, glm::vec3(1.2f, 0.8f, 1.0f), glm::vec3(0.0f));
  add_lsnif(s, model_b_, b_, 1, transform({0, 0, 1}, 0, glm::vec3(1.0f), glm::vec3(50.0f, 0, 0)));
  add_lsnif(s, model_a_, a_, 2, xf);
  add_lsnif(s, model_a_, a_, 2, xf);
  ASSERT_NO_FATAL_FAILURE(finish(s));
  s.boxes.erase(s.boxes.begin());  // aim at the pair
  const std::vector<Ray> rays = rays_at(s, 2000, 23);
  for (const uint32_t flags : {0u, LSNIF_RAY_FLAG_TERMINATE_ON_FIRST_HIT}) {
    const QueryRun q = query(s, rays, {flags});
    size_t hits = 0;
    for (const LsnifQueryResult& r : q.results) {
      if (r.kind != LSNIF_QUERY_HIT_LSNIF) continue;
      ++hits;
      EXPECT_EQ(r.instance_index, 1u) << "flags " << flags << ": the lower of two instances at equal t";
      EXPECT_EQ(r.instance_custom_index, 2u);
    }
    EXPECT_GT(hits, 100u);
  }
}

// More rays than one chunk (LSNIF_QUERY_CHUNK_RAYS): the scratch is sized for one chunk and reused,
// the second chunk's rays answer exactly as in a batch of their own, and the status adds the
// chunks' candidates.
TEST_P(PluginQueryPerBroadPhase, BatchesOfMoreThanOneChunk) {
  Scene s;
  const Cleanup cleanup{[&] { release(s); }};
  ASSERT_NO_FATAL_FAILURE(mixed_scene(s));
  const size_t tail = 1500;
  const std::vector<Ray> rays = rays_at(s, LSNIF_QUERY_CHUNK_RAYS + tail, 29);
  LsnifQueryInfo one{}, big{};
  one.rayCount = LSNIF_QUERY_CHUNK_RAYS;
  big.rayCount = uint32_t(rays.size());
  one.candidatesPerRay = big.candidatesPerRay = 2;
  VkDeviceSize one_bytes = 0, big_bytes = 0;
  ASSERT_EQ(lsnifGetQueryScratchSize(plugin_.context(), &one, &one_bytes), LSNIF_SUCCESS);
  ASSERT_EQ(lsnifGetQueryScratchSize(plugin_.context(), &big, &big_bytes), LSNIF_SUCCESS);
  EXPECT_EQ(big_bytes, one_bytes);
  const QueryRun all = query(s, rays, {0u}, 2);
  const std::vector<Ray> head_rays(rays.begin(), rays.begin() + tail);
  const std::vector<Ray> tail_rays(rays.end() - tail, rays.end());
  const QueryRun head = query(s, head_rays, {0u}, 2), last = query(s, tail_rays, {0u}, 2);
  ASSERT_EQ(all.results.size(), rays.size());
  EXPECT_EQ(all.status.capacity, 2u * LSNIF_QUERY_CHUNK_RAYS);
  EXPECT_EQ(all.status.dropped, 0u);
  EXPECT_GT(all.status.candidates, last.status.candidates + head.status.candidates);
  size_t same = 0, tail_hits = 0;
  for (size_t i = 0; i < tail; ++i) {
    const LsnifQueryResult& a = all.results[i];
    const LsnifQueryResult& t = all.results[rays.size() - tail + i];
    same += a.kind == head.results[i].kind && a.instance_index == head.results[i].instance_index &&
            a.t == head.results[i].t;
    same += t.kind == last.results[i].kind && t.instance_index == last.results[i].instance_index &&
            t.t == last.results[i].t;
    tail_hits += t.kind != LSNIF_QUERY_HIT_NONE;
  }
  EXPECT_EQ(same, 2 * tail) << "the chunks' rays answer as in batches of their own";
  EXPECT_GT(tail_hits, tail / 10) << "the second chunk must hit too";
}

// The stage timestamps (LsnifQueryTimestampsInfo): all written, in order, by a one-chunk batch (9),
// a two-chunk batch (17: eight per chunk) and an empty batch (9), without changing any answer; a
// wrong chain is refused.
TEST_P(PluginQueryPerBroadPhase, StageTimestamps) {
  Scene s;
  const Cleanup cleanup{[&] { release(s); }};
  ASSERT_NO_FATAL_FAILURE(mixed_scene(s));
  EXPECT_EQ(LSNIF_QUERY_TIMESTAMP_COUNT_FOR_RAYS(0u), LSNIF_QUERY_TIMESTAMP_COUNT);
  EXPECT_EQ(LSNIF_QUERY_TIMESTAMP_COUNT_FOR_RAYS(LSNIF_QUERY_CHUNK_RAYS), LSNIF_QUERY_TIMESTAMP_COUNT);
  EXPECT_EQ(LSNIF_QUERY_TIMESTAMP_COUNT_FOR_RAYS(LSNIF_QUERY_CHUNK_RAYS + 1u), 17u);
  EXPECT_EQ(LSNIF_QUERY_TIMESTAMP_COUNT_FOR_RAYS(0xffffffffu), 1u + 8u * 65536u);
  auto expect_ordered = [](const std::vector<std::array<uint64_t, 2>>& stamps, uint32_t count, const char* what) {
    ASSERT_EQ(stamps.size(), count) << what;
    for (uint32_t k = 0; k < count; ++k) {
      EXPECT_NE(stamps[k][1], 0u) << what << ": timestamp " << k << " was not written";
      if (k > 0) {
        EXPECT_LE(stamps[k - 1][0], stamps[k][0]) << what << ": timestamp " << k << " before " << k - 1;
      }
    }
  };
  const std::vector<Ray> rays = rays_at(s, 2000, 41);
  std::vector<std::array<uint64_t, 2>> stamps;
  const QueryRun timed = query(s, rays, {0u}, 4, nullptr, &stamps);
  expect_ordered(stamps, LSNIF_QUERY_TIMESTAMP_COUNT, "one chunk");
  EXPECT_LT(stamps[0][0], stamps[LSNIF_QUERY_TIMESTAMPS_PER_CHUNK][0]) << "the stages take time";
  const QueryRun plain = query(s, rays, {0u});
  ASSERT_EQ(timed.results.size(), plain.results.size());
  size_t same = 0;
  for (size_t i = 0; i < rays.size(); ++i)
    same += std::memcmp(&timed.results[i], &plain.results[i], sizeof(LsnifQueryResult)) == 0;
  EXPECT_EQ(same, rays.size()) << "timestamps change no answer";

  const std::vector<Ray> many = rays_at(s, LSNIF_QUERY_CHUNK_RAYS + 100, 43);
  query(s, many, {0u}, 2, nullptr, &stamps);
  constexpr uint32_t kPerChunk = LSNIF_QUERY_TIMESTAMPS_PER_CHUNK;
  expect_ordered(stamps, 1 + 2 * kPerChunk, "two chunks");
  if (stamps.size() == 1 + 2 * kPerChunk) {
    // Each chunk's stages are its own: the first chunk's broad phase traverses 65,536 rays, the
    // second's 100 (the same rays' distribution), so the first takes longer.
    EXPECT_GT(stamps[1][0] - stamps[0][0], stamps[kPerChunk + 1][0] - stamps[kPerChunk][0])
        << "broad phases of the two chunks";
  }
  query(s, {}, {0u}, 4, nullptr, &stamps);
  expect_ordered(stamps, LSNIF_QUERY_TIMESTAMP_COUNT, "empty batch");

  // A wrong chain records nothing and names the problem.
  LsnifQueryInfo info{};
  info.candidatesPerRay = 1;
  LsnifQueryTimestampsInfo chained{};
  chained.sType = LSNIF_STRUCTURE_TYPE_QUERY_PIPELINE_FLAGS_CREATE_INFO;
  info.pNext = &chained;
  VkDeviceSize need = 0;
  EXPECT_EQ(lsnifGetQueryScratchSize(plugin_.context(), &info, &need), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_NE(last_error().find("unknown structure type 1"), std::string::npos) << last_error();
  chained.sType = LSNIF_STRUCTURE_TYPE_QUERY_TIMESTAMPS_INFO;
  Status st = vk_.submit("refused", [&](VkCommandBuffer cmd) {
    EXPECT_EQ(lsnifCmdQuery(plugin_.context(), cmd, current_->get(), &info), LSNIF_ERROR_INVALID_ARGUMENT);
    EXPECT_NE(last_error().find("timestampPool is VK_NULL_HANDLE"), std::string::npos) << last_error();
    // A pool handle that is never used: every call below fails before recording anything.
    chained.timestampPool = reinterpret_cast<VkQueryPool>(uintptr_t(0x10));
    LsnifQueryTimestampsInfo more = chained;
    chained.pNext = &more;
    EXPECT_EQ(lsnifCmdQuery(plugin_.context(), cmd, current_->get(), &info), LSNIF_ERROR_INVALID_ARGUMENT);
    EXPECT_NE(last_error().find("structure type 2 appears twice"), std::string::npos) << last_error();
    // The model-index structure: its enum, its base's range, a base with the instance index.
    LsnifQueryModelIndexInfo index{};
    index.sType = LSNIF_STRUCTURE_TYPE_QUERY_MODEL_INDEX_INFO;
    chained.pNext = &index;
    const struct {
      uint32_t model_index, base;
      const char* error;
    } bad[] = {{7, 0, "modelIndex 7 is not a LsnifQueryModelIndex"},
               {LSNIF_QUERY_MODEL_INDEX_CUSTOM_INDEX, 1u << 24, "customIndexBase 16777216 is not below 2^24"},
               {LSNIF_QUERY_MODEL_INDEX_INSTANCE_INDEX, 3, "customIndexBase 3 with LSNIF_QUERY_MODEL_INDEX_INSTANCE_INDEX"}};
    for (const auto& b : bad) {
      index.modelIndex = LsnifQueryModelIndex(b.model_index);
      index.customIndexBase = b.base;
      EXPECT_EQ(lsnifCmdQuery(plugin_.context(), cmd, current_->get(), &info), LSNIF_ERROR_INVALID_ARGUMENT);
      EXPECT_NE(last_error().find(b.error), std::string::npos) << last_error();
    }
    // Looped chains end as repeated structures, in both entry points: a struct pointing to itself,
    // two pointing at each other.
    index.modelIndex = LSNIF_QUERY_MODEL_INDEX_CUSTOM_INDEX;
    index.customIndexBase = 0;
    for (int loop = 0; loop < 2; ++loop) {
      chained.pNext = loop == 0 ? static_cast<const void*>(&chained) : static_cast<const void*>(&index);
      index.pNext = loop == 0 ? nullptr : &chained;
      EXPECT_EQ(lsnifCmdQuery(plugin_.context(), cmd, current_->get(), &info), LSNIF_ERROR_INVALID_ARGUMENT);
      EXPECT_NE(last_error().find("appears twice"), std::string::npos) << last_error();
      VkDeviceSize size = 0;
      EXPECT_EQ(lsnifGetQueryScratchSize(plugin_.context(), &info, &size), LSNIF_ERROR_INVALID_ARGUMENT);
      EXPECT_NE(last_error().find("appears twice"), std::string::npos) << last_error();
    }
    index.pNext = nullptr;
  });
  EXPECT_TRUE(st) << st.message();
}

// An empty batch records nothing; a batch in which no ray reaches an LSNIF object writes every
// field (triangle hits and misses) and produces no candidate; a scene without LSNIF instances and
// an empty table works too.
TEST_P(PluginQueryPerBroadPhase, EmptyBatchesAndBatchesWithoutLsnif) {
  Scene s;
  const Cleanup cleanup{[&] { release(s); }};
  ASSERT_NO_FATAL_FAILURE(mixed_scene(s));
  const QueryRun empty = query(s, {}, {0u});
  EXPECT_TRUE(empty.results.empty());
  EXPECT_EQ(empty.status.candidates, ~0u) << "an empty batch records nothing, not even the status";

  // Rays from far away towards the triangle instance's box that miss every LSNIF box, and rays
  // pointing away from the scene.
  std::vector<Ray> rays;
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const Aabb& tri = s.boxes[1];
  while (rays.size() < 600) {
    Ray r;
    if (rays.size() % 2 == 0) {
      r.origin = tri.center() + glm::vec3(0, 3.0f * s.bounds.diagonal(), 0);
      r.direction = tri.lo + tri.extent() * glm::vec3(u(rng), u(rng), u(rng)) - r.origin;
    } else {
      r.origin = s.bounds.hi + glm::vec3(0.1f + u(rng));
      r.direction = glm::vec3(1.0f, 0.5f + u(rng), 0.25f);
    }
    bool crosses = false;
    for (const LsnifInstance& li : s.lsnif) {
      const Aabb& b = s.boxes[li.index];
      const glm::vec3 inv = 1.0f / r.direction;
      const glm::vec3 a = (b.lo - r.origin) * inv, c = (b.hi - r.origin) * inv;
      const glm::vec3 lo = glm::min(a, c), hi = glm::max(a, c);
      crosses |= std::max({lo.x, lo.y, lo.z, 0.0f}) <= std::min({hi.x, hi.y, hi.z});
    }
    if (!crosses) rays.push_back(r);
  }
  const QueryRun q = query(s, rays, {0u});
  EXPECT_EQ(q.status.candidates, 0u);
  EXPECT_EQ(q.status.dropped, 0u);
  EXPECT_EQ(q.status.incomplete_rays, 0u);
  const Agreement a = compare(s, rays, q.results, trace(s, rays, kModeClosest, 0));
  expect_agreement(a, "no LSNIF object reached");
  EXPECT_EQ(a.lsnif, 0u);
  EXPECT_GT(a.triangles, 100u);
  for (const LsnifQueryResult& r : q.results) {
    if (r.kind != LSNIF_QUERY_HIT_NONE) continue;
    EXPECT_EQ(r.material, 0u);
    EXPECT_EQ(r.front_face, 0u);
    EXPECT_EQ(r.primitive_index, ~0u);
    EXPECT_EQ(r.barycentric_u, 0.0f);
  }

  // Triangles only, no table at all.
  Scene t;
  const Cleanup cleanup_t{[&] { release(t); }};
  add_triangles(t, 0, Transform3x4());
  ASSERT_NO_FATAL_FAILURE(finish(t));
  const std::vector<Ray> at_triangles = rays_at(t, 600, 19);
  const QueryRun qt = query(t, at_triangles, {0u});
  const Agreement at = compare(t, at_triangles, qt.results, trace(t, at_triangles, kModeClosest, 0));
  expect_agreement(at, "triangles only");
  EXPECT_GT(at.triangles, 50u);
}

// The device check and the argument errors: nothing recorded, a message naming the problem.
TEST_F(PluginQuery, DeviceCheckAndArgumentErrors) {
  // A context told (pEnabledFeatures) that the device was created without rayQuery and without
  // rayTraversalPrimitiveCulling: no broad phase can run, and the error names both.
  LsnifDeviceFeatures features;
  lsnifInitDeviceFeatures(&features, nullptr);
  LsnifContextCreateInfo ci = vk::plugin_create_info(vk_);
  ci.pEnabledFeatures = &features.features2;
  LsnifContext ctx = nullptr;
  ASSERT_EQ(lsnifCreateContext(&ci, &ctx), LSNIF_SUCCESS) << last_error();
  LsnifQueryPipelineFlagsCreateInfo chained{};
  chained.sType = LSNIF_STRUCTURE_TYPE_QUERY_PIPELINE_FLAGS_CREATE_INFO;
  chained.flags = LSNIF_QUERY_PIPELINE_CREATE_TLAS_BIT;
  LsnifQueryPipelineCreateInfo pi{};
  pi.pNext = &chained;
  LsnifQueryPipeline p = nullptr;
  EXPECT_EQ(lsnifCreateQueryPipeline(ctx, &pi, &p), LSNIF_ERROR_DEVICE_UNSUPPORTED);
  EXPECT_NE(last_error().find("no broad phase can run"), std::string::npos) << last_error();
  EXPECT_NE(last_error().find("without feature rayQuery enabled"), std::string::npos) << last_error();
  EXPECT_NE(last_error().find("without feature rayTraversalPrimitiveCulling enabled"), std::string::npos)
      << last_error();
  EXPECT_EQ(p, nullptr);
  chained.flags = 0x10;
  EXPECT_EQ(lsnifCreateQueryPipeline(ctx, &pi, &p), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_NE(last_error().find("unknown flags 0x10"), std::string::npos) << last_error();
  chained.flags = LSNIF_QUERY_PIPELINE_CREATE_TLAS_BIT | LSNIF_QUERY_PIPELINE_CREATE_RAY_QUERY_BROAD_PHASE_BIT |
                  LSNIF_QUERY_PIPELINE_CREATE_TRACE_RAYS_BROAD_PHASE_BIT;
  EXPECT_EQ(lsnifCreateQueryPipeline(ctx, &pi, &p), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_NE(last_error().find("exclude each other"), std::string::npos) << last_error();
  chained.flags = LSNIF_QUERY_PIPELINE_CREATE_RAY_QUERY_BROAD_PHASE_BIT;
  EXPECT_EQ(lsnifCreateQueryPipeline(ctx, &pi, &p), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_NE(last_error().find("without LSNIF_QUERY_PIPELINE_CREATE_TLAS_BIT"), std::string::npos) << last_error();
  chained.flags = LSNIF_QUERY_PIPELINE_CREATE_TLAS_BIT;
  chained.sType = static_cast<LsnifStructureType>(7);
  EXPECT_EQ(lsnifCreateQueryPipeline(ctx, &pi, &p), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_NE(last_error().find("unknown structure type 7"), std::string::npos) << last_error();
  chained.sType = LSNIF_STRUCTURE_TYPE_QUERY_PIPELINE_FLAGS_CREATE_INFO;
  // A loop back to the create info, and one to itself: the one chained struct must end the chain.
  for (const void* loop : {static_cast<const void*>(&pi), static_cast<const void*>(&chained)}) {
    chained.pNext = loop;
    EXPECT_EQ(lsnifCreateQueryPipeline(ctx, &pi, &p), LSNIF_ERROR_INVALID_ARGUMENT);
    EXPECT_NE(last_error().find("LsnifQueryPipelineFlagsCreateInfo::pNext must be NULL"), std::string::npos)
        << last_error();
  }
  chained.pNext = nullptr;
  EXPECT_EQ(p, nullptr);
  LsnifQueryPipeline plain = nullptr;
  ASSERT_EQ(lsnifCreateQueryPipeline(ctx, nullptr, &plain), LSNIF_SUCCESS) << last_error();
  EXPECT_EQ(lsnifGetQueryBroadPhase(ctx, plain), LSNIF_QUERY_BROAD_PHASE_NONE);
  lsnifDestroyContext(ctx);  // the pipeline with it

  // rayQuery enabled: the automatic choice is the ray-query broad phase, and the ray-tracing one,
  // forced, names the feature it lacks; with rayTraversalPrimitiveCulling enabled instead, the
  // automatic choice is the ray-tracing one, and the ray-query one, forced, names what it lacks;
  // with both, the ray-query one.
  if (ray_query_missing_.empty() && trace_rays_missing_.empty()) {
    VkPhysicalDeviceRayQueryFeaturesKHR rq{};
    rq.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_RAY_QUERY_FEATURES_KHR;
    rq.rayQuery = VK_TRUE;
    features.rayTracingPipeline.pNext = &rq;
    ASSERT_EQ(lsnifCreateContext(&ci, &ctx), LSNIF_SUCCESS) << last_error();
    ASSERT_EQ(lsnifCreateQueryPipeline(ctx, &pi, &p), LSNIF_SUCCESS) << last_error();
    EXPECT_EQ(lsnifGetQueryBroadPhase(ctx, p), LSNIF_QUERY_BROAD_PHASE_RAY_QUERY);
    chained.flags = LSNIF_QUERY_PIPELINE_CREATE_TLAS_BIT | LSNIF_QUERY_PIPELINE_CREATE_TRACE_RAYS_BROAD_PHASE_BIT;
    LsnifQueryPipeline forced = nullptr;
    EXPECT_EQ(lsnifCreateQueryPipeline(ctx, &pi, &forced), LSNIF_ERROR_DEVICE_UNSUPPORTED);
    EXPECT_NE(last_error().find("without feature rayTraversalPrimitiveCulling enabled"), std::string::npos)
        << last_error();
    lsnifDestroyContext(ctx);
    features.rayTracingPipeline.pNext = nullptr;  // rayQuery no longer enabled
    features.rayTracingPipeline.rayTraversalPrimitiveCulling = VK_TRUE;
    chained.flags = LSNIF_QUERY_PIPELINE_CREATE_TLAS_BIT;
    ASSERT_EQ(lsnifCreateContext(&ci, &ctx), LSNIF_SUCCESS) << last_error();
    ASSERT_EQ(lsnifCreateQueryPipeline(ctx, &pi, &p), LSNIF_SUCCESS) << last_error();
    EXPECT_EQ(lsnifGetQueryBroadPhase(ctx, p), LSNIF_QUERY_BROAD_PHASE_TRACE_RAYS);
    chained.flags = LSNIF_QUERY_PIPELINE_CREATE_TLAS_BIT | LSNIF_QUERY_PIPELINE_CREATE_RAY_QUERY_BROAD_PHASE_BIT;
    EXPECT_EQ(lsnifCreateQueryPipeline(ctx, &pi, &forced), LSNIF_ERROR_DEVICE_UNSUPPORTED);
    EXPECT_NE(last_error().find("without feature rayQuery enabled"), std::string::npos) << last_error();
    lsnifDestroyContext(ctx);
    features.rayTracingPipeline.pNext = &rq;  // both
    chained.flags = LSNIF_QUERY_PIPELINE_CREATE_TLAS_BIT;
    ASSERT_EQ(lsnifCreateContext(&ci, &ctx), LSNIF_SUCCESS) << last_error();
    ASSERT_EQ(lsnifCreateQueryPipeline(ctx, &pi, &p), LSNIF_SUCCESS) << last_error();
    EXPECT_EQ(lsnifGetQueryBroadPhase(ctx, p), LSNIF_QUERY_BROAD_PHASE_RAY_QUERY);
    EXPECT_EQ(lsnifGetQueryBroadPhase(ctx, nullptr), LSNIF_QUERY_BROAD_PHASE_NONE);
    lsnifDestroyContext(ctx);
  }

  LsnifQueryPipeline without_tlas = nullptr;
  ASSERT_EQ(lsnifCreateQueryPipeline(plugin_.context(), nullptr, &without_tlas), LSNIF_SUCCESS) << last_error();
  LsnifModel unbuilt = nullptr;
  std::vector<uint8_t> bytes;
  ASSERT_TRUE(save_model_to_memory(model_a_, bytes));
  ASSERT_EQ(lsnifCreateModelFromMemory(plugin_.context(), bytes.data(), bytes.size(), &unbuilt), LSNIF_SUCCESS);

  const LsnifModel models[3] = {a_, b_, nullptr};
  LsnifQueryInfo info{};
  info.rayCount = 1000;
  info.candidatesPerRay = 2;
  info.tlas = 0x100000;
  info.cullMask = 0xFF;
  info.modelCount = 3;
  info.pModels = models;
  info.modelTable = 0x10000;
  info.rays = 0x20000;
  info.results = 0x30000;
  info.scratchBuffer = reinterpret_cast<VkBuffer>(uintptr_t(0x1234));  // never used: every call below fails
  VkDeviceSize need = 0;
  ASSERT_EQ(lsnifGetQueryScratchSize(plugin_.context(), &info, &need), LSNIF_SUCCESS) << last_error();
  info.scratchSize = need;
  VkDeviceSize more = 0;
  LsnifQueryInfo bigger = info;
  bigger.candidatesPerRay = 3;
  ASSERT_EQ(lsnifGetQueryScratchSize(plugin_.context(), &bigger, &more), LSNIF_SUCCESS);
  EXPECT_GT(more, need);

  // Each case changes one field of `info` (or the pipeline) and must be refused naming it.
  const LsnifModel foreign[3] = {a_, reinterpret_cast<LsnifModel>(&need), nullptr};
  const LsnifModel not_built[3] = {a_, b_, unbuilt};
  struct Case {
    const char* words;
    std::function<void(LsnifQueryInfo&)> change;
    LsnifQueryPipeline pipeline = pipeline_.get();
  };
  const Case cases[] = {
      {"created without LSNIF_QUERY_PIPELINE_CREATE_TLAS_BIT", [](LsnifQueryInfo&) {}, without_tlas},
      {"not a query pipeline of this context", [](LsnifQueryInfo&) {}, reinterpret_cast<LsnifQueryPipeline>(&need)},
      {"pInfo->candidatesPerRay 0 is not in 1 .. 32", [](LsnifQueryInfo& i) { i.candidatesPerRay = 0; }},
      {"pInfo->candidatesPerRay 33",
       [](LsnifQueryInfo& i) { i.candidatesPerRay = LSNIF_QUERY_MAX_CANDIDATES_PER_RAY + 1; }},
      {"pInfo->cullMask 0x100", [](LsnifQueryInfo& i) { i.cullMask = 0x100; }},
      {"pInfo->pNext: unknown structure type 1 (expected", [&](LsnifQueryInfo& i) { i.pNext = &chained; }},
      {"pInfo->modelCount 262145", [](LsnifQueryInfo& i) { i.modelCount = LSNIF_QUERY_MAX_MODELS + 1; }},
      {"pInfo->pModels is NULL", [](LsnifQueryInfo& i) { i.pModels = nullptr; }},
      {"pInfo->pModels[1] is not a model of this context", [&](LsnifQueryInfo& i) { i.pModels = foreign; }},
      {"pInfo->pModels[2] has not been built", [&](LsnifQueryInfo& i) { i.pModels = not_built; }},
      {"pInfo->tlas is 0", [](LsnifQueryInfo& i) { i.tlas = 0; }},
      {"pInfo->rays is not 16-byte aligned", [](LsnifQueryInfo& i) { i.rays = 0x20008; }},
      {"pInfo->results is 0", [](LsnifQueryInfo& i) { i.results = 0; }},
      {"pInfo->modelTable is not 8-byte aligned", [](LsnifQueryInfo& i) { i.modelTable = 0x10004; }},
      {"pInfo->status is not 4-byte aligned", [](LsnifQueryInfo& i) { i.status = 0x40002; }},
      {"pInfo->scratchBuffer is VK_NULL_HANDLE", [](LsnifQueryInfo& i) { i.scratchBuffer = VK_NULL_HANDLE; }},
      {"pInfo->scratchOffset is not a multiple of 16", [](LsnifQueryInfo& i) { i.scratchOffset = 8; }},
      {"pInfo->scratchOffset 18446744073709551600 plus pInfo->scratchSize",
       [](LsnifQueryInfo& i) { i.scratchOffset = ~VkDeviceSize(15); }},
      {"pInfo->scratchSize", [](LsnifQueryInfo& i) { i.scratchSize -= 4; }},
  };
  for (const Case& c : cases) {
    LsnifQueryInfo bad = info;
    c.change(bad);
    Status st = vk_.submit("refused", [&](VkCommandBuffer cmd) {
      EXPECT_EQ(lsnifCmdQuery(plugin_.context(), cmd, c.pipeline, &bad), LSNIF_ERROR_INVALID_ARGUMENT) << c.words;
    });
    EXPECT_TRUE(st) << st.message();
    EXPECT_NE(last_error().find(c.words), std::string::npos) << last_error();
  }
  EXPECT_EQ(lsnifGetQueryScratchSize(plugin_.context(), &info, nullptr), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(lsnifGetQueryScratchSize(plugin_.context(), nullptr, &need), LSNIF_ERROR_INVALID_ARGUMENT);
  LsnifQueryInfo bad = info;
  bad.pModels = foreign;
  EXPECT_EQ(lsnifGetQueryScratchSize(plugin_.context(), &bad, &need), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_NE(last_error().find("lsnifGetQueryScratchSize: pInfo->pModels[1]"), std::string::npos) << last_error();
  // An empty batch is valid without any address.
  LsnifQueryInfo empty{};
  empty.candidatesPerRay = 1;
  Status st = vk_.submit("empty", [&](VkCommandBuffer cmd) {
    EXPECT_EQ(lsnifCmdQuery(plugin_.context(), cmd, pipeline_.get(), &empty), LSNIF_SUCCESS) << last_error();
  });
  EXPECT_TRUE(st) << st.message();

  // lsnif.hpp's owner: a failed create holds nothing; moves carry the handle; its calls go to the
  // C API with its context and pipeline.
  plugin::QueryPipeline owner;
  EXPECT_EQ(owner.create(plugin_.context(), 0x2), LSNIF_ERROR_INVALID_ARGUMENT);
  EXPECT_FALSE(owner);
  ASSERT_EQ(owner.create(plugin_.context()), LSNIF_SUCCESS) << last_error();
  plugin::QueryPipeline moved(std::move(owner));
  EXPECT_FALSE(owner);
  ASSERT_TRUE(moved);
  EXPECT_EQ(moved.context(), plugin_.context());
  st = vk_.submit("refused", [&](VkCommandBuffer cmd) {
    EXPECT_EQ(moved.cmd_query(cmd, info), LSNIF_ERROR_INVALID_ARGUMENT);
    EXPECT_NE(last_error().find("pipeline was created without LSNIF_QUERY_PIPELINE_CREATE_TLAS_BIT"),
              std::string::npos)
        << last_error();
    const LsnifIntersectModelRaysInfo none{};
    EXPECT_EQ(moved.cmd_intersect_model_rays(cmd, none), LSNIF_ERROR_INVALID_ARGUMENT);
    EXPECT_NE(last_error().find("lsnifCmdIntersectModelRays"), std::string::npos) << last_error();
  });
  EXPECT_TRUE(st) << st.message();
  VkDeviceSize via_owner = 0;
  EXPECT_EQ(plugin::query_scratch_size(plugin_.context(), info, via_owner), LSNIF_SUCCESS);
  EXPECT_EQ(via_owner, need);
  moved.reset();
  EXPECT_FALSE(moved);

  lsnifDestroyModel(plugin_.context(), unbuilt);
  lsnifDestroyQueryPipeline(plugin_.context(), without_tlas);
}

}  // namespace
}  // namespace lsnif
