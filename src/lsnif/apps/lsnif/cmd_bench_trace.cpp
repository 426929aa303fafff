// lsnif bench-trace MESH MODEL: throughput of the LSNIF intersection shader (src/lsnif/shaders/lsnif.rint, as
// the plugin compiles it) in a real ray-tracing pipeline on the device, against the same rays
// traced through a triangle BLAS of the same mesh in the same run and the same pipeline.
//
// Setup: the harness's device (src/lsnif/harness/vk_compute.h, ray tracing on, validation only with
// --validation); the model uploaded by the plugin (model block + AABB BLAS, model table, instance
// record); a triangle BLAS of the mesh; two TLASes of one identity instance each (LSNIF: hit group
// 0 = lsnif.rint + bench_trace.rchit; triangles: hit group 1 = bench_trace_triangle.rchit); one
// pipeline (src/lsnif/apps/lsnif/shaders/bench_trace.*). Rays: N from one seed, origins on the sphere of
// radius 1.5 x half diagonal around the mesh AABB's center, unit directions towards uniform points
// inside the AABB, tmin 0, tmax inf. The triangle BLAS input is in Morton order of the triangle
// centroids by default (lavapipe builds its BVH in input order). Timing: one first trace of each
// (reported apart: it carries what a driver does on first use of the pipeline), then K repeats
// alternating LSNIF / triangles; medians of the host wall time around submit + wait, of the device
// time between timestamps around vkCmdTraceRaysKHR where the queue has timestamps, and of the
// process CPU time. Network evaluations = rays whose walk (src/lsnif/core/ray_walk.h, the CPU twin
// of the shader's walk) has boundary points: the intersection shader runs the MLP exactly for them.
//
// In the same run, the same rays also go through the plugin's batched path
// (lsnifCmdIntersectModelRays with a query pipeline of the same plugin context: narrow phase, MLP
// over the dense batch, decode, in compute; object space = world space as the instance is the
// identity), timed like the traces and alternating with them, with per-stage device times from
// its timestamps, and its hits compared ray by ray with the inline shader's. Likewise through
// lsnifCmdQuery (world-space rays against the LSNIF TLAS of the traces: the model as one identity
// instance, table entry 0): broad phase, counting sort, narrow phase / MLP / decode, resolve, with
// device timestamps around the call. The CPU limit of the
// network evaluation is an Eigen GEMM of the model's MLP shapes on the trainer's OpenMP threads.
#include <omp.h>
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "lsnif/apps/lsnif/args.h"
#include "lsnif/apps/lsnif/commands.h"
#include "lsnif/apps/lsnif/train_options.h"
#include "lsnif/apps/lsnif/device_option.h"
#include "lsnif/import/mesh.h"
#include "lsnif/core/model.h"
#include "lsnif/core/network.h"
#include "lsnif/apps/common/progress.h"
#include "lsnif/core/ray_walk.h"
#include <volk.h>  // before lsnif.h, which then uses volk's Vulkan declarations

#include "lsnif/lsnif.hpp"
#include "lsnif/harness/plugin_device.h"
#include "lsnif/harness/triangle_order.h"
#include "lsnif/harness/vk_raytracing.h"

