// renderer_inline.cpp -- InlinePaths (path_integrator.h), the Renderer's inline pipeline
// (PathPipeline::inline_rt): src/lsnif/renderer/shaders/render.rgen and its hit shaders in one
// ray-tracing pipeline, with the plugin's intersection shader for the LSNIF boxes; one
// vkCmdTraceRaysKHR per pass.
#include "lsnif/renderer/path_integrator.h"

#include <cstddef>

namespace lsnif::render {

namespace {
// The path tracer's shaders, compiled at build time (cmake/LsnifShaders.cmake).
#include "render_lsnif_rchit_spirv.h"
#include "render_rgen_spirv.h"
#include "render_rmiss_spirv.h"
#include "render_triangle_rahit_spirv.h"
#include "render_triangle_rchit_spirv.h"

static_assert(offsetof(RenderPush, model_table) == LSNIF_RT_PUSH_MODEL_TABLE_OFFSET, "binding convention");
static_assert(offsetof(RenderPush, model_count) == LSNIF_RT_PUSH_MODEL_COUNT_OFFSET, "binding convention");
static_assert(offsetof(RenderPush, frame) >= LSNIF_RT_PUSH_APP_OFFSET, "binding convention");

}  // namespace

InlinePaths::~InlinePaths() {
  if (ready_) tracer_.destroy(pipeline_);
}

Status InlinePaths::create() {
  if (ready_) return Status::ok();
  if (!ctx_.scalar_block_layout())
    return Status::error("device %s lacks the feature scalarBlockLayout (the path tracer's shaders use scalar "
                         "block layout)", ctx_.device_name().c_str());
  if (Status s = tracer_.init(); !s) return s;
  if (tracer_.max_hit_attribute_size() < sizeof(LsnifHitAttributes))
    return Status::error("device maxRayHitAttributeSize %u < %zu bytes of LSNIF hit attributes",
                         tracer_.max_hit_attribute_size(), sizeof(LsnifHitAttributes));
  vk::RtShaders shaders;
  shaders.raygen = spirv(render_rgen_spirv, sizeof render_rgen_spirv);
  shaders.miss = spirv(render_rmiss_spirv, sizeof render_rmiss_spirv);
  shaders.closest_hit = spirv(render_lsnif_rchit_spirv, sizeof render_lsnif_rchit_spirv);
  shaders.triangle_closest_hit = spirv(render_triangle_rchit_spirv, sizeof render_triangle_rchit_spirv);
  shaders.triangle_any_hit = spirv(render_triangle_rahit_spirv, sizeof render_triangle_rahit_spirv);
  if (lsnifGetIntersectionShaderSpirv(LSNIF_MODEL_LOOKUP_INSTANCE_TABLE, &shaders.intersection.code,
                                      &shaders.intersection.bytes) != LSNIF_SUCCESS)
    return plugin_error("render pipeline");
  Status s = tracer_.create_pipeline(shaders, sizeof(RenderPush), pipeline_);
  if (!s) return s.context("render pipeline");
  ready_ = true;
  return Status::ok();
}

Status InlinePaths::trace(const PassInputs& in, uint32_t first_sample, uint32_t samples, uint32_t /*max_bounces*/,
                          bool /*raster*/) {
  // The frame carries the bounces and the visibility buffer; the push constants the pass's samples.
  const DeviceScene::Mode& md = in.scene.mode();
  RenderPush push{};
  push.model_table = md.table_address;
  push.model_count = md.table_count;
  push.frame = in.scene.frame_address;
  push.sample_index = first_sample;
  push.samples = samples;
  if (Status s = tracer_.trace(pipeline_, md.tlas, &push, in.width * in.height); !s) return s.context("render pass");
  return Status::ok();
}

}  // namespace lsnif::render
