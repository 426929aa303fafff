// python_model.cpp -- lsnif.Model: .lsnif files and bytes, the model's description (Model.info, as
// `lsnif info --json`), and Model.intersect: the CPU reference intersector (intersector.h) or, with
// a device, the plugin's batched path (python_device.cpp).
#include <limits>

#include "lsnif/import/json_text.h"
#include "lsnif/python/python_module.h"
#include "lsnif/train/settings_io.h"

namespace lsnif::python {

py::object json_value(const std::string& text) { return py::module_::import("json").attr("loads")(text); }

uint32_t cull_flags(const std::string& cull) {
  if (cull == "none") return 0;
  if (cull == "back") return LSNIF_RAY_FLAG_CULL_BACK_FACING;
  if (cull == "front") return LSNIF_RAY_FLAG_CULL_FRONT_FACING;
  throw py::value_error("cull must be 'none', 'back' or 'front' (the facing of the predicted normal a hit is "
                        "rejected for), not '" + cull + "'");
}

py::dict hits_dict(const std::vector<LsnifHit>& hits) {
  const py::ssize_t n = py::ssize_t(hits.size());
  py::array_t<bool> hit(n), surface_learned(n), reports_uv(n);
  py::array_t<uint32_t> material(n);
  py::array_t<float> t = float_array({n}), occlusion = float_array({n}), metallic = float_array({n}),
                     roughness = float_array({n}), ambient_occlusion = float_array({n});
  py::array_t<float> normal = float_array({n, 3}), albedo = float_array({n, 3}), emission = float_array({n, 3}),
                     uv = float_array({n, 2});
  for (py::ssize_t i = 0; i < n; ++i) {
    const LsnifHit& h = hits[size_t(i)];
    hit.mutable_at(i) = h.hit;
    t.mutable_at(i) = h.hit ? h.t : std::numeric_limits<float>::infinity();
    occlusion.mutable_at(i) = h.occlusion;
    material.mutable_at(i) = h.material;
    surface_learned.mutable_at(i) = h.surface_learned;
    metallic.mutable_at(i) = h.metallic;
    roughness.mutable_at(i) = h.roughness;
    ambient_occlusion.mutable_at(i) = h.ambient_occlusion;
    reports_uv.mutable_at(i) = h.reports_uv;
    for (py::ssize_t k = 0; k < 3; ++k) {
      normal.mutable_at(i, k) = h.normal[int(k)];
      albedo.mutable_at(i, k) = h.albedo[int(k)];
      emission.mutable_at(i, k) = h.emission[int(k)];
    }
    uv.mutable_at(i, 0) = h.uv.x;
    uv.mutable_at(i, 1) = h.uv.y;
  }
  py::dict d;
  d["hit"] = hit;
  d["t"] = t;
  d["occlusion"] = occlusion;
  d["normal"] = normal;
  d["albedo"] = albedo;
  d["material"] = material;
  d["surface_learned"] = surface_learned;
  d["metallic"] = metallic;
  d["roughness"] = roughness;
  d["ambient_occlusion"] = ambient_occlusion;
  d["emission"] = emission;
  d["uv"] = uv;
  d["reports_uv"] = reports_uv;
  return d;
}

namespace {

PyModel load_model_file(const std::string& path) {
  PyModel out;
  Status s;
  {
    py::gil_scoped_release nogil;
    s = load_model(path, out.model);
  }
  check(s);
  return out;
}

PyModel model_from_bytes(const py::bytes& bytes) {
  PyModel out;
  const std::string_view data = bytes;
  check(load_model_from_memory(reinterpret_cast<const uint8_t*>(data.data()), data.size(), out.model));
  return out;
}

py::dict model_info(const PyModel& p, bool grid_usage) {
  nlohmann::ordered_json j;
  check(model_info_json(p.model, grid_usage, j));
  return json_value(json::dump(j));
}

py::dict intersect_model(const PyModel& p, py::handle origins, py::handle directions, double tmin, double tmax,
                         py::handle transform, const std::string& cull, py::handle device) {
  const std::vector<Ray> rays = rays_argument(origins, directions, tmin, tmax);
  const Transform3x4 object_to_world = transform_argument(transform);
  const uint32_t flags = cull_flags(cull);
  if (!device.is_none()) return device_intersect(device, p, rays, object_to_world, flags);
  std::vector<LsnifHit> hits(rays.size());
  Status s;
  {
    py::gil_scoped_release nogil;
    s = intersect(p.model, object_to_world, rays.data(), rays.size(), hits.data(), flags);
  }
  check(s);
  return hits_dict(hits);
}

}  // namespace

void register_model(py::module_& m) {
  using namespace pybind11::literals;
  py::class_<PyModel>(m, "Model", "A trained LSNIF model: voxels, sparse hash grid and MLP (.lsnif).")
      .def_static("load", &load_model_file, "path"_a, "Reads an .lsnif file (every format version the tools read).")
      .def_static("from_bytes", &model_from_bytes, "data"_a, "A model from the bytes of an .lsnif file.")
      .def(
          "save",
          [](const PyModel& p, const std::string& path) {
            Status s;
            {
              py::gil_scoped_release nogil;
              s = save_model(p.model, path);
            }
            check(s);
          },
          "path"_a, "Writes the model as an .lsnif file (the bytes `lsnif train` writes for the same training).")
      .def("to_bytes",
           [](const PyModel& p) {
             std::vector<uint8_t> bytes;
             check(save_model_to_memory(p.model, bytes));
             return py::bytes(reinterpret_cast<const char*>(bytes.data()), bytes.size());
           })
      .def("info", &model_info, py::kw_only(), "grid_usage"_a = false,
           "The model's configuration, memory breakdown ('bytes') and training record, as `lsnif info --json`.")
      .def_property_readonly("memory", [](const PyModel& p) { return py::object(model_info(p, false)["bytes"]); },
                             "Bytes of the voxels, grid, MLP, header and uv cells, and their total.")
      .def_property_readonly("config", [](const PyModel& p) { return p.model.config.describe(); })
      .def_property_readonly("training_record",
                             [](const PyModel& p) { return py::object(model_info(p, false)["training"]); },
                             "The settings and mesh the model was trained with (None for a file without a record).")
      .def_property_readonly("report", [](const PyModel& p) { return p.report; },
                             "What its training reported (seconds per stage, steps, final loss, warnings); None for "
                             "a model that was loaded.")
      .def_property_readonly("bounds",
                             [](const PyModel& p) {
                               const Aabb& b = p.model.bounds();
                               py::array_t<float> lo = float_array({3}), hi = float_array({3});
                               for (py::ssize_t k = 0; k < 3; ++k) {
                                 lo.mutable_at(k) = b.lo[int(k)];
                                 hi.mutable_at(k) = b.hi[int(k)];
                               }
                               return py::make_tuple(lo, hi);
                             },
                             "(lo, hi): the padded object-space box the voxels span.")
      .def("intersect", &intersect_model, "origins"_a, "directions"_a, py::kw_only(), "tmin"_a = 0.0,
           "tmax"_a = std::numeric_limits<double>::infinity(), "transform"_a = py::none(), "cull"_a = "none",
           "device"_a = py::none(),
           "Intersects world-space rays (origins and directions (N, 3), float32 or float64) with an instance of the "
           "model (transform: object to world, (3, 4) or (4, 4); None = identity). Returns a dict of arrays: hit, t "
           "(inf for misses), occlusion, normal (world), albedo, material, the surface channels, uv, reports_uv. "
           "device=None runs the CPU reference intersector; a lsnif.Device (or a device name or index, as the CLI's "
           "--device) runs the plugin's batched path (lsnifCmdIntersectModelRays) on it.")
      .def("__repr__", [](const PyModel& p) {
        return "<lsnif.Model " + p.model.config.describe() + ", " +
               std::to_string(memory_breakdown(p.model).total()) + " bytes>";
      });
}

}  // namespace lsnif::python
