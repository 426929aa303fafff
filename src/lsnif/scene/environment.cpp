// environment.cpp -- equirectangular environment map and its importance-sampling tables; the
// mapping, the distribution and the GPU layout are specified in environment.h.
#include "lsnif/scene/environment.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace lsnif::scene {
namespace {

constexpr float kPi = std::numbers::pi_v<float>;
constexpr float kOneMinusEpsilon = 1.0f - 1.0f / 16777216.0f;  // 1 - 2^-24: largest float < 1
constexpr uint64_t kMaxPixels = uint64_t(1) << 26;

glm::vec3 rotate_y(glm::vec3 d, float angle) {
  const float c = std::cos(angle), s = std::sin(angle);
  return glm::vec3(c * d.x + s * d.z, d.y, -s * d.x + c * d.z);
}

float luminance(const float* rgb) { return 0.2126f * rgb[0] + 0.7152f * rgb[1] + 0.0722f * rgb[2]; }

// The largest i in [0, n-1] with cdf[i] <= u, for a nondecreasing cdf of n + 1 entries with
// cdf[0] = 0 <= u < cdf[n] = 1.
uint32_t find_interval(const float* cdf, uint32_t n, float u) {
  const float* it = std::upper_bound(cdf, cdf + n + 1, u);
  const ptrdiff_t i = (it - cdf) - 1;
  return uint32_t(std::clamp<ptrdiff_t>(i, 0, ptrdiff_t(n) - 1));
}

float clamp_unit(float u) { return u >= 0.0f ? std::min(u, kOneMinusEpsilon) : 0.0f; }  // NaN -> 0

}  // namespace

glm::vec2 direction_to_uv(glm::vec3 direction, float rotation) {
  glm::vec3 e = rotate_y(direction, -rotation);
  const float len = glm::length(e);
  if (!(len > 0.0f) || !std::isfinite(len)) return glm::vec2(0.5f);
  e /= len;
  const float theta = std::acos(std::clamp(e.y, -1.0f, 1.0f));
  float phi = std::atan2(-e.x, e.z);
  if (phi < 0.0f) phi += 2.0f * kPi;
  return glm::vec2(std::min(phi / (2.0f * kPi), 1.0f), std::min(theta / kPi, 1.0f));
}

glm::vec3 uv_to_direction(glm::vec2 uv, float rotation) {
  const float phi = 2.0f * kPi * uv.x, theta = kPi * uv.y;
  const float st = std::sin(theta);
  return rotate_y(glm::vec3(-st * std::sin(phi), std::cos(theta), st * std::cos(phi)), rotation);
}

Status build_environment_map(const image::Image& image, glm::vec3 color, float rotation,
                             EnvironmentMap& out) {
  out = EnvironmentMap();
  const uint32_t W = image.width, H = image.height;
  if (W == 0 || H == 0 || uint64_t(W) * H > kMaxPixels)
    return Status::error("environment image size %ux%u unsupported (1x1 up to 2^26 pixels)", W, H);
  const size_t n = size_t(W) * H;
  if (image.rgb.size() != n * 3)
    return Status::error("environment image has %zu floats, %zu expected for %ux%u RGB",
                         image.rgb.size(), n * 3, W, H);
  if (!std::isfinite(color.x + color.y + color.z) || color.x < 0.0f || color.y < 0.0f || color.z < 0.0f)
    return Status::error("environment color must be finite and >= 0");
  if (!std::isfinite(rotation)) return Status::error("environment rotation must be finite");

  EnvironmentMap m;
  m.width = W;
  m.height = H;
  m.rotation = rotation;
  m.radiance.resize(n * 3);
  std::vector<double> lum(n);
  for (size_t i = 0; i < n; ++i) {
    for (int c = 0; c < 3; ++c) {
      const float v = image.rgb[3 * i + size_t(c)] * color[c];
      if (!std::isfinite(v))
        return Status::error("environment pixel (%zu, %zu) is NaN or infinite", i % W, i / W);
      m.radiance[3 * i + size_t(c)] = v;
    }
    lum[i] = std::max(0.0, double(luminance(&m.radiance[3 * i])));
  }

  // Solid angle of one pixel of each row; the weights are luminance x solid angle.
  std::vector<double> omega(H);
  for (uint32_t y = 0; y < H; ++y)
    omega[y] = (2.0 * std::numbers::pi / W) *
               (std::cos(std::numbers::pi * y / H) - std::cos(std::numbers::pi * (y + 1) / H));
  double total = 0.0;
  for (uint32_t y = 0; y < H; ++y)
    for (uint32_t x = 0; x < W; ++x) total += lum[size_t(y) * W + x] * omega[y];
  m.integral = total;
  if (!(total > 0.0) || !std::isfinite(total)) {  // black: uniform over the sphere
    std::fill(lum.begin(), lum.end(), 1.0);
    total = 0.0;
    for (uint32_t y = 0; y < H; ++y) total += double(W) * omega[y];
    m.integral = 0.0;
  }

  m.marginal_cdf.assign(size_t(H) + 1, 0.0f);
  m.conditional_cdf.assign(size_t(H) * (W + 1), 0.0f);
  m.pdf_table.resize(n);
  // Row sums in the same order as `total` (so the running sum ends exactly at `total`).
  double acc = 0.0;
  for (uint32_t y = 0; y < H; ++y) {
    double row = 0.0;
    for (uint32_t x = 0; x < W; ++x) row += lum[size_t(y) * W + x] * omega[y];
    float* c = &m.conditional_cdf[size_t(y) * (W + 1)];
    if (row > 0.0) {
      double racc = 0.0;
      for (uint32_t x = 0; x < W; ++x) {
        racc += lum[size_t(y) * W + x] * omega[y];
        c[x + 1] = float(racc / row);
      }
    } else {
      for (uint32_t x = 0; x <= W; ++x) c[x] = float(x) / float(W);
    }
    c[0] = 0.0f;
    c[W] = 1.0f;
    acc += row;
    m.marginal_cdf[y + 1] = float(acc / total);
    for (uint32_t x = 0; x < W; ++x) m.pdf_table[size_t(y) * W + x] = float(lum[size_t(y) * W + x] / total);
  }
  m.marginal_cdf[0] = 0.0f;
  m.marginal_cdf[H] = 1.0f;
  out = std::move(m);
  return Status::ok();
}

