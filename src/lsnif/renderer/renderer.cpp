// renderer.cpp -- the path tracer of renderer.h: sets a scene on the device (build_device_scene,
// device_scene.cpp), moves instances and switches modes on it, writes each pass's frame (view,
// image, rasterized visibility) and has the chosen pipeline (path_integrator.h: InlinePaths in
// renderer_inline.cpp, WavefrontPaths in renderer_wavefront.cpp) add its samples to the
// accumulation buffer.
#include "lsnif/renderer/renderer.h"

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "lsnif/format/instance_transform.h"
#include <volk.h>  // before lsnif.h, which then uses volk's Vulkan declarations

#include "lsnif/lsnif.hpp"
#include "lsnif/vulkan/plugin_device.h"
#include "lsnif/renderer/device_scene.h"
#include "lsnif/renderer/path_integrator.h"
#include "lsnif/renderer/shaders/render_host_device.h"
#include "lsnif/vulkan/triangle_order.h"

namespace lsnif::render {


Renderer::Renderer(vk::Context& ctx)
    : ctx_(ctx), tracer_(ctx), inline_(std::make_unique<InlinePaths>(ctx, tracer_)),
      wavefront_(std::make_unique<WavefrontPaths>(ctx)) {}

Renderer::~Renderer() {
  scene_.reset();
  visibility_.reset();
  release_accumulation();
  wavefront_.reset();
  inline_.reset();
}

std::string describe(const StageTimes& t) {
  char text[256];
  std::snprintf(text, sizeof text,
                "raster %.2f, camera %.2f, broad phase %.2f, sort %.2f, encode %.2f, MLP %.2f, resolve %.2f, shade %.2f "
                "(total %.2f)",
                t.raster, t.camera, t.broad, t.sort, t.encode, t.mlp, t.resolve, t.shade, t.total());
  return text;
}

const char* pipeline_name(PathPipeline p) { return p == PathPipeline::wavefront ? "wavefront" : "inline"; }

vk::ContextOptions context_options(bool validation, const std::string& device) {
  vk::ContextOptions options;
  options.ray_tracing = true;
  options.validation = validation;
  options.device = device;
  return options;
}

const char* broad_phase_name(BroadPhase b) {
  switch (b) {
    case BroadPhase::ray_query: return "ray-query";
    case BroadPhase::trace_rays: return "trace-rays";
    case BroadPhase::automatic: break;
  }
  return "auto";
}

bool parse_broad_phase(const std::string& name, BroadPhase& out) {
  if (name == "auto") out = BroadPhase::automatic;
  else if (name == "ray-query") out = BroadPhase::ray_query;
  else if (name == "trace-rays") out = BroadPhase::trace_rays;
  else return false;
  return true;
}

const char* broad_phase_name(LsnifQueryBroadPhase b) {
  switch (b) {
    case LSNIF_QUERY_BROAD_PHASE_RAY_QUERY: return "ray-query";
    case LSNIF_QUERY_BROAD_PHASE_TRACE_RAYS: return "trace-rays";
    default: break;
  }
  return "none";
}

LsnifQueryPipelineCreateFlags query_pipeline_flags(BroadPhase b) {
  LsnifQueryPipelineCreateFlags flags = LSNIF_QUERY_PIPELINE_CREATE_TLAS_BIT;
  if (b == BroadPhase::ray_query) flags |= LSNIF_QUERY_PIPELINE_CREATE_RAY_QUERY_BROAD_PHASE_BIT;
  if (b == BroadPhase::trace_rays) flags |= LSNIF_QUERY_PIPELINE_CREATE_TRACE_RAYS_BROAD_PHASE_BIT;
  return flags;
}

bool parse_pipeline(const std::string& name, PathPipeline& out) {
  if (name == "inline") out = PathPipeline::inline_rt;
  else if (name == "wavefront") out = PathPipeline::wavefront;
  else return false;
  return true;
}

const char* primary_name(PrimaryVisibility p) { return p == PrimaryVisibility::raster ? "raster" : "traced"; }

bool parse_primary(const std::string& name, PrimaryVisibility& out) {
  if (name == "traced") out = PrimaryVisibility::traced;
  else if (name == "raster") out = PrimaryVisibility::raster;
  else return false;
  return true;
}

Status Renderer::render(const scene::Scene& scene, const RenderSettings& settings, image::Image& out,
                        RenderStats& stats, const std::function<void(uint32_t)>& progress) {
  stats = RenderStats();
  out = image::Image();
  if (Status s = set_scene(scene, settings.reference, settings.environment,
                          /*both_modes=*/settings.primary == PrimaryVisibility::raster);
      !s)
    return s;
  return render(settings, out, stats, progress);
}


Status Renderer::set_scene(const scene::Scene& scene, bool reference, const scene::EnvironmentMap* environment,
                           bool both_modes) {
  scene_.reset();
  scene_stats_ = RenderStats();
  if (scene.instances.empty()) return Status::error("render: the scene %s has no objects", scene.path.c_str());
  if (Status s = inline_->create(); !s) return s;
  SceneBuildCounts counts{models_loaded_, blases_built_, tlases_built_};
  if (Status s = build_device_scene(ctx_, tracer_, scene, reference, environment, both_modes,
                                    inline_->triangle_sbt_offset(), counts, scene_);
      !s)
    return s;
  scene_stats_ = scene_->mode().stats;
  width_ = height_ = accumulated_ = 0;  // a new scene starts a new image
  return Status::ok();
}

Status Renderer::camera_view(int32_t camera, View& out) const {
  if (!scene_) return Status::error("render: no scene set");
  out = View();
  if (camera >= 0 && !scene_->cameras.empty()) {
    if (size_t(camera) >= scene_->cameras.size())
      return Status::error("render: camera %d does not exist (the scene has %zu)", camera, scene_->cameras.size());
    const scene::Camera& c = scene_->cameras[size_t(camera)];
    if (!finite(c.camera_to_world) || !(c.yfov > 0.0f && c.yfov < 3.1f))
      return Status::error("camera '%s' has a non-finite transform or a field of view outside (0, pi)", c.name.c_str());
    out.camera_to_world = c.camera_to_world;
    out.yfov = c.yfov;
    return Status::ok();
  }
  // Frame the scene from the front-right-top.
  const glm::vec3 center = 0.5f * (scene_->lo + scene_->hi);
  const float radius = 0.5f * glm::length(scene_->hi - scene_->lo);
  const glm::vec3 eye = center + radius / std::tan(0.5f * out.yfov) * glm::normalize(glm::vec3(0.6f, 0.4f, 1.0f));
  const glm::vec3 fwd = glm::normalize(center - eye), right = glm::normalize(glm::cross(fwd, glm::vec3(0, 1, 0)));
  const glm::vec3 up = glm::cross(right, fwd);
  out.camera_to_world = glm::mat4(glm::vec4(right, 0), glm::vec4(up, 0), glm::vec4(-fwd, 0), glm::vec4(eye, 1));
  return Status::ok();
}

Status Renderer::move_instance(size_t instance, const glm::mat4& object_to_world) {
  if (!scene_) return Status::error("render: no scene set");
  DeviceScene& dev = *scene_;
  if (instance >= dev.mode().instance_records.size())
    return Status::error("render: instance %zu does not exist (the scene has %zu)", instance,
                         dev.mode().instance_records.size());
  const VkTransformMatrixKHR xf = to_3x4(object_to_world);
  if (Status s = check_instance_transform(xf.matrix); !s) return s;
  for (DeviceScene::Mode& md : dev.modes) {
    if (!md.ready) continue;
    const auto [first, count] = md.instance_records[instance];
    for (size_t r = first; r < first + count; ++r) {
      if (md.record_model[r] >= 0) {
        LsnifInstanceInfo info{};
        info.model = dev.models[size_t(md.record_model[r])].get();
        info.transform = xf;
        info.instanceCustomIndex = uint32_t(r);
        info.mask = 0xFF;
        VkAccelerationStructureInstanceKHR rec;
        if (lsnifMakeInstance(dev.plugin.get(), &info, &rec) != LSNIF_SUCCESS) return plugin_error("move_instance");
        md.records[r] = rec;
      } else {
        md.records[r].transform = xf;
      }
      md.world_to_object_mapped[r] = glm::inverse(glm::mat3(object_to_world));
    }
    for (VisibilityDraw& d : md.raster_draws) {
      const size_t r = d.instance & ((1u << RENDER_VISIBILITY_GEOMETRY_SHIFT) - 1u);
      if (r >= first && r < first + count) d.object_to_world = object_to_world;
    }
    if (Status s = tracer_.update_tlas(md.records, md.tlas); !s) return s;
  }
  return Status::ok();
}

Status Renderer::set_mode(bool reference) {
  if (!scene_) return Status::error("render: no scene set");
  DeviceScene::Mode& md = scene_->modes[reference ? 1 : 0];
  if (!md.ready)
    return Status::error("render: the %s mode was not prepared by set_scene%s%s", reference ? "reference" : "LSNIF",
                         md.why_not.empty() ? " (both_modes)" : ": ", md.why_not.c_str());
  if (scene_->active != (reference ? 1 : 0)) {
    scene_->active = reference ? 1 : 0;
    scene_stats_ = md.stats;
    if (accumulation_.buffer) std::memset(accumulation_.mapped, 0, size_t(width_) * height_ * 16);
    accumulated_ = 0;
  }
  return Status::ok();
}

void Renderer::set_broad_phase(BroadPhase b) { wavefront_->set_broad_phase(b, scene_.get()); }

LsnifQueryBroadPhase Renderer::broad_phase_used() const {
  if (!scene_ || !scene_->query) return LSNIF_QUERY_BROAD_PHASE_NONE;
  return lsnifGetQueryBroadPhase(scene_->plugin.get(), scene_->query);
}

bool Renderer::reference_mode() const { return scene_ && scene_->active == 1; }

bool Renderer::world_bounds(glm::vec3& lo, glm::vec3& hi) const {
  if (!scene_) return false;
  lo = scene_->lo;
  hi = scene_->hi;
  return true;
}

void Renderer::release_accumulation() {
  if (accumulation_.buffer) ctx_.destroy_buffer(accumulation_);
  accumulation_ = vk::Buffer();
  width_ = height_ = accumulated_ = 0;
  inline_->release_image_buffers();
  wavefront_->release_image_buffers();
}

Status Renderer::reset_accumulation(uint32_t width, uint32_t height) {
  if (width == 0 || height == 0) return Status::error("render: width and height must be positive");
  if (uint64_t(width) * height > (1u << 26)) return Status::error("render: %ux%u pixels is too large", width, height);
  if (width != width_ || height != height_ || !accumulation_.buffer) {
    release_accumulation();
    if (Status s = ctx_.create_buffer(size_t(width) * height * 16, accumulation_); !s)
      return s.context(format("render: the accumulation buffer of a %ux%u image (16 bytes a pixel)", width, height));
    width_ = width;
    height_ = height;
  } else {
    std::memset(accumulation_.mapped, 0, size_t(width) * height * 16);
  }
  accumulated_ = 0;
  stage_times_ = StageTimes();
  stage_timed_samples_ = 0;
  return Status::ok();
}

Status Renderer::prepare_frame(const View& view, uint32_t first_sample, uint32_t samples, uint32_t max_bounces,
                               uint32_t rr_depth, PrimaryVisibility primary) {
  if (!finite(view.camera_to_world) || !(view.yfov > 0.0f && view.yfov < 3.1f) || !std::isfinite(view.env_rotation))
    return Status::error("render: the view has a non-finite transform or rotation or a field of view outside (0, pi)");
  RenderFrame frame = scene_->frame;
  const DeviceScene::Mode& md = scene_->mode();
  frame.instances = md.instances;
  frame.material_maps = md.material_maps;
  frame.world_to_object = md.world_to_object;
  frame.accumulation = accumulation_.address;
  frame.width = width_;
  frame.height = height_;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) frame.cam_to_world[r * 4 + c] = view.camera_to_world[c][r];
  frame.tan_half_fov_y = std::tan(0.5f * view.yfov);
  frame.aspect = float(width_) / float(height_);
  frame.env_rotation = scene_->env_rotation + view.env_rotation;
  frame.max_bounces = max_bounces;
  frame.rr_depth = rr_depth;
  if (primary == PrimaryVisibility::raster) {
    if (!md.raster_why_not.empty())
      return Status::error("render: rasterized primary visibility: %s", md.raster_why_not.c_str());
    if (!visibility_) visibility_ = std::make_unique<VisibilityBuffer>(ctx_);
    VisibilityCamera camera;
    camera.camera_to_world = view.camera_to_world;
    camera.tan_half_fov_y = frame.tan_half_fov_y;
    camera.aspect = frame.aspect;
    // Near plane: far below the scene's size (closer surfaces are clipped, which traced rays see).
    camera.near_plane = 1e-6f * std::max(glm::length(scene_->hi - scene_->lo), 1e-6f);
    const auto t0 = std::chrono::steady_clock::now();
    // The alpha test of cut-out draws reads the scene's tables through the frame.
    std::memcpy(scene_->frame_on_device, &frame, sizeof frame);
    if (Status s = visibility_->rasterize(md.raster_draws, camera, scene_->frame_address, width_, height_, first_sample,
                                          samples);
        !s)
      return s;
    // Its own submission, waited for: its wall time is the stage's time.
    if (stage_timing_)
      stage_times_.raster += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    frame.visibility = visibility_->texels_address();
    frame.visibility_t = visibility_->distances_address();
    frame.primary_raster = 1;
    frame.visibility_first_sample = first_sample;
  }
  std::memcpy(scene_->frame_on_device, &frame, sizeof frame);
  return Status::ok();
}

