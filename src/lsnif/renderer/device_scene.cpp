// device_scene.cpp -- build_device_scene (device_scene.h): a scene on the device for the Renderer.
// Per LSNIF object file one plugin model, per mesh primitive a triangle BLAS and its vertex data
// for the closest-hit shader, the materials and textures, and per mode (LSNIF, reference) a TLAS
// (one record per primitive of a triangle instance, one per LSNIF instance; custom index =
// RenderInstance index) with its tables; renderer.cpp traces it, renderer_wavefront.cpp casts its
// rays through lsnifCmdQuery.
#include "lsnif/renderer/device_scene.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <limits>

#include "lsnif/format/instance_transform.h"
#include "lsnif/vulkan/triangle_order.h"

namespace lsnif::render {

namespace {

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
    RenderMaterial r{m.base_color.r, m.base_color.g, m.base_color.b, m.alpha, m.metallic, m.roughness,
                     m.emission.r, m.emission.g, m.emission.b, tex(m.base_color_texture),
                     tex(m.metallic_roughness_texture), tex(m.emission_texture), tex(m.occlusion_texture),
                     m.occlusion_strength, tex(m.normal_texture), m.normal_scale, m.cutoff(), {}};
    static_assert(sizeof(r.uv_transform) == sizeof(float) * 6 * kTextureSlotCount, "one 2x3 transform per slot");
    for (uint32_t k = 0; k < kTextureSlotCount; ++k)
      for (int c = 0; c < 3; ++c)
        for (int row = 0; row < 2; ++row) r.uv_transform[6 * k + 2 * c + row] = m.uv_transform[k][c][row];
    materials.push_back(r);
  };
  for (const scene::Material& m : scene.materials) add(m);
  if (materials.empty()) {
    scene::Material fallback;
    fallback.base_color = glm::vec3(0.8f);
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
      const bool opaque = p.material >= scene.materials.size() || !(scene.materials[p.material].cutoff() > 0.0f);
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

Status build_device_scene(vk::Context& ctx, vk::RayTracer& tracer, const scene::Scene& scene, bool reference,
                          const scene::EnvironmentMap* environment, bool both_modes, uint32_t triangle_sbt_offset,
                          SceneBuildCounts counts, std::unique_ptr<DeviceScene>& out) {
  ScenePlan plan;
  if (Status s = plan_scene(scene, reference, both_modes, plan); !s) return s;

  auto dev_owner = std::make_unique<DeviceScene>(ctx, tracer);
  DeviceScene& dev = *dev_owner;
  SceneModels models;
  if (Status s = load_models(scene, plan, dev, counts.models_loaded, models); !s) return s;
  std::vector<RenderMaterial> materials;
  std::vector<RenderTexture> textures;
  if (Status s = upload_materials(scene, dev, materials, textures); !s) return s;
  ScenePrimitives prims;
  if (Status s = build_primitives(scene, plan, materials.size(), dev, counts.blases_built, prims); !s) return s;
  // Per mode: its TLAS, or why it is not prepared (for set_mode).
  for (int mode = 0; mode < 2; ++mode) {
    DeviceScene::Mode& md = dev.modes[mode];
    if (!plan.prepare[mode]) {
      md.why_not = plan.other.message();
      continue;
    }
    const bool ref = mode == 1;
    Status s = build_mode(scene, ref, models, prims, triangle_sbt_offset, dev, md, counts.tlases_built);
    if (!s) return s;
  }
  dev.active = reference ? 1 : 0;

  // What camera_view needs.
  scene_bounds(scene, dev.models, models.slot, dev.lo, dev.hi);
  dev.cameras = scene.cameras;
  if (Status s = upload_frame(scene, environment, prims.primitives, materials, textures, dev); !s) return s;
  out = std::move(dev_owner);
  return Status::ok();
}

}  // namespace lsnif::render
