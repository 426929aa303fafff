// renderer.cpp -- the path tracer of renderer.h: uploads the scene (per mesh primitive a triangle
// BLAS plus its vertex data, per LSNIF object a plugin model), builds the TLAS (one record per
// primitive of a triangle instance, one per LSNIF instance; custom index = RenderInstance index),
// and traces passes of src/lsnif/renderer/shaders/render.rgen into an accumulation buffer, or (wavefront) records the
// stages of src/lsnif/renderer/shaders/render_wave.comp with lsnifCmdQuery between them.
#include "lsnif/renderer/renderer.h"

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>

#include "lsnif/format/instance_transform.h"
#include <volk.h>  // before lsnif.h, which then uses volk's Vulkan declarations

#include "lsnif/lsnif.hpp"
#include "lsnif/harness/plugin_device.h"
#include "lsnif/renderer/shaders/render_host_device.h"
#include "lsnif/harness/triangle_order.h"

namespace lsnif::render {

namespace {
// The path tracer's shaders, compiled at build time (cmake/LsnifShaders.cmake).
#include "render_lsnif_rchit_spirv.h"
#include "render_rgen_spirv.h"
#include "render_rmiss_spirv.h"
#include "render_triangle_rchit_spirv.h"
#include "render_wave_comp_spirv.h"

static_assert(offsetof(RenderPush, model_table) == LSNIF_RT_PUSH_MODEL_TABLE_OFFSET, "binding convention");
static_assert(offsetof(RenderPush, model_count) == LSNIF_RT_PUSH_MODEL_COUNT_OFFSET, "binding convention");
static_assert(offsetof(RenderPush, frame) >= LSNIF_RT_PUSH_APP_OFFSET, "binding convention");

vk::Spirv spirv(const uint32_t* code, size_t bytes) {
  vk::Spirv s;
  s.code = code;
  s.bytes = bytes;
  return s;
}
}  // namespace

// Everything set_scene allocates on the device, and what a pass needs of the scene; released by
// the destructor.
struct DeviceScene {
  vk::ComputeContext& ctx;
  vk::RayTracer& tracer;
  plugin::Context plugin;
  std::vector<plugin::Model> models;     // per LSNIF object of the scene: its device model (or empty)
  std::vector<vk::Buffer> buffers;
  std::vector<vk::AccelerationStructure> blases;
  // What one mode (LSNIF: 0, reference: 1) traces: its TLAS over the shared BLASes and models, and
  // the tables its shaders read. set_mode switches between prepared modes without uploads.
  struct Mode {
    bool ready = false;
    std::string why_not;                  // set_scene's error for a mode it could not prepare
    vk::AccelerationStructure tlas;
    std::vector<VkAccelerationStructureInstanceKHR> records;  // TLAS records; record i has custom index i
    std::vector<int64_t> record_model;     // per record: index into `models` (LSNIF) or -1 (triangles)
    std::vector<std::pair<size_t, size_t>> instance_records;  // per scene instance: first record, count
    uint64_t instances = 0, material_maps = 0;  // RenderFrame::instances, material_maps of the mode
    uint64_t table_address = 0;
    uint32_t table_count = 0;              // entries of the model table
    std::vector<LsnifModel> table_models;  // per table entry: its model, null for triangle instances
    uint64_t world_to_object = 0;          // RenderFrame::world_to_object of the mode (per custom index)
    glm::mat3* world_to_object_mapped = nullptr;
    RenderStats stats;                     // what the mode uses (times 0)
    // Rasterized primary visibility: every record's triangle lists (an LSNIF record: its node's
    // mesh), or why the mode cannot be rasterized (an LSNIF node without a mesh).
    std::vector<VisibilityDraw> raster_draws;
    std::string raster_why_not;
  };
  Mode modes[2];
  int active = 0;
  RenderFrame frame{};                    // the scene's part filled in; view and image set per pass
  RenderFrame* frame_on_device = nullptr;  // mapped RenderFrame buffer
  uint64_t frame_address = 0;
  LsnifQueryPipeline query = nullptr;      // the wavefront pipeline's lsnifCmdQuery, made on first use
  glm::vec3 lo{0.0f}, hi{0.0f};           // world bounds (for a framing camera)
  std::vector<scene::Camera> cameras;
  float env_rotation = 0.0f;
  Mode& mode() { return modes[active]; }
  DeviceScene(vk::ComputeContext& c, vk::RayTracer& t) : ctx(c), tracer(t) {}
  ~DeviceScene() {
    if (query) lsnifDestroyQueryPipeline(plugin.get(), query);
    for (Mode& m : modes) tracer.destroy(m.tlas);
    for (vk::AccelerationStructure& b : blases) tracer.destroy(b);
    for (vk::Buffer& b : buffers) ctx.destroy_buffer(b);
    models.clear();  // before their context
    plugin.reset();
  }
  // A host-visible buffer holding `bytes` of `data` (zeroed when data is null); its device address.
  Status upload(const void* data, size_t bytes, uint64_t& address, VkBufferUsageFlags extra = 0) {
    vk::Buffer b;
    if (Status s = ctx.create_buffer(bytes, b, extra); !s) return s;
    if (data && bytes) std::memcpy(b.mapped, data, bytes);
    address = b.address;
    buffers.push_back(b);
    return Status::ok();
  }
  template <class T>
  Status upload(const std::vector<T>& v, uint64_t& address) {
    return upload(v.empty() ? nullptr : v.data(), v.size() * sizeof(T), address);
  }
};

namespace {

bool finite(const glm::mat4& m) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(m[c][r])) return false;
  return true;
}