namespace lsnif::cli {

namespace {

// The benchmark's own shaders (src/lsnif/apps/lsnif/shaders), compiled at build time.
#include "bench_trace_rchit_spirv.h"
#include "bench_trace_rgen_spirv.h"
#include "bench_trace_rmiss_spirv.h"
#include "bench_trace_triangle_rchit_spirv.h"

// The push constant block of shaders/bench_trace_common.glsl (model table first: host_device.h).
struct BenchTracePush {
  uint64_t model_table = 0;
  uint32_t model_count = 0, reserved = 0;
  uint64_t rays = 0, results = 0;
  uint32_t ray_count = 0, unused = 0;
};
static_assert(offsetof(BenchTracePush, model_table) == LSNIF_RT_PUSH_MODEL_TABLE_OFFSET, "binding convention");
static_assert(offsetof(BenchTracePush, model_count) == LSNIF_RT_PUSH_MODEL_COUNT_OFFSET, "binding convention");
static_assert(offsetof(BenchTracePush, rays) == LSNIF_RT_PUSH_APP_OFFSET, "binding convention");
static_assert(offsetof(BenchTracePush, ray_count) == 32, "push constant layout of bench_trace_common.glsl");

vk::Spirv spirv(const uint32_t* code, size_t bytes) {
  vk::Spirv s;
  s.code = code;
  s.bytes = bytes;
  return s;
}

// BenchTraceResult of shaders/bench_trace_common.glsl.
struct BenchTraceResult {
  float t;
  uint32_t info;
};
static_assert(sizeof(BenchTraceResult) == 8, "result layout of bench_trace_common.glsl");
constexpr uint32_t kResultHit = 1u, kResultPointsShift = 8u;
static_assert(sizeof(LsnifReferenceRay) == 32, "ray layout");

static_assert(sizeof(LsnifQueryRay) == 48 && sizeof(LsnifQueryHit) == 48, "batched query layouts");

constexpr uint32_t kMaxRays = 1u << 24;
constexpr uint32_t kMaxRepeat = 1000;
// Rays per lsnifCmdIntersectModelRays call: one chunk of the plugin, so that each call's middle
// timestamps bracket its stages (a call of more rays runs several chunks and times only the first
// chunk's stages); more rays go in several calls, one after the other, sharing the scratch.
constexpr uint32_t kMaxBatchRays = LSNIF_BATCH_CHUNK_RAYS;
constexpr uint32_t kLsnifRecord = 0, kTriangleRecord = 1;  // SBT hit group records

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// A JSON string literal of `s` (quotes, backslashes and control characters escaped).
std::string quoted(const std::string& s) {
  std::string out = "\"";
  for (const char c : s) {
    const auto u = static_cast<unsigned char>(c);
    if (c == '"' || c == '\\') out += std::string("\\") + c;
    else if (u < 0x20) out += format("\\u%04x", unsigned(u));
    else out += c;
  }
  return out + "\"";
}

// `count` rays from `seed` (see the file comment): origins uniform on the sphere of radius
// 1.5 x |extent| / 2 around box.center(), unit directions towards uniform points inside `box`.
// Every origin lies outside the box (the sphere encloses it).
std::vector<Ray> make_rays(const Aabb& box, uint32_t count, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const glm::vec3 center = box.center(), ext = box.extent();
  const float radius = 1.5f * 0.5f * box.diagonal();
  std::vector<Ray> rays(count);
  for (Ray& r : rays) {
    glm::vec3 dir;
    for (;;) {  // uniform on the unit sphere by rejection from the cube
      dir = glm::vec3(2.0f * u(rng) - 1.0f, 2.0f * u(rng) - 1.0f, 2.0f * u(rng) - 1.0f);
      const float l = glm::length(dir);
      if (l > 1e-3f && l <= 1.0f) {
        dir /= l;
        break;
      }
    }
    r.origin = center + radius * dir;
    const glm::vec3 target = box.lo + ext * glm::vec3(u(rng), u(rng), u(rng));
    r.direction = glm::normalize(target - r.origin);
    r.tmin = 0.0f;
    r.tmax = std::numeric_limits<float>::infinity();
  }
  return rays;
}

// The mesh's triangles as BLAS input (float3 positions, 3 uint32 indices per triangle). With
// `morton`, the triangles are ordered by the 30-bit Morton code of their centroid in the mesh AABB
// (ties keep file order): a driver that builds its BVH in primitive order without spatial sorting
// (lavapipe) then gets a spatially coherent tree, as a GPU driver's builder makes by itself.
void triangle_input(const Mesh& mesh, bool morton, std::vector<float>& positions, std::vector<uint32_t>& indices) {
  positions.clear();
  indices.clear();
  positions.reserve(3 * mesh.positions.size());
  indices.reserve(3 * mesh.triangles.size());
  for (const glm::vec3& p : mesh.positions) positions.insert(positions.end(), {p.x, p.y, p.z});
  std::vector<uint32_t> order(mesh.triangles.size());
  for (uint32_t i = 0; i < order.size(); ++i) order[i] = i;
  if (morton) {
    std::vector<uint32_t> flat;
    flat.reserve(3 * mesh.triangles.size());
    for (const glm::uvec3& t : mesh.triangles) flat.insert(flat.end(), {t.x, t.y, t.z});
    order = vk::morton_triangle_order(mesh.positions, flat);
  }
  for (const uint32_t i : order) {
    const glm::uvec3& t = mesh.triangles[i];
    indices.insert(indices.end(), {t.x, t.y, t.z});
  }
}

// A model trained on `mesh` has bounds == pad_aabb(mesh.bounds()) (src/lsnif/train/trainer.cpp). Ok when the
// corners agree within 1e-3 of the diagonal; otherwise an error naming both boxes.
Status check_same_object(const Mesh& mesh, const Model& model) {
  const Aabb expect = pad_aabb(mesh.bounds()), got = model.bounds();
  const float tol = 1e-3f * expect.diagonal();
  const glm::vec3 d = glm::max(glm::abs(expect.lo - got.lo), glm::abs(expect.hi - got.hi));
  if (std::max(d.x, std::max(d.y, d.z)) <= tol) return Status::ok();
  return Status::error(
      "the mesh does not match the model: the model's AABB is (%g %g %g)..(%g %g %g) but a model trained "
      "on this mesh would have (%g %g %g)..(%g %g %g) (is MODEL trained on MESH?)",
      double(got.lo.x), double(got.lo.y), double(got.lo.z), double(got.hi.x), double(got.hi.y), double(got.hi.z),
      double(expect.lo.x), double(expect.lo.y), double(expect.lo.z), double(expect.hi.x), double(expect.hi.y),
      double(expect.hi.z));
}

// Timings of one geometry kind.
// host: wall time around RayTracer::trace_timed (descriptor update, recording, submit, wait);
// device: timestamps around vkCmdTraceRaysKHR (-1 / empty without timestamps); cpu: user + system
// CPU time of this process during the trace (getrusage), which on lavapipe is the work of the
// trace and depends less on other load of a shared machine than the wall time (meaningless on a
// GPU, where the host only waits).
struct Timings {
  double first_host = 0, first_device = -1, first_cpu = 0;  // the first trace (first use of the pipeline)
  std::vector<double> host, device, cpu;                     // the K repeats
  double median_host() const { return median(host); }
  double min_host() const { return host.empty() ? 0.0 : *std::min_element(host.begin(), host.end()); }
  double median_cpu() const { return median(cpu); }
  double median_device() const { return device.empty() ? -1.0 : median(device); }
  // Stores the first run's times (`first`) or appends a repeat's (a device time < 0: none).
  void add(bool first, double host_seconds, double device_seconds, double cpu_seconds) {
    if (first) {
      first_host = host_seconds;
      first_device = device_seconds;
      first_cpu = cpu_seconds;
      return;
    }
    host.push_back(host_seconds);
    cpu.push_back(cpu_seconds);
    if (device_seconds >= 0) device.push_back(device_seconds);
  }
};

// Device times of the stages of one batched run, from its timestamps (summed over the calls when
// the rays need several): narrow phase (with the clear of the batch counter), MLP, decode.
struct StageTimes {
  double narrow = 0, mlp = 0, decode = 0;
};

// The CPU limit of the network evaluation (run_gemm).
struct GemmReport {
  std::vector<uint32_t> widths;  // input (padded as the GPU model pads it), hidden layers, output
  uint32_t threads = 0, batch = 0;  // OpenMP threads; columns per thread and pass
  uint64_t passes = 0;
  double seconds = 0;      // wall time of the timed passes
  double cpu_seconds = 0;  // process CPU time during them (all threads)
  double flops_per_column = 0;  // 2 x multiply-adds of the GEMMs (bias and activation not counted)
  uint64_t columns() const { return passes * threads * batch; }
  double evaluations_per_second() const { return seconds > 0 ? double(columns()) / seconds : 0.0; }
};

struct Report {
  std::string device, mesh_path, model_path, intersection_spv;
  uint32_t rays = 0, repeat = 0, triangles = 0;
  uint64_t seed = 0;
  double pipeline_create_seconds = 0, query_pipeline_create_seconds = 0;
  bool device_timestamps = false;
  bool morton_order = true;  // triangle BLAS input in Morton order of the centroids (else file order)
  Timings lsnif, tri, batched, query;
  uint32_t batched_calls = 0;                 // lsnifCmdIntersectModelRays calls per batched run
  StageTimes batched_first_stages;            // of the first batched run (where timestamps exist)
  std::vector<StageTimes> batched_stages;     // of the K repeats (empty without timestamps)
  // From the ray walk on the host (identical walk to the shader's, up to float rounding).
  uint32_t aabb_rays = 0, network_rays = 0;
  // From the traces' results.
  uint32_t lsnif_hits = 0, triangle_hits = 0, agree = 0, both_hit = 0, points_mismatch = 0;
  double median_t_difference = 0;  // |t_lsnif - t_triangle| / mesh AABB diagonal, rays both hit
  // From the batched hits of the last run, against the inline shader's (the LSNIF trace) and the
  // host walk. The inline shader reports its walk's points only for its hits, so `points` is
  // compared with it over those rays, and with the host walk over all rays.
  uint32_t batched_hits = 0, batched_network_rays = 0, batched_agree = 0, batched_both_hit = 0;
  uint32_t batched_points_mismatch = 0, batched_walk_mismatch = 0;
  double batched_max_t_difference = 0;  // |t_batched - t_inline| / mesh AABB diagonal, rays both hit
  // From the lsnifCmdQuery results of the last run against the inline shader's, and its status.
  uint32_t query_hits = 0, query_agree = 0, query_both_hit = 0, query_incomplete = 0;
  double query_max_t_difference = 0;  // |t_query - t_inline| / mesh AABB diagonal, rays both hit
  LsnifQueryStatus query_status{};
  GemmReport gemm;
  uint32_t validation_warnings = 0, validation_errors = 0;
  bool validation = false;

  double rays_per_second(const Timings& t) const { return double(rays) / t.median_host(); }
  double evaluations_per_second() const { return double(network_rays) / lsnif.median_host(); }
  double ratio() const { return rays_per_second(tri) / rays_per_second(lsnif); }
  double batched_evaluations_per_second() const { return double(batched_network_rays) / batched.median_host(); }
  // NaN (JSON null) when no ray has boundary points.
  double batched_over_inline() const { return batched_evaluations_per_second() / evaluations_per_second(); }
  double batched_over_gemm() const { return batched_evaluations_per_second() / gemm.evaluations_per_second(); }
  // lsnifCmdQuery evaluates the network for the same rays as the batched path (one identity
  // instance: a candidate per ray crossing the box, evaluated where the walk has points).
  double query_evaluations_per_second() const { return double(batched_network_rays) / query.median_host(); }
  double query_over_inline() const { return query_evaluations_per_second() / evaluations_per_second(); }
  // The MLP stage alone: evaluations per second of its median device time (-1 without timestamps).
  double mlp_stage_evaluations_per_second() const {
    const double t = median_stage(&StageTimes::mlp);
    return t > 0 ? double(batched_network_rays) / t : -1.0;
  }
  // Median over the repeats of one stage (-1 without timestamps).
  double median_stage(double StageTimes::*stage) const {
    if (batched_stages.empty()) return -1.0;
    std::vector<double> v;
    for (const StageTimes& s : batched_stages) v.push_back(s.*stage);
    return median(std::move(v));
  }
};

// Everything the benchmark creates on the device; release() frees it in dependency order (models
// and buffers before the device) and is safe to call twice.
struct DeviceState {
  vk::ComputeContext ctx;
  vk::RayTracer tracer{ctx};
  plugin::Context plugin;
  plugin::Model model;
  LsnifModel table_model = nullptr;  // the model table's one entry (the handle of `model`)
  vk::Buffer table, rays, lsnif_results, tri_results;
  vk::AccelerationStructure tri_blas, lsnif_tlas, tri_tlas;
  vk::RtPipeline pipeline;
  // The batched path: its pipeline, the rays as LsnifQueryRay, the hits, the scratch, and a pool of
  // LSNIF_INTERSECT_TIMESTAMP_COUNT timestamps per call (none where the queue has no timestamps).
  // The pipeline has the TLAS stages too (lsnifCmdQuery: its results, scratch, status and two
  // timestamps around the call).
  plugin::QueryPipeline query;
  vk::Buffer query_rays, query_hits, scratch;
  vk::Buffer query_results, query_scratch, query_status;
  VkQueryPool timestamps = VK_NULL_HANDLE, query_timestamps = VK_NULL_HANDLE;
  uint64_t timestamp_mask = 0;
  double timestamp_period = 0;  // nanoseconds per tick

