// renderer.h -- the hybrid path tracer on a Vulkan device: a scene's triangle meshes as
// triangle BLASes and its LSNIF objects through the plugin (src/lsnif/lsnif.h), in one TLAS, traced
// by src/lsnif/renderer/shaders/render.rgen. Two modes over the same scene: LSNIF (every node with an LSNIF object
// uses it) and reference (every such node uses its triangle mesh instead); both use the same
// per-pixel random sequences, so their difference is the geometry's, not noise. Two pipelines for
// the same estimator (src/lsnif/renderer/shaders/render_path.glsl): inline (a ray-tracing pipeline; every ray entering
// an LSNIF box runs the network in the intersection shader) and wavefront (compute passes; every
// ray cast goes through the plugin's lsnifCmdQuery in batches, docs/renderer.md).
#pragma once
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "lsnif/scene/environment.h"
#include "lsnif/renderer/render_defaults.h"
#include "lsnif/image/image_io.h"
#include "lsnif/scene/scene.h"
#include "lsnif/format/status.h"
#include "lsnif/renderer/visibility_buffer.h"
#include "lsnif/vulkan/raytracing.h"
#include "lsnif/lsnif.h"

namespace lsnif::render {

// How the paths are traced: the same estimator, the same per-pixel random sequences.
enum class PathPipeline {
  inline_rt,  // render.rgen: one ray-tracing launch per pass, networks in the intersection shader
  wavefront,  // render_wave.comp stages with lsnifCmdQuery between them
};
// "inline" / "wavefront".
const char* pipeline_name(PathPipeline p);
// Parses "inline" / "wavefront"; false on anything else.
bool parse_pipeline(const std::string& name, PathPipeline& out);
// What Context::init needs for a Renderer (either pipeline, either broad phase: the context
// enables ray queries and rayTraversalPrimitiveCulling where offered) on `device`
// (ContextOptions::device).
vk::ContextOptions context_options(bool validation, const std::string& device);

// The broad phase of the wavefront pipeline's lsnifCmdQuery (LsnifQueryBroadPhase of lsnif.h):
// automatic (the plugin chooses: ray queries where the device offers them, else the ray-tracing
// one) or forced (tests, measurements).
enum class BroadPhase { automatic, ray_query, trace_rays };
// "auto" / "ray-query" / "trace-rays".
const char* broad_phase_name(BroadPhase b);
// Parses "auto" / "ray-query" / "trace-rays"; false on anything else.
bool parse_broad_phase(const std::string& name, BroadPhase& out);
// "ray-query" / "trace-rays" for what a query pipeline runs, "none" without one.
const char* broad_phase_name(LsnifQueryBroadPhase b);
// The lsnifCreateQueryPipeline flags of a TLAS query pipeline with broad phase `b`.
LsnifQueryPipelineCreateFlags query_pipeline_flags(BroadPhase b);

// Where the camera rays' hits come from (docs/renderer.md): traced through the TLAS like every
// other ray, or rasterized (the paper's section 4): a graphics pass draws every object's triangles
// -- an LSNIF node's kept mesh (`lsnif convert --keep-meshes`) -- into a visibility buffer per
// sample, the paths start from it, and only secondary and shadow rays meet the networks.
enum class PrimaryVisibility { traced, raster };
// "traced" / "raster".
const char* primary_name(PrimaryVisibility p);
// Parses "traced" / "raster"; false on anything else.
bool parse_primary(const std::string& name, PrimaryVisibility& out);

// One pixel's primary hit (Renderer::primary_hits).
struct PrimaryHit {
  bool hit = false;
  uint32_t instance = 0;   // TLAS record (custom index)
  uint32_t geometry = 0;   // mesh primitive of the record (rasterized LSNIF records; 0 for triangle records)
  uint32_t primitive = 0;  // triangle
  float u = 0, v = 0;      // barycentrics (weights of vertices 1 and 2)
  float t = 0;             // distance along the (unit) camera ray
};

struct RenderSettings {
  uint32_t width = kDefaultImageWidth, height = kDefaultImageHeight;  // render_defaults.h
  uint32_t spp = kDefaultSpp;      // samples per pixel
  uint32_t samples_per_pass = 4;   // per submission (a vkCmdTraceRaysKHR or a wavefront command buffer)
  uint32_t max_bounces = 4;        // path vertices after the camera (the paper's 4)
  uint32_t rr_depth = 4;           // Russian roulette from this bounce on (only with max_bounces > 4)
  bool reference = false;          // triangles instead of LSNIF objects
  PathPipeline pipeline = PathPipeline::inline_rt;
  BroadPhase broad_phase = BroadPhase::automatic;  // wavefront: lsnifCmdQuery's broad phase
  PrimaryVisibility primary = PrimaryVisibility::traced;  // raster: the one-shot render prepares both modes
                                                           // (set_scene both_modes) for the LSNIF nodes' meshes
  bool warm_up = true;              // a discarded first pass (pipeline compile) before the timed ones
  bool stage_times = false;         // wavefront: time its stages with timestamps (RenderStats::stages)
  uint32_t first_sample = 0;       // index of the first sample: per-pixel random sequences start here
                                   // (renders with disjoint ranges have independent noise)
  int32_t camera = 0;              // Scene::cameras index; -1 or none: a camera framing the scene
  // The environment map with its sampling tables (scene/environment.h, e.g. load_environment_map of
  // the scene's environment); null: the scene's constant environment color, no importance sampling.
  const scene::EnvironmentMap* environment = nullptr;
};

// Device time of the wavefront pipeline's stages per sample, in milliseconds (timestamps after each
// stage; RenderSettings::stage_times). The query stages are lsnifCmdQuery's
// (LSNIF_QUERY_TIMESTAMP_COUNT_FOR_RAYS: every chunk of every query), summed over the path and the
// shadow rays of every bounce.
struct StageTimes {
  double raster = 0;   // the visibility pass of --primary raster (its own submission: wall time)
  double camera = 0;   // camera rays (traced primary) or the first vertex's shading (raster)
  double broad = 0;    // broad phase: TLAS traversal, LSNIF candidates collected
  double sort = 0;     // counting sort of the candidates by model
  double encode = 0;   // narrow phase: DDA walk and sparse-grid encoding
  double mlp = 0;      // the batched MLP
  double resolve = 0;  // decoding and the resolve against the triangle hits
  double shade = 0;    // shading, light connections, accumulation
  double total() const { return raster + camera + broad + sort + encode + mlp + resolve + shade; }
};
// "camera 0.13, broad 3.74, ..., shade 3.71 (total 35.34)": the stages in milliseconds.
std::string describe(const StageTimes& t);

// What one render cost and occupies on the device.
struct RenderStats {
  double seconds = 0;               // wall time of all passes (submit to finish)
  double ms_per_sample = 0;         // seconds * 1000 / spp (a sample = one path per pixel)
  uint64_t triangle_blas_bytes = 0; // triangle BLASes in use (accelerationStructureSize)
  uint64_t lsnif_bytes = 0;         // LSNIF model blocks + their AABB BLASes in use
  uint64_t tlas_bytes = 0;
  uint32_t triangle_instances = 0, lsnif_instances = 0, lsnif_models = 0;
  uint64_t triangles = 0;           // triangles of the meshes in use (unique, not per instance)
  bool has_stages = false;          // `stages` measured (wavefront with RenderSettings::stage_times)
  StageTimes stages;                // per sample
  // The broad phase the wavefront pipeline's queries ran with (NONE for the inline pipeline).
  LsnifQueryBroadPhase broad_phase = LSNIF_QUERY_BROAD_PHASE_NONE;
};

// Where the camera is and which way the environment faces, for one pass (a viewer changes it
// between frames; render() takes it from RenderSettings::camera).
struct View {
  glm::mat4 camera_to_world{1.0f};  // looks down -z, y up (glTF convention)
  float yfov = 0.8f;                 // radians, in (0, pi)
  float env_rotation = 0.0f;         // radians about +y added to the environment's own rotation
};

struct DeviceScene;  // device_scene.h: everything set_scene allocated on the device
class InlinePaths;   // path_integrator.h: the two pipelines
class WavefrontPaths;

class Renderer {
 public:
  // `ctx` must be initialized with ray tracing (Context::init(true, ...)) and outlive this.
  explicit Renderer(vk::Context& ctx);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // One-shot: set_scene(scene, settings.reference, settings.environment, both_modes = primary is
  // raster), then render(settings, ...).
  Status render(const scene::Scene& scene, const RenderSettings& settings, image::Image& out, RenderStats& stats,
                const std::function<void(uint32_t)>& progress = {});

