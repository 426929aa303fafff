// bench_trace_device.cpp -- the device side of `lsnif bench-trace` (bench_trace.h): the device, the
// model, the BLASes and TLASes, the ray-tracing pipeline with the benchmark's shaders, the inline
// traces, and the sequence of timed runs (traces, batched path, lsnifCmdQuery).
#include <sys/resource.h>

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "lsnif/apps/common/progress.h"
#include "lsnif/apps/lsnif/bench_trace.h"
#include "lsnif/vulkan/plugin_device.h"
#include "lsnif/vulkan/triangle_order.h"

namespace lsnif::cli::bench_trace {

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

static_assert(sizeof(LsnifReferenceRay) == 32, "ray layout");

constexpr uint32_t kLsnifRecord = 0, kTriangleRecord = 1;  // SBT hit group records

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

// The buffers of one element per ray, against the device's limits before any is made: each one's
// size, then all of them together against the memory heap they share. Errors name the buffer, its
// bytes, the limit and --rays.
Status check_ray_buffers(const vk::Context& ctx, uint64_t rays) {
  const std::pair<const char*, uint64_t> buffers[] = {
      {"ray buffer", sizeof(LsnifReferenceRay)},       {"LSNIF result buffer", sizeof(BenchTraceResult)},
      {"triangle result buffer", sizeof(BenchTraceResult)}, {"batched ray buffer", sizeof(LsnifQueryRay)},
      {"batched hit buffer", sizeof(LsnifQueryHit)},   {"query result buffer", sizeof(LsnifQueryResult)}};
  uint64_t total = 0;
  for (const auto& [name, per_ray] : buffers) {
    const std::string what = format("%s (%llu bytes a ray x --rays %llu)", name, (unsigned long long)per_ray,
                                    (unsigned long long)rays);
    if (Status s = ctx.check_buffer_size(what, per_ray * rays); !s)
      return Status::error("%s; lower --rays", s.message().c_str());
    total += per_ray * rays;
  }
  const uint64_t heap = ctx.buffer_limits().heap;
  if (heap && total > heap)
    return Status::error("the buffers of --rays %llu need %llu bytes in all, more than the device's host-visible "
                         "memory heap (%llu bytes); lower --rays", (unsigned long long)rays,
                         (unsigned long long)total, (unsigned long long)heap);
  // All of them stay mapped into this process: refused now rather than after the pipelines.
  if (!vk::address_space_for(total))
    return Status::error("the buffers of --rays %llu need %llu bytes in all, more than the process's address space "
                         "can take; lower --rays", (unsigned long long)rays, (unsigned long long)total);
  return Status::ok();
}

}  // namespace

Status set_up(DeviceState& st, const Options& options, const Mesh& mesh, const std::vector<Ray>& rays,
              Report& report) {
  vk::ContextOptions context_options;
  context_options.ray_tracing = true;
  context_options.validation = options.validation;
  context_options.device = options.device;
  context_options.on_validation_message = print_validation_message;
  Status s = st.ctx.init(context_options);
  if (!s) return s.context("Vulkan device with ray tracing");
  report.device = st.ctx.device_name();
  if (s = check_ray_buffers(st.ctx, rays.size()); !s) return s;
  if (s = st.tracer.init(); !s) return s;
  if (st.tracer.max_hit_attribute_size() < sizeof(LsnifHitAttributes))
    return Status::error("device %s: maxRayHitAttributeSize %u < %zu bytes of LsnifHitAttributes",
                         report.device.c_str(), st.tracer.max_hit_attribute_size(), sizeof(LsnifHitAttributes));

  auto plugin_error = [](const char* what) { return Status::error("%s: %s", what, lsnifGetLastErrorMessage()); };
  if (st.plugin.create(vk::plugin_create_info(st.ctx)) != LSNIF_SUCCESS) return plugin_error("plugin");
  if (st.model.create_from_file(st.plugin.get(), options.model_path.c_str()) != LSNIF_SUCCESS)
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
  if (options.intersection_spv.empty()) {
    if (lsnifGetIntersectionShaderSpirv(LSNIF_MODEL_LOOKUP_INSTANCE_TABLE, &shaders.intersection.code,
                                        &shaders.intersection.bytes) != LSNIF_SUCCESS)
      return plugin_error("intersection shader");
  } else {
    if (s = vk::read_spirv_file(options.intersection_spv, file_code); !s) return s;
    shaders.intersection = spirv(file_code.data(), file_code.size() * sizeof(uint32_t));
  }
  s = st.tracer.create_pipeline(shaders, sizeof(BenchTracePush), st.pipeline);
  if (!s) return s;
  if (st.pipeline.triangle_sbt_offset != kTriangleRecord)
    return Status::error("internal error: the triangle hit group is at SBT offset %u", st.pipeline.triangle_sbt_offset);
  report.pipeline_create_seconds = st.pipeline.create_seconds;

  const size_t n = rays.size();
  s = st.ctx.create_buffer(n * sizeof(LsnifReferenceRay), st.rays);
  if (s) s = st.ctx.create_buffer(n * sizeof(BenchTraceResult), st.lsnif_results);
  if (s) s = st.ctx.create_buffer(n * sizeof(BenchTraceResult), st.tri_results);
  if (!s) return s.context(format("the ray and result buffers of --rays %zu (lower --rays)", n));
  auto* out = static_cast<LsnifReferenceRay*>(st.rays.mapped);
  for (size_t i = 0; i < n; ++i) {
    const Ray& r = rays[i];
    out[i] = {r.origin.x, r.origin.y, r.origin.z, r.tmin, r.direction.x, r.direction.y, r.direction.z, r.tmax};
  }
  return set_up_batched(st, options, rays, report);
}

double process_cpu_seconds() {
  rusage u{};
  if (getrusage(RUSAGE_SELF, &u) != 0) return 0.0;
  auto secs = [](const timeval& tv) { return double(tv.tv_sec) + 1e-6 * double(tv.tv_usec); };
  return secs(u.ru_utime) + secs(u.ru_stime);
}

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
  progress.update(done);
  progress.finish(format("LSNIF %.3f s, triangles %.3f s, batched %.3f s, query %.3f s per run (median)",
                         report.lsnif.median_host(), report.tri.median_host(), report.batched.median_host(),
                         report.query.median_host()));
  return Status::ok();
}

}  // namespace lsnif::cli::bench_trace
