// python_train.cpp -- lsnif.train: the settings of settings_table.h as keyword arguments (resolved and
// checked like a `--config` file: presets, ranges, the checks of the settings together), the
// trainer with the GIL released, a progress callback, Ctrl-C; lsnif.settings: the table itself.
#include <omp.h>

#include <cstdint>
#include <exception>

#include "lsnif/import/json_text.h"
#include "lsnif/python/python_module.h"
#include "lsnif/train/settings_io.h"
#include "lsnif/train/trainer.h"

namespace lsnif::python {

namespace {

// One keyword argument as the JSON value a `--config` file would hold for it.
nlohmann::json setting_json(const std::string& key, py::handle value) {
  if (py::isinstance<py::bool_>(value)) return value.cast<bool>();
  if (py::isinstance<py::int_>(value)) {
    const py::int_ i = py::reinterpret_borrow<py::int_>(value);
    if (i < py::int_(INT64_MIN) || i > py::int_(UINT64_MAX))
      throw py::value_error(key + " = " + std::string(py::str(value)) + " is out of range");
    if (i < py::int_(0)) return i.cast<int64_t>();
    return i.cast<uint64_t>();
  }
  if (py::isinstance<py::float_>(value)) return value.cast<double>();
  if (py::isinstance<py::str>(value)) return value.cast<std::string>();
  if (py::isinstance<py::list>(value) || py::isinstance<py::tuple>(value)) {
    nlohmann::json list = nlohmann::json::array();
    for (py::handle e : value) list.push_back(setting_json(key, e));
    return list;
  }
  throw py::type_error(key + " must be a number, a string, a bool or a list of numbers (one per grid level), not " +
                       std::string(py::str(value.get_type().attr("__name__"))));
}

// Whether keyword `key` (as an option name) is a preset (quality, paper, tiny).
bool is_preset(const std::string& key) {
  for (const Preset& p : kPresets)
    if (key == p.option) return true;
  return false;
}

// The settings the keyword arguments give: names as the tools' options with '-' written '_'
// (table_log2=15, quality="low", tiny=True), resolved over the defaults with every check: the
// presets first, then the values given (which may change what a preset set: tiny=True, steps=300).
TrainSettings settings_from_kwargs(const py::kwargs& kwargs) {
  nlohmann::json presets = nlohmann::json::object(), values = nlohmann::json::object();
  for (const auto& [k, v] : kwargs) {
    std::string key = py::str(k);
    for (char& c : key)
      if (c == '_') c = '-';
    (is_preset(key) ? presets : values)[key] = setting_json(key, v);
  }
  // A setting that is unknown, of the wrong type or out of range is a wrong argument: ValueError.
  SettingLayer preset_layer, value_layer;
  TrainSettings settings;
  Status s = parse_settings_json(json::dump(presets), "keyword arguments", preset_layer);
  if (s) s = parse_settings_json(json::dump(values), "keyword arguments", value_layer);
  if (s) s = resolve_settings({&preset_layer, &value_layer}, settings);
  if (!s) throw py::value_error(s.message());
  return settings;
}

py::dict report_dict(const TrainReport& rep, uint32_t threads) {
  py::dict d;
  d["seconds"] = rep.seconds;
  d["steps"] = rep.steps;
  d["planned_steps"] = rep.planned_steps;
  d["budget_cut"] = rep.budget_cut;
  d["seconds_sampling"] = rep.seconds_sampling;
  d["seconds_encoding"] = rep.seconds_encoding;
  d["seconds_mlp"] = rep.seconds_mlp;
  d["seconds_loss"] = rep.seconds_loss;
  d["seconds_optimizer"] = rep.seconds_optimizer;
  d["rays"] = rep.rays;
  d["rays_cast"] = rep.rays_cast;
  d["occupied_voxels"] = rep.occupied_voxels;
  py::dict loss;
  loss["total"] = rep.final_loss.total();
  loss["occlusion"] = rep.final_loss.occlusion;
  loss["distance"] = rep.final_loss.distance;
  loss["normal"] = rep.final_loss.normal;
  loss["albedo"] = rep.final_loss.albedo;
  loss["material"] = rep.final_loss.material;
  loss["surface"] = rep.final_loss.surface;
  d["final_loss"] = loss;
  d["warnings"] = rep.uv_warnings;
  d["threads"] = threads;
  return d;
}

// OpenMP's thread count for one call, restored after it.
class ThreadCount {
 public:
  explicit ThreadCount(uint32_t threads) : before_(omp_get_max_threads()) {
    if (threads) omp_set_num_threads(int(threads));
  }
  ~ThreadCount() { omp_set_num_threads(before_); }
  ThreadCount(const ThreadCount&) = delete;
  ThreadCount& operator=(const ThreadCount&) = delete;

