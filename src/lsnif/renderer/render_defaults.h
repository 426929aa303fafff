// render_defaults.h -- the default image of a render: RenderSettings (renderer.h) starts from it,
// and `lsnif demo` and the benchmarks (`lsnif bench`) render it unless told otherwise. Constants
// only, no dependencies, so that a tool's help text and a scene's framing can use them.
#pragma once
#include <cstdint>

namespace lsnif::render {

inline constexpr uint32_t kDefaultImageWidth = 320;   // pixels
inline constexpr uint32_t kDefaultImageHeight = 240;  // pixels
inline constexpr uint32_t kDefaultSpp = 16;           // samples (paths) per pixel
// The ranges of what a caller may ask for (the tools' options, the Python module's arguments): an
// image side in pixels, samples per pixel, path bounces after the camera.
inline constexpr uint32_t kMaxImageSide = 16384, kMaxSpp = 1u << 20, kMaxBounces = 64;

}  // namespace lsnif::render
