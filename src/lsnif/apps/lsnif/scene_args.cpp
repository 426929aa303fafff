// scene_args.cpp -- see scene_args.h.
#include "lsnif/apps/lsnif/scene_args.h"

#include <cstdio>
#include <sstream>
#include <vector>

#include "lsnif/format/atomic_file.h"
#include "lsnif/scene/scene_edit.h"
#include "lsnif/scene/scene_gltf.h"

namespace lsnif::cli {

void SceneArgs::add_to(Args& args) {
  args.positional("SCENE", "glTF scene (.gltf / .glb)", &scene_path);
  args.checked_option("camera", "index of the scene's camera, from 0 (default: the first, or a view that frames "
                      "the scene when it has none)", "N", "", [this](const std::string& v) {
                        if (std::string why = whole_number_error(v); !why.empty()) return why;
                        uint32_t x = 0;
                        if (!parse_u32(v, x) || x > uint32_t(INT32_MAX))
                          return format("out of range [0, %d]", INT32_MAX);
                        camera = x;
                        camera_given = true;
                        return std::string();
                      });
  args.flag("frame-scene", "ignore the scene's cameras and frame the whole scene", &frame_scene);
  args.option("lsnif", "NODE=MODEL.lsnif[,NODE=MODEL...]: trace these nodes with these models", &lsnif_list);
  args.option("env", "HDR environment image (.hdr / .exr), replacing the scene's", &env_path);
  args.checked_option("env-intensity", format("environment intensity [0, %g]", scene::kMaxEnvironmentIntensity), "X",
                      "the scene's", [this](const std::string& v) {
                        float x = 0.0f;
                        if (std::string why = float_error(v); !why.empty()) return why;
                        parse_f32(v, x);
                        if (!(x >= 0.0f && double(x) <= scene::kMaxEnvironmentIntensity))
                          return format("out of range [0, %g]", scene::kMaxEnvironmentIntensity);
                        env_intensity = x;
                        return std::string();
                      });
  args.option("env-rotation", "environment rotation about +y in degrees", &env_rotation, -360.0f, 360.0f);
  args.option("node-transform",
              "NODE=TRANSFORM[;...]: replace a node's world transform; TRANSFORM is X,Y,Z[,SCALE[,DEGREES_ABOUT_Y]] "
              "or 12 numbers (row-major 3x4)",
              &node_transforms);
  args.option("look-from", "X,Y,Z: a camera at this point (replaces --camera), looking at --look-at", &look_from);
  args.option("look-at", "X,Y,Z: the point the --look-from camera looks at (default: the origin)", &look_at);
  args.option("fov", "vertical field of view of the --look-from camera in degrees", &fov, 0.01f, 179.99f);
  args.option("sun", "DX,DY,DZ,IRRADIANCE[,DIAMETER_DEGREES]: a sun towards (DX,DY,DZ) (replaces the scene's)", &sun);
  args.option("add", "MODEL.lsnif[;...]: place pre-trained models the scene does not contain (with --at)", &add_models);
  args.option("at", "TRANSFORM[;...]: where each --add model goes (same forms as --node-transform)", &add_at);
  args.flag("allow-outside-refs", "let files the scene refers to (buffers, images, models, HDR) lie outside its folder",
            &allow_outside_refs);
}

namespace {

std::vector<std::string> split(const std::string& text, char sep) {
  std::vector<std::string> out;
  if (text.empty()) return out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, sep)) out.push_back(item);
  return out;
}

}  // namespace

