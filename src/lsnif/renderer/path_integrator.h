// path_integrator.h -- the two ways the Renderer traces the same estimator
// (src/lsnif/renderer/shaders/render_path.glsl), behind one interface: InlinePaths (a ray-tracing
// pipeline, networks in the intersection shader; renderer_inline.cpp) and WavefrontPaths (compute
// passes with every ray cast through lsnifCmdQuery; renderer_wavefront.cpp). The Renderer
// (renderer.cpp) owns the scene, the accumulation image and the frame; an integrator only adds
// samples. Internal to lsnif_render, not installed.
#pragma once
#include <cstdint>
#include <vector>

#include "lsnif/renderer/device_scene.h"
#include "lsnif/renderer/renderer.h"

namespace lsnif::render {

// What a pass reads: the scene on the device, its frame written for the pass (Renderer's
// prepare_frame: view, image, accumulation buffer, visibility buffer), and where stage times go.
struct PassInputs {
  DeviceScene& scene;
  uint32_t width, height;   // the accumulation image
  StageTimes* stage_times;  // per-stage device time is added here (wavefront); null: untimed
  uint32_t* stage_timed_samples;  // with stage_times: the samples those times are of, added with them
};

class PathIntegrator {
 public:
  virtual ~PathIntegrator() = default;
  // Adds samples first_sample .. first_sample + samples - 1 of every pixel, paths of up to
  // `max_bounces` bounces, to the accumulation image; with `raster`, the first vertex comes from the
  // visibility buffer the frame names.
  virtual Status trace(const PassInputs& in, uint32_t first_sample, uint32_t samples, uint32_t max_bounces,
                       bool raster) = 0;
  // Frees what is sized to the accumulation image (it is being released or resized).
  virtual void release_image_buffers() = 0;
};

// render.rgen in one vkCmdTraceRaysKHR per pass; LSNIF rays run the plugin's intersection shader.
class InlinePaths final : public PathIntegrator {
 public:
  InlinePaths(vk::Context& ctx, vk::RayTracer& tracer) : ctx_(ctx), tracer_(tracer) {}
  ~InlinePaths() override;
  InlinePaths(const InlinePaths&) = delete;
  InlinePaths& operator=(const InlinePaths&) = delete;
  // Makes the ray-tracing pipeline (once): the device scene's triangle hit groups follow its
  // shader table (triangle_sbt_offset). Fails on a device without scalar block layout or with
  // too small a hit attribute size.
  Status create();
  uint32_t triangle_sbt_offset() const { return pipeline_.triangle_sbt_offset; }
  Status trace(const PassInputs& in, uint32_t first_sample, uint32_t samples, uint32_t max_bounces,
               bool raster) override;
  void release_image_buffers() override {}

 private:
  vk::Context& ctx_;
  vk::RayTracer& tracer_;
  vk::RtPipeline pipeline_{};
  bool ready_ = false;
};

// render_wave.comp's stages recorded with lsnifCmdQuery between them, one command buffer per pass.
class WavefrontPaths final : public PathIntegrator {
 public:
  explicit WavefrontPaths(vk::Context& ctx) : ctx_(ctx) {}
  ~WavefrontPaths() override;
  WavefrontPaths(const WavefrontPaths&) = delete;
  WavefrontPaths& operator=(const WavefrontPaths&) = delete;
  // Fails on a scene whose triangles include an alpha cut-out (lsnifCmdQuery treats every triangle
  // as opaque), a device that runs no broad phase, or a ray answered INCOMPLETE.
  Status trace(const PassInputs& in, uint32_t first_sample, uint32_t samples, uint32_t max_bounces,
               bool raster) override;
  void release_image_buffers() override;
  // The broad phase of the queries from the next pass on; `scene`'s query pipeline (null: none
  // set) is made again when this changes it.
  void set_broad_phase(BroadPhase b, DeviceScene* scene);
  // Renderer::primary_hits of the traced camera rays: the CAMERA stage and one query of the camera
  // rays of sample `sample_index` (`out` sized to the pixels).
  Status primary_hits(const PassInputs& in, uint32_t sample_index, std::vector<PrimaryHit>& out);

 private:
  // Makes the pipeline, the query pipeline and the buffers for the image where missing, and the
  // scratch and zeroed statuses for passes of `samples` samples of `max_bounces`.
  Status prepare(const PassInputs& in, uint32_t samples, uint32_t max_bounces);
  vk::Context& ctx_;
  vk::Pipeline pipeline_{};  // render_wave.comp
  // The buffers (RenderWave), sized for the accumulation image; scratch and statuses of the
  // queries (one LsnifQueryStatus per query of a pass).
  std::vector<vk::Buffer> buffers_;
  vk::Buffer scratch_{}, status_{};
  uint64_t wave_address_ = 0;
  BroadPhase broad_phase_ = BroadPhase::automatic;
  vk::Timestamps timestamps_;  // grown to what a pass needs
};

}  // namespace lsnif::render