Status Renderer::accumulate(const View& view, uint32_t first_sample, uint32_t samples, uint32_t max_bounces,
                            uint32_t rr_depth, PathPipeline pipeline, PrimaryVisibility primary) {
  if (!scene_) return Status::error("render: no scene set");
  if (!accumulation_.buffer) return Status::error("render: reset_accumulation before accumulate");
  if (samples == 0) return Status::ok();
  if (Status s = prepare_frame(view, first_sample, samples, max_bounces, rr_depth, primary); !s) return s;
  PathIntegrator& paths = pipeline == PathPipeline::wavefront ? static_cast<PathIntegrator&>(*wavefront_) : *inline_;
  const bool timed = stage_timing_ && pipeline == PathPipeline::wavefront;  // the inline pipeline has no stages
  const PassInputs in{*scene_, width_, height_, timed ? &stage_times_ : nullptr, &stage_timed_samples_};
  if (Status s = paths.trace(in, first_sample, samples, max_bounces, primary == PrimaryVisibility::raster); !s)
    return s;
  accumulated_ += samples;
  return Status::ok();
}

Status Renderer::primary_hits(const View& view, uint32_t sample_index, PrimaryVisibility primary,
                              std::vector<PrimaryHit>& out) {
  out.clear();
  if (!scene_) return Status::error("render: no scene set");
  if (!accumulation_.buffer) return Status::error("render: reset_accumulation before primary_hits");
  if (Status s = prepare_frame(view, sample_index, 1, 0, 0, primary); !s) return s;
  const size_t pixels = size_t(width_) * height_;
  out.resize(pixels);
  if (primary == PrimaryVisibility::raster) {
    const RenderVisibility* v = visibility_->texels();
    const float* t = visibility_->distances();
    for (size_t i = 0; i < pixels; ++i) {
      PrimaryHit& h = out[i];
      h.hit = v[i].instance != RENDER_VISIBILITY_NONE;
      if (!h.hit) continue;
      h.instance = v[i].instance & ((1u << RENDER_VISIBILITY_GEOMETRY_SHIFT) - 1u);
      h.geometry = v[i].instance >> RENDER_VISIBILITY_GEOMETRY_SHIFT;
      h.primitive = v[i].primitive;
      h.u = v[i].barycentric_u;
      h.v = v[i].barycentric_v;
      h.t = t[i];
    }
    return Status::ok();
  }
  // Traced: the wavefront's CAMERA stage and one query of the camera rays (renderer_wavefront.cpp).
  return wavefront_->primary_hits(PassInputs{*scene_, width_, height_, nullptr, nullptr}, sample_index, out);
}