  DeviceState() = default;
  DeviceState(const DeviceState&) = delete;
  DeviceState& operator=(const DeviceState&) = delete;
  ~DeviceState() { release(); }
  void release() {
    if (!ctx.device()) return;
    tracer.destroy(pipeline);
    tracer.destroy(lsnif_tlas);
    tracer.destroy(tri_tlas);
    tracer.destroy(tri_blas);
    for (vk::Buffer* b : {&table, &rays, &lsnif_results, &tri_results, &query_rays, &query_hits, &scratch,
                          &query_results, &query_scratch, &query_status})
      ctx.destroy_buffer(*b);
    for (VkQueryPool* pool : {&timestamps, &query_timestamps}) {
      if (*pool) vkDestroyQueryPool(ctx.device(), *pool, nullptr);
      *pool = VK_NULL_HANDLE;
    }
    query.reset();
    model.reset();
    plugin.reset();
  }
};

// lsnifCmdQuery of the first `count` rays (world space = object space) against the LSNIF TLAS of the
// traces (one identity instance, table entry 0), one candidate per ray at most; the buffers as far as
// they exist (none for the scratch size).
LsnifQueryInfo query_info(const DeviceState& st, uint32_t count) {
  LsnifQueryInfo q{};
  q.rayCount = count;
  q.candidatesPerRay = 1;
  q.tlas = st.lsnif_tlas.address;
  q.cullMask = 0xFF;
  q.modelCount = 1;
  q.pModels = &st.table_model;
  q.modelTable = st.table.address;
  q.rays = st.query_rays.address;
  q.results = st.query_results.address;
  q.scratchBuffer = st.query_scratch.buffer;
  q.scratchOffset = 0;
  q.scratchSize = st.query_scratch.size;
  q.status = st.query_status.address;
  return q;
}

// The batched path on the plugin context of `st`: the query pipeline, the rays as LsnifQueryRay
// (the same rays: the instance is the identity, so object space is world space; flags 0), the
// hits, the scratch for the largest call, and the timestamp pool where the queue has timestamps.
Status set_up_batched(DeviceState& st, const std::vector<Ray>& rays, Report& report) {
  auto plugin_error = [](const char* what) { return Status::error("%s: %s", what, lsnifGetLastErrorMessage()); };
  const auto t0 = std::chrono::steady_clock::now();
  if (st.query.create(st.plugin.get(), LSNIF_QUERY_PIPELINE_CREATE_TLAS_BIT) != LSNIF_SUCCESS)
    return plugin_error("query pipeline of the batched path and lsnifCmdQuery");
  report.query_pipeline_create_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  const uint32_t n = uint32_t(rays.size());
  report.batched_calls = (n + kMaxBatchRays - 1) / kMaxBatchRays;
  VkDeviceSize scratch_bytes = 0;
  if (lsnifGetIntersectScratchSize(st.plugin.get(), st.model.get(), std::min(n, kMaxBatchRays), &scratch_bytes) !=
      LSNIF_SUCCESS)
    return plugin_error("scratch size of the batched path");
  Status s = st.ctx.create_buffer(size_t(n) * sizeof(LsnifQueryRay), st.query_rays);
  if (s) s = st.ctx.create_buffer(size_t(n) * sizeof(LsnifQueryHit), st.query_hits);
  if (s) s = st.ctx.create_buffer(size_t(scratch_bytes), st.scratch);
  if (!s) return s.context("buffers of the batched path");
  LsnifQueryInfo qi = query_info(st, n);
  VkDeviceSize query_scratch_bytes = 0;
  if (plugin::query_scratch_size(st.plugin.get(), qi, query_scratch_bytes) != LSNIF_SUCCESS)
    return plugin_error("scratch size of lsnifCmdQuery");
  s = st.ctx.create_buffer(size_t(n) * sizeof(LsnifQueryResult), st.query_results);
  if (s) s = st.ctx.create_buffer(size_t(query_scratch_bytes), st.query_scratch, VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT);
  if (s) s = st.ctx.create_buffer(sizeof(LsnifQueryStatus), st.query_status);
  if (!s) return s.context("buffers of lsnifCmdQuery");
  auto* out = static_cast<LsnifQueryRay*>(st.query_rays.mapped);
  for (size_t i = 0; i < rays.size(); ++i) {
    const Ray& r = rays[i];
    out[i] = LsnifQueryRay{};
    out[i].origin_x = r.origin.x;
    out[i].origin_y = r.origin.y;
    out[i].origin_z = r.origin.z;
    out[i].tmin = r.tmin;
    out[i].direction_x = r.direction.x;
    out[i].direction_y = r.direction.y;
    out[i].direction_z = r.direction.z;
    out[i].tmax = r.tmax;
  }

  uint32_t family_count = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(st.ctx.physical_device(), &family_count, nullptr);
  std::vector<VkQueueFamilyProperties> families(family_count);
  vkGetPhysicalDeviceQueueFamilyProperties(st.ctx.physical_device(), &family_count, families.data());
  const uint32_t valid_bits =
      st.ctx.queue_family() < family_count ? families[st.ctx.queue_family()].timestampValidBits : 0u;
  if (valid_bits == 0) return Status::ok();
  VkPhysicalDeviceProperties props;
  vkGetPhysicalDeviceProperties(st.ctx.physical_device(), &props);
  st.timestamp_mask = valid_bits >= 64 ? ~uint64_t(0) : (uint64_t(1) << valid_bits) - 1;
  st.timestamp_period = double(props.limits.timestampPeriod);
  VkQueryPoolCreateInfo qci{};
  qci.sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO;
  qci.queryType = VK_QUERY_TYPE_TIMESTAMP;
  qci.queryCount = LSNIF_INTERSECT_TIMESTAMP_COUNT * report.batched_calls;
  LSNIF_VK_CHECK(vkCreateQueryPool(st.ctx.device(), &qci, nullptr, &st.timestamps));
  qci.queryCount = 2;
  LSNIF_VK_CHECK(vkCreateQueryPool(st.ctx.device(), &qci, nullptr, &st.query_timestamps));
  return Status::ok();
}

// Builds everything on the device `device` selects (vk::ContextOptions::device) for the model file
// `model_path` and `mesh` and writes `rays` into the ray buffer. The intersection shader is the
// plugin's, or the SPIR-V file `intersection_spv` when not empty.
Status set_up(DeviceState& st, const std::string& model_path, const Mesh& mesh, const std::vector<Ray>& rays,
              bool validation, const std::string& device, const std::string& intersection_spv, Report& report) {
  vk::ContextOptions options;
  options.ray_tracing = true;
  options.ray_query = true;  // lsnifCmdQuery
  options.validation = validation;
  options.device = device;
  Status s = st.ctx.init(options);
  if (!s) return s.context("Vulkan device with ray tracing and ray queries");
  report.device = st.ctx.device_name();
  if (s = st.tracer.init(); !s) return s;
  if (st.tracer.max_hit_attribute_size() < sizeof(LsnifHitAttributes))
    return Status::error("device %s: maxRayHitAttributeSize %u < %zu bytes of LsnifHitAttributes",
                         report.device.c_str(), st.tracer.max_hit_attribute_size(), sizeof(LsnifHitAttributes));

  auto plugin_error = [](const char* what) { return Status::error("%s: %s", what, lsnifGetLastErrorMessage()); };
  if (st.plugin.create(vk::plugin_create_info(st.ctx)) != LSNIF_SUCCESS) return plugin_error("plugin");
  if (st.model.create_from_file(st.plugin.get(), model_path.c_str()) != LSNIF_SUCCESS)
    return plugin_error("uploading the model");
  const LsnifModel handle = st.model.get();
  st.table_model = handle;
  if (lsnifBuildModels(st.plugin.get(), 1, &handle) != LSNIF_SUCCESS) return plugin_error("building the model BLAS");
  if (s = st.ctx.create_buffer(sizeof(uint64_t), st.table); !s) return s;
  if (lsnifWriteModelTable(st.plugin.get(), 1, &handle, static_cast<uint64_t*>(st.table.mapped)) != LSNIF_SUCCESS)
    return plugin_error("model table");

  std::vector<float> positions;
  std::vector<uint32_t> indices;
  triangle_input(mesh, report.morton_order, positions, indices);
  if (s = st.tracer.build_triangle_blas(positions, indices, st.tri_blas); !s) return s.context("triangle BLAS");

  // One identity instance per TLAS; the instance's SBT record offset picks the hit group.
  VkAccelerationStructureInstanceKHR lsnif_record{}, tri_record{};
  LsnifInstanceInfo info{};
  info.model = handle;
  for (uint32_t r = 0; r < 3; ++r) info.transform.matrix[r][r] = 1.0f;
  info.mask = 0xFF;
  info.instanceShaderBindingTableRecordOffset = kLsnifRecord;
  if (lsnifMakeInstance(st.plugin.get(), &info, &lsnif_record) != LSNIF_SUCCESS) return plugin_error("instance");
  for (uint32_t r = 0; r < 3; ++r) tri_record.transform.matrix[r][r] = 1.0f;
  tri_record.instanceCustomIndex = 0;
  tri_record.mask = 0xFF;
  tri_record.instanceShaderBindingTableRecordOffset = kTriangleRecord;
  tri_record.accelerationStructureReference = st.tri_blas.address;
  if (s = st.tracer.build_tlas({lsnif_record}, st.lsnif_tlas); !s) return s.context("LSNIF TLAS");
  if (s = st.tracer.build_tlas({tri_record}, st.tri_tlas); !s) return s.context("triangle TLAS");

  vk::RtShaders shaders;
  shaders.raygen = spirv(bench_trace_rgen_spirv, sizeof bench_trace_rgen_spirv);
  shaders.miss = spirv(bench_trace_rmiss_spirv, sizeof bench_trace_rmiss_spirv);
  shaders.closest_hit = spirv(bench_trace_rchit_spirv, sizeof bench_trace_rchit_spirv);
  shaders.triangle_closest_hit = spirv(bench_trace_triangle_rchit_spirv, sizeof bench_trace_triangle_rchit_spirv);
  std::vector<uint32_t> file_code;
  if (intersection_spv.empty()) {
    if (lsnifGetIntersectionShaderSpirv(LSNIF_MODEL_LOOKUP_INSTANCE_TABLE, &shaders.intersection.code,
                                        &shaders.intersection.bytes) != LSNIF_SUCCESS)
      return plugin_error("intersection shader");
  } else {
    if (s = vk::read_spirv_file(intersection_spv, file_code); !s) return s;
    shaders.intersection = spirv(file_code.data(), file_code.size() * sizeof(uint32_t));
  }
  s = st.tracer.create_pipeline(shaders, sizeof(BenchTracePush), st.pipeline);
  if (!s) return s;
  if (st.pipeline.triangle_sbt_offset != kTriangleRecord)
    return Status::error("internal error: the triangle hit group is at SBT offset %u", st.pipeline.triangle_sbt_offset);
  report.pipeline_create_seconds = st.pipeline.create_seconds;

  const size_t n = rays.size();
  if (s = st.ctx.create_buffer(n * sizeof(LsnifReferenceRay), st.rays); !s) return s;
  if (s = st.ctx.create_buffer(n * sizeof(BenchTraceResult), st.lsnif_results); !s) return s;
  if (s = st.ctx.create_buffer(n * sizeof(BenchTraceResult), st.tri_results); !s) return s;
  auto* out = static_cast<LsnifReferenceRay*>(st.rays.mapped);
  for (size_t i = 0; i < n; ++i) {
    const Ray& r = rays[i];
    out[i] = {r.origin.x, r.origin.y, r.origin.z, r.tmin, r.direction.x, r.direction.y, r.direction.z, r.tmax};
  }
  return set_up_batched(st, rays, report);
}

// User + system CPU time of this process so far (all threads, lavapipe's workers included).
double process_cpu_seconds() {
  rusage u{};
  if (getrusage(RUSAGE_SELF, &u) != 0) return 0.0;
  auto secs = [](const timeval& tv) { return double(tv.tv_sec) + 1e-6 * double(tv.tv_usec); };
  return secs(u.ru_utime) + secs(u.ru_stime);
}

// One timed trace of all rays through `tlas` into `results`; appends (or, with `first`, stores)
// the host and device times.
Status timed_trace(DeviceState& st, const vk::AccelerationStructure& tlas, const vk::Buffer& results,
                   uint32_t count, bool first, Timings& t) {
  BenchTracePush push;
  push.model_table = st.table.address;
  push.model_count = 1;
  push.rays = st.rays.address;
  push.results = results.address;
  push.ray_count = count;
  double device_seconds = -1;
  const double cpu0 = process_cpu_seconds();
  const auto t0 = std::chrono::steady_clock::now();
  const Status s = st.tracer.trace_timed(st.pipeline, tlas, &push, count, device_seconds);
  const double host_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double cpu_seconds = process_cpu_seconds() - cpu0;
  if (!s) return s;
  t.add(first, host_seconds, device_seconds, cpu_seconds);
  return Status::ok();
}

// One timed batched run of all rays: lsnifCmdIntersectModelRays (several calls when the rays are
// more than one call takes, with a barrier between them as they share the scratch) in one command
// buffer, submitted and waited for; the host time is the wall time around recording, submit and
// wait (as for the traces). Appends (or, with `first`, stores) the times and the stage times.
Status timed_batched(DeviceState& st, uint32_t count, bool first, Report& report) {
  const uint32_t calls = report.batched_calls;
  LsnifResult result = LSNIF_SUCCESS;
  const double cpu0 = process_cpu_seconds();
  const auto t0 = std::chrono::steady_clock::now();
  Status s = st.ctx.submit("lsnifCmdIntersectModelRays", [&](VkCommandBuffer cmd) {
    if (st.timestamps) vkCmdResetQueryPool(cmd, st.timestamps, 0, LSNIF_INTERSECT_TIMESTAMP_COUNT * calls);
    VkMemoryBarrier barrier{};
    barrier.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
    barrier.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
    barrier.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT;
    for (uint32_t c = 0; c < calls && result == LSNIF_SUCCESS; ++c) {
      if (c > 0)
        vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, 0, 1,
                             &barrier, 0, nullptr, 0, nullptr);
      const uint32_t first_ray = c * kMaxBatchRays;
      LsnifIntersectModelRaysInfo info{};
      info.model = st.model.get();
      info.rayCount = std::min(count - first_ray, kMaxBatchRays);
      info.rays = st.query_rays.address + VkDeviceAddress(first_ray) * sizeof(LsnifQueryRay);
      info.hits = st.query_hits.address + VkDeviceAddress(first_ray) * sizeof(LsnifQueryHit);
      info.scratch = st.scratch.address;
      info.scratchSize = st.scratch.size;
      info.timestampPool = st.timestamps;
      info.firstTimestamp = LSNIF_INTERSECT_TIMESTAMP_COUNT * c;
      result = st.query.cmd_intersect_model_rays(cmd, info);
    }
    vk::ComputeContext::barrier_compute_to_host(cmd);
  });
  const double host_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double cpu_seconds = process_cpu_seconds() - cpu0;
  // A failed call recorded nothing, so its timestamps were never written: no query below.
  if (result != LSNIF_SUCCESS) return Status::error("lsnifCmdIntersectModelRays: %s", lsnifGetLastErrorMessage());
  if (!s) return s;

