// lsnif flip REFERENCE TEST: the FLIP difference between two images (LDR-FLIP for 8-bit images,
// HDR-FLIP for EXR / HDR), pooled to mean, weighted median and quartiles, min and max, with an
// optional magma heatmap (docs/flip.md).
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>
#include <utility>

#include "lsnif/apps/lsnif/args.h"
#include "lsnif/format/atomic_file.h"
#include "lsnif/apps/lsnif/commands.h"
#include "lsnif/apps/flip/flip.h"
#include "lsnif/image/image_io.h"
#include "lsnif/import/json_text.h"

namespace lsnif::cli {
namespace {

// The range of --start-exposure and --stop-exposure, in stops (2^64 covers any float image).
constexpr float kMaxExposureStops = 64.0f;

// "auto" (empty optional) or a number of stops in [-kMaxExposureStops, kMaxExposureStops].
bool parse_exposure(const std::string& text, const char* name, std::optional<float>& out) {
  if (text.empty() || text == "auto") return true;
  float v = 0.0f;
  if (!parse_f32(text, v) || std::abs(v) > kMaxExposureStops) {
    std::fprintf(stderr, "lsnif flip: --%s expects a number of stops in [%g, %g] or 'auto', got '%s'\n", name,
                 -double(kMaxExposureStops), double(kMaxExposureStops), excerpt(text, 80).c_str());
    return false;
  }
  out = v;
  return true;
}

}  // namespace

int cmd_flip(int argc, char** argv) {
  std::string reference_path, test_path, heatmap_path, start_text = "auto", stop_text = "auto";
  float ppd = 67.0f;
  uint32_t exposures = 0;
  bool json = false;
  Args args("flip",
            "Compares TEST with REFERENCE using FLIP (Andersson et al. 2020, 2021): LDR-FLIP for 8-bit images "
            "(.png, .jpg), HDR-FLIP for linear HDR images (.exr, .hdr); both images must be of the same kind and "
            "size. Prints the mean, the error-weighted median and quartiles, min and max of the per-pixel error.");
  args.positional("REFERENCE", "reference image", &reference_path);
  args.positional("TEST", "test image", &test_path);
  args.option("heatmap", "write the error map through the magma colormap (.png, .jpg, .exr, .hdr)", &heatmap_path);
  args.option("ppd", "pixels per degree of visual angle (67: 0.7 m from a 0.7 m wide 4K monitor)", &ppd, 1.0f, 2000.0f);
  args.option("start-exposure", "HDR-FLIP: first exposure in stops, or auto (from the reference)", &start_text);
  args.option("stop-exposure", "HDR-FLIP: last exposure in stops, or auto (from the reference)", &stop_text);
  args.option("num-exposures", "HDR-FLIP: number of exposures, 0 = max(2, ceil(stop - start))", &exposures, 0, 1000);
  args.flag("json", "print JSON instead of text", &json);
  if (int r = args.parse(argc, argv)) return r == 1 ? 0 : 2;

  flip::FlipSettings settings;
  settings.pixels_per_degree = double(ppd);
  settings.num_exposures = exposures;
  settings.heatmap = !heatmap_path.empty();
  if (!parse_exposure(start_text, "start-exposure", settings.start_exposure) ||
      !parse_exposure(stop_text, "stop-exposure", settings.stop_exposure))
    return 2;
  const bool hdr = image::is_hdr_path(reference_path);
  if (hdr != image::is_hdr_path(test_path)) {
    std::fprintf(stderr,
                 "lsnif flip: the reference '%s' is %s but the test '%s' is %s; compare HDR (.exr, .hdr) with HDR "
                 "and 8-bit with 8-bit images\n",
                 reference_path.c_str(), hdr ? "HDR" : "8-bit", test_path.c_str(), hdr ? "8-bit" : "HDR");
    return 2;
  }
  if (!hdr && (settings.start_exposure || settings.stop_exposure || exposures)) {
    std::fprintf(stderr, "lsnif flip: the exposure options apply to HDR images (.exr, .hdr) only\n");
    return 2;
  }

  if (!heatmap_path.empty()) {
    Status s = check_not_an_input(heatmap_path, "--heatmap", {reference_path, test_path});
    if (s) s = check_output_path(heatmap_path).context("--heatmap");
    if (s) s = image::check_image_extension(heatmap_path).context("--heatmap");
    if (!s) {
      std::fprintf(stderr, "lsnif flip: %s\n", s.message().c_str());
      return 1;
    }
  }
  image::Image reference, test;
  for (auto [path, img] : {std::pair{&reference_path, &reference}, std::pair{&test_path, &test}})
    if (Status s = image::load_image(*path, *img); !s) {
      std::fprintf(stderr, "lsnif flip: %s\n", s.message().c_str());
      return 1;
    }
  if (reference.width != test.width || reference.height != test.height) {
    std::fprintf(stderr, "lsnif flip: the images differ in size: reference '%s' is %u x %u, test '%s' is %u x %u\n",
                 reference_path.c_str(), reference.width, reference.height, test_path.c_str(), test.width,
                 test.height);
    return 1;
  }
  flip::FlipResult result;
  if (Status s = hdr ? flip::hdr_flip(reference, test, settings, result)
                     : flip::ldr_flip(reference, test, settings, result);
      !s) {
    std::fprintf(stderr, "lsnif flip: %s\n", s.message().c_str());
    return 1;
  }
  if (!heatmap_path.empty())
    if (Status s = image::save_image(heatmap_path, result.heatmap); !s) {
      std::fprintf(stderr, "lsnif flip: %s\n", s.message().c_str());
      return 1;
    }

  const flip::FlipStatistics& st = result.stats;
  if (json) {
    nlohmann::ordered_json j;
    j["reference"] = reference_path;
    j["test"] = test_path;
    j["metric"] = hdr ? "HDR-FLIP" : "LDR-FLIP";
    j["width"] = result.width;
    j["height"] = result.height;
    j["pixels_per_degree"] = json::float32(ppd);
    if (hdr) {
      j["start_exposure"] = json::float32(result.start_exposure);
      j["stop_exposure"] = json::float32(result.stop_exposure);
      j["num_exposures"] = result.num_exposures;
    }
    j["mean"] = st.mean;
    j["weighted_median"] = st.weighted_median;
    j["weighted_quartile1"] = st.weighted_quartile1;
    j["weighted_quartile3"] = st.weighted_quartile3;
    j["min"] = st.min;
    j["max"] = st.max;
    j["heatmap"] = heatmap_path.empty() ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(heatmap_path);
    std::printf("%s\n", json::dump(j).c_str());
    return 0;
  }
  std::printf("reference               %s\n", reference_path.c_str());
  std::printf("test                    %s\n", test_path.c_str());
  std::printf("metric                  %s, %u x %u, %g pixels per degree\n", hdr ? "HDR-FLIP" : "LDR-FLIP",
              result.width, result.height, double(ppd));
  if (hdr)
    std::printf("exposures               %u from %.4f to %.4f stops (%s)\n", result.num_exposures,
                double(result.start_exposure), double(result.stop_exposure),
                settings.start_exposure && settings.stop_exposure ? "given"
                : settings.start_exposure || settings.stop_exposure ? "partly automatic"
                                                                    : "automatic, from the reference");
  std::printf("mean                    %.6f\n", st.mean);
  std::printf("weighted median         %.6f\n", st.weighted_median);
  std::printf("1st weighted quartile   %.6f\n", st.weighted_quartile1);
  std::printf("3rd weighted quartile   %.6f\n", st.weighted_quartile3);
  std::printf("min                     %.6f\n", st.min);
  std::printf("max                     %.6f\n", st.max);
  if (!heatmap_path.empty()) std::printf("heatmap                 %s\n", heatmap_path.c_str());
  return 0;
}

}  // namespace lsnif::cli
