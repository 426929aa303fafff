// feature_pipeline.cpp -- the feature pipeline of LDR-FLIP (paper, section 4.2): edges (first
// Gaussian derivative) and points (second derivative) are detected on the achromatic channel
// normalized to [0, 1]; the feature error is the larger of the differences in edge and in point
// magnitude between the images, scaled by 1/sqrt(2) into [0, 1] and raised to qf.
#include <algorithm>
#include <cmath>

#include "lsnif/apps/flip/flip_detail.h"

namespace lsnif::flip::detail {
namespace {

struct Magnitudes {
  std::vector<float> edge, point;
};

Magnitudes detect(const Image& img, const FeatureKernels& k) {
  const size_t n = size_t(img.width) * img.height;
  Plane gray(img.width, img.height);
  for (size_t i = 0; i < n; ++i) {
    const Vec3 o = xyz_to_ycxcz(linear_rgb_to_xyz({img.rgb[i * 3], img.rgb[i * 3 + 1], img.rgb[i * 3 + 2]}));
    gray.v[i] = (o[0] + 16.0f) / 116.0f;
  }
  // x derivatives: d(x) g(y); y derivatives: g(x) d(y).
  Plane rows_g, rows_d1, rows_d2, ex, ey, px, py;
  filter_rows(gray, k.gauss, rows_g);
  filter_rows(gray, k.d1, rows_d1);
  filter_rows(gray, k.d2, rows_d2);
  filter_columns(rows_d1, k.gauss, ex);
  filter_columns(rows_g, k.d1, ey);
  filter_columns(rows_d2, k.gauss, px);
  filter_columns(rows_g, k.d2, py);
  Magnitudes m;
  m.edge.resize(n);
  m.point.resize(n);
  for (size_t i = 0; i < n; ++i) {
    m.edge[i] = std::sqrt(ex.v[i] * ex.v[i] + ey.v[i] * ey.v[i]);
    m.point[i] = std::sqrt(px.v[i] * px.v[i] + py.v[i] * py.v[i]);
  }
  return m;
}

}  // namespace

std::vector<float> feature_error_map(const Image& reference, const Image& test, double ppd) {
  const FeatureKernels k = feature_kernels(ppd);
  const Magnitudes r = detect(reference, k), t = detect(test, k);
  std::vector<float> error(r.edge.size());
  const double inv_sqrt2 = 1.0 / std::sqrt(2.0);
  for (size_t i = 0; i < error.size(); ++i) {
    const double d = std::max(std::abs(double(r.edge[i]) - double(t.edge[i])),
                              std::abs(double(r.point[i]) - double(t.point[i])));
    error[i] = float(std::min(1.0, std::pow(d * inv_sqrt2, kQf)));
  }
  return error;
}

}  // namespace lsnif::flip::detail