  // Uploads `scene` in one mode (`reference`: every LSNIF node as its triangle mesh) with its
  // environment map (null: the scene's constant color; the map must outlive nothing, it is copied
  // to the device) and builds the TLAS, replacing the scene set before. With `both_modes` it also
  // prepares the other mode where the scene has the geometry for it (models, triangle BLASes of
  // the LSNIF nodes' meshes, a second TLAS), so that set_mode switches without uploads or builds.
  // Fails, naming the problem, on an empty scene, a node without the geometry the requested mode
  // needs, a non-finite transform, an unreadable or inconsistent .lsnif file or a device error; on
  // failure no scene is set.
  Status set_scene(const scene::Scene& scene, bool reference, const scene::EnvironmentMap* environment,
                   bool both_modes = false);
  // Makes `reference` (or the LSNIF mode) the mode traced from now on, without uploads or builds;
  // clears the accumulation when the mode changes. Fails, with set_scene's reason, on a mode
  // set_scene did not prepare (no scene, both_modes not given, or e.g. a node without a mesh).
  Status set_mode(bool reference);
  bool reference_mode() const;
  // Work done on the device by set_scene calls so far (set_mode adds none).
  uint32_t models_loaded() const { return models_loaded_; }
  uint32_t blases_built() const { return blases_built_; }
  uint32_t tlases_built() const { return tlases_built_; }
  bool has_scene() const { return scene_ != nullptr; }
  // Memory and instance counts of the scene set (times are 0).
  const RenderStats& scene_stats() const { return scene_stats_; }
  // Moves scene instance `instance` (an index into the Scene::instances given to set_scene) to
  // `object_to_world` by refitting the TLAS (of every prepared mode; no re-upload); the
  // accumulation is not reset. Fails on
  // a bad index, a non-finite or singular transform, no scene set or a device error.
  Status move_instance(size_t instance, const glm::mat4& object_to_world);
  // World bounds of the scene set (its instances' vertices, LSNIF-only nodes: the model box);
  // false without a scene.
  bool world_bounds(glm::vec3& lo, glm::vec3& hi) const;

