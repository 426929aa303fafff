// filters.cpp -- the spatial filters of FLIP: the contrast sensitivity (CSF) kernels of the color
// pipeline (LDR-FLIP paper, section 4.1.1) and the edge / point detection kernels of the feature
// pipeline (section 4.2), all applied as separable passes with the border pixels repeated.
#include <algorithm>
#include <cmath>
#include <numbers>

#include <omp.h>

#include "lsnif/apps/flip/flip_detail.h"

namespace lsnif::flip::detail {

void filter_rows(const Plane& in, const std::vector<float>& kernel, Plane& out) {
  const int r = int(kernel.size() / 2);
  const int w = int(in.width), h = int(in.height);
  out = Plane(in.width, in.height);
  // A padded row per thread, allocated before the region (a failure inside it would abort).
  const size_t row = size_t(w + 2 * r);
  std::vector<float> rows(row * size_t(omp_get_max_threads()));
#pragma omp parallel
  {
    float* padded = rows.data() + row * size_t(omp_get_thread_num());
#pragma omp for schedule(static)
    for (int y = 0; y < h; ++y) {
      const float* src = in.v.data() + size_t(y) * size_t(w);
      for (int i = 0; i < w + 2 * r; ++i) padded[i] = src[std::clamp(i - r, 0, w - 1)];
      float* dst = out.v.data() + size_t(y) * size_t(w);
      for (int x = 0; x < w; ++x) {
        float sum = 0.0f;
        const float* p = padded + x;
        for (int k = 0; k <= 2 * r; ++k) sum += kernel[size_t(k)] * p[k];
        dst[x] = sum;
      }
    }
  }
}

void filter_columns(const Plane& in, const std::vector<float>& kernel, Plane& out) {
  const int r = int(kernel.size() / 2);
  const int w = int(in.width), h = int(in.height);
  out = Plane(in.width, in.height);
#pragma omp parallel for schedule(static)
  for (int y = 0; y < h; ++y) {
    float* dst = out.v.data() + size_t(y) * size_t(w);
    for (int k = 0; k <= 2 * r; ++k) {
      const float c = kernel[size_t(k)];
      const float* src = in.v.data() + size_t(std::clamp(y + k - r, 0, h - 1)) * size_t(w);
      for (int x = 0; x < w; ++x) dst[x] += c * src[x];
    }
  }
}

int csf_radius(double ppd) {
  double b_max = 0;
  for (const CsfParams& p : kCsf) b_max = std::max({b_max, p.b1, p.b2});
  const double pi = std::numbers::pi;
  return int(std::ceil(3.0 * std::sqrt(b_max / (2.0 * pi * pi)) * ppd));
}

namespace {

// The terms of the CSF kernel in double: weight w_t and the 1D Gaussian g_t(i) = exp(-pi^2 (i/ppd)^2 / b_t);
// the 2D kernel is sum_t w_t g_t(x) g_t(y) / total.
struct CsfTerms {
  int radius = 0;
  std::vector<double> weight;
  std::vector<std::vector<double>> gauss;
  double total = 0;
};

CsfTerms csf_terms(int channel, double ppd) {
  const CsfParams& p = kCsf[channel];
  const double pi = std::numbers::pi;
  CsfTerms t;
  t.radius = csf_radius(ppd);
  const double a[2] = {p.a1, p.a2}, b[2] = {p.b1, p.b2};
  for (int g = 0; g < 2; ++g) {
    if (a[g] == 0.0) continue;
    std::vector<double> v(size_t(2 * t.radius + 1));
    double sum = 0;
    for (int i = -t.radius; i <= t.radius; ++i) {
      const double x = double(i) / ppd;  // degrees
      v[size_t(i + t.radius)] = std::exp(-pi * pi * x * x / b[g]);
      sum += v[size_t(i + t.radius)];
    }
    const double w = a[g] * std::sqrt(pi / b[g]);
    t.weight.push_back(w);
    t.gauss.push_back(std::move(v));
    t.total += w * sum * sum;  // the 2D sum of this separable term
  }
  return t;
}

}  // namespace

std::vector<SeparableTerm> csf_kernel(int channel, double ppd) {
  const CsfTerms t = csf_terms(channel, ppd);
  std::vector<SeparableTerm> terms;
  for (size_t g = 0; g < t.gauss.size(); ++g) {
    SeparableTerm term;
    const double scale = t.weight[g] / t.total;
    for (double v : t.gauss[g]) {
      term.horizontal.push_back(float(v));
      term.vertical.push_back(float(v * scale));
    }
    terms.push_back(std::move(term));
  }
  return terms;
}

std::vector<double> csf_kernel_2d(int channel, double ppd) {
  const CsfTerms t = csf_terms(channel, ppd);
  const size_t n = size_t(2 * t.radius + 1);
  std::vector<double> k(n * n, 0.0);
  for (size_t g = 0; g < t.gauss.size(); ++g)
    for (size_t y = 0; y < n; ++y)
      for (size_t x = 0; x < n; ++x) k[y * n + x] += t.weight[g] * t.gauss[g][x] * t.gauss[g][y] / t.total;
  return k;
}

Plane apply_separable(const Plane& in, const std::vector<SeparableTerm>& terms) {
  Plane out(in.width, in.height), rows, cols;
  for (const SeparableTerm& t : terms) {
    filter_rows(in, t.horizontal, rows);
    filter_columns(rows, t.vertical, cols);
    for (size_t i = 0; i < out.v.size(); ++i) out.v[i] += cols.v[i];
  }
  return out;
}

FeatureKernels feature_kernels(double ppd) {
  FeatureKernels k;
  k.sigma = 0.5 * kFeatureWidth * ppd;
  k.radius = int(std::ceil(3.0 * k.sigma));
  const size_t n = size_t(2 * k.radius + 1);
  std::vector<double> g(n), d1(n), d2(n);
  double gsum = 0, p1 = 0, n1 = 0, p2 = 0, n2 = 0;
  for (int i = -k.radius; i <= k.radius; ++i) {
    const double x = double(i);
    const double gi = std::exp(-x * x / (2.0 * k.sigma * k.sigma));
    const size_t j = size_t(i + k.radius);
    g[j] = gi;
    d1[j] = -x * gi;
    d2[j] = (x * x / (k.sigma * k.sigma) - 1.0) * gi;
    gsum += gi;
    (d1[j] > 0 ? p1 : n1) += std::abs(d1[j]);
    (d2[j] > 0 ? p2 : n2) += std::abs(d2[j]);
  }
  for (size_t j = 0; j < n; ++j) {
    k.gauss.push_back(float(g[j] / gsum));
    k.d1.push_back(float(d1[j] > 0 ? d1[j] / p1 : d1[j] / n1));
    k.d2.push_back(float(d2[j] > 0 ? d2[j] / p2 : d2[j] / n2));
  }
  return k;
}

}  // namespace lsnif::flip::detail