  double device_seconds = -1;
  StageTimes stages;
  if (st.timestamps) {
    std::vector<uint64_t> ticks(LSNIF_INTERSECT_TIMESTAMP_COUNT * calls);
    LSNIF_VK_CHECK(vkGetQueryPoolResults(st.ctx.device(), st.timestamps, 0, uint32_t(ticks.size()),
                                         ticks.size() * sizeof(uint64_t), ticks.data(), sizeof(uint64_t),
                                         VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT));
    auto seconds = [&](uint32_t from, uint32_t to) {
      return double((ticks[to] - ticks[from]) & st.timestamp_mask) * st.timestamp_period * 1e-9;
    };
    device_seconds = seconds(0, uint32_t(ticks.size()) - 1);
    for (uint32_t c = 0; c < calls; ++c) {
      const uint32_t b = LSNIF_INTERSECT_TIMESTAMP_COUNT * c;
      stages.narrow += seconds(b, b + 1);
      stages.mlp += seconds(b + 1, b + 2);
      stages.decode += seconds(b + 2, b + 3);
    }
  }
  report.batched.add(first, host_seconds, device_seconds, cpu_seconds);
  if (first)
    report.batched_first_stages = stages;
  else if (device_seconds >= 0)
    report.batched_stages.push_back(stages);
  return Status::ok();
}

// One timed lsnifCmdQuery of all rays in one command buffer (timestamps before and after the call
// where the queue has them), submitted and waited for, timed as the batched runs.
Status timed_query(DeviceState& st, uint32_t count, bool first, Report& report) {
  const LsnifQueryInfo info = query_info(st, count);
  LsnifResult result = LSNIF_SUCCESS;
  const double cpu0 = process_cpu_seconds();
  const auto t0 = std::chrono::steady_clock::now();
  Status s = st.ctx.submit("lsnifCmdQuery", [&](VkCommandBuffer cmd) {
    if (st.query_timestamps) {
      vkCmdResetQueryPool(cmd, st.query_timestamps, 0, 2);
      vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, st.query_timestamps, 0);
    }
    result = st.query.cmd_query(cmd, info);
    if (st.query_timestamps) vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, st.query_timestamps, 1);
    vk::ComputeContext::barrier_compute_to_host(cmd);
  });
  const double host_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double cpu_seconds = process_cpu_seconds() - cpu0;
  if (result != LSNIF_SUCCESS) return Status::error("lsnifCmdQuery: %s", lsnifGetLastErrorMessage());
  if (!s) return s;
  double device_seconds = -1;
  if (st.query_timestamps) {
    uint64_t ticks[2] = {0, 0};
    LSNIF_VK_CHECK(vkGetQueryPoolResults(st.ctx.device(), st.query_timestamps, 0, 2, sizeof ticks, ticks,
                                         sizeof(uint64_t), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT));
    device_seconds = double((ticks[1] - ticks[0]) & st.timestamp_mask) * st.timestamp_period * 1e-9;
  }
  report.query.add(first, host_seconds, device_seconds, cpu_seconds);
  return Status::ok();
}

