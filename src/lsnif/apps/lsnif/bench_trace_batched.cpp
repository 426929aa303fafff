// bench_trace_batched.cpp -- the plugin's batched paths in `lsnif bench-trace` (bench_trace.h):
// lsnifCmdIntersectModelRays of the model and lsnifCmdQuery against the LSNIF TLAS, their buffers
// and timestamps, and their timed runs.
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <vector>

#include "lsnif/apps/lsnif/bench_trace.h"
#include "lsnif/renderer/renderer.h"

namespace lsnif::cli::bench_trace {

namespace {

static_assert(sizeof(LsnifQueryRay) == 48 && sizeof(LsnifQueryHit) == 80, "batched query layouts");

// Rays per lsnifCmdIntersectModelRays call: one chunk of the plugin, so that each call's middle
// timestamps bracket its stages (a call of more rays runs several chunks and times only the first
// chunk's stages); more rays go in several calls, one after the other, sharing the scratch.
constexpr uint32_t kMaxBatchRays = LSNIF_BATCH_CHUNK_RAYS;

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

}  // namespace

Status set_up_batched(DeviceState& st, const Options& options, const std::vector<Ray>& rays, Report& report) {
  auto plugin_error = [](const char* what) { return Status::error("%s: %s", what, lsnifGetLastErrorMessage()); };
  render::BroadPhase broad_phase = render::BroadPhase::automatic;
  if (!render::parse_broad_phase(options.broad_phase, broad_phase))
    return Status::error("--broad-phase '%s': expected auto, trace-rays or ray-query", options.broad_phase.c_str());
  LsnifQueryPipelineCreateFlags flags = render::query_pipeline_flags(broad_phase);
  if (options.mlp_kernel == "cooperative-matrix") flags |= LSNIF_QUERY_PIPELINE_CREATE_COOPERATIVE_MATRIX_MLP_BIT_NV;
  report.mlp_kernel = options.mlp_kernel;
  const auto t0 = std::chrono::steady_clock::now();
  if (st.query.create(st.plugin.get(), flags) != LSNIF_SUCCESS)
    return plugin_error("query pipeline of the batched path and lsnifCmdQuery");
  report.broad_phase = render::broad_phase_name(st.query.broad_phase());
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
  if (!s) return s.context(format("buffers of the batched path for --rays %u (lower --rays)", n));
  LsnifQueryInfo qi = query_info(st, n);
  VkDeviceSize query_scratch_bytes = 0;
  if (plugin::query_scratch_size(st.plugin.get(), qi, query_scratch_bytes) != LSNIF_SUCCESS)
    return plugin_error("scratch size of lsnifCmdQuery");
  s = st.ctx.create_buffer(size_t(n) * sizeof(LsnifQueryResult), st.query_results);
  if (s) s = st.ctx.create_buffer(size_t(query_scratch_bytes), st.query_scratch, VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT);
  if (s) s = st.ctx.create_buffer(sizeof(LsnifQueryStatus), st.query_status);
  if (!s) return s.context(format("buffers of lsnifCmdQuery for --rays %u (lower --rays)", n));
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
    vk::Context::barrier_compute_to_host(cmd);
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
    vk::Context::barrier_compute_to_host(cmd);
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

}  // namespace lsnif::cli::bench_trace
