// flip.h -- the FLIP image difference evaluator (Andersson et al., "FLIP: A Difference Evaluator
// for Alternating Images", HPG 2020: LDR-FLIP; Andersson et al., "Visualizing Errors in Rendered
// High Dynamic Range Images", Eurographics 2021 short paper: HDR-FLIP), written from the papers.
// The renderer's evaluation compares its images with path-traced references through this, like
// section 6 of the LSNIF paper. docs/flip.md describes the stages, parameters and statistics.
//
// Images are image::Image: linear-light RGB, row 0 at the top (what image::load_image returns;
// 8-bit files are sRGB-decoded on load). LDR-FLIP clamps its inputs to [0, 1]; HDR-FLIP clamps
// negative values to 0. NaN or infinite values are refused.
#pragma once
#include <cstdint>
#include <optional>
#include <vector>

#include "lsnif/image/image_io.h"
#include "lsnif/format/status.h"

namespace lsnif::flip {

using image::Image;

// Pixels per degree of visual angle for an observer `distance_m` metres from a monitor
// `monitor_width_m` metres and `monitor_width_px` pixels wide: d * (px / w) * pi / 180. The papers'
// default viewing condition (0.7 m from a 0.7 m wide 3840-pixel monitor) gives 67.02.
double pixels_per_degree(double distance_m, double monitor_width_m, double monitor_width_px);

struct FlipSettings {
  double pixels_per_degree = 67.0;  // the papers' default; valid range [1, 2000]
  // HDR-FLIP exposure range in stops (exposure compensation 2^c). Unset: computed from the
  // reference as the HDR-FLIP paper does (the ACES tone-mapped 0.85 level at the maximum luminance
  // for the start, at the median luminance for the stop).
  std::optional<float> start_exposure, stop_exposure;
  uint32_t num_exposures = 0;  // HDR-FLIP; 0: max(2, ceil(stop - start)) as in the paper
  bool heatmap = true;         // fill FlipResult::heatmap
};

// Pooled statistics of an error map. The weighted percentiles weight every pixel by its own error
// (as the FLIP tool's "weighted median" / "weighted quartiles"): with the errors sorted ascending
// e_1 <= ... <= e_n and S = sum e_i, the weighted p-percentile is the first e_k whose running sum
// e_1 + ... + e_k exceeds p * S (0 when S = 0). See docs/flip.md.
struct FlipStatistics {
  double mean = 0, weighted_median = 0, weighted_quartile1 = 0, weighted_quartile3 = 0, min = 0, max = 0;
};
FlipStatistics pool_errors(const std::vector<float>& errors);

struct FlipResult {
  uint32_t width = 0, height = 0;
  std::vector<float> error;  // width * height per-pixel FLIP values in [0, 1], row 0 = top
  FlipStatistics stats;
  // The error map through the magma colormap (as the papers show it), as linear RGB so that
  // image::save_image writes magma's sRGB colours. Empty if FlipSettings::heatmap is false.
  Image heatmap;
  // HDR-FLIP only: the exposures used, and per pixel the index (0 .. num_exposures - 1) of the
  // exposure whose LDR-FLIP value was the largest (the first such one on ties).
  bool hdr = false;
  float start_exposure = 0, stop_exposure = 0;
  uint32_t num_exposures = 0;
  std::vector<uint32_t> exposure_index;
};

// LDR-FLIP of two images of equal size (values clamped to [0, 1]).
Status ldr_flip(const Image& reference, const Image& test, const FlipSettings& settings, FlipResult& result);

// HDR-FLIP: the per-pixel maximum of LDR-FLIP over exposures c in [start, stop] of the images
// exposed by 2^c, tone mapped with the ACES curve (Narkowicz's fit, 0.6 pre-exposure folded in)
// and clamped to [0, 1]. The automatic exposure range depends on the reference only.
Status hdr_flip(const Image& reference, const Image& test, const FlipSettings& settings, FlipResult& result);

// The magma colormap (matplotlib's 256 sRGB entries) at round(255 * clamp(e, 0, 1)), as linear RGB.
Image magma_heatmap(const std::vector<float>& errors, uint32_t width, uint32_t height);

}  // namespace lsnif::flip
