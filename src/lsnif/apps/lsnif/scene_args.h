// scene_args.h -- the scene options shared by `lsnif render` and `lsnif view` (one Settings struct):
// the scene file, LSNIF overrides, environment overrides and the camera, and the load of the scene
// and its environment map with them.
#pragma once
#include <cstdint>
#include <string>

#include "lsnif/apps/lsnif/args.h"
#include "lsnif/scene/environment.h"
#include "lsnif/scene/scene.h"

namespace lsnif::cli {

struct SceneArgs {
  std::string scene_path, lsnif_list, env_path;
  std::string node_transforms;  // "NODE=TRANSFORM[;NODE=TRANSFORM...]" (scene_edit.h parse_transform)
  std::string look_from, look_at;  // "X,Y,Z": a camera replacing the scene's (with --fov)
  float fov = 45.0f;                // degrees, vertical, for --look-from
  std::string sun;                 // "DX,DY,DZ,IRRADIANCE[,DIAMETER_DEGREES]" (scene_edit.h parse_sun)
  std::string add_models, add_at;  // "MODEL[;MODEL...]" placed at "TRANSFORM[;TRANSFORM...]" (paired)
  float env_intensity = -1.0f, env_rotation = 0.0f;  // < 0: the scene's intensity; degrees
  uint32_t camera = 0;
  bool camera_given = false;  // --camera was given: it must name one of the scene's cameras
  bool frame_scene = false;
  bool allow_outside_refs = false;

  // Registers SCENE and --lsnif, --env, --env-intensity, --env-rotation, --camera, --frame-scene,
  // --look-from, --look-at, --fov, --node-transform, --add, --at, --sun, --allow-outside-refs.
  void add_to(Args& args);
  // The camera index for RenderSettings::camera / ViewerSettings::camera (-1: frame the scene).
  // (--look-from: the camera it adds, which load() puts first.)
  int32_t camera_index() const { return frame_scene ? -1 : look_from.empty() ? int32_t(camera) : 0; }
  // Loads the scene with the overrides, applies the edits (node transforms, added objects named
  // "added_0", "added_1", ...) and, when it has an environment image, loads its sampling
  // tables (environment.width stays 0 otherwise). Returns the exit code: 0, 2 for a malformed
  // --lsnif, 1 when the scene or environment cannot be loaded; errors are printed to stderr as
  // "lsnif COMMAND: ...", naming the option or file at fault.
  int load(const char* command, scene::Scene& scene, scene::EnvironmentMap& environment) const;
  // An error (printed as "lsnif COMMAND: ...", returns 1) when `output` is one of the files the
  // options name or the scene file; `what` names the output option.
  int check_output(const char* command, const char* what, const std::string& output) const;

 private:
  int apply_edits(const char* command, scene::Scene& scene) const;
  // An error (printed, returns 2) when --camera names no camera of `scene` as loaded, or is given
  // with --frame-scene or --look-from.
  int check_camera(const char* command, const scene::Scene& scene) const;
};

}  // namespace lsnif::cli