// The first trace of each kind, the first batched run and the first lsnifCmdQuery, then `repeat`
// alternating rounds (LSNIF, triangles, batched, query), with a progress line on stderr.
Status run_traces(DeviceState& st, uint32_t count, uint32_t repeat, Report& report) {
  ProgressBar progress("bench-trace", 4 + 4 * uint64_t(repeat));
  uint64_t done = 0;
  auto step = [&](const vk::AccelerationStructure& tlas, const vk::Buffer& results, bool first, Timings& t,
                  const char* what) {
    progress.update(done, format("tracing %s%s", what, first ? " (first trace)" : ""));
    const Status s = timed_trace(st, tlas, results, count, first, t);
    ++done;
    return s ? Status::ok() : Status(s).context(format("%s trace", what));
  };
  auto batched = [&](bool first) {
    progress.update(done, format("batched path%s", first ? " (first run)" : ""));
    const Status s = timed_batched(st, count, first, report);
    ++done;
    return s ? Status::ok() : Status(s).context("batched path");
  };
  auto query = [&](bool first) {
    progress.update(done, format("lsnifCmdQuery%s", first ? " (first run)" : ""));
    const Status s = timed_query(st, count, first, report);
    ++done;
    return s ? Status::ok() : Status(s).context("lsnifCmdQuery");
  };
  Status s = step(st.lsnif_tlas, st.lsnif_results, true, report.lsnif, "LSNIF");
  if (s) s = step(st.tri_tlas, st.tri_results, true, report.tri, "triangles");
  if (s) s = batched(true);
  if (s) s = query(true);
  for (uint32_t k = 0; k < repeat && s; ++k) {
    s = step(st.lsnif_tlas, st.lsnif_results, false, report.lsnif, "LSNIF");
    if (s) s = step(st.tri_tlas, st.tri_results, false, report.tri, "triangles");
    if (s) s = batched(false);
    if (s) s = query(false);
  }
  if (!s) return s;
  report.device_timestamps =
      !report.lsnif.device.empty() && !report.tri.device.empty() && !report.batched.device.empty();
  progress.finish(format("LSNIF %.3f s, triangles %.3f s, batched %.3f s, query %.3f s per run (median)",
                         report.lsnif.median_host(), report.tri.median_host(), report.batched.median_host(),
                         report.query.median_host()));
  return Status::ok();
}

// The CPU limit of the network evaluation: the model's MLP as Eigen GEMMs (float32, the model's
// weights, the input padded to an even width as the GPU model block pads it, bias and leaky ReLU
// after every hidden layer as src/lsnif/core/network.cpp computes them) on `threads` OpenMP threads, each
// pushing its own `batch` columns of fixed random inputs through all layers per pass (one
// single-threaded GEMM per layer, chunk and thread, as mlp_forward runs the trainer's batches),
// repeated for at least `min_seconds` after one untimed pass.
GemmReport run_gemm(const Model& model, uint32_t batch, double min_seconds) {
  const Config& config = model.config;
  const std::vector<LayerView> layers = mlp_layers(config);
  GemmReport g;
  g.threads = uint32_t(std::max(1, omp_get_max_threads()));
  g.batch = batch;
  std::vector<Matrix> weights;
  std::vector<Eigen::VectorXf> biases;
  for (size_t l = 0; l < layers.size(); ++l) {
    const LayerView& v = layers[l];
    const uint32_t in = l == 0 ? 2u * LSNIF_GPU_ROW_WORDS(v.in) : v.in;
    Matrix w = Matrix::Zero(v.out, in);
    for (uint32_t r = 0; r < v.out; ++r)
      for (uint32_t c = 0; c < v.in; ++c) w(r, c) = model.mlp[v.weight_offset + size_t(r) * v.in + c];
    weights.push_back(std::move(w));
    biases.push_back(Eigen::Map<const Eigen::VectorXf>(model.mlp.data() + v.bias_offset, v.out));
    if (l == 0) g.widths.push_back(in);
    g.widths.push_back(v.out);
    g.flops_per_column += 2.0 * double(in) * double(v.out);
  }
  // Per thread: the input and one output per layer, allocated once (no allocation in the passes).
  std::vector<std::vector<Matrix>> acts(g.threads);
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (std::vector<Matrix>& a : acts) {
    for (const uint32_t w : g.widths) a.emplace_back(w, batch);
    for (Eigen::Index i = 0; i < a[0].size(); ++i) a[0].data()[i] = u(rng);
  }
  const float slope = config.leaky_slope;
  auto pass = [&]() {
#pragma omp parallel num_threads(int(g.threads))
    {
      std::vector<Matrix>& a = acts[size_t(omp_get_thread_num())];
      for (size_t l = 0; l < weights.size(); ++l) {
        a[l + 1].noalias() = weights[l] * a[l];
        a[l + 1].colwise() += biases[l];
        if (l + 1 < weights.size()) a[l + 1] = a[l + 1].cwiseMax(slope * a[l + 1]);
      }
    }
  };
  pass();
  const double cpu0 = process_cpu_seconds();
  const auto t0 = std::chrono::steady_clock::now();
  do {
    pass();
    ++g.passes;
    g.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  } while (g.seconds < min_seconds);
  g.cpu_seconds = process_cpu_seconds() - cpu0;
  return g;
}

