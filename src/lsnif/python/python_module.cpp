// python_module.cpp -- the extension module lsnif._lsnif (docs/python.md): lsnif.Error, the checks
// of arrays where they enter, and the registration of every part.
#include <cmath>
#include <cstdio>
#include <limits>

#include "lsnif/lsnif_version.h"
#include "lsnif/python/python_module.h"

namespace lsnif::python {

namespace {

// "float64 array of shape (10, 4)" / "list": what the caller passed, for messages.
std::string described(py::handle object) {
  if (py::isinstance<py::array>(object)) {
    const py::array a = py::reinterpret_borrow<py::array>(object);
    std::string shape;
    for (py::ssize_t d = 0; d < a.ndim(); ++d) shape += (d ? ", " : "") + std::to_string(a.shape(d));
    if (a.ndim() == 1) shape += ",";
    return std::string(py::str(a.dtype())) + " array of shape (" + shape + ")";
  }
  return std::string(py::str(object.get_type().attr("__name__")));
}

std::string format_number(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

}  // namespace

void check(const Status& s, const char* what) {
  if (s) return;
  throw Error(what ? std::string(what) + ": " + s.message() : s.message());
}

FloatRows float_rows(py::handle object, const char* name, size_t cols, bool image) {
  const std::string want = image ? "(H, W, " + std::to_string(cols) + ")" : "(N, " + std::to_string(cols) + ")";
  if (!py::isinstance<py::array>(object))
    throw py::type_error(std::string(name) + " must be a NumPy array of shape " + want + " (float32 or float64), not " +
                         described(object) + ": pass numpy.asarray(" + name + ", dtype=numpy.float32)");
  FloatRows out;
  out.array = py::reinterpret_borrow<py::array>(object);
  const py::array& a = out.array;
  out.f64 = a.dtype().is(py::dtype::of<double>());
  if (!out.f64 && !a.dtype().is(py::dtype::of<float>()))
    throw py::type_error(std::string(name) + " must hold float32 or float64 values, not " + described(object) +
                         ": convert it with " + name + ".astype(numpy.float32)");
  const py::ssize_t ndim = image ? 3 : 2;
  if (a.ndim() != ndim || a.shape(ndim - 1) != py::ssize_t(cols))
    throw py::value_error(std::string(name) + " must have the shape " + want + ", not that of a " + described(object));
  if (!(a.flags() & py::array::c_style))
    throw py::value_error(std::string(name) + " must be C-contiguous (a " + described(object) +
                          " view with strides): pass numpy.ascontiguousarray(" + name + ")");
  out.data = a.data();
  out.cols = cols;
  out.rows = size_t(a.shape(0)) * (image ? size_t(a.shape(1)) : 1u);
  for (size_t r = 0; r < out.rows; ++r)
    for (size_t c = 0; c < cols; ++c)
      if (!std::isfinite(out.at(r, c))) {
        std::string row;
        for (size_t k = 0; k < cols; ++k) row += (k ? ", " : "") + format_number(out.at(r, k));
        const std::string at = image ? "[" + std::to_string(r / size_t(a.shape(1))) + ", " +
                                                std::to_string(r % size_t(a.shape(1))) + "]"
                                          : "[" + std::to_string(r) + "]";
        throw py::value_error(std::string(name) + at + " = (" + row + ") is not finite");
      }
  return out;
}

py::array_t<float> float_array(const std::vector<py::ssize_t>& shape) {
  py::array_t<float> a(shape);
  std::fill(a.mutable_data(), a.mutable_data() + a.size(), 0.0f);
  return a;
}

double checked_number(double value, const char* name, double lo, double hi) {
  if (!(value >= lo && value <= hi))
    throw py::value_error(std::string(name) + " = " + format_number(value) + " is out of range [" + format_number(lo) +
                          ", " + format_number(hi) + "]");
  return value;
}

int64_t checked_int(py::handle value, const char* name, int64_t lo, int64_t hi) {
  if (!py::isinstance<py::int_>(value) || py::isinstance<py::bool_>(value))
    throw py::type_error(std::string(name) + " must be an int, not " + described(value));
  const py::int_ i = py::reinterpret_borrow<py::int_>(value);
  if (i < py::int_(lo) || i > py::int_(hi))
    throw py::value_error(std::string(name) + " = " + std::string(py::str(value)) + " is out of range [" +
                          std::to_string(lo) + ", " + std::to_string(hi) + "]");
  return i.cast<int64_t>();
}

uint64_t checked_u64(py::handle value, const char* name) {
  if (!py::isinstance<py::int_>(value) || py::isinstance<py::bool_>(value))
    throw py::type_error(std::string(name) + " must be an int, not " + described(value));
  const py::int_ i = py::reinterpret_borrow<py::int_>(value);
  if (i < py::int_(0) || i > py::int_(UINT64_MAX))
    throw py::value_error(std::string(name) + " = " + std::string(py::str(value)) + " is out of range [0, 2^64 - 1]");
  return i.cast<uint64_t>();
}

Transform3x4 transform_argument(py::handle object) {
  Transform3x4 t;
  if (object.is_none()) return t;
  if (py::isinstance<py::array>(object) && py::reinterpret_borrow<py::array>(object).ndim() == 2 &&
      py::reinterpret_borrow<py::array>(object).shape(0) == 4) {
    const FloatRows m = float_rows(object, "transform", 4);
    if (m.at(3, 0) != 0.0 || m.at(3, 1) != 0.0 || m.at(3, 2) != 0.0 || m.at(3, 3) != 1.0)
      throw py::value_error("transform: the last row of a 4 x 4 transform must be (0, 0, 0, 1) (an affine map)");
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) t.m[r][c] = float(m.at(size_t(r), size_t(c)));
    return t;
  }
  const FloatRows m = float_rows(object, "transform", 4);
  if (m.rows != 3) throw py::value_error("transform must have the shape (3, 4) or (4, 4), not (" +
                                         std::to_string(m.rows) + ", 4)");
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) t.m[r][c] = float(m.at(size_t(r), size_t(c)));
  return t;
}