  // Renders the scene set into `out` (linear RGB, the mean of settings.spp samples; the fields
  // `reference` and `environment` of `settings` are not used: they belong to set_scene).
  // `progress` (may be empty) is called after every pass with the samples done. Fails on bad
  // settings, a bad camera index, no scene set or a device error.
  Status render(const RenderSettings& settings, image::Image& out, RenderStats& stats,
                const std::function<void(uint32_t)>& progress = {});

  // The view of RenderSettings::camera for a width x height image: the scene's camera `camera`,
  // or for -1 / a scene without cameras one that frames the whole scene. Fails on a bad index or
  // a camera with a non-finite transform or a field of view outside (0, pi).
  Status camera_view(int32_t camera, View& out) const;

  // Progressive rendering (the viewer): reset_accumulation clears (and sizes) the accumulation
  // image; accumulate traces `samples` more samples per pixel, numbered from `first_sample`, from
  // `view` and adds them; resolve writes the mean so far (black before any sample).
  Status reset_accumulation(uint32_t width, uint32_t height);
  // With PathPipeline::wavefront it fails when the device can run no broad phase of lsnifCmdQuery
  // (set_broad_phase; the plugin's error names what is missing), or when a query answers a ray INCOMPLETE (more LSNIF boxes on one ray than the candidate capacity).
  // With PrimaryVisibility::raster it fails, naming the node, when an LSNIF node of the mode has no
  // mesh to rasterize (none in the scene, or set_scene without both_modes did not upload it).
  Status accumulate(const View& view, uint32_t first_sample, uint32_t samples, uint32_t max_bounces = 4,
                    uint32_t rr_depth = 4, PathPipeline pipeline = PathPipeline::inline_rt,
                    PrimaryVisibility primary = PrimaryVisibility::traced);
  // The primary hit of every pixel of sample `sample_index` from `view` (row-major, width x height
  // of the accumulation image): rasterized (the visibility buffer the render uses), or traced (the
  // camera rays cast through lsnifCmdQuery). For tests comparing
  // the two. Same errors as accumulate.
  Status primary_hits(const View& view, uint32_t sample_index, PrimaryVisibility primary,
                      std::vector<PrimaryHit>& out);
  void resolve(image::Image& out) const;
  uint32_t accumulated_samples() const { return accumulated_; }
  // With `on`, wavefront passes write timestamps after every stage and stage_times() sums them
  // (from the next reset_accumulation on); off by default (the timestamps cost a little).
  void set_stage_timing(bool on) { stage_timing_ = on; }
  // The broad phase of the wavefront pipeline's queries from the next accumulate on (its query
  // pipeline is made again when this changes it).
  void set_broad_phase(BroadPhase b);
  // The broad phase the wavefront pipeline's query pipeline runs (LSNIF_QUERY_BROAD_PHASE_NONE
  // before the first wavefront pass on the scene).
  LsnifQueryBroadPhase broad_phase_used() const;
  // The stage times of the wavefront passes accumulated since reset_accumulation, in total (not per
  // sample), over stage_timed_samples() samples.
  const StageTimes& stage_times() const { return stage_times_; }
  uint32_t stage_timed_samples() const { return stage_timed_samples_; }

 private:
  void release_accumulation();
  // Writes the frame of `view` (and, for raster, the visibility buffer of the samples) to the device.
  Status prepare_frame(const View& view, uint32_t first_sample, uint32_t samples, uint32_t max_bounces,
                       uint32_t rr_depth, PrimaryVisibility primary);
  vk::Context& ctx_;
  vk::RayTracer tracer_;
  std::unique_ptr<InlinePaths> inline_;        // PathPipeline::inline_rt (path_integrator.h)
  std::unique_ptr<WavefrontPaths> wavefront_;  // PathPipeline::wavefront
  std::unique_ptr<DeviceScene> scene_;
  RenderStats scene_stats_;
  vk::Buffer accumulation_{};
  std::unique_ptr<VisibilityBuffer> visibility_;  // rasterized primary visibility, made on first use
  bool stage_timing_ = false;
  StageTimes stage_times_;
  uint32_t stage_timed_samples_ = 0;
  uint32_t width_ = 0, height_ = 0, accumulated_ = 0;
  uint32_t models_loaded_ = 0, blases_built_ = 0, tlases_built_ = 0;
};

}  // namespace lsnif::render
