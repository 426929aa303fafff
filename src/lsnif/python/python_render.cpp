// python_render.cpp -- lsnif.render: a glTF scene path traced on a device (the renderer of `lsnif
// render`, its pipeline chosen as `--pipeline auto` does), returned as a linear RGB float32 image.
#include "lsnif/python/python_device.h"

#include <exception>

#include "lsnif/renderer/render_choice.h"
#include "lsnif/renderer/render_defaults.h"
#include "lsnif/renderer/renderer.h"
#include "lsnif/scene/environment.h"
#include "lsnif/scene/scene_edit.h"
#include "lsnif/scene/scene_gltf.h"

namespace lsnif::python {

namespace {

struct RenderArgs {
  std::string scene;
  render::RenderSettings settings;
  std::string pipeline = "auto", primary = "auto";
  py::object camera = py::none(), environment = py::none(), models = py::none(), device = py::none(),
             progress = py::none();
};

scene::SceneLoadOptions load_options(const RenderArgs& a) {
  scene::SceneLoadOptions options;
  options.quiet = true;  // the warnings go to Python's warnings module
  if (!a.environment.is_none()) options.environment.hdr = py::str(a.environment).cast<std::string>();
  if (!a.models.is_none()) {
    if (!py::isinstance<py::dict>(a.models))
      throw py::type_error("models must be a dict of node name -> .lsnif path (the LSNIF object each named node is "
                           "traced with), or None");
    for (const auto& [node, path] : py::reinterpret_borrow<py::dict>(a.models)) {
      scene::LsnifOverride o;
      o.node = py::str(node);
      o.model_path = py::str(path);
      if (o.node.empty() || o.model_path.empty()) throw py::value_error("models: a node name and a model path are needed");
      options.lsnif_overrides.push_back(o);
    }
  }
  return options;
}

// The camera: None (the scene's first, or a view framing the scene when it has none), -1 (framing
// the scene), or the index of one of its cameras.
int32_t camera_index(py::handle camera, const scene::Scene& scene) {
  if (camera.is_none()) return 0;
  const int64_t c = checked_int(camera, "camera", -1, INT32_MAX);
  if (c == -1) return -1;
  if (c < 0 || uint64_t(c) >= scene.cameras.size())
    throw py::value_error("camera " + std::to_string(c) + ": the scene has " + std::to_string(scene.cameras.size()) +
                          " camera(s) (-1 frames the scene)");
  return int32_t(c);
}

py::array_t<float> render_scene(RenderArgs a) {
  render::RenderSettings& settings = a.settings;
  render::PathPipeline pipeline = render::PathPipeline::inline_rt;
  render::PrimaryVisibility primary = render::PrimaryVisibility::traced;
  if (a.pipeline != "auto" && !render::parse_pipeline(a.pipeline, pipeline))
    throw py::value_error("pipeline must be 'auto', 'inline' or 'wavefront', not '" + a.pipeline + "'");
  if (a.primary != "auto" && !render::parse_primary(a.primary, primary))
    throw py::value_error("primary must be 'auto', 'traced' or 'raster', not '" + a.primary + "'");
  if (!a.progress.is_none() && !PyCallable_Check(a.progress.ptr()))
    throw py::type_error("progress must be callable as progress(samples_done, spp), or None");

  const scene::SceneLoadOptions options = load_options(a);
  scene::Scene scene;
  scene::EnvironmentMap environment;
  Status s;
  {
    py::gil_scoped_release nogil;
    s = scene::load_scene(a.scene, options, scene);
    if (s) s = scene::check_models_fit_meshes(scene);
    if (s && !scene.environment.path.empty()) s = scene::load_environment_map(scene.environment, environment);
  }
  check(s);
  for (const std::string& w : scene.warnings) py::module_::import("warnings").attr("warn")(a.scene + ": " + w);
  settings.camera = camera_index(a.camera, scene);
  settings.environment = environment.width ? &environment : nullptr;

  const std::shared_ptr<PyDevice> dev = device_argument(a.device.is_none() ? py::str("") : a.device);
  image::Image out;
  render::RenderStats stats;
  std::exception_ptr failure;
  {
    py::gil_scoped_release nogil;
    PyDevice::Use use(*dev);
    if (a.pipeline == "auto" || a.primary == "auto") {
      render::DevicePaths paths;
      s = render::device_paths(use.context(), paths);
      if (!s) s = s.context("asking the device what it runs");
      const render::RenderChoice choice =
          render::choose_render_path(scene, settings.reference, paths, uint64_t(settings.width) * settings.height);
      if (a.pipeline == "auto") pipeline = choice.pipeline;
      if (a.primary == "auto") primary = choice.primary;
    }
    settings.pipeline = pipeline;
    settings.primary = primary;
    if (s) {
      render::Renderer renderer(use.context());
      s = renderer.render(scene, settings, out, stats, [&](uint32_t done) {
        if (a.progress.is_none() || failure) return;
        py::gil_scoped_acquire gil;
        try {
          a.progress(done, settings.spp);
        } catch (...) {
          failure = std::current_exception();  // raised when the render returns (it cannot stop midway)
        }
      });
    }
  }
  if (failure) std::rethrow_exception(failure);
  check(s);
  dev->check_validation("render");
  py::array_t<float> image = float_array({py::ssize_t(out.height), py::ssize_t(out.width), 3});
  std::copy(out.rgb.begin(), out.rgb.end(), image.mutable_data());
  return image;
}

}  // namespace

void register_render(py::module_& m) {
  using namespace pybind11::literals;
  m.def(
      "render",
      [](const std::string& scene, py::handle width, py::handle height, py::handle spp, py::handle bounces,
         bool reference, const std::string& pipeline, const std::string& primary, py::object camera,
         py::object environment, py::object models, py::object device, py::object progress) {
        RenderArgs a;
        a.scene = scene;
        a.settings.width = uint32_t(checked_int(width, "width", 1, render::kMaxImageSide));
        a.settings.height = uint32_t(checked_int(height, "height", 1, render::kMaxImageSide));
        a.settings.spp = uint32_t(checked_int(spp, "spp", 1, render::kMaxSpp));
        a.settings.max_bounces = uint32_t(checked_int(bounces, "bounces", 0, render::kMaxBounces));
        a.settings.reference = reference;
        a.pipeline = pipeline;
        a.primary = primary;
        a.camera = camera;
        a.environment = environment;
        a.models = models;
        a.device = device;
        a.progress = progress;
        return render_scene(std::move(a));
      },
      "scene"_a, py::kw_only(), "width"_a = render::kDefaultImageWidth, "height"_a = render::kDefaultImageHeight,
      "spp"_a = render::kDefaultSpp, "bounces"_a = render::RenderSettings().max_bounces, "reference"_a = false,
      "pipeline"_a = "auto", "primary"_a = "auto", "camera"_a = py::none(), "environment"_a = py::none(),
      "models"_a = py::none(), "device"_a = py::none(), "progress"_a = py::none(),
      "Path traces a glTF scene (.gltf/.glb with the LSNIF extensions) on a Vulkan device, as `lsnif render`: LSNIF "
      "nodes through their networks, or every node as triangles with reference=True (the same random sequences). "
      "Returns linear RGB, float32 (height, width, 3). camera: the scene camera's index (None: its first; -1: a "
      "view framing the scene); environment: an .hdr image replacing the scene's; models: {node name: .lsnif path}; "
      "device: a lsnif.Device, a name or an index (None: chosen as the CLI does); progress(samples_done, spp).");
}

}  // namespace lsnif::python
