// bench_scenes.h -- the scenes of `lsnif bench` (docs/bench-scenes.md), built from the meshes and
// HDR environments scripts/setup.sh fetches into data/: each is a ground quad, objects (every
// unique object becomes one LSNIF model, placed by one or more instances), an HDR environment and a
// camera. They are generated, not stored: make_bench_scene builds one in memory (the training
// meshes included) and write_bench_scene saves it as glTF with the LSNIF extensions
// (src/lsnif/scene/gltf_build.h).
#pragma once
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "lsnif/import/mesh.h"
#include "lsnif/scene/scene.h"
#include "lsnif/format/status.h"

namespace lsnif::cli {

// One unique object: one mesh, one LSNIF model (trained on `mesh`), one or more instances.
struct BenchObject {
  std::string name;    // node, mesh and model-file stem (NAME.lsnif)
  std::string origin;  // how the mesh was made, for reports ("bunny00.off subdivided 2x")
  Mesh mesh;           // object space, standing on y = 0; one material whose base color is the
                       // object's color (the albedo the model learns)
  scene::Material material;            // the scene material (base color = mesh.materials[0]'s)
  // The base colour image (PNG with alpha) of an alpha-tested object: mesh.textures[0], which
  // mesh.materials[0] uses with mesh.uvs and a MASK cutoff equal to material's; the
  // scene file refers to a copy beside it. Empty for the untextured objects.
  std::string texture;
  std::vector<glm::mat4> placements;   // object-to-world per instance (node NAME, NAME_1, ...)
};

struct BenchScene {
  std::string name, summary;
  std::vector<BenchObject> objects;
  glm::vec3 ground_center{0.0f};
  float ground_half_size = 1.0f;
  scene::Camera camera;
  std::string hdr;  // the environment image (a file under data/hdr)
  float env_intensity = 1.0f, env_rotation_degrees = 0.0f;
};

// The scenes, in the order `lsnif bench` runs them by default: bunny, dragons, heavy, strands,
// foliage, grid.
const std::vector<std::string>& bench_scene_names();

// The files under `data_dir` that scene `name` needs (meshes or textures, and the HDR image).
std::vector<std::string> bench_scene_inputs(const std::string& name, const std::string& data_dir);

// Builds scene `name` from the files under `data_dir`. Errors: an unknown name (listing the
// known ones), a missing or unreadable input file (naming it).
Status make_bench_scene(const std::string& name, const std::string& data_dir, BenchScene& out);

// Writes `scene` into the existing folder `dir` as NAME.gltf + NAME.bin and copies its HDR image
// and the objects' textures there; object nodes carry LSNIF_neural_object with the model OBJECT.lsnif (relative to `dir`) and
// the object's mesh as their reference. The models themselves are not written.
Status write_bench_scene(const BenchScene& scene, const std::string& dir);

// Fingerprints (hex CRC-32) for reuse decisions: of a training mesh or an object's (positions,
// normals, uvs, triangles, colors, the alpha test and texels of cut-out materials), and of a whole scene as written (objects, placements, ground,
// camera, environment).
std::string mesh_fingerprint(const Mesh& mesh);
std::string object_fingerprint(const BenchObject& object);  // its mesh's
std::string scene_fingerprint(const BenchScene& scene);

// The single meshes of `lsnif bench-size`: "bunny", "armadillo", "dragon", loaded as the scenes load
// them (upright, standing on y = 0, largest extent 1, the scene's color as the only material), with
// the HDR environment of the scene that shows them. Errors: an unknown name, a missing file.
const std::vector<std::string>& bench_mesh_names();
std::vector<std::string> bench_mesh_inputs(const std::string& name, const std::string& data_dir);
Status load_bench_mesh(const std::string& name, const std::string& data_dir, Mesh& out, std::string& hdr);

// Instanced triangles of the scene's objects (the ground excluded).
uint64_t object_triangles(const BenchScene& scene);

// Every edge of `mesh` as a closed triangular prism of the given radius (three sides with normals
// pointing away from the edge, two end caps): a wire sculpture of thin strands.
Mesh wireframe_mesh(const Mesh& mesh, float radius);

// One alpha-tested card: a parallelogram centre +- right +- up, its texture spanning it (uv (0, 0)
// at centre - right + up, the image's top left; (1, 1) at centre + right - up).
struct Card {
  glm::vec3 center, right, up;
};

// The cards as a mesh of two triangles each (normal cross(right, up)) with one material: white
// base colour times `texture`, alpha MASK at `cutoff` (`name` names the material).
Mesh card_mesh(const std::vector<Card>& cards, Texture texture, const std::string& name, float cutoff);

}  // namespace lsnif::cli
