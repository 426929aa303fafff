// environment.h -- the environment light (scene.h Environment): an equirectangular image of linear
// RGB radiance and its importance-sampling tables, laid out to be uploaded to the GPU as one float
// array, with CPU twins of the shader's sample() and pdf() for tests and reference renders.
//
// Direction <-> image mapping (the renderer's GLSL must use exactly this):
//   u = (x + 0.5) / W across columns, v = (y + 0.5) / H down rows (row 0 = top of the image);
//   phi = 2 pi u, theta = pi v (polar angle from +y; row 0 looks up);
//   d_env = (-sin(theta) sin(phi), cos(theta), sin(theta) cos(phi)),
//   so the image centre (u, v) = (0.5, 0.5) is -z (where a default glTF camera looks), u = 0.75 is
//   +x (to the viewer's right, the image is not mirrored), u = 0 / 1 is +z (behind).
//   The environment is rotated by `rotation` radians about +y: d_world = Ry(rotation) d_env with
//   Ry(a) (x, y, z) = (cos a x + sin a z, y, -sin a x + cos a z); a lookup uses Ry(-rotation).
//   Inverse: theta = acos(clamp(d_env.y, -1, 1)), phi = atan2(-d_env.x, d_env.z) wrapped into
//   [0, 2 pi); pixel x = min(floor(phi / (2 pi) W), W-1), y = min(floor(theta / pi H), H-1).
//
// Sampling distribution: pixel (x, y) is chosen with probability proportional to
//   luminance(x, y) * solid_angle(row y),  solid_angle(y) = (2 pi / W) (cos(theta0) - cos(theta1))
// with theta0 = pi y / H, theta1 = pi (y+1) / H (that is luminance x sin(theta at the row centre)
// up to a constant factor), luminance = 0.2126 R + 0.7152 G + 0.0722 B of radiance = image x color
// (negative values count as 0). Within the pixel the direction is uniform in solid angle (phi
// uniform, cos(theta) uniform between the row's bounds), so the solid-angle pdf is constant per
// pixel: pdf = luminance(x, y) / integral, integral = sum of luminance x solid angle over all
// pixels (= the integral of luminance over the sphere). A black environment (integral 0) falls back
// to uniform sphere sampling: every pixel weighs its solid angle and pdf = 1 / (4 pi).
//
// GPU layout (EnvironmentMap::packed(), floats, W = width, H = height):
//   [0, H+1)                       marginal CDF over rows: m[0] = 0, m[H] = 1, nondecreasing
//   [H+1, H+1 + H(W+1))            conditional CDFs, row y at offset H+1 + y (W+1): c[0] = 0,
//                                  c[W] = 1 (a row of zero weight is uniform: c[x] = x / W)
//   [H+1 + H(W+1), ... + W H)      solid-angle pdf of each pixel, row-major (y W + x)
// sample(u1, u2), u in [0, 1) (clamped to [0, 1 - 2^-24]):
//   y  = the largest index in [0, H-1] with m[y] <= u1 (binary search); fy = (u1 - m[y]) / (m[y+1] - m[y])
//   x  = the largest index in [0, W-1] with c_y[x] <= u2;                 fx = (u2 - c_y[x]) / (c_y[x+1] - c_y[x])
//   phi = 2 pi (x + fx) / W;  cos(theta) = mix(cos(pi y / H), cos(pi (y+1) / H), fy)
//   direction = Ry(rotation) d_env(theta, phi);  pdf = pdf_table[y W + x]
// pdf(direction) = pdf_table[pixel(direction)], 0 for pixels of zero luminance (BSDF sampling
// covers those; combine with MIS).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "lsnif/image/image_io.h"
#include "lsnif/scene/scene.h"
#include "lsnif/format/status.h"

namespace lsnif::scene {

struct EnvironmentSample {
  glm::vec3 direction{0.0f, 1.0f, 0.0f};  // unit, world space, pointing away from the scene
  float pdf = 0.0f;                       // w.r.t. solid angle
  uint32_t x = 0, y = 0;                  // the sampled pixel
};

struct EnvironmentMap {
  uint32_t width = 0, height = 0;
  float rotation = 0.0f;                // radians about +y
  std::vector<float> radiance;          // width * height * 3 linear RGB = image x color, row 0 = top
  std::vector<float> marginal_cdf;      // height + 1
  std::vector<float> conditional_cdf;   // height * (width + 1)
  std::vector<float> pdf_table;         // width * height, solid-angle pdf per pixel
  double integral = 0.0;                // integral of luminance over the sphere (0: black map)

  // marginal_cdf, conditional_cdf and pdf_table concatenated (layout above).
  std::vector<float> packed() const;
  size_t conditional_offset() const { return size_t(height) + 1; }
  size_t pdf_offset() const { return conditional_offset() + size_t(height) * (size_t(width) + 1); }

  // CPU twins of the shader functions. `sample` expects u1, u2 in [0, 1).
  EnvironmentSample sample(float u1, float u2) const;
  float pdf(glm::vec3 direction) const;
  // Nearest-pixel radiance seen along a world direction (no filtering).
  glm::vec3 lookup(glm::vec3 direction) const;
  // Pixel containing a world direction (the mapping above).
  glm::uvec2 pixel(glm::vec3 direction) const;
};

// Builds the map and its tables from a linear RGB image (any size >= 1x1, at most 2^26 pixels;
// finite pixels), multiplied by `color` (>= 0), rotated by `rotation` radians about +y.
Status build_environment_map(const image::Image& image, glm::vec3 color, float rotation,
                             EnvironmentMap& out);

// The scene's environment: env.path read with image::load_image (HDR or 8-bit, linear), or a 1x1
// white image when the path is empty (a constant environment of radiance env.color).
Status load_environment_map(const Environment& env, EnvironmentMap& out);

// The mapping above, rotation included: world direction (any length > 0) <-> (u, v) in [0, 1]^2.
glm::vec2 direction_to_uv(glm::vec3 direction, float rotation);
glm::vec3 uv_to_direction(glm::vec2 uv, float rotation);

}  // namespace lsnif::scene