void Renderer::resolve(image::Image& out) const {
  out = image::Image();
  out.width = width_;
  out.height = height_;
  const size_t pixels = size_t(width_) * height_;
  out.rgb.assign(pixels * 3, 0.0f);
  if (!accumulation_.buffer) return;
  const float* acc = static_cast<const float*>(accumulation_.mapped);
  for (size_t i = 0; i < pixels; ++i) {
    const float w = acc[i * 4 + 3];
    for (int k = 0; k < 3; ++k) out.rgb[i * 3 + size_t(k)] = w > 0 ? acc[i * 4 + size_t(k)] / w : 0.0f;
  }
}

Status Renderer::render(const RenderSettings& settings, image::Image& out, RenderStats& stats,
                        const std::function<void(uint32_t)>& progress) {
  stats = scene_stats_;
  out = image::Image();
  if (!scene_) return Status::error("render: no scene set");
  if (settings.width == 0 || settings.height == 0 || settings.spp == 0 || settings.samples_per_pass == 0)
    return Status::error("render: width, height, spp and samples per pass must be positive");
  View view;
  if (Status s = camera_view(settings.camera, view); !s) return s;
  if (Status s = reset_accumulation(settings.width, settings.height); !s) return s;
  set_broad_phase(settings.broad_phase);
  // A first 1-sample pass, discarded, makes the driver compile the pipeline (lavapipe does it on
  // first use), so the timed passes measure tracing only.
  if (settings.warm_up) {
    if (Status s = accumulate(view, settings.first_sample, 1, settings.max_bounces, settings.rr_depth,
                              settings.pipeline, settings.primary);
        !s)
      return s.context("warm-up");
    if (Status s = reset_accumulation(settings.width, settings.height); !s) return s;
  }
  // Stage timing for the timed passes only (the viewer's setting is restored after).
  const bool viewer_timing = stage_timing_;
  stage_timing_ = settings.stage_times && settings.pipeline == PathPipeline::wavefront;
  const auto t0 = std::chrono::steady_clock::now();
  uint32_t done = 0;
  Status s = Status::ok();
  while (s && done < settings.spp) {
    const uint32_t n = std::min(settings.samples_per_pass, settings.spp - done);
    s = accumulate(view, settings.first_sample + done, n, settings.max_bounces, settings.rr_depth, settings.pipeline,
                   settings.primary);
    if (!s) break;
    done += n;
    if (progress) progress(done);
  }
  stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  stats.ms_per_sample = stats.seconds * 1000.0 / settings.spp;
  if (s && stage_timing_) {
    stats.has_stages = true;
    StageTimes& per = stats.stages;
    per = stage_times_;
    for (double StageTimes::*f : {&StageTimes::raster, &StageTimes::camera, &StageTimes::broad, &StageTimes::sort, &StageTimes::encode,
                                  &StageTimes::mlp, &StageTimes::resolve, &StageTimes::shade})
      per.*f /= settings.spp;
  }
  stage_timing_ = viewer_timing;
  if (!s) return s;
  if (settings.pipeline == PathPipeline::wavefront) stats.broad_phase = broad_phase_used();
  resolve(out);
  return Status::ok();
}

}  // namespace lsnif::render