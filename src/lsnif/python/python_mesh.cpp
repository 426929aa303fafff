// python_mesh.cpp -- lsnif.Mesh: meshes from files (load_mesh) or from NumPy arrays (finalize_mesh,
// the step every importer ends with), and their arrays back.
#include <algorithm>

#include "lsnif/python/python_module.h"
#include "lsnif/train/settings_io.h"

namespace lsnif::python {

namespace {

// The faces of from_arrays: a (F, 3) integer array, C-contiguous, every index in [0, vertices).
std::vector<glm::uvec3> faces_argument(py::handle object, size_t vertices) {
  if (!py::isinstance<py::array>(object))
    throw py::type_error("faces must be a NumPy integer array of shape (F, 3): pass numpy.asarray(faces, dtype=numpy.int32)");
  const py::array a = py::reinterpret_borrow<py::array>(object);
  const char kind = a.dtype().kind();
  if ((kind != 'i' && kind != 'u') || (a.itemsize() != 4 && a.itemsize() != 8))
    throw py::type_error("faces must hold int32, int64, uint32 or uint64 indices, not " + std::string(py::str(a.dtype())));
  if (a.ndim() != 2 || a.shape(1) != 3)
    throw py::value_error("faces must have the shape (F, 3): three vertex indices per triangle");
  if (!(a.flags() & py::array::c_style)) throw py::value_error("faces must be C-contiguous: pass numpy.ascontiguousarray(faces)");
  const size_t count = size_t(a.shape(0));
  std::vector<glm::uvec3> faces(count);
  for (size_t f = 0; f < count; ++f)
    for (int k = 0; k < 3; ++k) {
      const size_t i = f * 3 + size_t(k);
      int64_t v = 0;
      if (kind == 'i')
        v = a.itemsize() == 4 ? int64_t(static_cast<const int32_t*>(a.data())[i]) : static_cast<const int64_t*>(a.data())[i];
      else if (a.itemsize() == 4)
        v = int64_t(static_cast<const uint32_t*>(a.data())[i]);
      else
        v = int64_t(std::min<uint64_t>(static_cast<const uint64_t*>(a.data())[i], uint64_t(INT64_MAX)));
      if (v < 0 || uint64_t(v) >= vertices)
        throw py::value_error("faces[" + std::to_string(f) + "] indexes vertex " + std::to_string(v) + " of " +
                              std::to_string(vertices) + " (indices must lie in [0, " + std::to_string(vertices) + "))");
      faces[f][k] = uint32_t(v);
    }
  return faces;
}

py::array_t<float> vec3_array(const std::vector<glm::vec3>& v) {
  py::array_t<float> a = float_array({py::ssize_t(v.size()), 3});
  std::copy_n(&v.data()->x, v.size() * 3, a.mutable_data());
  return a;
}

PyMesh mesh_from_arrays(py::handle vertices, py::handle faces, py::handle normals, const std::string& name,
                        bool allow_dropping_most) {
  PyMesh out;
  out.name = name;
  const FloatRows v = float_rows(vertices, "vertices", 3);
  if (v.rows == 0) throw py::value_error("vertices is empty: a mesh needs at least one triangle");
  if (v.rows > size_t(UINT32_MAX)) throw py::value_error("vertices holds more than 2^32 - 1 vertices");
  out.mesh.positions.resize(v.rows);
  for (size_t i = 0; i < v.rows; ++i) out.mesh.positions[i] = v.vec3(i);
  out.mesh.triangles = faces_argument(faces, v.rows);
  if (out.mesh.triangles.empty()) throw py::value_error("faces is empty: a mesh needs at least one triangle");
  if (!normals.is_none()) {
    const FloatRows n = float_rows(normals, "normals", 3);
    if (n.rows != v.rows)
      throw py::value_error("normals must have one row per vertex: " + std::to_string(n.rows) + " rows for " +
                            std::to_string(v.rows) + " vertices");
    out.mesh.normals.resize(n.rows);
    for (size_t i = 0; i < n.rows; ++i) out.mesh.normals[i] = n.vec3(i);
  }
  MeshImportReport report;
  check(finalize_mesh(out.mesh, &report, name, allow_dropping_most));
  out.warnings = report.warnings;
  return out;
}

}  // namespace

void register_mesh(py::module_& m) {
  using namespace pybind11::literals;
  py::class_<PyMesh>(m, "Mesh",
                     "A triangle mesh in object space, as the library trains on it: degenerate triangles dropped, "
                     "vertex normals computed where missing, one default material where none is given.")
      .def_static(
          "load",
          [](const std::string& path, bool allow_outside_refs, bool allow_dropping_most) {
            PyMesh out;
            MeshImportOptions options;
            options.allow_outside_refs = allow_outside_refs;
            options.allow_dropping_most = allow_dropping_most;
            MeshImportReport report;
            Status s;
            {
              py::gil_scoped_release nogil;
              s = load_mesh(path, out.mesh, &report, options);
            }
            check(s);
            out.name = recorded_mesh_name(path);
            out.warnings = report.warnings;
            return out;
          },
          "path"_a, py::kw_only(), "allow_outside_refs"_a = false, "allow_dropping_most"_a = false,
          "Reads .off, .obj, .ply, .gltf, .glb or .lsmesh (glTF node transforms flattened, materials and textures "
          "kept). The name a trained model's record gives it is the file's name.")
      .def_static("from_arrays", &mesh_from_arrays, "vertices"_a, "faces"_a, py::kw_only(), "normals"_a = py::none(),
                  "name"_a = "arrays", "allow_dropping_most"_a = false,
                  "A mesh from vertices (V, 3) float32/float64, faces (F, 3) integer indices and optional vertex "
                  "normals (V, 3). Raises ValueError on a wrong shape, a value that is not finite or an index out of "
                  "range; lsnif.Error when too few triangles are left (degenerate ones are dropped).")
      .def_property_readonly("name", [](const PyMesh& p) { return p.name; })
      .def_property_readonly("warnings", [](const PyMesh& p) { return p.warnings; },
                             "What the import changed or dropped (one line each).")
      .def_property_readonly("vertices", [](const PyMesh& p) { return vec3_array(p.mesh.positions); })
      .def_property_readonly("normals", [](const PyMesh& p) { return vec3_array(p.mesh.normals); })
      .def_property_readonly("faces",
                             [](const PyMesh& p) {
                               py::array_t<uint32_t> a({py::ssize_t(p.mesh.triangles.size()), py::ssize_t(3)});
                               std::copy_n(&p.mesh.triangles.data()->x, p.mesh.triangles.size() * 3, a.mutable_data());
                               return a;
                             })
      .def_property_readonly("material_count", [](const PyMesh& p) { return p.mesh.materials.size(); })
      .def_property_readonly("bounds",
                             [](const PyMesh& p) {
                               const Aabb b = p.mesh.bounds();
                               return py::make_tuple(vec3_array({b.lo}).attr("reshape")(3),
                                                     vec3_array({b.hi}).attr("reshape")(3));
                             },
                             "(lo, hi): the corners of the mesh's bounding box.")
      .def("__repr__", [](const PyMesh& p) {
        return "<lsnif.Mesh '" + p.name + "': " + std::to_string(p.mesh.triangles.size()) + " triangles, " +
               std::to_string(p.mesh.positions.size()) + " vertices, " + std::to_string(p.mesh.materials.size()) +
               " materials>";
      });
}

}  // namespace lsnif::python
