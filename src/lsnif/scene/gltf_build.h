// gltf_build.h -- writing glTF 2.0 scenes with the LSNIF extensions (docs/scene-format.md) through
// tinygltf: the inverse of load_scene (scene_gltf.h) for what the renderer reads. Used by
// `lsnif bench` to generate its scenes and meant for the scene converter (`lsnif convert`).
// Library `lsnif_gltf_build` (tinygltf comes from lsnif_import, src/lsnif/import/gltf_access.h).
//
// Usage: model = new_gltf_model(...); add materials, meshes (referring to the materials by glTF
// index), nodes (referring to the meshes), cameras; mark nodes as LSNIF objects; set the
// environment; save_gltf(model, "dir/scene.gltf") writes dir/scene.gltf and dir/scene.bin.
//
// Guarantees: what these functions write is what load_scene reads back: glTF material i is scene
// material i; mesh primitives keep their vertex and index order (positions, normals, uvs bit for
// bit); a node's transform is its world transform (every node is a root of the default scene);
// cameras and the environment keep their values up to float rounding. Binary data goes to one
// buffer (buffer 0), each array in its own 4-byte-aligned bufferView.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "lsnif/import/gltf_access.h"  // tinygltf with the project's configuration macros
#include "lsnif/scene/scene.h"
#include "lsnif/format/status.h"

namespace lsnif::scene {

// An empty glTF 2.0 model: asset version "2.0" with `generator`, one scene (the default scene, no
// nodes yet) and one empty buffer that add_mesh appends to.
tinygltf::Model new_gltf_model(const std::string& generator);

// Appends `material` as a glTF metallic-roughness material and returns its index. Written: name,
// baseColorFactor (RGBA), metallicFactor, roughnessFactor, emission (emissiveFactor, scaled into
// [0, 1] with KHR_materials_emissive_strength carrying the rest when a component exceeds 1).
// baseColorTexture when base_color_texture >= 0, which is then a glTF texture index (from
// add_image_texture), not a Scene::textures one; alphaMode MASK with alphaCutoff cutoff() when
// cutoff() > 0. The other textures and the uv transforms are not written. Factors are written
// as given: the caller keeps them finite (the loader clamps base color, metallic and roughness to
// [0, 1]).
int add_material(tinygltf::Model& model, const Material& material);

// Appends an image with `uri` (a PNG or JPEG file relative to the folder the model will be saved
// in; neither read nor checked here) and a texture of it with the default sampler (bilinear,
// repeat, as the renderer samples); returns the texture's index.
int add_image_texture(tinygltf::Model& model, const std::string& uri);

// Appends `mesh` (its name and one TRIANGLES primitive per Primitive, in order) and sets `index`
// to the new glTF mesh index. Per primitive: POSITION (float VEC3, with the min / max glTF
// requires), NORMAL when `normals` is not empty, TEXCOORD_0 when `uvs` is not empty, indices as
// unsigned 32-bit, material = Primitive::material. Fails, leaving `model` unchanged, naming the
// mesh, the primitive and the problem, when: the mesh has no primitive; a primitive has no
// triangle, an index count that is not a multiple of 3, an index >= its vertex count, a non-finite
// position, normal or uv, normals or uvs whose count is neither 0 nor the vertex count, or a
// material that is not an index into model.materials; or the buffer would exceed 2^32 bytes.
Status add_mesh(tinygltf::Model& model, const Mesh& mesh, int& index);

// Appends a node named `name` to the default scene's root nodes and returns its index. `mesh` is a
// glTF mesh index or -1 (no mesh); `transform` is the node's object-to-world matrix (column-major
// glm), written as the node's "matrix" unless it is the identity. The caller keeps it affine,
// finite and invertible (load_scene rejects other matrices).
int add_node(tinygltf::Model& model, const std::string& name, int mesh, const glm::mat4& transform);

// Marks node `node` (an index returned by add_node) as an LSNIF object: sets its
// LSNIF_neural_object extension to {"model": model_uri, "materials": materials} ("materials"
// omitted when empty: the loader's default map) and lists the extension in extensionsUsed.
// `model_uri` is a path relative to the folder the file will be saved in, or absolute; the file
// itself is neither read nor checked here (load_scene checks it).
void set_neural_object(tinygltf::Model& model, int node, const std::string& model_uri,
                       const std::vector<uint32_t>& materials);

// Appends a perspective camera (yfov, aspectRatio unless 0, znear, zfar; named camera.name) and a
// root node named camera.name that places it with camera.camera_to_world (looking down -z, y up);
// returns the node's index. The caller keeps 0 < yfov < pi and 0 < znear < zfar.
int add_camera(tinygltf::Model& model, const Camera& camera, float znear, float zfar);

// The root LSNIF_environment extension, field for field (docs/scene-format.md).
struct EnvironmentSpec {
  std::string hdr;                // image path relative to the saved file's folder, or absolute; "" = none
  glm::vec3 color{1.0f};          // linear RGB >= 0
  float intensity = 1.0f;         // >= 0
  float rotation_degrees = 0.0f;  // about +y
};

// Sets the root LSNIF_environment extension to `env` (replacing an earlier one) and lists it in
// extensionsUsed. "hdr" is omitted when empty.
void set_environment(tinygltf::Model& model, const EnvironmentSpec& env);

// The glTF JSON of `model` (pretty-printed) with buffer 0, when it holds data, referred to as
// `bin_uri` (its bytes are not in the text). Fails when the model has more than one buffer.
Status gltf_text(const tinygltf::Model& model, const std::string& bin_uri, std::string& text);

// The glTF JSON of `model` with its buffers embedded as data URIs (a scene checked before it is
// written: nothing goes to disk). Both texts are what tinygltf writes, repaired where it breaks the
// specification: objects without properties (a node `{}`) are written as {}, not
// null, and a perspective camera without zfar (infinite) without it, not as zfar 0.
Status gltf_text_embedded(const tinygltf::Model& model, std::string& text);

// Writes `model` to `path` (a .gltf file: JSON, pretty-printed) and its buffer 0 to the file
// named STEM.bin beside it (STEM = `path`'s file name without extension), replacing both, each
// atomically (src/lsnif/format/atomic_file.h; the buffer first). The folder must exist. Fails naming the
// file that could not be written, or when `path` does not end in ".gltf" or the model has a
// buffer other than buffer 0.
Status save_gltf(const tinygltf::Model& model, const std::string& path);

}  // namespace lsnif::scene
