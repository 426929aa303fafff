// gltf_scene.cpp -- the node walk of gltf_scene.h.
#include "lsnif/import/gltf_scene.h"


#include <algorithm>
#include <cstdint>
#include <cmath>
#include <limits>

#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>

#include "lsnif/format/numbers.h"

namespace lsnif {
namespace {

constexpr const char* kNodeExtension = "LSNIF_neural_object";

bool all_finite(const std::vector<double>& v) {
  return std::all_of(v.begin(), v.end(), [](double d) { return std::isfinite(d); });
}

// The roots of the walk: the default scene's nodes, or the parentless ones without scenes.
Status scene_roots(const tinygltf::Model& model, const std::string& name, GltfScene& out, std::vector<int>& roots) {
  if (!model.scenes.empty()) {
    int si = model.defaultScene;
    if (si >= int(model.scenes.size()))
      return Status::error("%s: default scene %d does not exist (%zu scenes)", name.c_str(), si, model.scenes.size());
    if (si < 0) si = 0;
    out.scene = si;
    roots = model.scenes[size_t(si)].nodes;
    return Status::ok();
  }
  roots = gltf::parentless_nodes(model);
  if (roots.empty() && !model.nodes.empty())
    return Status::error("%s: no scene and no root node (every node has a parent)", name.c_str());
  return Status::ok();
}

// Depth-first walk with an explicit stack (no recursion on file-controlled depth).
class NodeWalk {
 public:
  NodeWalk(const tinygltf::Model& model, const std::string& name, GltfScene& out)
      : model_(model), name_(name), out_(out), on_path_(model.nodes.size(), 0), reached_(model.nodes.size(), 0) {}

  Status run(const std::vector<int>& roots) {
    for (int r : roots) {
      Status s = visit_tree(r);
      if (!s) return s;
    }
    return Status::ok();
  }

 private:
  struct Frame {
    int node;
    size_t next_child;
    glm::dmat4 world;
  };

  // Visits `root` and its subtree; on_path_ marks the nodes of the current path.
  Status visit_tree(int root) {
    std::vector<Frame> stack;
    Status s = enter(root, glm::dmat4(1.0), stack);
    while (s && !stack.empty()) {
      Frame& f = stack.back();
      const std::vector<int>& children = model_.nodes[size_t(f.node)].children;
      if (f.next_child == children.size()) {
        on_path_[size_t(f.node)] = 0;
        stack.pop_back();
        continue;
      }
      const int child = children[f.next_child++];
      const glm::dmat4 parent = f.world;  // enter() may reallocate the stack
      s = enter(child, parent, stack);
    }
    return s;
  }

  // Checks node `index` reached under `parent`, records it and pushes it on the path.
  Status enter(int index, const glm::dmat4& parent, std::vector<Frame>& stack) {
    if (index < 0 || size_t(index) >= model_.nodes.size())
      return Status::error("%s: node %d does not exist (%zu nodes)", name_.c_str(), index, model_.nodes.size());
    if (on_path_[size_t(index)])
      return Status::error("%s: node %d is its own ancestor (cyclic node hierarchy)", name_.c_str(), index);
    if (reached_[size_t(index)])
      return Status::error("%s: %s is reached a second time (a child of two parents, or listed twice): glTF node "
                           "hierarchies are disjoint trees", name_.c_str(), gltf_node_label(model_, index).c_str());
    if (stack.size() > size_t(kGltfMaxNodeDepth))
      return Status::error("%s: node hierarchy deeper than %d levels", name_.c_str(), kGltfMaxNodeDepth);
    glm::dmat4 local;
    Status s = gltf_local_transform(model_, index, name_, local);
    if (!s) return s;
    const glm::dmat4 world = parent * local;
    const tinygltf::Node& node = model_.nodes[size_t(index)];
    if (node.mesh >= 0 || node.camera >= 0 || node.extensions.count(kNodeExtension)) {
      glm::mat4 checked;
      s = check_world_transform(world, checked);
      if (!s) return s.context(format("%s: %s", name_.c_str(), gltf_node_label(model_, index).c_str()));
    }
    reached_[size_t(index)] = 1;
    on_path_[size_t(index)] = 1;
    out_.nodes.push_back({index, world});
    stack.push_back({index, 0, world});
    return Status::ok();
  }

