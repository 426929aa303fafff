// color_pipeline.cpp -- the color pipeline of LDR-FLIP (paper, section 4.1): both images go to the
// opponent space YCxCz, each channel is filtered with its contrast sensitivity kernel, the result
// goes back to linear RGB clamped to [0, 1] (the filters can leave the gamut), then to CIELAB with
// the Hunt adjustment; the per-pixel HyAB distance is redistributed to [0, 1].
#include <algorithm>

#include "lsnif/apps/flip/flip_detail.h"

namespace lsnif::flip::detail {
namespace {

// The image filtered in YCxCz, as Hunt-adjusted CIELAB per pixel.
std::vector<Vec3> filtered_hunt_lab(const Image& img, const std::vector<SeparableTerm> (&kernels)[3]) {
  const size_t n = size_t(img.width) * img.height;
  Plane channel[3];
  for (Plane& p : channel) p = Plane(img.width, img.height);
  for (size_t i = 0; i < n; ++i) {
    const Vec3 o = xyz_to_ycxcz(linear_rgb_to_xyz({img.rgb[i * 3], img.rgb[i * 3 + 1], img.rgb[i * 3 + 2]}));
    for (int c = 0; c < 3; ++c) channel[c].v[i] = o[size_t(c)];
  }
  Plane filtered[3];
  for (int c = 0; c < 3; ++c) filtered[c] = apply_separable(channel[c], kernels[c]);
  std::vector<Vec3> lab(n);
#pragma omp parallel for schedule(static)
  for (size_t i = 0; i < n; ++i) {
    Vec3 rgb = xyz_to_linear_rgb(ycxcz_to_xyz({filtered[0].v[i], filtered[1].v[i], filtered[2].v[i]}));
    for (float& v : rgb) v = std::clamp(v, 0.0f, 1.0f);
    lab[i] = linear_rgb_to_hunt_lab(rgb);
  }
  return lab;
}

}  // namespace

std::vector<float> color_error_map(const Image& reference, const Image& test, double ppd) {
  std::vector<SeparableTerm> kernels[3];
  for (int c = 0; c < 3; ++c) kernels[c] = csf_kernel(c, ppd);
  const std::vector<Vec3> ref = filtered_hunt_lab(reference, kernels);
  const std::vector<Vec3> tst = filtered_hunt_lab(test, kernels);
  std::vector<float> error(ref.size());
#pragma omp parallel for schedule(static)
  for (size_t i = 0; i < ref.size(); ++i) error[i] = redistribute_color_error(hyab(ref[i], tst[i]));
  return error;
}

}  // namespace lsnif::flip::detail
