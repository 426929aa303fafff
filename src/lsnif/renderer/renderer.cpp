// renderer.cpp -- the path tracer of renderer.h: uploads the scene (per mesh primitive a triangle
// BLAS plus its vertex data, per LSNIF object a plugin model), builds the TLAS (one record per
// primitive of a triangle instance, one per LSNIF instance; custom index = RenderInstance index),
// and traces passes of src/lsnif/renderer/shaders/render.rgen into an accumulation buffer; the
// wavefront pipeline (the stages of src/lsnif/renderer/shaders/render_wave.comp with lsnifCmdQuery
// between them) is renderer_wavefront.cpp's.
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
#include "lsnif/renderer/device_scene.h"
#include "lsnif/renderer/shaders/render_host_device.h"
#include "lsnif/harness/triangle_order.h"

namespace lsnif::render {

namespace {
// The path tracer's shaders, compiled at build time (cmake/LsnifShaders.cmake); the wavefront's
// render_wave.comp is renderer_wavefront.cpp's.
#include "render_lsnif_rchit_spirv.h"
#include "render_rgen_spirv.h"
#include "render_rmiss_spirv.h"
#include "render_triangle_rahit_spirv.h"
#include "render_triangle_rchit_spirv.h"

static_assert(offsetof(RenderPush, model_table) == LSNIF_RT_PUSH_MODEL_TABLE_OFFSET, "binding convention");
static_assert(offsetof(RenderPush, model_count) == LSNIF_RT_PUSH_MODEL_COUNT_OFFSET, "binding convention");
static_assert(offsetof(RenderPush, frame) >= LSNIF_RT_PUSH_APP_OFFSET, "binding convention");

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
  shaders.triangle_any_hit = spirv(render_triangle_rahit_spirv, sizeof render_triangle_rahit_spirv);
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

namespace {

// What set_scene prepares of a scene (plan_scene).
struct ScenePlan {
  bool prepare[2] = {false, false};  // [0]: LSNIF mode, [1]: reference mode
  Status other = Status::ok();       // with both_modes: why the other mode is not prepared (kept for set_mode)
  std::vector<bool> model_used;      // per LSNIF object: the LSNIF mode uses its model
};

// The LSNIF models on the device (load_models).
struct SceneModels {
  // Objects naming the same file (e.g. with different material maps) share one model on the device:
  // slot[i] is the first such object, the one that is loaded and uploaded.
  std::vector<size_t> slot;
  uint32_t count = 0;  // models loaded and built
  uint64_t bytes = 0;  // their model blocks and AABB BLASes
};

// The triangle primitives on the device (build_primitives): per primitive its vertex data for the
// closest-hit shader and one BLAS (DeviceScene::blases, same index).
struct ScenePrimitives {
  std::vector<RenderPrimitive> primitives;
  std::vector<uint32_t> primitive_triangles;           // per primitives entry
  std::vector<std::string> primitive_cutout;           // per primitives entry: its material's name when
                                                       // that is an alpha cut-out, else ""
  std::vector<std::vector<uint32_t>> mesh_primitives;  // per scene mesh: -> primitives / blases index
  std::vector<uint64_t> mesh_blas_bytes, mesh_triangles;  // per scene mesh
};

// One mode's tables while build_mode collects them: record i (custom index i) is RenderInstance i
// and model table entry i.
struct ModeTables {
  std::vector<bool> mesh_counted;  // per scene mesh: its BLAS bytes and triangles are in the mode's stats
  std::vector<RenderInstance> instances;
  std::vector<uint64_t> model_table;
  std::vector<uint32_t> material_maps;
  std::vector<VkAccelerationStructureInstanceKHR> records;
  std::vector<glm::mat3> world_to_object;  // per record (custom index)
};

// Checks that every instance of `scene` has what mode `ref` (reference, or else LSNIF) needs: a
// finite transform, LSNIF object and mesh indices in range, a triangle mesh where it does not use an
// LSNIF object. Marks in `model_used` the LSNIF objects the mode uses (also those met before a failure).
Status check_mode(const scene::Scene& scene, bool ref, std::vector<bool>& model_used) {
  const size_t object_count = scene.lsnif_objects.size();
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
    if (use_lsnif) model_used[size_t(in.lsnif)] = true;
  }
  return Status::ok();
}

// Scene validation: the modes to prepare (`reference`, and with both_modes the other one where the
// scene has its geometry; its error is kept for set_mode), the LSNIF models the LSNIF mode uses and
// their material maps. Fails, naming the node or object, on what the requested mode lacks.
Status plan_scene(const scene::Scene& scene, bool reference, bool both_modes, ScenePlan& plan) {
  const size_t object_count = scene.lsnif_objects.size();
  plan.model_used.assign(object_count, false);
  if (Status s = check_mode(scene, reference, plan.model_used); !s) return s;
  plan.prepare[0] = !reference;
  plan.prepare[1] = reference;
  if (both_modes) {
    plan.other = check_mode(scene, !reference, plan.model_used);
    plan.prepare[reference ? 0 : 1] = bool(plan.other);
  }
  for (size_t i = 0; i < object_count; ++i) {
    if (!plan.model_used[i]) continue;
    if (scene.lsnif_objects[i].material_map.empty())
      return Status::error("LSNIF object %s has an empty material map", scene.lsnif_objects[i].model_path.c_str());
    for (uint32_t m : scene.lsnif_objects[i].material_map)
      if (m >= scene.materials.size())
        return Status::error("LSNIF object %s maps to material %u of %zu", scene.lsnif_objects[i].model_path.c_str(), m,
                             scene.materials.size());
  }
  return Status::ok();
}

// The model file of an LSNIF object: a loaded scene's relative model path resolves against the scene
// file's folder (resolved_path).
const std::string& model_file(const scene::LsnifObject& obj) {
  return obj.resolved_path.empty() ? obj.model_path : obj.resolved_path;
}

// Model deduplication and upload: creates the plugin context of `dev` and, per file the plan uses,
// loads one model (dev.models[slot], the sharing objects' entries stay empty) and builds them all;
// `loaded` counts the models loaded. Fails on an unreadable or inconsistent .lsnif file or a device
// error.
Status load_models(const scene::Scene& scene, const ScenePlan& plan, DeviceScene& dev, uint32_t& loaded,
                   SceneModels& out) {
  const size_t object_count = scene.lsnif_objects.size();
  const std::vector<bool>& model_used = plan.model_used;
  std::vector<size_t>& slot = out.slot;
  slot.resize(object_count);
  for (size_t i = 0; i < object_count; ++i) {
    slot[i] = i;
    for (size_t j = 0; j < i; ++j)
      if (model_used[j] && model_file(scene.lsnif_objects[j]) == model_file(scene.lsnif_objects[i])) {
        slot[i] = j;
        break;
      }
  }

  if (dev.plugin.create(vk::plugin_create_info(dev.ctx)) != LSNIF_SUCCESS) return plugin_error("render");
  dev.models.resize(object_count);
  std::vector<LsnifModel> to_build;
  for (size_t i = 0; i < object_count; ++i) {
    if (!model_used[i] || slot[i] != i) continue;
    if (dev.models[i].create_from_file(dev.plugin.get(), model_file(scene.lsnif_objects[i]).c_str()) != LSNIF_SUCCESS)
      return plugin_error(scene.lsnif_objects[i].model_path.c_str());
    to_build.push_back(dev.models[i].get());
  }
  if (lsnifBuildModels(dev.plugin.get(), uint32_t(to_build.size()), to_build.data()) != LSNIF_SUCCESS)
    return plugin_error("render");
  loaded += uint32_t(to_build.size());
  out.count = uint32_t(to_build.size());
  for (LsnifModel m : to_build) {
    LsnifModelMemory mem{};
    if (lsnifGetModelMemory(dev.plugin.get(), m, &mem) != LSNIF_SUCCESS) return plugin_error("render");
    out.bytes += mem.blockBytes + mem.blasBytes;
  }
  return Status::ok();
}

// Materials, textures: the scene's materials as the shaders read them (a default one for a scene
// without any) and its textures, uploaded to `dev`. Fails on a texture whose bytes do not match its
// size, or a device error.
Status upload_materials(const scene::Scene& scene, DeviceScene& dev, std::vector<RenderMaterial>& materials,
                        std::vector<RenderTexture>& textures) {
  auto tex = [&](int32_t t) -> uint32_t {
    return t >= 0 && size_t(t) < scene.textures.size() ? uint32_t(t) : RENDER_NO_TEXTURE;
  };
  auto add = [&](const scene::Material& m) {
    RenderMaterial r{m.base_color.r, m.base_color.g, m.base_color.b, m.base_color.a, m.metallic, m.roughness,
                     m.emission.r, m.emission.g, m.emission.b, tex(m.base_color_texture),
                     tex(m.metallic_roughness_texture), tex(m.emission_texture), tex(m.occlusion_texture),
                     m.occlusion_strength, tex(m.normal_texture), m.normal_scale, m.alpha_cutoff, {}};
    static_assert(sizeof(r.uv_transform) == sizeof(float) * 6 * kTextureSlotCount, "one 2x3 transform per slot");
    for (uint32_t k = 0; k < kTextureSlotCount; ++k)
      for (int c = 0; c < 3; ++c)
        for (int row = 0; row < 2; ++row) r.uv_transform[6 * k + 2 * c + row] = m.uv_transform[k][c][row];
    materials.push_back(r);
  };
  for (const scene::Material& m : scene.materials) add(m);
  if (materials.empty()) {
    scene::Material fallback;
    fallback.base_color = glm::vec4(0.8f, 0.8f, 0.8f, 1.0f);
    fallback.metallic = 0.0f;
    add(fallback);
  }
  for (const scene::Texture& t : scene.textures) {
    if (t.rgba.size() != size_t(t.width) * t.height * 4 || t.width == 0)
      return Status::error("texture '%s' has %zu bytes for %ux%u texels", t.name.c_str(), t.rgba.size(), t.width,
                           t.height);
    RenderTexture rt{};
    if (Status s = dev.upload(t.rgba.data(), t.rgba.size(), rt.texels); !s) return s;
    rt.width = t.width;
    rt.height = t.height;
    textures.push_back(rt);
  }
  return Status::ok();
}

// Acceleration structures (BLAS): per primitive of the meshes the prepared modes use, vertex data
// for the closest-hit shader and one BLAS, on `dev`; `built` counts the BLASes. Fails on a primitive
// whose material is not among the `material_count` materials, or a device error.
Status build_primitives(const scene::Scene& scene, const ScenePlan& plan, size_t material_count, DeviceScene& dev,
                        uint32_t& built, ScenePrimitives& out) {
  std::vector<bool> mesh_used(scene.meshes.size(), false);
  out.mesh_primitives.resize(scene.meshes.size());
  out.mesh_blas_bytes.assign(scene.meshes.size(), 0);
  out.mesh_triangles.assign(scene.meshes.size(), 0);
  for (const scene::Instance& in : scene.instances)
    for (int mode = 0; mode < 2; ++mode)
      if (plan.prepare[mode] && !(in.lsnif >= 0 && mode == 0)) mesh_used[size_t(in.mesh)] = true;
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    if (!mesh_used[m]) continue;
    for (const scene::Primitive& p : scene.meshes[m].primitives) {
      if (p.indices.empty()) continue;
      if (p.material >= material_count)
        return Status::error("mesh '%s' uses material %u of %zu", scene.meshes[m].name.c_str(), p.material,
                             material_count);
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
      // A cut-out material's geometry is not opaque: its hits run the alpha test (render_triangle.rahit).
      const bool opaque = p.material >= scene.materials.size() || !(scene.materials[p.material].alpha_cutoff > 0.0f);
      vk::AccelerationStructure blas;
      if (Status s = dev.tracer.build_triangle_blas(flat, indices, blas, opaque); !s)
        return s.context(("mesh '" + scene.meshes[m].name + "'").c_str());
      ++built;
      out.mesh_blas_bytes[m] += blas.storage.size;
      out.mesh_triangles[m] += p.indices.size() / 3;
      dev.blases.push_back(blas);
      out.mesh_primitives[m].push_back(uint32_t(out.primitives.size()));
      out.primitives.push_back(rp);
      out.primitive_triangles.push_back(uint32_t(p.indices.size() / 3));
      out.primitive_cutout.push_back(opaque ? std::string() : scene.materials[p.material].name);
    }
  }
  return Status::ok();
}

// Adds LSNIF instance `in` to the LSNIF mode `md`: one TLAS record of its model with its material
// map, and for rasterized primary visibility one draw per primitive of its kept mesh (or why not).
// Fails on a plugin error.
Status add_lsnif_instance(const scene::Scene& scene, const scene::Instance& in, const SceneModels& models,
                          const ScenePrimitives& prims, DeviceScene& dev, DeviceScene::Mode& md, ModeTables& t) {
  const scene::LsnifObject& obj = scene.lsnif_objects[size_t(in.lsnif)];
  RenderInstance ri{RENDER_INSTANCE_LSNIF, RENDER_NO_MESH, uint32_t(t.material_maps.size()),
                    uint32_t(obj.material_map.size())};
  // Its kept mesh, for rasterized primary visibility: one draw per mesh primitive.
  const std::vector<uint32_t>* mesh = in.mesh >= 0 ? &prims.mesh_primitives[size_t(in.mesh)] : nullptr;
  if (md.raster_why_not.empty()) {
    if (!mesh)
      md.raster_why_not = "LSNIF node '" + in.node_name +
                          "' has no triangle mesh to rasterize (keep it with lsnif convert --keep-meshes)";
    else if (mesh->empty())
      md.raster_why_not = "the mesh of LSNIF node '" + in.node_name +
                          "' was not uploaded (set_scene without both_modes)";
    else if (mesh->size() > RENDER_VISIBILITY_MAX_PRIMITIVES)
      md.raster_why_not = "the mesh of LSNIF node '" + in.node_name + "' has more than 255 primitives";
  }
  if (mesh && !mesh->empty() && mesh->size() <= RENDER_VISIBILITY_MAX_PRIMITIVES) {
    ri.first_primitive = mesh->front();
    for (size_t k = 0; k < mesh->size(); ++k) {
      const RenderPrimitive& rp = prims.primitives[(*mesh)[k]];
      md.raster_draws.push_back({uint32_t(t.instances.size()) | uint32_t(k << RENDER_VISIBILITY_GEOMETRY_SHIFT),
                                 rp.positions, rp.indices, prims.primitive_triangles[(*mesh)[k]], in.object_to_world,
                                 !prims.primitive_cutout[(*mesh)[k]].empty()});
    }
  }
  t.material_maps.insert(t.material_maps.end(), obj.material_map.begin(), obj.material_map.end());
  const plugin::Model& model = dev.models[models.slot[size_t(in.lsnif)]];
  LsnifInstanceInfo info{};
  info.model = model.get();
  info.transform = to_3x4(in.object_to_world);
  info.instanceCustomIndex = uint32_t(t.instances.size());
  info.mask = 0xFF;
  VkAccelerationStructureInstanceKHR rec;
  if (lsnifMakeInstance(dev.plugin.get(), &info, &rec) != LSNIF_SUCCESS)
    return plugin_error(("node '" + in.node_name + "'").c_str());
  t.model_table.push_back(model.properties().blockAddress);
  md.table_models.push_back(model.get());
  t.world_to_object.push_back(glm::inverse(glm::mat3(in.object_to_world)));
  t.instances.push_back(ri);
  t.records.push_back(rec);
  md.record_model.push_back(int64_t(models.slot[size_t(in.lsnif)]));
  md.instance_records.back().second = 1;
  ++md.stats.lsnif_instances;
  return Status::ok();
}

// Adds triangle instance `in` to mode `md`: one TLAS record per primitive of its mesh (hit group at
// `triangle_sbt_offset`) and one draw each for rasterized primary visibility. Fails on a transform
// the TLAS cannot hold.
Status add_triangle_instance(const scene::Instance& in, const ScenePrimitives& prims, uint32_t triangle_sbt_offset,
                             const DeviceScene& dev, DeviceScene::Mode& md, ModeTables& t) {
  const VkTransformMatrixKHR xf = to_3x4(in.object_to_world);
  if (Status s = check_instance_transform(xf.matrix); !s) return s.context(("node '" + in.node_name + "'").c_str());
  if (!t.mesh_counted[size_t(in.mesh)]) {
    t.mesh_counted[size_t(in.mesh)] = true;
    md.stats.triangle_blas_bytes += prims.mesh_blas_bytes[size_t(in.mesh)];
    md.stats.triangles += prims.mesh_triangles[size_t(in.mesh)];
  }
  for (uint32_t prim : prims.mesh_primitives[size_t(in.mesh)]) {
    VkAccelerationStructureInstanceKHR rec{};
    rec.transform = xf;
    rec.instanceCustomIndex = uint32_t(t.instances.size()) & 0xffffffu;
    rec.mask = 0xFF;
    rec.instanceShaderBindingTableRecordOffset = triangle_sbt_offset & 0xffffffu;  // triangle hit group
    rec.accelerationStructureReference = dev.blases[prim].address;
    const std::string& cutout = prims.primitive_cutout[prim];
    if (!cutout.empty() && md.cutout_material.empty()) md.cutout_material = cutout;
    md.raster_draws.push_back({uint32_t(t.instances.size()), prims.primitives[prim].positions,
                               prims.primitives[prim].indices, prims.primitive_triangles[prim], in.object_to_world,
                               !cutout.empty()});
    t.instances.push_back({RENDER_INSTANCE_TRIANGLES, prim, 0, 0});
    t.model_table.push_back(0);
    md.table_models.push_back(nullptr);
    t.world_to_object.push_back(glm::inverse(glm::mat3(in.object_to_world)));
    t.records.push_back(rec);
    md.record_model.push_back(-1);
    ++md.instance_records.back().second;
    ++md.stats.triangle_instances;
  }
  return Status::ok();
}

// Per-mode TLAS: the instances of mode `ref` (reference, or else LSNIF; custom index i ->
// RenderInstance i and model table entry i), material maps, model table and TLAS (built for
// updates), uploaded to `dev` into `md`, which is then ready; `tlases_built` counts the TLAS. Fails
// on a transform the TLAS cannot hold, too many records, a plugin or a device error.
Status build_mode(const scene::Scene& scene, bool ref, const SceneModels& models, const ScenePrimitives& prims,
                  uint32_t triangle_sbt_offset, DeviceScene& dev, DeviceScene::Mode& md, uint32_t& tlases_built) {
  RenderStats& stats = md.stats;
  ModeTables t;
  t.mesh_counted.assign(scene.meshes.size(), false);
  for (const scene::Instance& in : scene.instances) {
    md.instance_records.emplace_back(t.records.size(), 0);
    if (in.lsnif >= 0 && !ref) {
      if (Status s = add_lsnif_instance(scene, in, models, prims, dev, md, t); !s) return s;
    } else if (Status s = add_triangle_instance(in, prims, triangle_sbt_offset, dev, md, t); !s) {
      return s;
    }
  }
  if (t.instances.size() >= (1u << 24))
    return Status::error("render: %zu TLAS instances exceed 2^24", t.instances.size());
  if (!ref) {
    stats.lsnif_bytes = models.bytes;
    stats.lsnif_models = models.count;
  }
  // Built for updates: move_instance refits it.
  if (Status s = dev.tracer.build_tlas(t.records, md.tlas, /*allow_update=*/true); !s) return s;
  ++tlases_built;
  md.records = std::move(t.records);
  stats.tlas_bytes = md.tlas.storage.size;
  if (Status s = dev.upload(t.instances, md.instances); !s) return s;
  if (Status s = dev.upload(t.material_maps.empty() ? std::vector<uint32_t>(1) : t.material_maps, md.material_maps);
      !s)
    return s;
  if (Status s = dev.upload(t.model_table, md.table_address); !s) return s;
  md.table_count = uint32_t(t.model_table.size());
  static_assert(sizeof(glm::mat3) == 36, "RenderFrame::world_to_object is float3x3 per instance");
  if (Status s = dev.upload(t.world_to_object, md.world_to_object); !s) return s;
  md.world_to_object_mapped = static_cast<glm::mat3*>(dev.buffers.back().mapped);
  md.ready = true;
  return Status::ok();
}

// Frame data: the scene's part of the RenderFrame (primitives, materials, textures, the
// environment -- `environment`'s map where given -- and the sun), uploaded to `dev` with the frame
// itself (DeviceScene::frame, frame_on_device). Fails on an environment map whose tables do not
// match its size, a bad sun or a device error.
Status upload_frame(const scene::Scene& scene, const scene::EnvironmentMap* environment,
                    const std::vector<RenderPrimitive>& primitives, const std::vector<RenderMaterial>& materials,
                    const std::vector<RenderTexture>& textures, DeviceScene& dev) {
  RenderFrame& frame = dev.frame;
  if (Status s = dev.upload(primitives.empty() ? std::vector<RenderPrimitive>(1) : primitives, frame.primitives); !s)
    return s;
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
  return Status::ok();
}

}  // namespace

