// hdr_flip.cpp -- HDR-FLIP (Eurographics 2021 short paper): LDR-FLIP evaluated on a series of
// exposures of both images, each exposed by 2^c, tone mapped and clamped to [0, 1]; the HDR-FLIP
// value of a pixel is its largest LDR-FLIP value over the exposures. The exposure range is
// computed from the reference unless given.
#include <algorithm>
#include <cmath>

#include "lsnif/apps/flip/flip_detail.h"

namespace lsnif::flip {
namespace detail {

double tone_map(double x) {
  const double* k = kAces;
  return (k[0] * x * x + k[1] * x + k[2]) / (k[3] * x * x + k[4] * x + k[5]);
}

double tone_map_inverse(double t) {
  const double* k = kAces;
  const double a = t * k[3] - k[0], b = t * k[4] - k[1], c = t * k[5] - k[2];
  if (a == 0.0) return -c / b;
  const double disc = std::sqrt(std::max(0.0, b * b - 4.0 * a * c));
  // For 0 <= t < k0 / k3 (the curve's limit) a < 0 <= c: one root is >= 0, the other <= 0.
  return std::max((-b + disc) / (2.0 * a), (-b - disc) / (2.0 * a));
}

float luminance(const Vec3& rgb) { return linear_rgb_to_xyz(rgb)[1]; }

void auto_exposure_range(const Image& reference, float& start, float& stop) {
  const size_t n = size_t(reference.width) * reference.height;
  std::vector<float> lum(n);
  float y_max = 0.0f;
  for (size_t i = 0; i < n; ++i) {
    Vec3 rgb = {reference.rgb[i * 3], reference.rgb[i * 3 + 1], reference.rgb[i * 3 + 2]};
    for (float& v : rgb) v = std::max(v, 0.0f);
    lum[i] = std::max(luminance(rgb), 0.0f);
    y_max = std::max(y_max, lum[i]);
  }
  start = stop = 0.0f;
  if (!(y_max > 0.0f)) return;
  std::nth_element(lum.begin(), lum.begin() + std::ptrdiff_t(n / 2), lum.end());
  float y_median = lum[n / 2];
  if (!(y_median > 0.0f)) {
    std::vector<float> positive;
    for (float v : lum)
      if (v > 0.0f) positive.push_back(v);
    std::nth_element(positive.begin(), positive.begin() + std::ptrdiff_t(positive.size() / 2), positive.end());
    y_median = positive[positive.size() / 2];
  }
  const double x085 = tone_map_inverse(0.85);
  start = float(std::log2(x085 / double(y_max)));
  stop = float(std::log2(x085 / double(y_median)));
}

Image expose_and_tone_map(const Image& img, float exposure) {
  Image out = img;
  const double scale = std::exp2(double(exposure));
  for (float& v : out.rgb) v = float(std::clamp(tone_map(std::max(0.0, double(v) * scale)), 0.0, 1.0));
  return out;
}

}  // namespace detail

Status hdr_flip(const Image& reference, const Image& test, const FlipSettings& settings, FlipResult& result) {
  if (Status s = detail::check_inputs(reference, test, settings); !s) return s.context("HDR-FLIP");
  float start = 0, stop = 0;
  if (!settings.start_exposure || !settings.stop_exposure) detail::auto_exposure_range(reference, start, stop);
  if (settings.start_exposure) start = *settings.start_exposure;
  if (settings.stop_exposure) stop = *settings.stop_exposure;
  if (!std::isfinite(start) || !std::isfinite(stop))
    return Status::error("HDR-FLIP: the exposure range [%g, %g] is not finite", double(start), double(stop));
  if (start > stop)
    return Status::error("HDR-FLIP: the start exposure %g is above the stop exposure %g", double(start), double(stop));
  uint32_t count = settings.num_exposures;
  if (count == 0) count = uint32_t(std::max(2.0, std::ceil(double(stop) - double(start))));
  if (count > 1000) return Status::error("HDR-FLIP: %u exposures are too many (at most 1000)", count);

  FlipResult r;
  r.width = reference.width;
  r.height = reference.height;
  r.hdr = true;
  r.start_exposure = start;
  r.stop_exposure = stop;
  r.num_exposures = count;
  r.error.assign(size_t(r.width) * r.height, 0.0f);
  r.exposure_index.assign(r.error.size(), 0);
  const double step = count > 1 ? (double(stop) - double(start)) / double(count - 1) : 0.0;
  std::vector<float> previous;
  for (uint32_t e = 0; e < count; ++e) {
    const float exposure = float(double(start) + double(e) * step);
    // Equal exposures (start == stop) give equal maps; evaluate once.
    std::vector<float> map = e > 0 && step == 0.0
                                 ? previous
                                 : detail::ldr_flip_map(detail::expose_and_tone_map(reference, exposure),
                                                        detail::expose_and_tone_map(test, exposure),
                                                        settings.pixels_per_degree);
    for (size_t i = 0; i < map.size(); ++i)
      if (e == 0 || map[i] > r.error[i]) {
        r.error[i] = map[i];
        r.exposure_index[i] = e;
      }
    previous = std::move(map);
  }
  detail::finish(r, settings);
  result = std::move(r);
  return Status::ok();
}

}  // namespace lsnif::flip
