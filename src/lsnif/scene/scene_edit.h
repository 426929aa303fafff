// scene_edit.h -- editing a loaded scene at render time, without retraining (the paper's
// section 6.4): a node's transform, and a pre-trained LSNIF object placed where the scene never
// had one. Used by `lsnif render` / `lsnif view` (--node-transform, --add / --at).
#pragma once
#include <string>

#include <glm/glm.hpp>

#include "lsnif/scene/scene.h"
#include "lsnif/format/status.h"

namespace lsnif::scene {

// Parses a transform given on the command line:
//   "X,Y,Z"              translation
//   "X,Y,Z,S"            then uniform scale S (> 0)
//   "X,Y,Z,S,DEG"        then a rotation of DEG degrees about +y (applied before the translation)
//   12 numbers           a row-major 3x4 affine matrix (the layout of VkTransformMatrixKHR)
// Object-to-world = T * R_y * S. Fails, quoting the text, on another count, a non-number, a
// non-finite value, a scale <= 0 or a singular matrix.
Status parse_transform(const std::string& text, glm::mat4& out);

// Parses a point or vector "X,Y,Z" (three finite numbers); `what` names the option in errors.
Status parse_point(const std::string& text, const char* what, glm::vec3& out);

// Sets the world transform of every instance of node `node` (glTF node name). Fails when no
// instance has that name, or on a non-finite or singular transform.
Status set_node_transform(Scene& scene, const std::string& node, const glm::mat4& object_to_world);

// Places the pre-trained model `model_path` (checked with check_lsnif_file; used as given, i.e.
// relative to the working directory) as a new instance named `name` with `object_to_world`. Its
// material outputs all map to one new material (white base color, which the network's albedo
// replaces; dielectric, roughness 0.5). The instance has no triangle mesh, so it has no reference
// mode. Fails on a bad file, an empty name or a non-finite or singular transform.
Status add_lsnif_instance(Scene& scene, const std::string& model_path, const glm::mat4& object_to_world,
                          const std::string& name);

// A model traced in place of a node's mesh must have been trained in that mesh's object space: for
// every instance with both a mesh and an LSNIF object, the model's stored bounds (read from the
// file) must be the mesh's object-space bounds padded as the trainer pads them, within 10% of the
// diagonal per coordinate. Otherwise (e.g. a model trained on the raw file while the scene
// normalizes the mesh) the render would be garbage: an error naming the node, the model and both
// boxes. Also an error when a model file does not load.
Status check_models_fit_meshes(const Scene& scene);

// A camera at `from` looking at `to` with +y up (when looking straight up or down, -z is up), named
// `name`, vertical field of view `yfov_degrees` in (0, 180). Fails on non-finite input or from == to.
Status make_look_at_camera(glm::vec3 from, glm::vec3 to, float yfov_degrees, const std::string& name, Camera& out);

// Fills `out` (enabled) from a direction towards the sun (non-zero, normalized here), an
// irradiance (finite, >= 0) and an angular diameter in degrees (0 < D < 90). Errors name `where`.
Status make_sun(glm::dvec3 direction, glm::dvec3 irradiance, double diameter_degrees, const std::string& where,
                Sun& out);

// Parses --sun "DX,DY,DZ,IRRADIANCE[,DIAMETER_DEGREES]" (a white sun; diameter default 0.53).
Status parse_sun(const std::string& text, Sun& out);

}  // namespace lsnif::scene