 private:
  int before_;
};

PyModel train(const PyMesh& mesh, py::object progress, py::handle threads_arg, double time_budget, const py::kwargs& kwargs) {
  TrainSettings settings = settings_from_kwargs(kwargs);
  const uint32_t threads = uint32_t(checked_int(threads_arg, "threads", 0, kMaxThreads));
  settings.time_budget = checked_number(time_budget, "time_budget", 0.0, kMaxTimeBudget);
  if (!progress.is_none() && !PyCallable_Check(progress.ptr()))
    throw py::type_error("progress must be callable as progress(step, steps, loss), or None");
  const ThreadCount thread_count(threads);
  PyModel out;
  TrainReport rep;
  std::exception_ptr failure;  // raised by the callback or a signal (Ctrl-C): the training stops
  Status s;
  {
    py::gil_scoped_release nogil;
    // After every step, under the GIL: pending signals (KeyboardInterrupt), then the callback.
    s = train_model(mesh.mesh, settings, out.model, &rep, [&](uint32_t step, const LossTerms& loss, const Model&) {
      py::gil_scoped_acquire gil;
      try {
        if (PyErr_CheckSignals() != 0) throw py::error_already_set();
        if (!progress.is_none()) progress(step, settings.steps, loss.total());
      } catch (...) {
        failure = std::current_exception();
        return false;
      }
      return true;
    });
  }
  if (failure) std::rethrow_exception(failure);
  check(s, "training failed");
  // A budget's run is the run of the steps it planned (its schedule's): the record says so, as the CLI's.
  if (settings.time_budget > 0) settings.steps = rep.planned_steps;
  const int used_threads = omp_get_max_threads();
  out.model.training = training_record(settings, mesh.mesh, mesh.name, used_threads);
  out.report = report_dict(rep, uint32_t(used_threads));
  return out;
}

// settings_table.h as a list of dicts: name (as a keyword), kind, default, range, choices, help.
py::list settings_table() {
  py::list out;
  for (const SettingDef& d : kSettingDefs) {
    std::string name = d.name;
    for (char& c : name)
      if (c == '-') c = '_';
    py::dict e;
    e["name"] = name;
    const char* kinds[] = {"int", "int per level", "int", "float", "choice"};
    e["kind"] = kinds[static_cast<int>(d.kind)];
    if (d.kind == SettingKind::Choice) {
      py::list choices;
      for (uint32_t c = 0; c < d.choice_count; ++c) {
        choices.append(d.choices[c].name);
        if (d.choices[c].value == uint32_t(d.def)) e["default"] = d.choices[c].name;
      }
      e["choices"] = choices;
    } else if (d.kind == SettingKind::F32) {
      e["default"] = d.def;
      e["min"] = d.min;
      e["max"] = d.max;
      e["min_open"] = d.min_open;
      e["max_open"] = d.max_open;
    } else if (d.kind == SettingKind::U64) {
      e["default"] = uint64_t(d.def);
    } else {
      e["default"] = uint64_t(d.def);
      e["min"] = uint64_t(d.min);
      e["max"] = uint64_t(d.max);
    }
    e["help"] = d.help;
    out.append(e);
  }
  return out;
}

}  // namespace

void register_training(py::module_& m) {
  using namespace pybind11::literals;
  m.def("train", &train, "mesh"_a, py::kw_only(), "progress"_a = py::none(), "threads"_a = 0,
        "time_budget"_a = 0.0,
        "Trains an LSNIF model of `mesh` (a lsnif.Mesh). Settings are keyword arguments named as the tools' "
        "options with '_' for '-' (steps=600, batch=2048, table_log2=[15, 17], quality='low', tiny=True; "
        "lsnif.settings() lists them), checked against the same ranges. progress(step, steps, loss) is called after "
        "every step; an exception it raises, or Ctrl-C, stops the training and is raised here. threads: worker "
        "threads (0: all cores); time_budget: seconds the training loop may take (0: none; as `lsnif train "
        "--time-budget`). The GIL is released while it runs.");
  m.def("settings", &settings_table,
        "The settings lsnif.train takes: name, kind, default, range or choices, help (the tools' settings table).");
  m.attr("MAX_THREADS") = kMaxThreads;
}

}  // namespace lsnif::python