// Hit statistics of the last traces and batched run, and the host walk of every ray.
void compare_results(const DeviceState& st, const Model& model, const Mesh& mesh, const std::vector<Ray>& rays,
                     Report& report) {
  const auto* lsnif = static_cast<const BenchTraceResult*>(st.lsnif_results.mapped);
  const auto* tri = static_cast<const BenchTraceResult*>(st.tri_results.mapped);
  const double diag = double(mesh.bounds().diagonal());
  std::vector<double> t_diff;
  std::vector<uint32_t> host_points(rays.size());
  RayWalk walk;
  for (size_t i = 0; i < rays.size(); ++i) {
    const uint32_t points = walk_ray(model.voxels, rays[i], model.config.max_points, walk);
    host_points[i] = points;
    report.aabb_rays += walk.hits_aabb;
    report.network_rays += points > 0;
    const bool lh = (lsnif[i].info & kResultHit) != 0, th = (tri[i].info & kResultHit) != 0;
    report.lsnif_hits += lh;
    report.triangle_hits += th;
    report.agree += lh == th;
    if (lh && ((lsnif[i].info >> kResultPointsShift) & 0xffu) != points) ++report.points_mismatch;
    if (lh && th) {
      ++report.both_hit;
      t_diff.push_back(std::fabs(double(lsnif[i].t) - double(tri[i].t)) / diag);
    }
  }
  report.median_t_difference = median(std::move(t_diff));

  // The batched hits against the inline shader's, ray by ray, and their walks against the host's.
  const auto* batched = static_cast<const LsnifQueryHit*>(st.query_hits.mapped);
  for (size_t i = 0; i < rays.size(); ++i) {
    const bool bh = batched[i].kind == LSNIF_QUERY_HIT_LSNIF, lh = (lsnif[i].info & kResultHit) != 0;
    report.batched_hits += bh;
    report.batched_network_rays += batched[i].points > 0;
    report.batched_agree += bh == lh;
    if (lh && ((lsnif[i].info >> kResultPointsShift) & 0xffu) != std::min(batched[i].points, 255u))
      ++report.batched_points_mismatch;
    report.batched_walk_mismatch += batched[i].points != host_points[i];
    if (bh && lh) {
      ++report.batched_both_hit;
      report.batched_max_t_difference =
          std::max(report.batched_max_t_difference, std::fabs(double(batched[i].t) - double(lsnif[i].t)) / diag);
    }
  }

  // The lsnifCmdQuery results against the inline shader's.
  const auto* query = static_cast<const LsnifQueryResult*>(st.query_results.mapped);
  for (size_t i = 0; i < rays.size(); ++i) {
    const bool qh = query[i].kind == LSNIF_QUERY_HIT_LSNIF, lh = (lsnif[i].info & kResultHit) != 0;
    report.query_hits += qh;
    report.query_incomplete += query[i].kind == LSNIF_QUERY_HIT_INCOMPLETE;
    report.query_agree += qh == lh;
    if (qh && lh) {
      ++report.query_both_hit;
      report.query_max_t_difference =
          std::max(report.query_max_t_difference, std::fabs(double(query[i].t) - double(lsnif[i].t)) / diag);
    }
  }
  std::memcpy(&report.query_status, st.query_status.mapped, sizeof report.query_status);
}

// "-" for a missing device time.
std::string seconds_text(double s) { return s < 0 ? std::string("-") : format("%.4f", s); }
std::string json_number(double v) { return v < 0 || !std::isfinite(v) ? std::string("null") : format("%.6g", v); }

void print_text(const Report& r) {
  const double n = double(r.rays);
  std::printf("bench-trace: LSNIF intersection shader vs triangle BLAS, same rays, same pipeline\n");
  std::printf("device                 %s\n", r.device.c_str());
  std::printf("mesh                   %s (%u triangles; BLAS input in %s order)\n", r.mesh_path.c_str(),
              r.triangles, r.morton_order ? "Morton" : "file");
  std::printf("model                  %s\n", r.model_path.c_str());
  std::printf("intersection shader    %s\n", r.intersection_spv.c_str());
  std::printf("rays                   %u (seed %llu): origins on a sphere (1.5 x half diagonal) around the mesh "
              "AABB, aimed at uniform points inside it\n",
              r.rays, static_cast<unsigned long long>(r.seed));
  std::printf("timer                  host wall time around submit + wait per trace, median of %u repeat%s "
              "(alternating)%s\n",
              r.repeat, r.repeat == 1 ? "" : "s",
              r.device_timestamps ? "; device: timestamps around vkCmdTraceRaysKHR and the batched stages" : "");
  std::printf("pipeline creation      %.3f s (ray tracing), %.3f s (batched path: lsnifCreateQueryPipeline)\n",
              r.pipeline_create_seconds, r.query_pipeline_create_seconds);
  std::printf("batched path           lsnifCmdIntersectModelRays on the same rays (identity instance: object space "
              "= world space), %u call%s per run, alternating with the traces\n\n",
              r.batched_calls, r.batched_calls == 1 ? "" : "s");
  std::printf("%-32s %14s %14s %14s\n", "", "LSNIF", "triangles", "batched");
  std::printf("%-32s %14.4f %14.4f %14.4f\n", "first trace (s, host)", r.lsnif.first_host, r.tri.first_host,
              r.batched.first_host);
  std::printf("%-32s %14.4f %14.4f %14.4f\n", "median trace (s, host)", r.lsnif.median_host(), r.tri.median_host(),
              r.batched.median_host());
  std::printf("%-32s %14.4f %14.4f %14.4f\n", "fastest trace (s, host)", r.lsnif.min_host(), r.tri.min_host(),
              r.batched.min_host());
  if (r.device_timestamps)
    std::printf("%-32s %14s %14s %14s\n", "median trace (s, device)", seconds_text(r.lsnif.median_device()).c_str(),
                seconds_text(r.tri.median_device()).c_str(), seconds_text(r.batched.median_device()).c_str());
  std::printf("%-32s %14.4f %14.4f %14.4f\n", "median process CPU time (s)", r.lsnif.median_cpu(), r.tri.median_cpu(),
              r.batched.median_cpu());
  std::printf("%-32s %14.4g %14.4g %14.4g\n", "rays/s (host median)", r.rays_per_second(r.lsnif),
              r.rays_per_second(r.tri), r.rays_per_second(r.batched));
  std::printf("%-32s %14u %14u %14u\n", "hits", r.lsnif_hits, r.triangle_hits, r.batched_hits);
  std::printf("\nLSNIF network evaluations       %u rays (%.1f%%; %u rays, %.1f%%, reach the intersection "
              "shader)\n",
              r.network_rays, 100.0 * r.network_rays / n, r.aabb_rays, 100.0 * r.aabb_rays / n);
  std::printf("network evaluations/s           %.4g\n", r.evaluations_per_second());
  std::printf("triangle rays/s / LSNIF rays/s  %.3g\n", r.ratio());
  std::printf("hit agreement                   %.2f%% (LSNIF hit == triangle hit); median |t difference| "
              "%.3g%% of the diagonal over %u rays both hit\n",
              100.0 * r.agree / n, 100.0 * r.median_t_difference, r.both_hit);
  std::printf("walk check                      %u LSNIF hits whose shader walk points differ from the host "
              "walk\n",
              r.points_mismatch);

  std::printf("batched stages (s, device)      ");
  if (r.batched_stages.empty())
    std::printf("- (the queue has no timestamps)\n");
  else
    std::printf("narrow phase %.4f, MLP %.4f, decode %.4f (medians; first run %.4f, %.4f, %.4f)\n",
                r.median_stage(&StageTimes::narrow), r.median_stage(&StageTimes::mlp),
                r.median_stage(&StageTimes::decode), r.batched_first_stages.narrow, r.batched_first_stages.mlp,
                r.batched_first_stages.decode);
  std::printf("batched network evaluations     %u rays (points > 0)\n", r.batched_network_rays);
  std::printf("batched network evaluations/s   %.4g (%s x the inline shader's)\n", r.batched_evaluations_per_second(),
              std::isfinite(r.batched_over_inline()) ? format("%.3g", r.batched_over_inline()).c_str() : "-");
  if (r.mlp_stage_evaluations_per_second() > 0)
    std::printf("MLP stage alone                 %.4g evaluations/s (device median)\n",
                r.mlp_stage_evaluations_per_second());
  std::printf("batched vs inline               hit == hit for %.4f%% of the rays; max |t difference| %.3g%% of the "
              "diagonal over %u rays both hit\n",
              100.0 * r.batched_agree / n, 100.0 * r.batched_max_t_difference, r.batched_both_hit);
  std::printf("batched walk check              %u of the %u inline hits with other points; %u rays whose points "
              "differ from the host walk\n",
              r.batched_points_mismatch, r.lsnif_hits, r.batched_walk_mismatch);
  std::printf("\nquery path                      lsnifCmdQuery on the same rays against the LSNIF TLAS (one identity "
              "instance), alternating with the others\n");
  std::printf("query trace (s, host)           median %.4f, fastest %.4f, first %.4f; process CPU time %.4f (median)\n",
              r.query.median_host(), r.query.min_host(), r.query.first_host, r.query.median_cpu());
  std::printf("query trace (s, device)         %s (median; timestamps around the call)\n",
              seconds_text(r.query.median_device()).c_str());
  std::printf("query rays/s (host median)      %.4g\n", r.rays_per_second(r.query));
  std::printf("query network evaluations/s     %.4g (%s x the inline shader's)\n", r.query_evaluations_per_second(),
              std::isfinite(r.query_over_inline()) ? format("%.3g", r.query_over_inline()).c_str() : "-");
  std::printf("query vs inline                 hit == hit for %.4f%% of the rays; max |t difference| %.3g%% of the "
              "diagonal over %u rays both hit; %u hits, %u incomplete\n",
              100.0 * r.query_agree / n, 100.0 * r.query_max_t_difference, r.query_both_hit, r.query_hits,
              r.query_incomplete);
  std::printf("query status                    %u candidates, capacity %u, %u dropped, %u not evaluated\n",
              r.query_status.candidates, r.query_status.capacity, r.query_status.dropped,
              r.query_status.unevaluated);
  std::string widths;
  for (const uint32_t w : r.gemm.widths) widths += format(widths.empty() ? "%u" : "-%u", w);
  std::printf("\nCPU limit                       Eigen GEMM %s float32 (bias + leaky ReLU included), %u OpenMP "
              "thread%s x %u columns, %llu passes in %.3f s (process CPU time %.3f s; %.3g GFLOP/s in the GEMMs)\n",
              widths.c_str(), r.gemm.threads, r.gemm.threads == 1 ? "" : "s", r.gemm.batch,
              static_cast<unsigned long long>(r.gemm.passes), r.gemm.seconds, r.gemm.cpu_seconds,
              r.gemm.evaluations_per_second() * r.gemm.flops_per_column * 1e-9);
  std::printf("GEMM network evaluations/s      %.4g\n", r.gemm.evaluations_per_second());
  std::printf("batched / GEMM evaluations/s    %.3g", r.batched_over_gemm());
  if (r.mlp_stage_evaluations_per_second() > 0)
    std::printf(" (MLP stage alone / GEMM: %.3g)",
                r.mlp_stage_evaluations_per_second() / r.gemm.evaluations_per_second());
  std::printf("\n");
  if (r.validation)
    std::printf("validation                      %u errors, %u warnings\n", r.validation_errors,
                r.validation_warnings);
}