// Row-major 3x4 of an affine glm matrix.
VkTransformMatrixKHR to_3x4(const glm::mat4& m) {
  VkTransformMatrixKHR xf;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) xf.matrix[r][c] = m[c][r];
  return xf;
}

// The plugin's last error as a Status (after a failed call of the C API).
Status plugin_error(const char* what) { return Status::error("%s: %s", what, lsnifGetLastErrorMessage()); }

// World bounds of the scene's instances (their meshes' vertices; LSNIF-only nodes: the model box).
// `slot` maps an LSNIF object to the object whose model was loaded for it.
void scene_bounds(const scene::Scene& s, const std::vector<plugin::Model>& models, const std::vector<size_t>& slot,
                  glm::vec3& lo, glm::vec3& hi) {
  lo = glm::vec3(std::numeric_limits<float>::infinity());
  hi = -lo;
  for (const scene::Instance& in : s.instances) {
    auto add = [&](glm::vec3 p) {
      const glm::vec3 w = glm::vec3(in.object_to_world * glm::vec4(p, 1.0f));
      lo = glm::min(lo, w);
      hi = glm::max(hi, w);
    };
    if (in.mesh >= 0) {
      for (const scene::Primitive& p : s.meshes[size_t(in.mesh)].primitives)
        for (const glm::vec3& v : p.positions) add(v);
    } else if (in.lsnif >= 0) {
      const LsnifModelProperties p = models[slot[size_t(in.lsnif)]].properties();
      for (int k = 0; k < 8; ++k)
        add(glm::vec3(k & 1 ? p.boundsMax[0] : p.boundsMin[0], k & 2 ? p.boundsMax[1] : p.boundsMin[1],
                      k & 4 ? p.boundsMax[2] : p.boundsMin[2]));
    }
  }
}

}  // namespace

Renderer::Renderer(vk::ComputeContext& ctx) : ctx_(ctx), tracer_(ctx) {}