Status load_environment_map(const Environment& env, EnvironmentMap& out) {
  image::Image img;
  if (env.path.empty()) {
    img.width = img.height = 1;
    img.rgb = {1.0f, 1.0f, 1.0f};
  } else {
    Status s = image::load_image(env.path, img);
    if (!s) return s.context("environment");
  }
  Status s = build_environment_map(img, env.color, env.rotation, out);
  if (!s && !env.path.empty()) s.context(env.path);
  return s;
}

std::vector<float> EnvironmentMap::packed() const {
  std::vector<float> p;
  p.reserve(marginal_cdf.size() + conditional_cdf.size() + pdf_table.size());
  p.insert(p.end(), marginal_cdf.begin(), marginal_cdf.end());
  p.insert(p.end(), conditional_cdf.begin(), conditional_cdf.end());
  p.insert(p.end(), pdf_table.begin(), pdf_table.end());
  return p;
}

EnvironmentSample EnvironmentMap::sample(float u1, float u2) const {
  EnvironmentSample s;
  if (width == 0 || height == 0) return s;
  u1 = clamp_unit(u1);
  u2 = clamp_unit(u2);
  const uint32_t y = find_interval(marginal_cdf.data(), height, u1);
  const float m0 = marginal_cdf[y], m1 = marginal_cdf[y + 1];
  const float fy = m1 > m0 ? std::clamp((u1 - m0) / (m1 - m0), 0.0f, 1.0f) : 0.5f;
  const float* c = &conditional_cdf[size_t(y) * (width + 1)];
  const uint32_t x = find_interval(c, width, u2);
  const float fx = c[x + 1] > c[x] ? std::clamp((u2 - c[x]) / (c[x + 1] - c[x]), 0.0f, 1.0f) : 0.5f;
  const float phi = 2.0f * kPi * (float(x) + fx) / float(width);
  const float cos0 = std::cos(kPi * float(y) / float(height));
  const float cos1 = std::cos(kPi * float(y + 1) / float(height));
  const float cos_theta = cos0 + (cos1 - cos0) * fy;
  const float sin_theta = std::sqrt(std::max(0.0f, 1.0f - cos_theta * cos_theta));
  s.direction = rotate_y(glm::vec3(-sin_theta * std::sin(phi), cos_theta, sin_theta * std::cos(phi)),
                         rotation);
  s.pdf = pdf_table[size_t(y) * width + x];
  s.x = x;
  s.y = y;
  return s;
}

glm::uvec2 EnvironmentMap::pixel(glm::vec3 direction) const {
  const glm::vec2 uv = direction_to_uv(direction, rotation);
  const uint32_t x = std::min(uint32_t(uv.x * float(width)), width - 1);
  const uint32_t y = std::min(uint32_t(uv.y * float(height)), height - 1);
  return glm::uvec2(x, y);
}

float EnvironmentMap::pdf(glm::vec3 direction) const {
  if (width == 0 || height == 0) return 0.0f;
  const glm::uvec2 p = pixel(direction);
  return pdf_table[size_t(p.y) * width + p.x];
}

glm::vec3 EnvironmentMap::lookup(glm::vec3 direction) const {
  if (width == 0 || height == 0) return glm::vec3(0.0f);
  const glm::uvec2 p = pixel(direction);
  const float* r = &radiance[(size_t(p.y) * width + p.x) * 3];
  return glm::vec3(r[0], r[1], r[2]);
}

}  // namespace lsnif::scene
