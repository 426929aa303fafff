// scene.h -- the scene model the renderer draws and the converter writes: triangle meshes,
// materials, textures, instances with transforms, cameras, LSNIF objects and the environment light,
// as loaded from a glTF file (scene_gltf.cpp; the LSNIF node extension is documented in
// docs/scene-format.md) or written to one (gltf_build.h). No Vulkan.
// Units and conventions: right-handed, y up (glTF); colors linear RGB; transforms column-major glm.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "lsnif/format/status.h"
#include "lsnif/import/mesh.h"

namespace lsnif::scene {

// An 8-bit RGBA texture as stored in the file (sRGB-encoded for base color, linear otherwise): the
// importer's (src/lsnif/import/mesh.h), read by the same function (read_gltf_image, gltf_material.h).
using Texture = lsnif::Texture;

// The one material (src/lsnif/import/mesh.h): texture indices index Scene::textures. A triangle
// point whose alpha (alpha x the base colour texture's alpha) is below cutoff() is a hole.
using Material = lsnif::Material;

// One triangle list with one material (a glTF primitive of mode TRIANGLES, indexed or not).
struct Primitive {
  std::vector<glm::vec3> positions;
  std::vector<glm::vec3> normals;  // empty: use face normals
  std::vector<glm::vec2> uvs;      // empty: no texturing (uv = 0)
  std::vector<uint32_t> indices;   // 3 per triangle, < positions.size()
  uint32_t material = 0;           // index into Scene::materials (a default material is appended
                                   // when a primitive names none)
};

struct Mesh {
  std::string name;
  std::vector<Primitive> primitives;
};

// A model to be traced through the LSNIF plugin instead of (or in place of) a triangle mesh.
struct LsnifObject {
  std::string model_path;                 // .lsnif file, absolute or relative to the scene file
  std::vector<uint32_t> material_map;     // model material index -> Scene::materials index
  // Added by scene_gltf.cpp (load_scene):
  // - resolved_path: the file to open (model_path joined to the scene file's folder when relative;
  //   an override's path as given). load_scene checked that it exists and starts with the .lsnif
  //   magic; the model itself is not parsed.
  // - material_map is never empty after load_scene; a model material i >= material_map.size()
  //   uses material_map[0] (so a one-entry map gives every model material the same one).
  std::string resolved_path;
};

// One placed object: a glTF node with a mesh and/or the LSNIF extension, its world transform
// flattened from the node hierarchy.
struct Instance {
  std::string node_name;
  glm::mat4 object_to_world{1.0f};
  int32_t mesh = -1;   // index into Scene::meshes: the triangle geometry (the reference of an LSNIF node)
  int32_t lsnif = -1;  // index into Scene::lsnif_objects: traced through the plugin in LSNIF mode
};

struct Camera {
  std::string name;
  glm::mat4 camera_to_world{1.0f};  // looks down -z, y up (glTF camera convention)
  float yfov = 0.8f;                // radians
  float aspect = 0.0f;              // 0: take the image's
};

// Image-based light: an equirectangular HDR image (longitude along x, +y up at row 0).
struct Environment {
  std::string path;          // .hdr / .exr read through OpenImageIO; empty: constant `color`
  glm::vec3 color{1.0f};     // multiplies the image (or is the light when there is none)
  float rotation = 0.0f;     // radians about +y
  // load_scene: `path` is resolved (openable as is) and checked to exist; `color` already includes
  // the LSNIF_environment "intensity". Without the extension and without an override the
  // environment is this default: constant white, radiance 1. Direction <-> pixel mapping and the
  // importance-sampling tables: environment.h.
};
// The largest environment intensity (the LSNIF_environment "intensity" or its override): beyond it
// the radiance an image holds (environments reach 1e5) overflows 32-bit float sums into infinities.
inline constexpr double kMaxEnvironmentIntensity = 1e6;

// A distant light (the sun): a uniformly bright disk of `angular_diameter` about `direction`,
// sampled by next-event estimation. `irradiance` is what it delivers to a surface facing it
// (linear RGB); its radiance is irradiance / (the disk's solid angle).
struct Sun {
  bool enabled = false;
  glm::vec3 direction{0.0f, 1.0f, 0.0f};  // unit, from the scene towards the sun (world space)
  glm::vec3 irradiance{0.0f};
  float angular_diameter = 0.00925f;      // radians (0.53 degrees, the real sun's)
};

struct Scene {
  std::string path;  // the file it came from
  std::vector<Texture> textures;
  std::vector<Material> materials;
  std::vector<Mesh> meshes;
  std::vector<LsnifObject> lsnif_objects;
  std::vector<Instance> instances;
  std::vector<Camera> cameras;
  Environment environment;
  Sun sun;  // LSNIF_environment "sun" (docs/scene-format.md) or --sun
  // Added by scene_gltf.cpp: what load_scene reported besides errors (skipped primitives and
  // cameras, ignored extensions, undecodable textures, ...), one line each, also printed to stderr
  // unless SceneLoadOptions::quiet.
  std::vector<std::string> warnings;
};

// The importer's mesh (src/lsnif/import/mesh.h) in the scene: every vertex in order with its
// normal and uv where the mesh has them, every triangle, all of material `material` (Scene::materials).
Primitive primitive_from(const lsnif::Mesh& mesh, uint32_t material);

// The same, one primitive per mesh material that has triangles (mesh material k -> scene material
// materials[k]), each with the vertices its triangles use, in order of first use.
Mesh mesh_from(const std::string& name, const lsnif::Mesh& mesh, const std::vector<uint32_t>& materials);

}  // namespace lsnif::scene
