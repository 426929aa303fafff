// python_eval.cpp -- measuring against exact ray casting: lsnif.eval (as `lsnif eval --json`),
// lsnif.eval_rays (its held-out rays), lsnif.reference_intersect (Embree's hits on the mesh);
// lsnif.flip (FLIP of two images, as `lsnif flip`) and image files (lsnif.load_image, save_image:
// the stb readers and writers, PNG, JPEG, HDR).
#include <limits>

#include "lsnif/apps/flip/flip.h"
#include "lsnif/python/python_module.h"
#include "lsnif/train/evaluate.h"
#include "lsnif/train/ground_truth.h"
#include "lsnif/train/settings_io.h"

namespace lsnif::python {

namespace {

EvalSettings eval_settings(const PyModel& model, py::handle rays, py::handle seed) {
  EvalSettings settings;
  settings.rays = size_t(checked_int(rays, "rays", 1, kMaxEvalRays));
  settings.seed = checked_u64(seed, "seed");
  // The reference normal the model learned: with the normal maps applied, if its training baked them.
  settings.normal_maps = recorded_normal_maps(model.model.training);
  return settings;
}

py::dict evaluate(const PyModel& model, const PyMesh& mesh, py::handle rays, py::handle seed) {
  const EvalSettings settings = eval_settings(model, rays, seed);
  EvalReport report;
  Status s;
  {
    py::gil_scoped_release nogil;
    s = evaluate_model(model.model, mesh.mesh, settings, report);
  }
  check(s);
  return json_value(report.to_json());
}

py::tuple eval_rays(const PyModel& model, const PyMesh& mesh, py::handle count, py::handle seed) {
  const EvalSettings settings = eval_settings(model, count, seed);
  std::vector<Ray> rays;
  Status s;
  {
    py::gil_scoped_release nogil;
    s = held_out_rays(model.model, mesh.mesh, settings, rays);
  }
  check(s);
  py::array_t<float> origins = float_array({py::ssize_t(rays.size()), 3}), directions = float_array({py::ssize_t(rays.size()), 3});
  for (size_t i = 0; i < rays.size(); ++i)
    for (py::ssize_t k = 0; k < 3; ++k) {
      origins.mutable_at(py::ssize_t(i), k) = rays[i].origin[int(k)];
      directions.mutable_at(py::ssize_t(i), k) = rays[i].direction[int(k)];
    }
  return py::make_tuple(origins, directions);
}

py::dict reference_intersect(const PyMesh& mesh, py::handle origins, py::handle directions, double tmin, double tmax) {
  const std::vector<Ray> rays = rays_argument(origins, directions, tmin, tmax);
  std::vector<ReferenceHit> hits(rays.size());
  Status s;
  {
    py::gil_scoped_release nogil;
    GroundTruth truth;
    s = truth.build(mesh.mesh);
    if (s) {
      const int64_t n = int64_t(rays.size());
#pragma omp parallel for schedule(dynamic, 256)
      for (int64_t i = 0; i < n; ++i) hits[size_t(i)] = truth.trace(rays[size_t(i)]);
    }
  }
  check(s, "building the Embree reference");
  const py::ssize_t n = py::ssize_t(hits.size());
  py::array_t<bool> hit(n);
  py::array_t<uint32_t> material(n), triangle(n);
  py::array_t<float> t = float_array({n}), metallic = float_array({n}), roughness = float_array({n}),
                     ambient_occlusion = float_array({n});
  py::array_t<float> normal = float_array({n, 3}), mapped = float_array({n, 3}), geometric = float_array({n, 3}),
                     albedo = float_array({n, 3}), emission = float_array({n, 3}), uv = float_array({n, 2});
  for (py::ssize_t i = 0; i < n; ++i) {
    const ReferenceHit& h = hits[size_t(i)];
    hit.mutable_at(i) = h.hit;
    t.mutable_at(i) = h.hit ? h.t : std::numeric_limits<float>::infinity();
    material.mutable_at(i) = h.material;
    triangle.mutable_at(i) = h.hit ? h.triangle : UINT32_MAX;
    if (!h.hit) continue;
    metallic.mutable_at(i) = h.surface.metallic;
    roughness.mutable_at(i) = h.surface.roughness;
    ambient_occlusion.mutable_at(i) = h.surface.ambient_occlusion;
    for (py::ssize_t k = 0; k < 3; ++k) {
      normal.mutable_at(i, k) = h.normal[int(k)];
      mapped.mutable_at(i, k) = h.surface.normal[int(k)];
      geometric.mutable_at(i, k) = h.geometric_normal[int(k)];
      albedo.mutable_at(i, k) = h.albedo[int(k)];
      emission.mutable_at(i, k) = h.surface.emission[int(k)];
    }
    uv.mutable_at(i, 0) = h.uv.x;
    uv.mutable_at(i, 1) = h.uv.y;
  }
  py::dict d;
  d["hit"] = hit;
  d["t"] = t;
  d["normal"] = normal;
  d["normal_mapped"] = mapped;
  d["geometric_normal"] = geometric;
  d["albedo"] = albedo;
  d["material"] = material;
  d["triangle"] = triangle;
  d["metallic"] = metallic;
  d["roughness"] = roughness;
  d["ambient_occlusion"] = ambient_occlusion;
  d["emission"] = emission;
  d["uv"] = uv;
  return d;
}

image::Image image_argument(py::handle object, const char* name) {
  const FloatRows rows = float_rows(object, name, 3, true);
  image::Image img;
  img.height = uint32_t(rows.array.shape(0));
  img.width = uint32_t(rows.array.shape(1));
  img.rgb.resize(rows.rows * 3);
  for (size_t r = 0; r < rows.rows; ++r)
    for (size_t c = 0; c < 3; ++c) img.rgb[r * 3 + c] = float(rows.at(r, c));
  return img;
}

py::dict flip_images(py::handle reference, py::handle test, bool hdr, double pixels_per_degree) {
  const image::Image ref = image_argument(reference, "reference"), img = image_argument(test, "test");
  flip::FlipSettings settings;
  settings.pixels_per_degree = checked_number(pixels_per_degree, "pixels_per_degree", 1.0, 2000.0);
  flip::FlipResult result;
  Status s;
  {
    py::gil_scoped_release nogil;
    s = hdr ? flip::hdr_flip(ref, img, settings, result) : flip::ldr_flip(ref, img, settings, result);
  }
  check(s);
  py::array_t<float> error = float_array({py::ssize_t(result.height), py::ssize_t(result.width)});
  std::copy(result.error.begin(), result.error.end(), error.mutable_data());
  py::array_t<float> heatmap = float_array({py::ssize_t(result.height), py::ssize_t(result.width), 3});
  std::copy(result.heatmap.rgb.begin(), result.heatmap.rgb.end(), heatmap.mutable_data());
  py::dict d;
  d["mean"] = result.stats.mean;
  d["weighted_median"] = result.stats.weighted_median;
  d["weighted_quartile1"] = result.stats.weighted_quartile1;
  d["weighted_quartile3"] = result.stats.weighted_quartile3;
  d["min"] = result.stats.min;
  d["max"] = result.stats.max;
  d["error"] = error;
  d["heatmap"] = heatmap;
  return d;
}

py::array_t<float> read_image(const std::string& path) {
  image::Image img;
  Status s;
  {
    py::gil_scoped_release nogil;
    s = image::load_image(path, img);
  }
  check(s);
  py::array_t<float> out = float_array({py::ssize_t(img.height), py::ssize_t(img.width), 3});
  std::copy(img.rgb.begin(), img.rgb.end(), out.mutable_data());
  return out;
}

void write_image(const std::string& path, py::handle image) {
  const image::Image img = image_argument(image, "image");
  Status s;
  {
    py::gil_scoped_release nogil;
    s = image::save_image(path, img);
  }
  check(s);
}

}  // namespace

void register_evaluation(py::module_& m) {
  using namespace pybind11::literals;
  const uint64_t default_seed = EvalSettings().seed;
  m.def("eval", &evaluate, "model"_a, "mesh"_a, py::kw_only(), "rays"_a = 100000, "seed"_a = default_seed,
        "Measures the model against exact ray casting (Embree) of the mesh it was trained on, on held-out rays: "
        "the dict `lsnif eval --json` prints (model, voxel_baseline, model_from_outside, model_from_surface, ...).");
  m.def("eval_rays", &eval_rays, "model"_a, "mesh"_a, py::kw_only(), "rays"_a = 100000, "seed"_a = default_seed,
        "The held-out rays lsnif.eval measures on (object space): (origins, directions), float32 (N, 3) each.");
  m.def("reference_intersect", &reference_intersect, "mesh"_a, "origins"_a, "directions"_a, py::kw_only(),
        "tmin"_a = 0.0, "tmax"_a = std::numeric_limits<double>::infinity(),
        "Exact closest hits of rays with the mesh (Embree, alpha cut-outs tested), the ground truth of training: "
        "a dict of arrays (hit, t: inf for misses, normal: interpolated, normal_mapped, geometric_normal, albedo, "
        "material, triangle, the surface channels, uv).");
  m.def("flip", &flip_images, "reference"_a, "test"_a, py::kw_only(), "hdr"_a = false, "pixels_per_degree"_a = 67.0,
        "FLIP of two linear RGB images (H, W, 3) (LDR-FLIP, values clamped to [0, 1]; hdr=True: HDR-FLIP): a dict "
        "with the mean and the weighted percentiles, the per-pixel error (H, W) and its magma heatmap (H, W, 3).");
  m.def("load_image", &read_image, "path"_a,
        "Reads a .png, .jpg or .hdr image as linear RGB, float32 (H, W, 3) (8-bit images decoded from sRGB).");
  m.def("save_image", &write_image, "path"_a, "image"_a,
        "Writes linear RGB (H, W, 3) as .hdr, or as .png / .jpg (sRGB-encoded, clamped to [0, 1]).");
  m.attr("MAX_EVAL_RAYS") = kMaxEvalRays;
}

}  // namespace lsnif::python