  const tinygltf::Model& model_;
  const std::string& name_;
  GltfScene& out_;
  std::vector<uint8_t> on_path_, reached_;
};

}  // namespace

std::string gltf_node_label(const tinygltf::Model& model, int index) {
  const std::string& n = model.nodes[size_t(index)].name;
  if (n.empty()) return format("node %d", index);
  return format("node %d ('%s')", index, excerpt(n).c_str());
}

std::string gltf_node_name(const tinygltf::Model& model, int index) {
  const std::string& n = model.nodes[size_t(index)].name;
  return n.empty() ? format("node_%d", index) : n;
}

std::string gltf_mesh_name(const tinygltf::Model& model, int index) {
  const std::string& n = model.meshes[size_t(index)].name;
  return n.empty() ? format("mesh_%d", index) : n;
}

Status gltf_local_transform(const tinygltf::Model& model, int index, const std::string& name, glm::dmat4& out) {
  const tinygltf::Node& node = model.nodes[size_t(index)];
  const std::string who = gltf_node_label(model, index);
  auto finite = [&](const std::vector<double>& v, const char* what) {
    return all_finite(v) ? Status::ok()
                         : Status::error("%s: %s: NaN or infinite value in its %s", name.c_str(), who.c_str(), what);
  };
  if (!node.matrix.empty()) {
    if (node.matrix.size() != 16)
      return Status::error("%s: %s: matrix has %zu numbers (16 expected)", name.c_str(), who.c_str(),
                           node.matrix.size());
    Status s = finite(node.matrix, "matrix");
    if (!s) return s;
    out = glm::make_mat4(node.matrix.data());  // column-major
    if (std::abs(out[0][3]) > 1e-6 || std::abs(out[1][3]) > 1e-6 || std::abs(out[2][3]) > 1e-6 ||
        std::abs(out[3][3] - 1.0) > 1e-6)
      return Status::error("%s: %s: matrix is not affine (its last row must be 0 0 0 1)", name.c_str(), who.c_str());
    out[0][3] = out[1][3] = out[2][3] = 0.0;
    out[3][3] = 1.0;
    return Status::ok();
  }
  if ((!node.translation.empty() && node.translation.size() != 3) ||
      (!node.rotation.empty() && node.rotation.size() != 4) || (!node.scale.empty() && node.scale.size() != 3))
    return Status::error("%s: %s: translation / rotation / scale must have 3 / 4 / 3 numbers", name.c_str(),
                         who.c_str());
  Status s = finite(node.translation, "translation");
  if (s) s = finite(node.rotation, "rotation");
  if (s) s = finite(node.scale, "scale");
  if (!s) return s;
  out = glm::dmat4(1.0);
  if (node.translation.size() == 3)
    out[3] = glm::dvec4(node.translation[0], node.translation[1], node.translation[2], 1.0);
  if (node.rotation.size() == 4) {  // glTF stores (x, y, z, w)
    const glm::dquat q(node.rotation[3], node.rotation[0], node.rotation[1], node.rotation[2]);
    const double len = glm::length(q);
    if (!(len > 1e-12)) return Status::error("%s: %s: rotation quaternion has zero length", name.c_str(), who.c_str());
    out *= glm::mat4_cast(q / len);
  }
  if (node.scale.size() == 3) {
    out[0] *= node.scale[0];
    out[1] *= node.scale[1];
    out[2] *= node.scale[2];
  }
  return Status::ok();
}

Status check_world_transform(const glm::dmat4& world, glm::mat4& out) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) {
      out[c][r] = to_float(world[c][r]);
      if (!std::isfinite(out[c][r])) return Status::error("NaN or infinite value in its world transform");
    }
  const glm::dmat3 m = glm::dmat3(glm::dmat4(out));
  const double norms = glm::length(m[0]) * glm::length(m[1]) * glm::length(m[2]);
  const double det = glm::determinant(m);
  if (!(norms > 1e-30) || !(std::abs(det) > 1e-6 * norms))
    return Status::error("non-invertible world transform (determinant %g)", det);
  return Status::ok();
}

std::vector<int> gltf_placed_meshes(const tinygltf::Model& model, const GltfScene& walk) {
  std::vector<int> out;
  for (const GltfSceneNode& n : walk.nodes)
    if (model.nodes[size_t(n.node)].mesh >= 0) out.push_back(model.nodes[size_t(n.node)].mesh);
  return out;
}

static_assert(kGltfMaxGeometry == uint64_t(1) << 27, "the message says 2^27");

Status check_gltf_geometry(const tinygltf::Model& model, const std::vector<int>& meshes, bool placements,
                           const std::string& name) {
  // Counts come from the file: sums saturate instead of wrapping.
  const auto add = [](uint64_t a, uint64_t b) { return a > UINT64_MAX - b ? UINT64_MAX : a + b; };
  // Each mesh's size once, then the sum over the list (a mesh may be listed many times).
  std::vector<gltf::PrimitiveSize> size(model.meshes.size());
  for (size_t m = 0; m < model.meshes.size(); ++m)
    for (const tinygltf::Primitive& prim : model.meshes[m].primitives) {
      const gltf::PrimitiveSize p = gltf::primitive_size(model, prim);
      size[m].vertices = add(size[m].vertices, p.vertices);
      size[m].triangles = add(size[m].triangles, p.triangles);
    }
  uint64_t triangles = 0, vertices = 0;
  for (const int m : meshes) {
    if (m < 0 || size_t(m) >= size.size()) continue;
    triangles = add(triangles, size[size_t(m)].triangles);
    vertices = add(vertices, size[size_t(m)].vertices);
  }
  const bool too_many_triangles = triangles > kGltfMaxGeometry;
  if (too_many_triangles || vertices > kGltfMaxGeometry)
    return Status::error("%s: the scene's %zu %s %llu %s, more than the %llu (2^27) a tool builds from one glTF "
                         "file", name.c_str(), meshes.size(),
                         meshes.size() == 1 ? (placements ? "mesh placement holds" : "mesh holds")
                                            : (placements ? "mesh placements hold" : "meshes hold"),
                         (unsigned long long)(too_many_triangles ? triangles : vertices),
                         too_many_triangles ? "triangles" : "vertices", (unsigned long long)kGltfMaxGeometry);
  return Status::ok();
}

Status read_gltf_scene(const tinygltf::Model& model, const std::string& name, GltfScene& out) {
  out = GltfScene{};
  std::vector<int> roots;
  Status s = scene_roots(model, name, out, roots);
  if (s) s = NodeWalk(model, name, out).run(roots);
  if (!s) out = GltfScene{};
  return s;
}

}  // namespace lsnif
