// renderer_wavefront.cpp -- WavefrontPaths (path_integrator.h), the Renderer's wavefront pipeline
// (PathPipeline::wavefront): the stages of src/lsnif/renderer/shaders/render_wave.comp recorded with
// lsnifCmdQuery between them into one command buffer per pass, their buffers and scratch, and the
// traced primary hits (Renderer::primary_hits) through the same CAMERA stage and query.
#include "lsnif/renderer/path_integrator.h"

#include <algorithm>
#include <cstddef>
#include <cstring>
#include <utility>
#include <vector>

#include "lsnif/renderer/shaders/render_host_device.h"

namespace lsnif::render {

namespace {
// The wavefront's shader, compiled at build time (cmake/LsnifShaders.cmake).
#include "render_wave_comp_spirv.h"

// The queries of the wavefront pipeline over the scene's TLAS (rays, results, status and the
// scratch fields are set per query). Candidates: one per LSNIF instance a ray can cross, so that
// no ray runs out of capacity up to LSNIF_QUERY_MAX_CANDIDATES_PER_RAY instances.
LsnifQueryInfo wave_query_info(const DeviceScene::Mode& md) {
  LsnifQueryInfo q{};
  q.candidatesPerRay = std::clamp(md.stats.lsnif_instances, 1u, LSNIF_QUERY_MAX_CANDIDATES_PER_RAY);
  q.tlas = md.tlas.address;
  q.cullMask = 0xFF;
  q.modelCount = md.table_count;
  q.pModels = md.table_models.data();
  q.modelTable = md.table_address;
  return q;
}

// The push constants of the wavefront stages over the active mode (stage, bounce and sample are
// set per dispatch).
RenderPush wave_push(DeviceScene& dev, uint64_t wave) {
  RenderPush push{};
  push.model_table = dev.mode().table_address;
  push.model_count = dev.mode().table_count;
  push.frame = dev.frame_address;
  push.samples = 1;
  push.wave = wave;
  return push;
}

// Between the wavefront's passes: compute writes (and the queries' indirect arguments) before
// compute reads and writes and indirect reads.
void wave_barrier(VkCommandBuffer cmd) {
  VkMemoryBarrier b{};
  b.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
  b.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
  b.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_INDIRECT_COMMAND_READ_BIT;
  const VkPipelineStageFlags stages = VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT;
  vkCmdPipelineBarrier(cmd, stages, stages, 0, 1, &b, 0, nullptr, 0, nullptr);
}

}  // namespace

WavefrontPaths::~WavefrontPaths() {
  release_image_buffers();
  ctx_.destroy_pipeline(pipeline_);
}

void WavefrontPaths::set_broad_phase(BroadPhase b, DeviceScene* scene) {
  if (b == broad_phase_) return;
  broad_phase_ = b;
  // Every submission of the renderer waits for its fence, so the GPU no longer uses the pipeline.
  if (scene && scene->query) {
    lsnifDestroyQueryPipeline(scene->plugin.get(), scene->query);
    scene->query = nullptr;
  }
}

void WavefrontPaths::release_image_buffers() {
  for (vk::Buffer& b : buffers_) ctx_.destroy_buffer(b);
  buffers_.clear();
  ctx_.destroy_buffer(scratch_);
  ctx_.destroy_buffer(status_);
  ctx_.destroy_timestamps(timestamps_);
  wave_address_ = 0;
}

Status WavefrontPaths::prepare(const PassInputs& in, uint32_t samples, uint32_t max_bounces) {
  DeviceScene& dev = in.scene;
  if (!pipeline_.pipeline) {
    Status s = ctx_.create_pipeline(spirv(render_wave_comp_spirv, sizeof render_wave_comp_spirv), sizeof(RenderPush),
                                    pipeline_);
    if (!s) return s.context("wavefront pipeline");
  }
  if (!dev.query) {
    LsnifQueryPipelineFlagsCreateInfo flags{};
    flags.sType = LSNIF_STRUCTURE_TYPE_QUERY_PIPELINE_FLAGS_CREATE_INFO;
    flags.flags = query_pipeline_flags(broad_phase_);
    LsnifQueryPipelineCreateInfo info{};
    info.pNext = &flags;
    if (lsnifCreateQueryPipeline(dev.plugin.get(), &info, &dev.query) != LSNIF_SUCCESS)
      return plugin_error("wavefront pipeline");
  }
  const size_t pixels = size_t(in.width) * in.height;
  if (buffers_.empty()) {
    RenderWave w{};
    const std::pair<uint64_t*, size_t> parts[] = {
        {&w.paths, pixels * sizeof(RenderWavePath)},
        {&w.rays, pixels * sizeof(LsnifQueryRay)},
        {&w.results, pixels * sizeof(LsnifQueryResult)},
        {&w.shadow_rays, RENDER_WAVE_SHADOWS * pixels * sizeof(LsnifQueryRay)},
        {&w.shadow_results, RENDER_WAVE_SHADOWS * pixels * sizeof(LsnifQueryResult)},
        {&w.shadows, RENDER_WAVE_SHADOWS * pixels * sizeof(RenderWaveShadow)}};
    for (const auto& [address, bytes] : parts) {
      vk::Buffer b;
      if (Status s = ctx_.create_buffer(bytes, b); !s)
        return s.context(format("render: the wavefront buffers of a %ux%u image", in.width, in.height));
      buffers_.push_back(b);
      *address = b.address;
    }
    vk::Buffer b;
    if (Status s = ctx_.create_buffer(sizeof w, b); !s) return s;
    std::memcpy(b.mapped, &w, sizeof w);
    buffers_.push_back(b);
    wave_address_ = b.address;
  }
  // The scratch of the larger batch (the shadow rays), for this scene's models and capacity.
  LsnifQueryInfo q = wave_query_info(dev.mode());
  q.rayCount = uint32_t(RENDER_WAVE_SHADOWS * pixels);
  VkDeviceSize bytes = 0;
  if (lsnifGetQueryScratchSize(dev.plugin.get(), &q, &bytes) != LSNIF_SUCCESS) return plugin_error("wavefront scratch");
  if (scratch_.size < bytes) {
    ctx_.destroy_buffer(scratch_);
    if (Status s = ctx_.create_buffer(size_t(bytes), scratch_, VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT); !s) return s;
  }
  const size_t status_bytes = size_t(samples) * (2 * max_bounces + 1) * sizeof(LsnifQueryStatus);
  if (status_.size < status_bytes) {
    ctx_.destroy_buffer(status_);
    if (Status s = ctx_.create_buffer(status_bytes, status_); !s) return s;
  }
  std::memset(status_.mapped, 0, status_bytes);
  return Status::ok();
}

Status WavefrontPaths::trace(const PassInputs& in, uint32_t first_sample, uint32_t samples, uint32_t max_bounces,
                             bool raster) {
  DeviceScene& dev = in.scene;
  if (!dev.mode().cutout_material.empty())
    return Status::error("render: the wavefront pipeline's lsnifCmdQuery treats every triangle as opaque, and "
                         "material '%s' is an alpha cut-out: use --pipeline inline (or auto)",
                         printable(dev.mode().cutout_material).c_str());
  if (Status s = prepare(in, samples, max_bounces); !s) return s;
  const bool timing = in.stage_times != nullptr;
  const uint32_t pixels = in.width * in.height, groups = (pixels + 63) / 64;
  RenderWave w;
  std::memcpy(&w, buffers_.back().mapped, sizeof w);
  LsnifQueryInfo q = wave_query_info(dev.mode());
  q.scratchBuffer = scratch_.buffer;
  q.scratchSize = scratch_.size;
  RenderPush push = wave_push(dev, wave_address_);
  LsnifResult recorded = LSNIF_SUCCESS;
  uint32_t queries = 0;
  // Stage timing: a timestamp after every stage; interval[k] is the StageTimes field that the time
  // between timestamps k - 1 and k belongs to (interval[0] is unused: timestamp 0 starts the pass).
  std::vector<double StageTimes::*> interval;
  // Per sample: the camera, path and shadow queries (each followed by its shade or connect stage,
  // one stamp) and the accumulation.
  const uint32_t path_stamps = LSNIF_QUERY_TIMESTAMP_COUNT_FOR_RAYS(pixels) + 1;
  const uint32_t shadow_stamps = LSNIF_QUERY_TIMESTAMP_COUNT_FOR_RAYS(RENDER_WAVE_SHADOWS * pixels) + 1;
  const uint32_t stamps_per_sample = 2 + (max_bounces + 1) * path_stamps + max_bounces * shadow_stamps;
  const uint32_t stamp_count = timing ? 1 + samples * stamps_per_sample : 0;
  if (stamp_count > timestamps_.count) {
    ctx_.destroy_timestamps(timestamps_);
    if (Status s = ctx_.create_timestamps(stamp_count, timestamps_); !s) return s.context("stage timing");
  }
  LsnifQueryTimestampsInfo query_stamps{};
  query_stamps.sType = LSNIF_STRUCTURE_TYPE_QUERY_TIMESTAMPS_INFO;
  query_stamps.timestampPool = timestamps_.pool;
  Status st = ctx_.submit("wavefront pass", [&](VkCommandBuffer cmd) {
    auto stamp = [&](double StageTimes::*what) {
      if (!timing) return;
      vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, timestamps_.pool, uint32_t(interval.size()));
      interval.push_back(what);
    };
    auto stage = [&](uint32_t which, uint32_t bounce, double StageTimes::*what) {
      push.stage = which;
      push.bounce = bounce;
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline_.pipeline);  // a query binds its own
      vkCmdPushConstants(cmd, pipeline_.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof push, &push);
      vkCmdDispatch(cmd, groups, 1, 1);
      wave_barrier(cmd);
      stamp(what);
    };
    auto query = [&](uint64_t rays, uint64_t results, uint32_t count) {
      q.rayCount = count;
      q.rays = rays;
      q.results = results;
      q.status = status_.address + queries++ * sizeof(LsnifQueryStatus);
      q.pNext = nullptr;
      if (timing) {
        // The query's timestamps: [0] follows the previous stamp (no work between), then
        // LSNIF_QUERY_TIMESTAMPS_PER_CHUNK per chunk of rays (lsnif.h).
        query_stamps.firstQuery = uint32_t(interval.size());
        q.pNext = &query_stamps;
        interval.push_back(&StageTimes::shade);
        for (uint32_t c = 0; c < LSNIF_QUERY_CHUNK_COUNT(count); ++c) {
          interval.push_back(&StageTimes::broad);
          interval.push_back(&StageTimes::sort);
          for (uint32_t r = 0; r < LSNIF_QUERY_ROUNDS; ++r)  // the last round's decoding ends the chunk
            for (double StageTimes::*what : {&StageTimes::encode, &StageTimes::mlp, &StageTimes::resolve})
              interval.push_back(what);
        }
        static_assert(LSNIF_QUERY_TIMESTAMPS_PER_CHUNK == 2 + 3 * LSNIF_QUERY_ROUNDS, "the chunk's intervals above");
      }
      if (recorded == LSNIF_SUCCESS) recorded = lsnifCmdQuery(dev.plugin.get(), cmd, dev.query, &q);
      wave_barrier(cmd);
    };
    if (timing) vkCmdResetQueryPool(cmd, timestamps_.pool, 0, stamp_count);
    // The TLAS (built or refitted before) and the frame for the first pass.
    VkMemoryBarrier b{};
    b.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
    b.srcAccessMask = VK_ACCESS_ACCELERATION_STRUCTURE_WRITE_BIT_KHR | VK_ACCESS_SHADER_WRITE_BIT;
    b.dstAccessMask = VK_ACCESS_ACCELERATION_STRUCTURE_READ_BIT_KHR | VK_ACCESS_SHADER_READ_BIT;
    vkCmdPipelineBarrier(cmd,
                         VK_PIPELINE_STAGE_ACCELERATION_STRUCTURE_BUILD_BIT_KHR | VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                         VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, 0, 1, &b, 0, nullptr, 0, nullptr);
    stamp(nullptr);
    for (uint32_t s = 0; s < samples; ++s) {
      push.sample_index = first_sample + s;
      stage(RENDER_WAVE_CAMERA, 0, &StageTimes::camera);
      for (uint32_t bounce = 0; bounce <= max_bounces; ++bounce) {
        if (!(raster && bounce == 0)) {  // rasterized: CAMERA shaded the first vertex
          query(w.rays, w.results, pixels);
          stage(RENDER_WAVE_SHADE, bounce, &StageTimes::shade);
        }
        if (bounce == max_bounces) break;  // the last vertex samples no light
        query(w.shadow_rays, w.shadow_results, RENDER_WAVE_SHADOWS * pixels);
        stage(RENDER_WAVE_CONNECT, bounce, &StageTimes::shade);
      }
      stage(RENDER_WAVE_ACCUMULATE, 0, &StageTimes::shade);
    }
    vk::Context::barrier_compute_to_host(cmd);
  });
  if (recorded != LSNIF_SUCCESS) return plugin_error("wavefront pass");
  if (!st) return st.context("wavefront pass");
  if (timing) {
    std::vector<double> ms;
    if (Status s = ctx_.read_timestamps_ms(timestamps_, 0, uint32_t(interval.size()), ms); !s)
      return s.context("stage timing");
    for (size_t k = 1; k < ms.size(); ++k) in.stage_times->*interval[k] += ms[k] - ms[k - 1];
    *in.stage_timed_samples += samples;
  }
  // INCOMPLETE answers are not misses: a render with any fails.
  const auto* status = static_cast<const LsnifQueryStatus*>(status_.mapped);
  uint64_t incomplete = 0, dropped = 0;
  for (uint32_t i = 0; i < queries; ++i) {
    incomplete += status[i].incomplete_rays;
    dropped += status[i].dropped;
  }
  if (incomplete > 0)
    return Status::error("render (wavefront): %llu rays answered incomplete (%llu LSNIF candidates did not fit %u "
                         "per ray)", static_cast<unsigned long long>(incomplete),
                         static_cast<unsigned long long>(dropped), q.candidatesPerRay);
  return Status::ok();
}