Renderer::~Renderer() {
  scene_.reset();
  visibility_.reset();
  release_accumulation();
  if (pipeline_ready_) tracer_.destroy(pipeline_);
  ctx_.destroy_pipeline(wave_pipeline_);
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

vk::ContextOptions context_options(PathPipeline pipeline, bool validation, const std::string& device) {
  vk::ContextOptions options;
  options.ray_tracing = true;
  options.ray_query = pipeline == PathPipeline::wavefront;
  options.validation = validation;
  options.device = device;
  return options;
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

Status Renderer::create_pipeline() {
  if (pipeline_ready_) return Status::ok();
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
  if (lsnifGetIntersectionShaderSpirv(LSNIF_MODEL_LOOKUP_INSTANCE_TABLE, &shaders.intersection.code,
                                      &shaders.intersection.bytes) != LSNIF_SUCCESS)
    return plugin_error("render pipeline");
  Status s = tracer_.create_pipeline(shaders, sizeof(RenderPush), pipeline_);
  if (!s) return s.context("render pipeline");
  pipeline_ready_ = true;
  return Status::ok();
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
  if (Status s = create_pipeline(); !s) return s;

  // The modes to prepare: `reference`, and with both_modes the other one where the scene has its
  // geometry (its error is kept for set_mode). LSNIF models the LSNIF mode uses.
  const size_t object_count = scene.lsnif_objects.size();
  std::vector<bool> model_used(object_count, false);
  auto check_mode = [&](bool ref, bool mark) -> Status {
    for (const scene::Instance& in : scene.instances) {
      if (!finite(in.object_to_world)) return Status::error("node '%s' has a non-finite transform", in.node_name.c_str());
      const bool use_lsnif = in.lsnif >= 0 && !ref;
      if (in.lsnif >= 0 && size_t(in.lsnif) >= object_count)
        return Status::error("node '%s' names LSNIF object %d of %zu", in.node_name.c_str(), in.lsnif, object_count);
      if (in.mesh >= 0 && size_t(in.mesh) >= scene.meshes.size())
        return Status::error("node '%s' names mesh %d of %zu", in.node_name.c_str(), in.mesh, scene.meshes.size());
      if (!use_lsnif && in.mesh < 0)
        return Status::error("node '%s' has no triangle mesh%s", in.node_name.c_str(),
                             ref ? " for the reference mode" : "");
      if (use_lsnif && mark) model_used[size_t(in.lsnif)] = true;
    }
    return Status::ok();
  };
  if (Status s = check_mode(reference, true); !s) return s;
  bool prepare[2] = {!reference, reference};  // [0]: LSNIF mode, [1]: reference mode
  Status other = Status::ok();
  if (both_modes) {
    other = check_mode(!reference, true);
    prepare[reference ? 0 : 1] = bool(other);
  }
  // Objects naming the same file (e.g. with different material maps) share one model on the device:
  // slot[i] is the first such object, the one that is loaded and uploaded.
  // A loaded scene's relative model path resolves against the scene file's folder (resolved_path).
  auto file_of = [&](size_t i) -> const std::string& {
    const scene::LsnifObject& obj = scene.lsnif_objects[i];
    return obj.resolved_path.empty() ? obj.model_path : obj.resolved_path;
  };
  std::vector<size_t> slot(object_count);
  for (size_t i = 0; i < object_count; ++i) {
    slot[i] = i;
    for (size_t j = 0; j < i; ++j)
      if (model_used[j] && file_of(j) == file_of(i)) {
        slot[i] = j;
        break;
      }
  }
  for (size_t i = 0; i < object_count; ++i) {
    if (!model_used[i]) continue;
    if (scene.lsnif_objects[i].material_map.empty())
      return Status::error("LSNIF object %s has an empty material map", scene.lsnif_objects[i].model_path.c_str());
    for (uint32_t m : scene.lsnif_objects[i].material_map)
      if (m >= scene.materials.size())
        return Status::error("LSNIF object %s maps to material %u of %zu", scene.lsnif_objects[i].model_path.c_str(), m,
                             scene.materials.size());
  }

  auto dev_owner = std::make_unique<DeviceScene>(ctx_, tracer_);
  DeviceScene& dev = *dev_owner;
  if (dev.plugin.create(vk::plugin_create_info(ctx_)) != LSNIF_SUCCESS) return plugin_error("render");
  dev.models.resize(object_count);
  std::vector<LsnifModel> to_build;
  for (size_t i = 0; i < object_count; ++i) {
    if (!model_used[i] || slot[i] != i) continue;
    if (dev.models[i].create_from_file(dev.plugin.get(), file_of(i).c_str()) != LSNIF_SUCCESS)
      return plugin_error(scene.lsnif_objects[i].model_path.c_str());
    to_build.push_back(dev.models[i].get());
  }
  if (lsnifBuildModels(dev.plugin.get(), uint32_t(to_build.size()), to_build.data()) != LSNIF_SUCCESS)
    return plugin_error("render");
  models_loaded_ += uint32_t(to_build.size());
  uint64_t lsnif_bytes = 0;
  for (LsnifModel m : to_build) {
    LsnifModelMemory mem{};
    if (lsnifGetModelMemory(dev.plugin.get(), m, &mem) != LSNIF_SUCCESS) return plugin_error("render");
    lsnif_bytes += mem.blockBytes + mem.blasBytes;
  }

  // Materials, textures, material maps.
  std::vector<RenderMaterial> materials;
  for (const scene::Material& m : scene.materials) {
    auto tex = [&](int32_t t) -> uint32_t {
      return t >= 0 && size_t(t) < scene.textures.size() ? uint32_t(t) : RENDER_NO_TEXTURE;
    };
    materials.push_back({m.base_color.r, m.base_color.g, m.base_color.b, m.base_color.a, m.metallic, m.roughness,
                         m.emission.r, m.emission.g, m.emission.b, tex(m.base_color_texture),
                         tex(m.metallic_roughness_texture), tex(m.emission_texture)});
  }
  if (materials.empty()) materials.push_back({0.8f, 0.8f, 0.8f, 1, 0, 1, 0, 0, 0, RENDER_NO_TEXTURE, RENDER_NO_TEXTURE, RENDER_NO_TEXTURE});
  std::vector<RenderTexture> textures;
  for (const scene::Texture& t : scene.textures) {
    if (t.rgba.size() != size_t(t.width) * t.height * 4 || t.width == 0)
      return Status::error("texture '%s' has %zu bytes for %ux%u texels", t.name.c_str(), t.rgba.size(), t.width, t.height);
    RenderTexture rt{};
    if (Status s = dev.upload(t.rgba.data(), t.rgba.size(), rt.texels); !s) return s;
    rt.width = t.width;
    rt.height = t.height;
    textures.push_back(rt);
  }

  // Triangle primitives: vertex data for the closest-hit shader and one BLAS each (per mesh in use).
  std::vector<RenderPrimitive> primitives;
  std::vector<uint32_t> primitive_triangles;  // per primitives entry
  std::vector<std::vector<uint32_t>> mesh_primitives(scene.meshes.size());  // -> primitives / blases index
  std::vector<bool> mesh_used(scene.meshes.size(), false);
  std::vector<uint64_t> mesh_blas_bytes(scene.meshes.size(), 0), mesh_triangles(scene.meshes.size(), 0);
  for (const scene::Instance& in : scene.instances)
    for (int mode = 0; mode < 2; ++mode)
      if (prepare[mode] && !(in.lsnif >= 0 && mode == 0)) mesh_used[size_t(in.mesh)] = true;
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    if (!mesh_used[m]) continue;
    for (const scene::Primitive& p : scene.meshes[m].primitives) {
      if (p.indices.empty()) continue;
      if (p.material >= materials.size())
        return Status::error("mesh '%s' uses material %u of %zu", scene.meshes[m].name.c_str(), p.material, materials.size());
      RenderPrimitive rp{};
      rp.material = p.material;
      // BLAS input in Morton order (triangle_order.h); the closest-hit shader reads the same indices.
      std::vector<uint32_t> indices;
      indices.reserve(p.indices.size());
      for (uint32_t t : vk::morton_triangle_order(p.positions, p.indices))
        indices.insert(indices.end(), {p.indices[3 * t], p.indices[3 * t + 1], p.indices[3 * t + 2]});
      if (Status s = dev.upload(p.positions, rp.positions); !s) return s;
      if (Status s = dev.upload(indices, rp.indices); !s) return s;
      if (p.normals.size() == p.positions.size()) {
        if (Status s = dev.upload(p.normals, rp.normals); !s) return s;
      }
      if (p.uvs.size() == p.positions.size()) {
        if (Status s = dev.upload(p.uvs, rp.uvs); !s) return s;
      }
      std::vector<float> flat(p.positions.size() * 3);
      std::memcpy(flat.data(), p.positions.data(), flat.size() * sizeof(float));
      vk::AccelerationStructure blas;
      if (Status s = tracer_.build_triangle_blas(flat, indices, blas); !s)
        return s.context(("mesh '" + scene.meshes[m].name + "'").c_str());
      ++blases_built_;
      mesh_blas_bytes[m] += blas.storage.size;
      mesh_triangles[m] += p.indices.size() / 3;
      dev.blases.push_back(blas);
      mesh_primitives[m].push_back(uint32_t(primitives.size()));
      primitives.push_back(rp);
      primitive_triangles.push_back(uint32_t(p.indices.size() / 3));
    }
  }

  // Per prepared mode: instances (custom index i -> RenderInstance i and model table entry i),
  // material maps, model table and TLAS.
  for (int mode = 0; mode < 2; ++mode) {
    DeviceScene::Mode& md = dev.modes[mode];
    if (!prepare[mode]) {
      md.why_not = other.message();
      continue;
    }
    const bool ref = mode == 1;
    RenderStats& stats = md.stats;
    std::vector<bool> mesh_counted(scene.meshes.size(), false);
    std::vector<RenderInstance> instances;
    std::vector<uint64_t> model_table;
    std::vector<uint32_t> material_maps;
    std::vector<VkAccelerationStructureInstanceKHR> records;
    std::vector<glm::mat3> world_to_object;  // per record (custom index)
    for (const scene::Instance& in : scene.instances) {
      md.instance_records.emplace_back(records.size(), 0);
      if (in.lsnif >= 0 && !ref) {
        const scene::LsnifObject& obj = scene.lsnif_objects[size_t(in.lsnif)];
        RenderInstance ri{RENDER_INSTANCE_LSNIF, RENDER_NO_MESH, uint32_t(material_maps.size()),
                          uint32_t(obj.material_map.size())};
        // Its kept mesh, for rasterized primary visibility: one draw per mesh primitive.
        const std::vector<uint32_t>* mesh = in.mesh >= 0 ? &mesh_primitives[size_t(in.mesh)] : nullptr;
        if (md.raster_why_not.empty()) {
          if (!mesh)
            md.raster_why_not = "LSNIF node '" + in.node_name +
                                "' has no triangle mesh to rasterize (keep it with lsnif convert --keep-meshes)";
          else if (mesh->empty())
            md.raster_why_not = "the mesh of LSNIF node '" + in.node_name +
                                "' was not uploaded (set_scene without both_modes)";
          else if (mesh->size() > 255)
            md.raster_why_not = "the mesh of LSNIF node '" + in.node_name + "' has more than 255 primitives";
        }
        if (mesh && !mesh->empty() && mesh->size() <= 255) {
          ri.first_primitive = mesh->front();
          for (size_t k = 0; k < mesh->size(); ++k) {
            const RenderPrimitive& rp = primitives[(*mesh)[k]];
            md.raster_draws.push_back({uint32_t(instances.size()) | uint32_t(k << RENDER_VISIBILITY_GEOMETRY_SHIFT),
                                       rp.positions, rp.indices, primitive_triangles[(*mesh)[k]], in.object_to_world});
          }
        }
        material_maps.insert(material_maps.end(), obj.material_map.begin(), obj.material_map.end());
        const plugin::Model& model = dev.models[slot[size_t(in.lsnif)]];
        LsnifInstanceInfo info{};
        info.model = model.get();
        info.transform = to_3x4(in.object_to_world);
        info.instanceCustomIndex = uint32_t(instances.size());
        info.mask = 0xFF;
        VkAccelerationStructureInstanceKHR rec;
        if (lsnifMakeInstance(dev.plugin.get(), &info, &rec) != LSNIF_SUCCESS)
          return plugin_error(("node '" + in.node_name + "'").c_str());
        model_table.push_back(model.properties().blockAddress);
        md.table_models.push_back(model.get());
        world_to_object.push_back(glm::inverse(glm::mat3(in.object_to_world)));
        instances.push_back(ri);
        records.push_back(rec);
        md.record_model.push_back(int64_t(slot[size_t(in.lsnif)]));
        md.instance_records.back().second = 1;
        ++stats.lsnif_instances;
        continue;
      }
      const VkTransformMatrixKHR xf = to_3x4(in.object_to_world);
      if (Status s = check_instance_transform(xf.matrix); !s) return s.context(("node '" + in.node_name + "'").c_str());
      if (!mesh_counted[size_t(in.mesh)]) {
        mesh_counted[size_t(in.mesh)] = true;
        stats.triangle_blas_bytes += mesh_blas_bytes[size_t(in.mesh)];
        stats.triangles += mesh_triangles[size_t(in.mesh)];
      }
      for (uint32_t prim : mesh_primitives[size_t(in.mesh)]) {
        VkAccelerationStructureInstanceKHR rec{};
        rec.transform = xf;
        rec.instanceCustomIndex = uint32_t(instances.size()) & 0xffffffu;
        rec.mask = 0xFF;
        rec.instanceShaderBindingTableRecordOffset = pipeline_.triangle_sbt_offset & 0xffffffu;  // triangle hit group
        rec.accelerationStructureReference = dev.blases[prim].address;
        md.raster_draws.push_back({uint32_t(instances.size()), primitives[prim].positions, primitives[prim].indices,
                                   primitive_triangles[prim], in.object_to_world});
        instances.push_back({RENDER_INSTANCE_TRIANGLES, prim, 0, 0});
        model_table.push_back(0);
        md.table_models.push_back(nullptr);
        world_to_object.push_back(glm::inverse(glm::mat3(in.object_to_world)));
        records.push_back(rec);
        md.record_model.push_back(-1);
        ++md.instance_records.back().second;
        ++stats.triangle_instances;
      }
    }
    if (instances.size() >= (1u << 24)) return Status::error("render: %zu TLAS instances exceed 2^24", instances.size());
    if (!ref) {
      stats.lsnif_bytes = lsnif_bytes;
      stats.lsnif_models = uint32_t(to_build.size());
    }
    // Built for updates: move_instance refits it.
    if (Status s = tracer_.build_tlas(records, md.tlas, /*allow_update=*/true); !s) return s;
    ++tlases_built_;
    md.records = std::move(records);
    stats.tlas_bytes = md.tlas.storage.size;
    if (Status s = dev.upload(instances, md.instances); !s) return s;
    if (Status s = dev.upload(material_maps.empty() ? std::vector<uint32_t>(1) : material_maps, md.material_maps); !s)
      return s;
    if (Status s = dev.upload(model_table, md.table_address); !s) return s;
    md.table_count = uint32_t(model_table.size());
    static_assert(sizeof(glm::mat3) == 36, "RenderFrame::world_to_object is float3x3 per instance");
    if (Status s = dev.upload(world_to_object, md.world_to_object); !s) return s;
    md.world_to_object_mapped = static_cast<glm::mat3*>(dev.buffers.back().mapped);
    md.ready = true;
  }
  dev.active = reference ? 1 : 0;

  // What camera_view needs.
  scene_bounds(scene, dev.models, slot, dev.lo, dev.hi);
  dev.cameras = scene.cameras;

  // Frame data.
  RenderFrame& frame = dev.frame;
  if (Status s = dev.upload(primitives.empty() ? std::vector<RenderPrimitive>(1) : primitives, frame.primitives); !s) return s;
  if (Status s = dev.upload(materials, frame.materials); !s) return s;
  if (Status s = dev.upload(textures.empty() ? std::vector<RenderTexture>(1) : textures, frame.textures); !s) return s;
  const scene::Environment& env = scene.environment;
  frame.env_r = env.color.r;
  frame.env_g = env.color.g;
  frame.env_b = env.color.b;
  frame.env_rotation = env.rotation;
  if (environment && environment->width > 0) {
    const scene::EnvironmentMap& e = *environment;
    if (e.radiance.size() != size_t(e.width) * e.height * 3 || e.pdf_table.size() != size_t(e.width) * e.height)
      return Status::error("render: the environment map's tables do not match its %ux%u size", e.width, e.height);
    if (Status s = dev.upload(e.radiance, frame.environment); !s) return s;
    if (Status s = dev.upload(e.packed(), frame.env_tables); !s) return s;
    frame.env_width = e.width;
    frame.env_height = e.height;
    frame.env_rotation = e.rotation;
    frame.env_importance = e.integral > 0 ? 1u : 0u;
  }
  if (scene.sun.enabled) {
    const scene::Sun& sun = scene.sun;
    const float len = glm::length(sun.direction);
    if (!(len > 0.0f) || !std::isfinite(len) || !(sun.angular_diameter > 0.0f && sun.angular_diameter < 1.6f) ||
        !std::isfinite(sun.irradiance.x + sun.irradiance.y + sun.irradiance.z) ||
        glm::any(glm::lessThan(sun.irradiance, glm::vec3(0.0f))))
      return Status::error("render: the sun needs a non-zero direction, an angular diameter in (0, 90) degrees and a "
                           "finite irradiance >= 0");
    const glm::vec3 d = sun.direction / len;
    // The solid angle from the float cosine the shader tests and samples with, so that sampling the
    // disk delivers exactly `irradiance` to a surface facing it.
    const float cos_max = float(std::cos(0.5 * double(sun.angular_diameter)));
    const double solid_angle = 2.0 * 3.14159265358979323846 * (1.0 - double(cos_max));
    frame.sun_enabled = 1;
    frame.sun_x = d.x;
    frame.sun_y = d.y;
    frame.sun_z = d.z;
    frame.sun_cos_max = cos_max;
    frame.sun_r = float(double(sun.irradiance.x) / solid_angle);
    frame.sun_g = float(double(sun.irradiance.y) / solid_angle);
    frame.sun_b = float(double(sun.irradiance.z) / solid_angle);
  }
  dev.env_rotation = frame.env_rotation;
  if (Status s = dev.upload(&frame, sizeof frame, dev.frame_address); !s) return s;
  dev.frame_on_device = static_cast<RenderFrame*>(dev.buffers.back().mapped);
  scene_ = std::move(dev_owner);
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
  release_wavefront();
}

void Renderer::release_wavefront() {
  for (vk::Buffer& b : wave_buffers_) ctx_.destroy_buffer(b);
  wave_buffers_.clear();
  ctx_.destroy_buffer(wave_scratch_);
  ctx_.destroy_buffer(wave_status_);
  ctx_.destroy_timestamps(wave_timestamps_);
  wave_address_ = 0;
}

namespace {

// The queries of the wavefront pipeline over the scene's TLAS (rays, results, status and the
// scratch fields are set per query). Candidates: one per LSNIF instance a ray can cross, so that
// no ray runs out of capacity up to LSNIF_QUERY_MAX_CANDIDATES_PER_RAY instances.
LsnifQueryInfo wave_query_info(const DeviceScene::Mode& md, uint32_t lsnif_instances) {
  LsnifQueryInfo q{};
  q.candidatesPerRay = std::clamp(lsnif_instances, 1u, LSNIF_QUERY_MAX_CANDIDATES_PER_RAY);
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

Status Renderer::prepare_wavefront(uint32_t samples, uint32_t max_bounces) {
  DeviceScene& dev = *scene_;
  if (!wave_pipeline_.pipeline) {
    Status s = ctx_.create_pipeline(spirv(render_wave_comp_spirv, sizeof render_wave_comp_spirv), sizeof(RenderPush),
                                    wave_pipeline_);
    if (!s) return s.context("wavefront pipeline");
  }
  if (!dev.query) {
    LsnifQueryPipelineFlagsCreateInfo flags{};
    flags.sType = LSNIF_STRUCTURE_TYPE_QUERY_PIPELINE_FLAGS_CREATE_INFO;
    flags.flags = LSNIF_QUERY_PIPELINE_CREATE_TLAS_BIT;
    LsnifQueryPipelineCreateInfo info{};
    info.pNext = &flags;
    if (lsnifCreateQueryPipeline(dev.plugin.get(), &info, &dev.query) != LSNIF_SUCCESS)
      return plugin_error("wavefront pipeline");
  }
  const size_t pixels = size_t(width_) * height_;
  if (wave_buffers_.empty()) {
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
      if (Status s = ctx_.create_buffer(bytes, b); !s) return s;
      wave_buffers_.push_back(b);
      *address = b.address;
    }
    vk::Buffer b;
    if (Status s = ctx_.create_buffer(sizeof w, b); !s) return s;
    std::memcpy(b.mapped, &w, sizeof w);
    wave_buffers_.push_back(b);
    wave_address_ = b.address;
  }
  // The scratch of the larger batch (the shadow rays), for this scene's models and capacity.
  LsnifQueryInfo q = wave_query_info(dev.mode(), scene_stats_.lsnif_instances);
  q.rayCount = uint32_t(RENDER_WAVE_SHADOWS * pixels);
  VkDeviceSize bytes = 0;
  if (lsnifGetQueryScratchSize(dev.plugin.get(), &q, &bytes) != LSNIF_SUCCESS) return plugin_error("wavefront scratch");
  if (wave_scratch_.size < bytes) {
    ctx_.destroy_buffer(wave_scratch_);
    if (Status s = ctx_.create_buffer(size_t(bytes), wave_scratch_, VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT); !s) return s;
  }
  const size_t status_bytes = size_t(samples) * (2 * max_bounces + 1) * sizeof(LsnifQueryStatus);
  if (wave_status_.size < status_bytes) {
    ctx_.destroy_buffer(wave_status_);
    if (Status s = ctx_.create_buffer(status_bytes, wave_status_); !s) return s;
  }
  std::memset(wave_status_.mapped, 0, status_bytes);
  return Status::ok();
}

Status Renderer::accumulate_wavefront(uint32_t first_sample, uint32_t samples, uint32_t max_bounces, bool raster) {
  if (Status s = prepare_wavefront(samples, max_bounces); !s) return s;
  DeviceScene& dev = *scene_;
  const uint32_t pixels = width_ * height_, groups = (pixels + 63) / 64;
  RenderWave w;
  std::memcpy(&w, wave_buffers_.back().mapped, sizeof w);
  LsnifQueryInfo q = wave_query_info(dev.mode(), scene_stats_.lsnif_instances);
  q.scratchBuffer = wave_scratch_.buffer;
  q.scratchSize = wave_scratch_.size;
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
  const uint32_t stamp_count = stage_timing_ ? 1 + samples * stamps_per_sample : 0;
  if (stamp_count > wave_timestamps_.count) {
    ctx_.destroy_timestamps(wave_timestamps_);
    if (Status s = ctx_.create_timestamps(stamp_count, wave_timestamps_); !s) return s.context("stage timing");
  }
  LsnifQueryTimestampsInfo query_stamps{};
  query_stamps.sType = LSNIF_STRUCTURE_TYPE_QUERY_TIMESTAMPS_INFO;
  query_stamps.timestampPool = wave_timestamps_.pool;
  Status st = ctx_.submit("wavefront pass", [&](VkCommandBuffer cmd) {
    auto stamp = [&](double StageTimes::*what) {
      if (!stage_timing_) return;
      vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, wave_timestamps_.pool, uint32_t(interval.size()));
      interval.push_back(what);
    };
    auto stage = [&](uint32_t which, uint32_t bounce, double StageTimes::*what) {
      push.stage = which;
      push.bounce = bounce;
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, wave_pipeline_.pipeline);  // a query binds its own
      vkCmdPushConstants(cmd, wave_pipeline_.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof push, &push);
      vkCmdDispatch(cmd, groups, 1, 1);
      wave_barrier(cmd);
      stamp(what);
    };
    auto query = [&](uint64_t rays, uint64_t results, uint32_t count) {
      q.rayCount = count;
      q.rays = rays;
      q.results = results;
      q.status = wave_status_.address + queries++ * sizeof(LsnifQueryStatus);
      q.pNext = nullptr;
      if (stage_timing_) {
        // The query's timestamps: [0] follows the previous stamp (no work between), then five per
        // chunk of rays.
        query_stamps.firstQuery = uint32_t(interval.size());
        q.pNext = &query_stamps;
        interval.push_back(&StageTimes::shade);
        for (uint32_t c = 0; c < LSNIF_QUERY_CHUNK_COUNT(count); ++c)
          for (double StageTimes::*what :
               {&StageTimes::broad, &StageTimes::sort, &StageTimes::encode, &StageTimes::mlp, &StageTimes::resolve})
            interval.push_back(what);
      }
      if (recorded == LSNIF_SUCCESS) recorded = lsnifCmdQuery(dev.plugin.get(), cmd, dev.query, &q);
      wave_barrier(cmd);
    };
    if (stage_timing_) vkCmdResetQueryPool(cmd, wave_timestamps_.pool, 0, stamp_count);
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
    vk::ComputeContext::barrier_compute_to_host(cmd);
  });
  if (recorded != LSNIF_SUCCESS) return plugin_error("wavefront pass");
  if (!st) return st.context("wavefront pass");
  if (stage_timing_) {
    std::vector<double> ms;
    if (Status s = ctx_.read_timestamps_ms(wave_timestamps_, 0, uint32_t(interval.size()), ms); !s)
      return s.context("stage timing");
    for (size_t k = 1; k < ms.size(); ++k) stage_times_.*interval[k] += ms[k] - ms[k - 1];
    stage_timed_samples_ += samples;
  }
  // INCOMPLETE answers are not misses: a render with any fails.
  const auto* status = static_cast<const LsnifQueryStatus*>(wave_status_.mapped);
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

Status Renderer::reset_accumulation(uint32_t width, uint32_t height) {
  if (width == 0 || height == 0) return Status::error("render: width and height must be positive");
  if (uint64_t(width) * height > (1u << 26)) return Status::error("render: %ux%u pixels is too large", width, height);
  if (width != width_ || height != height_ || !accumulation_.buffer) {
    release_accumulation();
    if (Status s = ctx_.create_buffer(size_t(width) * height * 16, accumulation_); !s) return s;
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
    if (Status s = visibility_->rasterize(md.raster_draws, camera, width_, height_, first_sample, samples); !s)
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
  const DeviceScene::Mode& md = scene_->mode();
  RenderPush push{};
  push.model_table = md.table_address;
  push.model_count = md.table_count;
  push.frame = scene_->frame_address;
  push.sample_index = first_sample;
  push.samples = samples;
  if (pipeline == PathPipeline::wavefront) {
    if (Status s = accumulate_wavefront(first_sample, samples, max_bounces, primary == PrimaryVisibility::raster); !s)
      return s;
  } else if (Status s = tracer_.trace(pipeline_, md.tlas, &push, width_ * height_); !s) {
    return s.context("render pass");
  }
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
  // Traced: the wavefront's CAMERA stage and one query of the camera rays.
  if (Status s = prepare_wavefront(1, 0); !s) return s;
  DeviceScene& dev = *scene_;
  RenderWave w;
  std::memcpy(&w, wave_buffers_.back().mapped, sizeof w);
  LsnifQueryInfo q = wave_query_info(dev.mode(), scene_stats_.lsnif_instances);
  q.scratchBuffer = wave_scratch_.buffer;
  q.scratchSize = wave_scratch_.size;
  q.rayCount = uint32_t(pixels);
  q.rays = w.rays;
  q.results = w.results;
  q.status = wave_status_.address;
  RenderPush push = wave_push(dev, wave_address_);
  push.sample_index = sample_index;
  push.stage = RENDER_WAVE_CAMERA;
  LsnifResult recorded = LSNIF_SUCCESS;
  Status st = ctx_.submit("primary hits", [&](VkCommandBuffer cmd) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, wave_pipeline_.pipeline);
    vkCmdPushConstants(cmd, wave_pipeline_.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof push, &push);
    vkCmdDispatch(cmd, uint32_t((pixels + 63) / 64), 1, 1);
    wave_barrier(cmd);
    recorded = lsnifCmdQuery(dev.plugin.get(), cmd, dev.query, &q);
    vk::ComputeContext::barrier_compute_to_host(cmd);
  });
  if (recorded != LSNIF_SUCCESS) return plugin_error("primary hits");
  if (!st) return st;
  const auto* results = static_cast<const LsnifQueryResult*>(wave_buffers_[2].mapped);
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
  resolve(out);
  return Status::ok();
}

}  // namespace lsnif::render