Status Renderer::set_scene(const scene::Scene& scene, bool reference, const scene::EnvironmentMap* environment,
                           bool both_modes) {
  scene_.reset();
  scene_stats_ = RenderStats();
  if (scene.instances.empty()) return Status::error("render: the scene %s has no objects", scene.path.c_str());
  if (Status s = create_pipeline(); !s) return s;
  ScenePlan plan;
  if (Status s = plan_scene(scene, reference, both_modes, plan); !s) return s;

  auto dev_owner = std::make_unique<DeviceScene>(ctx_, tracer_);
  DeviceScene& dev = *dev_owner;
  SceneModels models;
  if (Status s = load_models(scene, plan, dev, models_loaded_, models); !s) return s;
  std::vector<RenderMaterial> materials;
  std::vector<RenderTexture> textures;
  if (Status s = upload_materials(scene, dev, materials, textures); !s) return s;
  ScenePrimitives prims;
  if (Status s = build_primitives(scene, plan, materials.size(), dev, blases_built_, prims); !s) return s;
  // Per mode: its TLAS, or why it is not prepared (for set_mode).
  for (int mode = 0; mode < 2; ++mode) {
    DeviceScene::Mode& md = dev.modes[mode];
    if (!plan.prepare[mode]) {
      md.why_not = plan.other.message();
      continue;
    }
    const bool ref = mode == 1;
    Status s = build_mode(scene, ref, models, prims, pipeline_.triangle_sbt_offset, dev, md, tlases_built_);
    if (!s) return s;
  }
  dev.active = reference ? 1 : 0;

  // What camera_view needs.
  scene_bounds(scene, dev.models, models.slot, dev.lo, dev.hi);
  dev.cameras = scene.cameras;
  if (Status s = upload_frame(scene, environment, prims.primitives, materials, textures, dev); !s) return s;
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
  const DeviceScene::Mode& md = scene_->mode();
  RenderPush push{};
  push.model_table = md.table_address;
  push.model_count = md.table_count;
  push.frame = scene_->frame_address;
  push.sample_index = first_sample;
  push.samples = samples;
  if (pipeline == PathPipeline::wavefront) {
    if (!md.cutout_material.empty())
      return Status::error("render: the wavefront pipeline's lsnifCmdQuery treats every triangle as opaque, and "
                           "material '%s' is an alpha cut-out: use --pipeline inline (or auto)",
                           printable(md.cutout_material).c_str());
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
  // Traced: the wavefront's CAMERA stage and one query of the camera rays (renderer_wavefront.cpp).
  return trace_primary_hits(sample_index, out);
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