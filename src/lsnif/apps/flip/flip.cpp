// flip.cpp -- LDR-FLIP (paper, section 4): the color and feature pipelines combined per pixel as
// color^(1 - feature), with input checks, statistics and the heatmap.
#include "lsnif/apps/flip/flip.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "lsnif/apps/flip/flip_detail.h"

namespace lsnif::flip {

double pixels_per_degree(double distance_m, double monitor_width_m, double monitor_width_px) {
  return distance_m * (monitor_width_px / monitor_width_m) * std::numbers::pi / 180.0;
}

namespace detail {

std::vector<float> combine(const std::vector<float>& color, const std::vector<float>& feature) {
  std::vector<float> out(color.size());
  for (size_t i = 0; i < out.size(); ++i)
    out[i] = std::clamp(float(std::pow(double(color[i]), 1.0 - double(feature[i]))), 0.0f, 1.0f);
  return out;
}

std::vector<float> ldr_flip_map(const Image& reference, const Image& test, double ppd) {
  return combine(color_error_map(reference, test, ppd), feature_error_map(reference, test, ppd));
}

Status check_inputs(const Image& reference, const Image& test, const FlipSettings& settings) {
  if (!(settings.pixels_per_degree >= 1.0 && settings.pixels_per_degree <= 2000.0))
    return Status::error("pixels per degree %g is outside [1, 2000]", settings.pixels_per_degree);
  const Image* images[2] = {&reference, &test};
  const char* names[2] = {"reference", "test"};
  for (int i = 0; i < 2; ++i) {
    const Image& img = *images[i];
    if (img.width == 0 || img.height == 0) return Status::error("the %s image is empty", names[i]);
    if (img.rgb.size() != size_t(img.width) * img.height * 3)
      return Status::error("the %s image holds %zu values, %u x %u x 3 expected", names[i], img.rgb.size(), img.width,
                           img.height);
    for (size_t k = 0; k < img.rgb.size(); ++k)
      if (!std::isfinite(img.rgb[k])) {
        const size_t p = k / 3;
        return Status::error("the %s image has a non-finite value (%g) at pixel (%zu, %zu)", names[i],
                             double(img.rgb[k]), p % img.width, p / img.width);
      }
  }
  if (reference.width != test.width || reference.height != test.height)
    return Status::error("the images differ in size: reference %u x %u, test %u x %u", reference.width,
                         reference.height, test.width, test.height);
  return Status::ok();
}

void finish(FlipResult& result, const FlipSettings& settings) {
  result.stats = pool_errors(result.error);
  result.heatmap = settings.heatmap ? magma_heatmap(result.error, result.width, result.height) : Image{};
}

}  // namespace detail

Status ldr_flip(const Image& reference, const Image& test, const FlipSettings& settings, FlipResult& result) {
  if (Status s = detail::check_inputs(reference, test, settings); !s) return s.context("LDR-FLIP");
  Image ref = reference, tst = test;
  for (float& v : ref.rgb) v = std::clamp(v, 0.0f, 1.0f);
  for (float& v : tst.rgb) v = std::clamp(v, 0.0f, 1.0f);
  FlipResult r;
  r.width = reference.width;
  r.height = reference.height;
  r.error = detail::ldr_flip_map(ref, tst, settings.pixels_per_degree);
  detail::finish(r, settings);
  result = std::move(r);
  return Status::ok();
}

Image magma_heatmap(const std::vector<float>& errors, uint32_t width, uint32_t height) {
  Image img;
  if (errors.size() != size_t(width) * height) return img;
  const auto& table = detail::magma_table();
  std::array<std::array<float, 3>, 256> linear;
  for (size_t i = 0; i < 256; ++i)
    for (size_t c = 0; c < 3; ++c) linear[i][c] = detail::srgb_to_linear(table[i][c]);
  img.width = width;
  img.height = height;
  img.rgb.resize(errors.size() * 3);
  for (size_t i = 0; i < errors.size(); ++i) {
    const float e = std::isnan(errors[i]) ? 0.0f : std::clamp(errors[i], 0.0f, 1.0f);
    const auto& c = linear[size_t(std::lround(e * 255.0f))];
    img.rgb[i * 3] = c[0];
    img.rgb[i * 3 + 1] = c[1];
    img.rgb[i * 3 + 2] = c[2];
  }
  return img;
}

}  // namespace lsnif::flip
