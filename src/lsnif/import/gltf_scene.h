// gltf_scene.h -- the one reader of a glTF file's node graph: which nodes its rendered scene holds
// and where they are. The mesh importer (load_mesh: `lsnif train`, `eval`), the converter's plan
// (`lsnif convert`) and the renderer's scene loader (`lsnif render`, `view`, `bench`) all walk the
// nodes through it, so every tool gives a file the same verdict. Part of lsnif_import.
//
// The rules (glTF 2.0's own, and the strictest any of the tools applied before):
// - The scene is the file's `scene` (an index past the list is an error), else scene 0. A file
//   without scenes walks its parentless nodes (an error when every node has a parent); a file with
//   neither scenes nor nodes has an empty walk, and the caller decides what that means.
// - Every node index exists. The hierarchy is a set of disjoint trees: a node that is its own
//   ancestor is an error ("cyclic node hierarchy"), and so is a node reached a second time (a child
//   of two parents, or listed twice), so a walk visits each node at most once: no file can make it
//   do more work than its node count. Depth at most kGltfMaxNodeDepth.
// - A node's local transform is its "matrix" (16 finite numbers whose last row is 0 0 0 1) or
//   translation * rotation * scale (3 / 4 / 3 finite numbers; the quaternion must not have zero
//   length and is normalized).
// - The world transform of a node that places something (a mesh, a camera or an
//   LSNIF_neural_object) is finite and invertible after conversion to float (check_world_transform).
// Messages name the file, the node ("node 3 ('wheel')") and the problem.
#pragma once
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "lsnif/format/status.h"
#include "lsnif/import/gltf_access.h"

namespace lsnif {

inline constexpr int kGltfMaxNodeDepth = 256;

// The most triangles, and the most vertices, a tool builds from one glTF file: the flattened mesh
// of `lsnif train`, `eval` and `convert`, where every placement of a mesh counts (a mesh placed by
// 1000 nodes is flattened 1000 times), and the meshes the renderer's scene loader reads (`render`,
// `view`, `bench`), each once (its nodes instance it). Counted from the accessors' counts before
// any data is read (check_gltf_geometry), so that a small file placing a large (or a sparse,
// zero-filled) accessor many times is refused at once rather than after gigabytes.
inline constexpr uint64_t kGltfMaxGeometry = uint64_t(1) << 27;

struct GltfSceneNode {
  int node = -1;          // index into tinygltf::Model::nodes
  glm::dmat4 world{1.0};  // the node's space -> the scene's: the local transforms from its root down
};

struct GltfScene {
  int scene = -1;                     // the scene walked; -1: the file has none (parentless nodes)
  std::vector<GltfSceneNode> nodes;   // each node of the scene once, depth first, in file order
};

// Walks the rendered scene of `model` under the rules above; `name` names the file in messages.
// On error `out` is left empty.
Status read_gltf_scene(const tinygltf::Model& model, const std::string& name, GltfScene& out);

// The nodes of `walk` that place a mesh (node.mesh >= 0), as mesh indices in walk order.
std::vector<int> gltf_placed_meshes(const tinygltf::Model& model, const GltfScene& walk);

// Sums the triangles and vertices of `meshes` (mesh indices; a repeated one counts again; one out of
// range counts nothing) with gltf::primitive_size (sums saturate), and refuses more than kGltfMaxGeometry
// of either:
// "NAME: the scene's 2000 mesh placements hold 699050000 triangles, more than the 134217728 (2^27)
// a tool builds from one glTF file". `placements`: the list's entries are called mesh placements in
// that message (a flattening tool's), else meshes (the renderer's).
Status check_gltf_geometry(const tinygltf::Model& model, const std::vector<int>& meshes, bool placements,
                           const std::string& name);

// The local transform of node `index` under the rules above (errors name `name` and the node).
Status gltf_local_transform(const tinygltf::Model& model, int index, const std::string& name, glm::dmat4& out);

// `world` converted to float in `out`: an error unless every value is finite and the linear part is
// invertible relative to the size of its columns (|det| > 1e-6 * |c0| |c1| |c2|). The message
// names the problem only; callers add the file and node.
Status check_world_transform(const glm::dmat4& world, glm::mat4& out);

// "node 3" or "node 3 ('wheel')" (the name shortened and made printable) for messages.
std::string gltf_node_label(const tinygltf::Model& model, int index);

// The name every tool shows and matches for node `index` (render's and view's --node-transform and
// --lsnif, convert's --select / --exclude and its report): the node's own name, or "node_<index>"
// when it has none (names are optional in glTF).
std::string gltf_node_name(const tinygltf::Model& model, int index);
// The same for mesh `index`: its own name, or "mesh_<index>".
std::string gltf_mesh_name(const tinygltf::Model& model, int index);

}  // namespace lsnif
