// flip_detail.h -- the stages of FLIP, exposed for the tests and for readers who want to follow the
// papers step by step. One file per stage: color_space.cpp (sRGB, XYZ, YCxCz, CIELAB, Hunt, HyAB),
// filters.cpp (the CSF and feature kernels, separable convolution), color_pipeline.cpp,
// feature_pipeline.cpp, flip.cpp (LDR-FLIP), hdr_flip.cpp (tone mapper, exposure range, loop),
// pooling.cpp (statistics), magma.cpp (the colormap).
#pragma once
#include <array>
#include <cstdint>
#include <vector>

#include "lsnif/apps/flip/flip.h"

namespace lsnif::flip::detail {

using Vec3 = std::array<float, 3>;

// ---- constants of the papers -------------------------------------------------------------------
// CSF of each opponent channel (A = achromatic Y, RG = Cx, BY = Cz) as a sum of two Gaussians in
// the frequency domain, a1 exp(-b1 f^2) + a2 exp(-b2 f^2); in the spatial domain (x in degrees)
// a1 sqrt(pi / b1) exp(-pi^2 x^2 / b1) + a2 sqrt(pi / b2) exp(-pi^2 x^2 / b2).
struct CsfParams {
  double a1, b1, a2, b2;
};
constexpr CsfParams kCsf[3] = {
    {1.0, 0.0047, 0.0, 1.0e-5},   // A
    {1.0, 0.0053, 0.0, 1.0e-5},   // RG
    {34.1, 0.04, 13.5, 0.025},    // BY
};
constexpr double kQc = 0.7;    // color error exponent
constexpr double kPc = 0.4;    // fraction of cmax where the error compression starts ...
constexpr double kPt = 0.95;   // ... mapped to this error
constexpr double kQf = 0.5;    // feature error exponent
constexpr double kFeatureWidth = 0.082;  // w in degrees: feature filters use sigma = 0.5 w ppd

// ---- color spaces (color_space.cpp) -------------------------------------------------------------
float srgb_to_linear(float c);
float linear_to_srgb(float c);
// The sRGB matrices are derived from the primaries R(0.64, 0.33), G(0.30, 0.60), B(0.15, 0.06)
// and the D65 white (0.3127, 0.3290) with Y_white = 1; the reference white of the XYZ-based
// spaces below is the matrix applied to RGB (1, 1, 1).
Vec3 linear_rgb_to_xyz(const Vec3& rgb);
Vec3 xyz_to_linear_rgb(const Vec3& xyz);
Vec3 white_xyz();
// YCxCz (Johnson & Fairchild's linearized CIELAB): Y = 116 y - 16, Cx = 500 (x - y), Cz = 200 (y - z)
// with x, y, z the white-normalized X, Y, Z.
Vec3 xyz_to_ycxcz(const Vec3& xyz);
Vec3 ycxcz_to_xyz(const Vec3& ycxcz);
Vec3 xyz_to_lab(const Vec3& xyz);
// Hunt effect: a and b scaled by 0.01 L.
Vec3 hunt_adjust(const Vec3& lab);
// HyAB distance: |dL| + sqrt(da^2 + db^2).
float hyab(const Vec3& lab1, const Vec3& lab2);
// linear RGB in [0, 1] -> CIELAB -> Hunt-adjusted.
Vec3 linear_rgb_to_hunt_lab(const Vec3& rgb);
// cmax^qc with cmax = HyAB(Hunt(green), Hunt(blue)), the largest distance in the sRGB gamut.
double max_color_error();
// The error redistribution of the color pipeline: HyAB distance -> color error in [0, 1].
float redistribute_color_error(float hyab_distance);

// ---- filters (filters.cpp) ----------------------------------------------------------------------
// A single-channel float image, row-major, row 0 = top.
struct Plane {
  uint32_t width = 0, height = 0;
  std::vector<float> v;
  Plane() = default;
  Plane(uint32_t w, uint32_t h) : width(w), height(h), v(size_t(w) * h, 0.0f) {}
  float& at(uint32_t x, uint32_t y) { return v[size_t(y) * width + x]; }
  float at(uint32_t x, uint32_t y) const { return v[size_t(y) * width + x]; }
};
// out(x, y) = sum_k kernel[k] * in(x + k - r, y) with r = kernel.size() / 2 (a correlation; all
// kernels here are symmetric or antisymmetric, so only a sign can differ from a convolution), the
// image extended by repeating its border pixels.
void filter_rows(const Plane& in, const std::vector<float>& kernel, Plane& out);
void filter_columns(const Plane& in, const std::vector<float>& kernel, Plane& out);

// Radius of the CSF filters: ceil(3 sqrt(b_max / (2 pi^2)) ppd), b_max the largest b of all channels.
int csf_radius(double ppd);
// A 2D kernel written as a sum of separable terms: K(x, y) = sum_t horizontal_t(x) vertical_t(y).
struct SeparableTerm {
  std::vector<float> horizontal, vertical;
};
// The CSF kernel of channel 0 (A), 1 (RG) or 2 (BY): the spatial-domain formula above sampled at
// pixel offsets / ppd degrees on a (2r+1)^2 grid, normalized to sum 1. Each Gaussian is separable,
// so the kernel is one term per Gaussian with a nonzero weight (A, RG: one; BY: two).
std::vector<SeparableTerm> csf_kernel(int channel, double ppd);
// The same kernel as a dense (2r+1)^2 array (row-major), for tests and illustration.
std::vector<double> csf_kernel_2d(int channel, double ppd);
Plane apply_separable(const Plane& in, const std::vector<SeparableTerm>& terms);

// Feature detection kernels for sigma = 0.5 w ppd and radius ceil(3 sigma): the Gaussian (sum 1)
// and its first and second derivatives along one axis, each derivative with its positive weights
// normalized to sum 1 and its negative weights to sum -1. The 2D edge filter along x is
// d1(x) g(y) and the point filter d2(x) g(y) (transposed for y); their positive / negative parts
// then also sum to +1 / -1 in 2D.
struct FeatureKernels {
  int radius = 0;
  double sigma = 0;
  std::vector<float> gauss, d1, d2;
};
FeatureKernels feature_kernels(double ppd);

// ---- pipelines ----------------------------------------------------------------------------------
// Both take linear RGB already clamped to [0, 1] (and of equal size).
// Color pipeline: YCxCz, CSF filtering per channel, back to linear RGB clamped to [0, 1], CIELAB,
// Hunt, HyAB, redistribution. Per-pixel color error in [0, 1].
std::vector<float> color_error_map(const Image& reference, const Image& test, double ppd);
// Feature pipeline on the achromatic channel normalized to [0, 1], (Y + 16) / 116: edge and point
// magnitudes, (max(|d edge|, |d point|) / sqrt(2))^qf. Per-pixel feature error in [0, 1].
std::vector<float> feature_error_map(const Image& reference, const Image& test, double ppd);
// FLIP = color^(1 - feature), per pixel.
std::vector<float> combine(const std::vector<float>& color, const std::vector<float>& feature);
// LDR-FLIP map of inputs already clamped to [0, 1].
std::vector<float> ldr_flip_map(const Image& reference, const Image& test, double ppd);
// The checks shared by ldr_flip and hdr_flip: ppd in range, images non-empty, consistent, finite
// and of equal size.
Status check_inputs(const Image& reference, const Image& test, const FlipSettings& settings);
// Fills result.stats and (if asked for) result.heatmap from result.error.
void finish(FlipResult& result, const FlipSettings& settings);

// ---- HDR-FLIP (hdr_flip.cpp) --------------------------------------------------------------------
// ACES (Narkowicz's fit with the 0.6 pre-exposure folded in) as the rational function
// (k0 x^2 + k1 x + k2) / (k3 x^2 + k4 x + k5).
constexpr double kAces[6] = {0.6 * 0.6 * 2.51, 0.6 * 0.03, 0.0, 0.6 * 0.6 * 2.43, 0.6 * 0.59, 0.14};
double tone_map(double x);
// The x >= 0 with tone_map(x) = t (the positive root of (t k3 - k0) x^2 + (t k4 - k1) x + t k5 - k2).
double tone_map_inverse(double t);
// Luminance of linear RGB (the Y row of the sRGB matrix).
float luminance(const Vec3& rgb);
// The automatic exposure range: start = log2(x_0.85 / Y_max), stop = log2(x_0.85 / Y_median) of
// the reference, x_0.85 = tone_map_inverse(0.85). If the median is 0, the median of the positive
// luminances is used; if there is none, both are 0.
void auto_exposure_range(const Image& reference, float& start, float& stop);
// exposure -> tone map -> clamp to [0, 1], per channel (negative inputs count as 0).
Image expose_and_tone_map(const Image& img, float exposure);

// ---- colormap (magma.cpp) -----------------------------------------------------------------------
// matplotlib's magma, 256 sRGB-encoded entries.
const std::array<std::array<float, 3>, 256>& magma_table();

}  // namespace lsnif::flip::detail