std::string timings_json(const Report& r, const Timings& t) {
  auto list = [](const std::vector<double>& v) {
    std::string out = "[";
    for (size_t i = 0; i < v.size(); ++i) out += (i ? ", " : "") + format("%.6g", v[i]);
    return out + "]";
  };
  return format("{\"first_trace_seconds\": %.6g, \"first_trace_device_seconds\": %s, "
                "\"first_trace_cpu_seconds\": %.6g, \"median_trace_seconds\": %.6g, "
                "\"min_trace_seconds\": %.6g, \"median_trace_device_seconds\": %s, "
                "\"median_trace_cpu_seconds\": %.6g, \"rays_per_second\": %.6g, \"trace_seconds\": %s, "
                "\"trace_device_seconds\": %s, \"trace_cpu_seconds\": %s}",
                t.first_host, json_number(t.first_device).c_str(), t.first_cpu, t.median_host(), t.min_host(),
                json_number(t.median_device()).c_str(), t.median_cpu(), r.rays_per_second(t), list(t.host).c_str(),
                list(t.device).c_str(), list(t.cpu).c_str());
}

std::string stages_json(const StageTimes& s, bool valid) {
  if (!valid) return "null";
  return format("{\"narrow_seconds\": %.6g, \"mlp_seconds\": %.6g, \"decode_seconds\": %.6g}", s.narrow, s.mlp,
                s.decode);
}

// The batched path: its timings (the keys of the traces' objects) and its stages.
std::string batched_json(const Report& r) {
  std::string t = timings_json(r, r.batched);
  t.pop_back();  // the closing brace
  auto list = [&](double StageTimes::*stage) {
    std::string out = "[";
    for (size_t i = 0; i < r.batched_stages.size(); ++i)
      out += (i ? ", " : "") + format("%.6g", r.batched_stages[i].*stage);
    return out + "]";
  };
  return t + format(", \"calls_per_run\": %u, \"first_run_stages\": %s, \"median_narrow_seconds\": %s, "
                    "\"median_mlp_seconds\": %s, \"median_decode_seconds\": %s, \"narrow_seconds\": %s, "
                    "\"mlp_seconds\": %s, \"decode_seconds\": %s}",
                    r.batched_calls, stages_json(r.batched_first_stages, r.batched.first_device >= 0).c_str(),
                    json_number(r.median_stage(&StageTimes::narrow)).c_str(),
                    json_number(r.median_stage(&StageTimes::mlp)).c_str(),
                    json_number(r.median_stage(&StageTimes::decode)).c_str(), list(&StageTimes::narrow).c_str(),
                    list(&StageTimes::mlp).c_str(), list(&StageTimes::decode).c_str());
}

std::string gemm_json(const GemmReport& g) {
  std::string widths = "[";
  for (size_t i = 0; i < g.widths.size(); ++i) widths += format(i ? ", %u" : "%u", g.widths[i]);
  widths += "]";
  return format("{\"layer_widths\": %s, \"float32\": true, \"bias_and_activation\": true, \"threads\": %u, "
                "\"columns_per_thread\": %u, \"passes\": %llu, \"seconds\": %.6g, \"cpu_seconds\": %.6g, "
                "\"flops_per_evaluation\": %.6g, \"evaluations_per_second\": %.6g}",
                widths.c_str(), g.threads, g.batch, static_cast<unsigned long long>(g.passes), g.seconds,
                g.cpu_seconds, g.flops_per_column, g.evaluations_per_second());
}

void print_json(const Report& r) {
  std::printf(
      "{\"device\": %s, \"mesh\": %s, \"model\": %s, \"intersection_shader\": %s, \"mesh_triangles\": %u, "
      "\"triangle_order\": \"%s\", \"rays\": %u, \"seed\": %llu, "
      "\"repeat\": %u, \"timer\": \"host wall time around submit + wait, median of the repeats\", "
      "\"device_timestamps\": %s, \"pipeline_create_seconds\": %.6g, \"lsnif\": %s, \"triangles\": %s, "
      "\"lsnif_hits\": %u, \"triangle_hits\": %u, \"intersection_shader_rays\": %u, "
      "\"network_evaluations\": %u, \"network_evaluations_per_second\": %.6g, "
      "\"triangle_over_lsnif_rays_per_second\": %.6g, \"hit_agreement\": %.6g, \"both_hit\": %u, "
      "\"median_t_difference_over_diagonal\": %.6g, \"walk_points_mismatches\": %u, "
      "\"query_pipeline_create_seconds\": %.6g, \"batched\": %s, \"batched_hits\": %u, "
      "\"batched_network_evaluations\": %u, \"batched_network_evaluations_per_second\": %.6g, "
      "\"batched_over_inline_network_evaluations_per_second\": %s, \"batched_inline_hit_agreement\": %.6g, "
      "\"batched_inline_both_hit\": %u, \"batched_inline_max_t_difference_over_diagonal\": %.6g, "
      "\"batched_inline_points_mismatches\": %u, \"batched_walk_points_mismatches\": %u, \"gemm\": %s, "
      "\"batched_over_gemm_network_evaluations_per_second\": %s, "
      "\"batched_mlp_stage_evaluations_per_second\": %s, \"query\": %s, \"query_hits\": %u, "
      "\"query_incomplete_rays\": %u, \"query_candidates\": %u, \"query_dropped\": %u, "
      "\"query_unevaluated\": %u, \"query_network_evaluations_per_second\": %.6g, "
      "\"query_over_inline_network_evaluations_per_second\": %s, \"query_inline_hit_agreement\": %.6g, "
      "\"query_inline_both_hit\": %u, \"query_inline_max_t_difference_over_diagonal\": %.6g, "
      "\"validation\": %s, "
      "\"validation_errors\": %u, \"validation_warnings\": %u}\n",
      quoted(r.device).c_str(), quoted(r.mesh_path).c_str(), quoted(r.model_path).c_str(),
      quoted(r.intersection_spv).c_str(), r.triangles,
      r.morton_order ? "morton" : "file", r.rays,
      static_cast<unsigned long long>(r.seed), r.repeat, r.device_timestamps ? "true" : "false",
      r.pipeline_create_seconds, timings_json(r, r.lsnif).c_str(), timings_json(r, r.tri).c_str(), r.lsnif_hits,
      r.triangle_hits, r.aabb_rays, r.network_rays, r.evaluations_per_second(), r.ratio(),
      double(r.agree) / double(r.rays), r.both_hit, r.median_t_difference, r.points_mismatch,
      r.query_pipeline_create_seconds, batched_json(r).c_str(), r.batched_hits, r.batched_network_rays,
      r.batched_evaluations_per_second(), json_number(r.batched_over_inline()).c_str(),
      double(r.batched_agree) / double(r.rays),
      r.batched_both_hit, r.batched_max_t_difference, r.batched_points_mismatch, r.batched_walk_mismatch,
      gemm_json(r.gemm).c_str(), json_number(r.batched_over_gemm()).c_str(),
      json_number(r.mlp_stage_evaluations_per_second()).c_str(), timings_json(r, r.query).c_str(), r.query_hits,
      r.query_incomplete, r.query_status.candidates, r.query_status.dropped, r.query_status.unevaluated,
      r.query_evaluations_per_second(), json_number(r.query_over_inline()).c_str(),
      double(r.query_agree) / double(r.rays), r.query_both_hit, r.query_max_t_difference,
      r.validation ? "true" : "false", r.validation_errors,
      r.validation_warnings);
}

}  // namespace