Status WavefrontPaths::primary_hits(const PassInputs& in, uint32_t sample_index, std::vector<PrimaryHit>& out) {
  const size_t pixels = size_t(in.width) * in.height;
  if (Status s = prepare(in, 1, 0); !s) return s;
  DeviceScene& dev = in.scene;
  RenderWave w;
  std::memcpy(&w, buffers_.back().mapped, sizeof w);
  LsnifQueryInfo q = wave_query_info(dev.mode());
  q.scratchBuffer = scratch_.buffer;
  q.scratchSize = scratch_.size;
  q.rayCount = uint32_t(pixels);
  q.rays = w.rays;
  q.results = w.results;
  q.status = status_.address;
  RenderPush push = wave_push(dev, wave_address_);
  push.sample_index = sample_index;
  push.stage = RENDER_WAVE_CAMERA;
  LsnifResult recorded = LSNIF_SUCCESS;
  Status st = ctx_.submit("primary hits", [&](VkCommandBuffer cmd) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline_.pipeline);
    vkCmdPushConstants(cmd, pipeline_.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof push, &push);
    vkCmdDispatch(cmd, uint32_t((pixels + 63) / 64), 1, 1);
    wave_barrier(cmd);
    recorded = lsnifCmdQuery(dev.plugin.get(), cmd, dev.query, &q);
    vk::Context::barrier_compute_to_host(cmd);
  });
  if (recorded != LSNIF_SUCCESS) return plugin_error("primary hits");
  if (!st) return st;
  const auto* results = static_cast<const LsnifQueryResult*>(buffers_[2].mapped);
  for (size_t i = 0; i < pixels; ++i) {
    const LsnifQueryResult& r = results[i];
    PrimaryHit& h = out[i];
    h.hit = r.kind == LSNIF_QUERY_HIT_TRIANGLE || r.kind == LSNIF_QUERY_HIT_LSNIF;
    if (!h.hit) continue;
    h.instance = r.instance_custom_index;
    h.geometry = r.geometry_index;
    h.primitive = r.primitive_index;
    h.u = r.barycentric_u;
    h.v = r.barycentric_v;
    h.t = r.t;
  }
  return Status::ok();
}

}  // namespace lsnif::render
