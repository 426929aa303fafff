// bench_trace.h -- what the files of `lsnif bench-trace` share: its options, the report it prints,
// the device state, and the steps cmd_bench_trace.cpp runs in sequence. The benchmark:
// throughput of the LSNIF intersection shader (src/lsnif/shaders/lsnif.rint, as the plugin
// compiles it) in a real ray-tracing pipeline on the device, against the same rays traced through a
// triangle BLAS of the same mesh in the same run and the same pipeline.
//
// Setup: the Vulkan context's device (src/lsnif/vulkan/context.h, ray tracing on, validation only with
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
//
// The files: bench_trace_rays.cpp (the rays, the mesh / model check), bench_trace_device.cpp (the
// device, the pipeline, the inline traces and the sequence of runs), bench_trace_batched.cpp (the
// batched path and lsnifCmdQuery), bench_trace_compare.cpp (the results ray by ray),
// bench_trace_gemm.cpp (the CPU GEMM), bench_trace_report.cpp (text and JSON output).
#pragma once
#include <algorithm>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "lsnif/core/geometry.h"
#include "lsnif/core/model.h"
#include "lsnif/format/status.h"
#include "lsnif/import/mesh.h"
#include "lsnif/vulkan/raytracing.h"  // volk first: lsnif.h then uses its Vulkan declarations
#include "lsnif/lsnif.hpp"

namespace lsnif::cli::bench_trace {

// The options of `lsnif bench-trace` as parsed (cmd_bench_trace.cpp checks their ranges).
struct Options {
  std::string mesh_path, model_path, triangle_order = "morton", device;
  std::string intersection_spv;  // empty: the plugin's intersection shader
  std::string broad_phase = "auto";  // lsnifCmdQuery's: auto, trace-rays or ray-query (render::parse_broad_phase)
  // The batched paths' MLP kernel: portable or cooperative-matrix
  // (LSNIF_QUERY_PIPELINE_CREATE_COOPERATIVE_MATRIX_MLP_BIT_NV, unverified).
  std::string mlp_kernel = "portable";
  uint32_t rays = 1u << 18, repeat = 5, gemm_batch = 4096;
  float gemm_seconds = 0.5f;
  uint64_t seed = 1;
  bool json = false, validation = false;
  MeshImportOptions import_options;
};

// BenchTraceResult of shaders/bench_trace_common.glsl.
struct BenchTraceResult {
  float t;
  uint32_t info;
};
static_assert(sizeof(BenchTraceResult) == 8, "result layout of bench_trace_common.glsl");
constexpr uint32_t kResultHit = 1u, kResultPointsShift = 8u;

// The median of `v` (0 when empty; the mean of the two middle values for an even count).
double median(std::vector<double> v);

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
  std::string broad_phase;  // the broad phase lsnifCmdQuery ran with ("trace-rays", "ray-query")
  std::string mlp_kernel;   // the batched paths' MLP kernel ("portable", "cooperative-matrix")
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
  vk::Context ctx;
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

// --- bench_trace_rays.cpp ---

// A model trained on `mesh` has bounds == pad_aabb(mesh.bounds()) (src/lsnif/train/trainer.cpp). Ok when the
// corners agree within 1e-3 of the diagonal; otherwise an error naming both boxes.
Status check_same_object(const Mesh& mesh, const Model& model);

// `count` rays from `seed` (see the file comment): origins uniform on the sphere of radius
// 1.5 x |extent| / 2 around box.center(), unit directions towards uniform points inside `box`.
// Every origin lies outside the box (the sphere encloses it).
std::vector<Ray> make_rays(const Aabb& box, uint32_t count, uint64_t seed);

// --- bench_trace_device.cpp ---

// User + system CPU time of this process so far (all threads, lavapipe's workers included).
double process_cpu_seconds();

// Builds everything on the device options.device selects (vk::ContextOptions::device) for the model
// file options.model_path and `mesh` and writes `rays` into the ray buffer, then sets up the batched
// path (set_up_batched). The intersection shader is the plugin's, or the SPIR-V file
// options.intersection_spv when not empty; the triangle order is report.morton_order's.
Status set_up(DeviceState& st, const Options& options, const Mesh& mesh, const std::vector<Ray>& rays,
              Report& report);

// The first trace of each kind, the first batched run and the first lsnifCmdQuery, then `repeat`
// alternating rounds (LSNIF, triangles, batched, query), with a progress line on stderr.
Status run_traces(DeviceState& st, uint32_t count, uint32_t repeat, Report& report);

// --- bench_trace_batched.cpp ---

// The batched path on the plugin context of `st`: the query pipeline, the rays as LsnifQueryRay
// (the same rays: the instance is the identity, so object space is world space; flags 0), the
// hits, the scratch for the largest call, and the timestamp pool where the queue has timestamps.
// lsnifCmdQuery's broad phase is the one options.broad_phase names (the plugin's choice for auto).
Status set_up_batched(DeviceState& st, const Options& options, const std::vector<Ray>& rays, Report& report);

// One timed batched run of all rays: lsnifCmdIntersectModelRays (several calls when the rays are
// more than one call takes, with a barrier between them as they share the scratch) in one command
// buffer, submitted and waited for; the host time is the wall time around recording, submit and
// wait (as for the traces). Appends (or, with `first`, stores) the times and the stage times.
Status timed_batched(DeviceState& st, uint32_t count, bool first, Report& report);

// One timed lsnifCmdQuery of all rays in one command buffer (timestamps before and after the call
// where the queue has them), submitted and waited for, timed as the batched runs.
Status timed_query(DeviceState& st, uint32_t count, bool first, Report& report);

// --- bench_trace_compare.cpp ---

// Hit statistics of the last traces and batched run, and the host walk of every ray.
void compare_results(const DeviceState& st, const Model& model, const Mesh& mesh, const std::vector<Ray>& rays,
                     Report& report);

// --- bench_trace_gemm.cpp ---

// The CPU limit of the network evaluation: the model's MLP as Eigen GEMMs (float32, the model's
// weights, the input padded to an even width as the GPU model block pads it, bias and leaky ReLU
// after every hidden layer as src/lsnif/core/network.cpp computes them) on `threads` OpenMP threads, each
// pushing its own `batch` columns of fixed random inputs through all layers per pass (one
// single-threaded GEMM per layer, chunk and thread, as mlp_forward runs the trainer's batches),
// repeated for at least `min_seconds` after one untimed pass.
GemmReport run_gemm(const Model& model, uint32_t batch, double min_seconds);

// --- bench_trace_report.cpp ---

// The report as text on stdout.
void print_text(const Report& r);

// The report as one JSON object (one line) on stdout.
void print_json(const Report& r);

}  // namespace lsnif::cli::bench_trace