int SceneArgs::apply_edits(const char* command, scene::Scene& scene) const {
  for (const std::string& item : split(node_transforms, ';')) {
    const size_t eq = item.find('=');
    glm::mat4 m;
    if (eq == std::string::npos || eq == 0) {
      std::fprintf(stderr, "lsnif %s: --node-transform '%s': expected NODE=TRANSFORM\n", command, item.c_str());
      return 2;
    }
    if (Status s = scene::parse_transform(item.substr(eq + 1), m); !s) {
      std::fprintf(stderr, "lsnif %s: --node-transform: %s\n", command, s.message().c_str());
      return 2;
    }
    if (Status s = scene::set_node_transform(scene, item.substr(0, eq), m); !s) {
      std::fprintf(stderr, "lsnif %s: --node-transform: %s\n", command, s.message().c_str());
      return 1;
    }
  }
  if (!look_from.empty() || !look_at.empty()) {
    glm::vec3 from(0.0f), to(0.0f);
    Status s = look_from.empty() ? Status::error("--look-at needs --look-from")
                                 : scene::parse_point(look_from, "--look-from", from);
    if (s && !look_at.empty()) s = scene::parse_point(look_at, "--look-at", to);
    scene::Camera cam;
    if (s) s = scene::make_look_at_camera(from, to, fov, "--look-from", cam);
    if (!s) {
      std::fprintf(stderr, "lsnif %s: %s\n", command, s.message().c_str());
      return 2;
    }
    scene.cameras.insert(scene.cameras.begin(), cam);
  }
  if (!sun.empty()) {
    if (Status s = scene::parse_sun(sun, scene.sun); !s) {
      std::fprintf(stderr, "lsnif %s: %s\n", command, s.message().c_str());
      return 2;
    }
  }
  const std::vector<std::string> models = split(add_models, ';'), places = split(add_at, ';');
  if (models.size() != places.size()) {
    std::fprintf(stderr, "lsnif %s: --add names %zu models but --at gives %zu transforms\n", command, models.size(),
                 places.size());
    return 2;
  }
  for (size_t i = 0; i < models.size(); ++i) {
    glm::mat4 m;
    if (Status s = scene::parse_transform(places[i], m); !s) {
      std::fprintf(stderr, "lsnif %s: --at: %s\n", command, s.message().c_str());
      return 2;
    }
    if (Status s = scene::add_lsnif_instance(scene, models[i], m, "added_" + std::to_string(i)); !s) {
      std::fprintf(stderr, "lsnif %s: --add: %s\n", command, s.message().c_str());
      return 1;
    }
  }
  return 0;
}

int SceneArgs::check_camera(const char* command, const scene::Scene& scene) const {
  if (!camera_given) return 0;
  if (frame_scene || !look_from.empty()) {
    std::fprintf(stderr, "lsnif %s: --camera chooses one of the scene's cameras; --%s replaces them\n", command,
                 frame_scene ? "frame-scene" : "look-from");
    return 2;
  }
  if (camera >= scene.cameras.size()) {
    if (scene.cameras.empty())
      std::fprintf(stderr, "lsnif %s: --camera %u: the scene has no camera (--frame-scene or --look-from make one)\n",
                   command, camera);
    else
      std::fprintf(stderr, "lsnif %s: --camera %u: the scene has %zu camera%s (0 to %zu)\n", command, camera,
                   scene.cameras.size(), scene.cameras.size() == 1 ? "" : "s", scene.cameras.size() - 1);
    return 2;
  }
  return 0;
}

int SceneArgs::load(const char* command, scene::Scene& scene, scene::EnvironmentMap& environment) const {
  scene::SceneLoadOptions options;
  std::stringstream list(lsnif_list);
  std::string item;
  while (std::getline(list, item, ',')) {  // "NODE=MODEL[,NODE=MODEL...]"
    scene::LsnifOverride o;
    if (Status s = scene::parse_lsnif_override(item, o); !s) {
      std::fprintf(stderr, "lsnif %s: --lsnif: %s\n", command, s.message().c_str());
      return 2;
    }
    options.lsnif_overrides.push_back(o);
  }
  if (!env_path.empty()) options.environment.hdr = env_path;
  if (env_intensity >= 0.0f) options.environment.intensity = env_intensity;
  if (env_rotation != 0.0f) options.environment.rotation_degrees = env_rotation;
  options.allow_outside_refs = allow_outside_refs;
  Status s = scene::load_scene(scene_path, options, scene);
  if (s) s = scene::check_models_fit_meshes(scene);
  if (!s) {
    std::fprintf(stderr, "lsnif %s: %s\n", command, s.message().c_str());
    return 1;
  }
  if (int r = check_camera(command, scene)) return r;
  if (int r = apply_edits(command, scene)) return r;
  environment = scene::EnvironmentMap();
  if (!scene.environment.path.empty()) {
    if (Status e = scene::load_environment_map(scene.environment, environment); !e) {
      std::fprintf(stderr, "lsnif %s: environment: %s\n", command, e.message().c_str());
      return 1;
    }
  }
  return 0;
}

int SceneArgs::check_output(const char* command, const char* what, const std::string& output) const {
  std::vector<std::string> inputs{scene_path, env_path};
  for (const std::string& item : split(lsnif_list, ',')) {
    scene::LsnifOverride o;
    if (scene::parse_lsnif_override(item, o)) inputs.push_back(o.model_path);
  }
  for (const std::string& model : split(add_models, ';')) inputs.push_back(model);
  for (const std::string& input : inputs)
    if (Status s = check_not_an_input(output, what, {input}); !s) {
      std::fprintf(stderr, "lsnif %s: %s\n", command, s.message().c_str());
      return 1;
    }
  if (Status s = check_output_path(output); !s) {
    std::fprintf(stderr, "lsnif %s: %s: %s\n", command, what, s.message().c_str());
    return 1;
  }
  return 0;
}

}  // namespace lsnif::cli