int cmd_bench_trace(int argc, char** argv) {
  std::string mesh_path, model_path, triangle_order = "morton", device;
  std::string intersection_spv;
  uint32_t rays = 1u << 18, repeat = 5, gemm_batch = 4096;
  float gemm_seconds = 0.5f;
  uint64_t seed = 1;
  bool json = false, validation = false;
  MeshImportOptions import_options;
  Args args("bench-trace",
            "Throughput of the LSNIF intersection shader (src/lsnif/shaders/lsnif.rint, embedded in the plugin) in a\n"
            "ray-tracing pipeline on the Vulkan device, against a triangle BLAS of the same mesh: the same rays\n"
            "through a TLAS of one LSNIF instance and a TLAS of one triangle instance (identity transforms), in\n"
            "one pipeline. Rays start on a sphere around the mesh AABB and aim at uniform points inside it.\n"
            "Reports the first trace of each (first use of the pipeline) and the median of the repeats\n"
            "(host wall time around submit + wait; device timestamps too where the queue has them), rays/s,\n"
            "LSNIF network evaluations/s, the triangle / LSNIF ratio and the hit agreement of the two.\n"
            "The same rays also go through the plugin's batched path (lsnifCmdIntersectModelRays: narrow phase,\n"
            "MLP, decode in compute), timed the same way with per-stage device times and compared ray by ray\n"
            "with the intersection shader; likewise through lsnifCmdQuery against the LSNIF TLAS (needs\n"
            "VK_KHR_ray_query); and an Eigen GEMM of the model's MLP on the CPU (the trainer's\n"
            "OpenMP threads) gives the CPU limit of the network evaluations/s.\n"
            "MODEL must have been trained on MESH (same object space; checked by the AABB).");
  args.positional("MESH", "the mesh (.off .obj .ply .gltf .glb)", &mesh_path);
  args.positional("MODEL", "the model trained on it (.lsnif)", &model_path);
  args.option("rays", "rays per trace (1..2^24)", &rays);
  args.option("repeat", "timed traces of each kind after the first (1..1000)", &repeat);
  args.option("seed", "ray seed", &seed);
  args.option("triangle-order",
              "triangle order of the BLAS input: morton (centroid Morton code) or file (as loaded); lavapipe "
              "builds its BVH in this order",
              &triangle_order);
  args.option("intersection-shader",
              "SPIR-V file of the intersection shader instead of the plugin's (to compare shader versions; its "
              "hit attributes and model lookup must keep the layouts of the build)",
              &intersection_spv);
  args.option("gemm-batch", "columns per OpenMP thread of the CPU GEMM (1..65536)", &gemm_batch);
  args.option("gemm-seconds", "least time of the timed CPU GEMM passes (0.01..60 s)", &gemm_seconds);
  args.flag("json", "print one JSON object instead of text", &json);
  args.flag("validation", "enable the Khronos validation layer (slow; exit 1 if it reports anything)", &validation);
  add_device_option(args, &device);
  add_import_flags(args, &import_options);
  if (int r = args.parse(argc, argv)) return r == 1 ? 0 : 2;
  if (rays == 0 || rays > kMaxRays) {
    std::fprintf(stderr, "lsnif bench-trace: --rays %u out of range 1..%u\n", rays, kMaxRays);
    return 2;
  }
  if (repeat == 0 || repeat > kMaxRepeat) {
    std::fprintf(stderr, "lsnif bench-trace: --repeat %u out of range 1..%u\n", repeat, kMaxRepeat);
    return 2;
  }

  if (gemm_batch == 0 || gemm_batch > 65536) {
    std::fprintf(stderr, "lsnif bench-trace: --gemm-batch %u out of range 1..65536\n", gemm_batch);
    return 2;
  }
  if (!(gemm_seconds >= 0.01f && gemm_seconds <= 60.0f)) {
    std::fprintf(stderr, "lsnif bench-trace: --gemm-seconds %g out of range 0.01..60\n", double(gemm_seconds));
    return 2;
  }

  if (triangle_order != "morton" && triangle_order != "file") {
    std::fprintf(stderr, "lsnif bench-trace: --triangle-order '%s': expected morton or file\n",
                 triangle_order.c_str());
    return 2;
  }

  auto fail = [](const Status& s) {
    std::fprintf(stderr, "lsnif bench-trace: %s\n", s.message().c_str());
    return 1;
  };
  Mesh mesh;
  if (Status s = load_mesh(mesh_path, mesh, nullptr, import_options); !s) return fail(s);
  Model model;
  if (Status s = load_model(model_path, model); !s) return fail(s);
  if (Status s = check_same_object(mesh, model); !s) return fail(s.context(mesh_path + " / " + model_path));

  Report report;
  report.mesh_path = mesh_path;
  report.model_path = model_path;
  report.intersection_spv = intersection_spv.empty() ? "the plugin's (lsnifGetIntersectionShaderSpirv)" : intersection_spv;
  report.rays = rays;
  report.repeat = repeat;
  report.seed = seed;
  report.triangles = uint32_t(mesh.triangles.size());
  report.validation = validation;
  report.morton_order = triangle_order == "morton";
  const std::vector<Ray> ray_list = make_rays(mesh.bounds(), rays, seed);

  DeviceState st;
  Status s = set_up(st, model_path, mesh, ray_list, validation, device, intersection_spv, report);
  if (s) s = run_traces(st, rays, repeat, report);
  if (!s) return fail(s);
  compare_results(st, model, mesh, ray_list, report);
  // After the device work, so that lavapipe's threads are idle while the GEMM has the cores.
  std::fprintf(stderr, "bench-trace: CPU GEMM of the MLP for %.2g s or more\n", double(gemm_seconds));
  report.gemm = run_gemm(model, gemm_batch, double(gemm_seconds));
  // Free everything, then the device, so that validation also sees leaks at vkDestroyDevice.
  st.release();
  st.ctx.destroy_device();
  report.validation_errors = st.ctx.validation_errors();
  report.validation_warnings = st.ctx.validation_warnings();

  if (json)
    print_json(report);
  else
    print_text(report);
  if (report.validation_errors + report.validation_warnings > 0) {
    std::fprintf(stderr, "lsnif bench-trace: the validation layer reported %u errors and %u warnings\n",
                 report.validation_errors, report.validation_warnings);
    return 1;
  }
  return 0;
}

}  // namespace lsnif::cli