std::vector<Ray> rays_argument(py::handle origins, py::handle directions, double tmin, double tmax) {
  const FloatRows o = float_rows(origins, "origins", 3);
  const FloatRows d = float_rows(directions, "directions", 3);
  if (o.rows != d.rows)
    throw py::value_error("origins and directions must hold as many rays: " + std::to_string(o.rows) + " and " +
                          std::to_string(d.rows));
  checked_number(tmin, "tmin", 0.0, double(std::numeric_limits<float>::max()));
  if (!(tmax >= tmin)) throw py::value_error("tmax = " + format_number(tmax) + " must be at least tmin = " + format_number(tmin));
  std::vector<Ray> rays(o.rows);
  for (size_t i = 0; i < o.rows; ++i) {
    rays[i].origin = o.vec3(i);
    rays[i].direction = d.vec3(i);
    if (rays[i].direction == glm::vec3(0.0f))
      throw py::value_error("directions[" + std::to_string(i) + "] is zero: a ray needs a direction");
    rays[i].tmin = float(tmin);
    rays[i].tmax = float(tmax);
  }
  return rays;
}

}  // namespace lsnif::python

PYBIND11_MODULE(_lsnif, m) {
  namespace lp = lsnif::python;
  namespace py = pybind11;
  m.doc() = "LSNIF, the Locally-Subdivided Neural Intersection Function: train, query and render from NumPy "
            "(docs/python.md).";
  m.attr("__version__") = LSNIF_VERSION_STRING;
  py::register_exception<lp::Error>(m, "Error", PyExc_RuntimeError);
  lp::register_mesh(m);
  lp::register_model(m);
  lp::register_training(m);
  lp::register_evaluation(m);
  lp::register_device(m);
  lp::register_render(m);
}
