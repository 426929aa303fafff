// convert_plan.h -- the converter's first stage: read the input glTF and decide, node by node,
// what becomes an LSNIF object and which model each one uses (one model per glTF mesh however many
// nodes use it; one per --group), with the checks that make an object fail on its own (missing or
// outside buffers, non-triangle modes, unsupported primitives) instead of the whole run.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "lsnif/apps/convert/convert_settings.h"
#include "lsnif/import/gltf_access.h"
#include "lsnif/format/status.h"

namespace lsnif::convert {

enum class Decision {
  Convert,         // becomes (part of) an LSNIF object
  BelowThreshold,  // fewer triangles than --min-triangles
  NoMemorySaved,   // the memory rule: frees less BLAS memory than --memory-margin x its model
  NotSelected,     // --select matches neither the node nor the mesh name
  Excluded,        // --exclude matches the node or the mesh name
  TaggedOff,       // node extras {"lsnif": false}
  AlreadyLsnif,    // the node already carries LSNIF_neural_object; left as it is
  Failed,          // selected, but its mesh cannot be converted (PlannedModel::error)
};
const char* decision_text(Decision d);

// One node of the default scene that has a mesh.
struct PlannedNode {
  int node = -1;
  std::string name;       // node name ("node<N>" when unnamed)
  int mesh = -1;
  std::string mesh_name;  // mesh name ("mesh<M>" when unnamed)
  uint64_t triangles = 0;  // of its mesh (triangle modes only)
  glm::dmat4 world{1.0};   // node-to-world transform in the default scene
  std::string group;       // the group it was put in (extras "lsnif_group" or --group); "" for none
  Decision decision = Decision::BelowThreshold;
  int model = -1;          // index into Plan::models when Convert or Failed
};

// One model to make: a glTF mesh (shared by all its converted nodes) or a group.
struct PlannedModel {
  std::string name;   // unique, file-name safe
  std::string file;   // .lsnif file name, in the output's folder
  std::string group;  // group name; empty for a mesh model
  int mesh = -1;      // the glTF mesh of a mesh model
  std::vector<int> nodes;  // the PlannedNode indices it replaces (its instances / group members)
  uint64_t triangles = 0;  // of the object (a group: all members)
  uint64_t model_bytes = 0;  // estimated from the settings (planned_model_bytes)
  std::string error;       // non-empty: bad input, the model is not made (names the object)
};

// One row of the memory table: a glTF mesh of the default scene (its nodes outside groups) or a
// group, converted or not.
struct MemoryRow {
  std::string name;          // the mesh name or the group name
  bool group = false;
  int mesh = -1;             // the glTF mesh of a mesh row
  std::vector<int> nodes;    // its PlannedNode indices (already-LSNIF nodes are in no row)
  uint64_t triangles = 0;    // of the mesh (a group: all members)
  uint64_t blas_bytes = 0;   // the triangle BLASes of the mesh (a group: of its distinct member meshes)
  uint64_t freed_bytes = 0;  // of those, what converting its candidates frees (freed_blas_bytes)
  uint64_t model_bytes = 0;  // its model, estimated from the settings
  int model = -1;            // Plan::models index when it is (partly) converted
};

// The scene's memory in the renderer's LSNIF mode, before and after the conversion.
struct SceneMemory {
  uint64_t blas_before = 0;  // triangle BLASes of the meshes its mesh nodes draw
  uint64_t blas_after = 0;   // those still drawn as triangles by some node
  uint64_t models = 0;       // the new models (failed ones not counted)
  uint64_t after() const { return blas_after + models; }
};

struct Plan {
  tinygltf::Model gltf;      // the input, as read
  std::string input_dir;     // folder of the input file
  int scene = -1;            // the default scene converted (-1: the file's root nodes)
  std::vector<PlannedNode> nodes;
  std::vector<PlannedModel> models;
  std::vector<std::string> bad_buffers;  // per glTF buffer: why its data is missing ("" = fine)
  std::vector<std::string> warnings;
  std::vector<uint64_t> mesh_blas;  // per glTF mesh: its triangle BLAS bytes (0: no node of the scene draws it)
  std::string blas_source;          // how they were found (BlasSizer::source or the estimate's name)
  std::vector<MemoryRow> memory;    // the memory table, in the order of the meshes' first nodes

