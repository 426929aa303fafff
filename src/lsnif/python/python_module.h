// python_module.h -- what the parts of the Python module `lsnif` share (docs/python.md): the
// library's errors as lsnif.Error, NumPy arrays checked where they enter (shape, dtype, contiguity,
// finite values: never converted or copied behind the caller's back), arrays made for results, and
// each part's registration function (python_module.cpp calls them in order).
#pragma once
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>  // std::vector<std::string> (warnings) as lists

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "lsnif/core/intersector.h"
#include "lsnif/core/model.h"
#include "lsnif/import/mesh.h"
#include "lsnif/format/status.h"

namespace lsnif::python {

namespace py = pybind11;

// A failure the library reported (Status::message); Python sees lsnif.Error, a RuntimeError.
struct Error : std::runtime_error {
  using std::runtime_error::runtime_error;
};
// Throws Error with the message of a failed `s`, prefixed by `what` when given.
void check(const Status& s, const char* what = nullptr);

// A (N, cols) float32 or float64 NumPy array, C-contiguous, read in place (float_rows makes it);
// `array` keeps it alive.
struct FloatRows {
  py::array array;
  const void* data = nullptr;
  bool f64 = false;
  size_t rows = 0, cols = 0;
  double at(size_t r, size_t c) const {
    const size_t i = r * cols + c;
    return f64 ? static_cast<const double*>(data)[i] : double(static_cast<const float*>(data)[i]);
  }
  glm::vec3 vec3(size_t r) const { return {float(at(r, 0)), float(at(r, 1)), float(at(r, 2))}; }
};
// Checks `object` (named `name` in errors) as a NumPy array of shape (N, cols) (with `image`:
// (H, W, cols), read as H * W rows), float32 or float64, C-contiguous, every value finite. Raises
// TypeError (not a NumPy array, another dtype) or ValueError (shape, contiguity, the first value that
// is not finite) naming the array, what it must be and how to fix it.
FloatRows float_rows(py::handle object, const char* name, size_t cols, bool image = false);

// A new C-contiguous float32 array of `shape`, zeroed.
py::array_t<float> float_array(const std::vector<py::ssize_t>& shape);

// A float argument checked against [lo, hi]: ValueError naming it otherwise (NaN included).
double checked_number(double value, const char* name, double lo, double hi);

// An integer argument checked against [lo, hi]: TypeError for anything but an int (a bool
// included), ValueError naming it when out of range.
int64_t checked_int(py::handle value, const char* name, int64_t lo, int64_t hi);
// The same for an unsigned 64-bit value (a seed): any int in [0, 2^64 - 1].
uint64_t checked_u64(py::handle value, const char* name);

// A transform argument: None (identity) or a (3, 4) or (4, 4) array (object to world, rows; a 4 x 4's
// last row must be 0 0 0 1), float32 or float64, finite.
Transform3x4 transform_argument(py::handle object);

// Rays from `origins` and `directions` (both (N, 3), checked by float_rows), tmin and tmax for all;
// a zero direction is a ValueError naming the ray.
std::vector<Ray> rays_argument(py::handle origins, py::handle directions, double tmin, double tmax);

// lsnif.Mesh: a mesh as the library holds it (finalized: degenerate triangles dropped, normals
// computed where missing), with the name a training record gives it and what its import warned of.
struct PyMesh {
  Mesh mesh;
  std::string name;
  std::vector<std::string> warnings;
};

// lsnif.Model: a trained or loaded model; `report` is what the training reported (a dict, None for a
// loaded model).
struct PyModel {
  Model model;
  py::object report = py::none();
};

// The hits of Model.intersect as a dict of arrays (hit, t: inf for a miss, occlusion, normal, albedo,
// material, surface_learned, metallic, roughness, ambient_occlusion, emission, uv, reports_uv).
py::dict hits_dict(const std::vector<LsnifHit>& hits);
// The parsed JSON `text` (Python's json.loads).
py::object json_value(const std::string& text);
// Model.intersect on a device (python_device.cpp): `device` a lsnif.Device, a device name or an index.
py::dict device_intersect(py::handle device, const PyModel& model, const std::vector<Ray>& rays,
                          const Transform3x4& object_to_world, uint32_t ray_flags);

// The parts of the module, registered on `m` in this order.
void register_mesh(py::module_& m);
void register_model(py::module_& m);
void register_training(py::module_& m);
void register_evaluation(py::module_& m);
void register_device(py::module_& m);
void register_render(py::module_& m);

}  // namespace lsnif::python