  size_t instances_converted() const;  // nodes that become LSNIF objects
  size_t failed_models() const;
};

// Every file the input scene `input` refers to, resolved against its folder (buffers, images, the
// models of LSNIF nodes, the environment image) and the input itself: what the converter must
// never overwrite.
std::vector<std::string> referenced_files(const Plan& plan, const std::string& input);

// The settings' own errors: an invalid regular expression, a --group without NAME or REGEX, a
// --memory-margin outside [kMinMemoryMargin, kMaxMemoryMargin].
Status check_settings(const ConvertSettings& settings);

// The default rule for an object (a mesh with its untagged nodes, or a group) that no tag forces
// in: BelowThreshold under `min_triangles` triangles, else under ConvertWhen::Memory
// NoMemorySaved when `freed_blas` < memory_margin x `model_bytes`, else Convert.
Decision size_rule(const ConvertSettings& settings, uint64_t triangles, uint64_t freed_blas, uint64_t model_bytes);

// The BLASes the renderer builds for glTF mesh `mesh`: one per triangle primitive (others none).
std::vector<BlasPrimitive> blas_primitives(const tinygltf::Model& gltf, int mesh);

// The triangle BLAS bytes that converting the nodes `object` (PlannedNode indices) frees: the
// BLAS of each of their meshes that no other node draws as triangles (already-LSNIF nodes draw
// none).
uint64_t freed_blas_bytes(const Plan& plan, const std::vector<int>& object);

// The scene's memory before and after; `model_bytes` per plan.models (empty: their estimates).
SceneMemory scene_memory(const Plan& plan, const std::vector<uint64_t>& model_bytes = {});

// Reads settings.input and makes the plan. Errors (the whole run stops): an unreadable or broken
// file (too deeply nested JSON, an LSNIF extension that is not an object, an image leaving the
// scene's folder), an invalid regular expression, a malformed --group, a cyclic node hierarchy.
// Model file names are unique and never name a file the input refers to (referenced_files). A bad object
// is not an error here: its model carries `error`.
Status make_plan(const ConvertSettings& settings, Plan& plan);

// The model's size on disk and on the GPU, known before training (memory_breakdown of a model with
// `material_count` materials): from the settings, and for indexed levels (sized to the mesh) and uv
// cells from `mesh` (its voxels; the cells build_uv_cells makes). Without `mesh` an indexed level
// counts as hashed (2^table-log2 entries: the bunny's indexed coarse level has a third of that) and,
// when `textured` (a material will report texture coordinates) under --texture-coordinates auto,
// the uv cells of a typical surface (4 V^2 occupied voxels, S^2 maps each: within about 40% of
// the cells of four textured assets made elsewhere). With `mesh`, its materials decide that. Either
// counts the cells of every material whose layout allows coordinates: the measurement after
// training (measure_uv_materials) may drop some, and the model is then smaller.
uint64_t estimated_model_bytes(const TrainSettings& train, uint32_t material_count, bool textured,
                               const Mesh* mesh = nullptr);

// estimated_model_bytes of planned model `m`: its materials (planned_material_count) and whether one
// of them has a texture and its primitive texture coordinates (planned_textured).
uint64_t planned_model_bytes(const TrainSettings& train, const Plan& plan, const PlannedModel& m);
bool planned_textured(const Plan& plan, const PlannedModel& m);

// Distinct materials the model of `m` will have (its primitives' materials, the default counted
// once), as the mesh importer creates them.
uint32_t planned_material_count(const Plan& plan, const PlannedModel& m);

}  // namespace lsnif::convert
