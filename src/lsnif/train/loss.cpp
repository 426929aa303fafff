#include "lsnif/train/loss.h"

#include <algorithm>
#include <cmath>

#include "lsnif/core/head.h"
#include "lsnif/format/status.h"

namespace lsnif {

const char* to_string(NormalLoss l) {
  for (const SettingChoice& c : kNormalLossChoices)
    if (c.value == static_cast<uint32_t>(l)) return c.name;
  return "unknown";
}
static_assert(kNormalLossChoices[0].value == static_cast<uint32_t>(NormalLoss::Angle) &&
              kNormalLossChoices[1].value == static_cast<uint32_t>(NormalLoss::Cosine));

std::string LossSettings::describe() const {
  return format("loss weights occ=%g dist=%g normal=%g albedo=%g mat=%g surface=%g, normal loss %s",
                double(occlusion), double(distance), double(normal), double(albedo), double(material),
                double(surface), to_string(normal_loss));
}

LossTerms ray_loss(const Config& config, const float* raw, const LossTarget& target,
                   const LossSettings& weights, float scale, float* d_raw) {
  LossTerms terms;
  std::fill(d_raw, d_raw + config.output_dim(), 0.0f);

  // Occlusion: binary cross-entropy on sigmoid(z), computed stably from the logit.
  const float z = raw[LSNIF_OUT_OCCLUSION], y = target.hit ? 1.0f : 0.0f;
  terms.occlusion = weights.occlusion * (std::max(z, 0.0f) - z * y + std::log1p(std::exp(-std::fabs(z))));
  d_raw[LSNIF_OUT_OCCLUSION] = scale * weights.occlusion * (sigmoid(z) - y);
  if (!target.hit) return terms;

  // Distance: |s - s*| with s = sigmoid(z_d).
  const float s = sigmoid(raw[LSNIF_OUT_DISTANCE]);
  const float diff = s - target.s;
  terms.distance = weights.distance * std::fabs(diff);
  const float sign = diff > 0.0f ? 1.0f : (diff < 0.0f ? -1.0f : 0.0f);
  d_raw[LSNIF_OUT_DISTANCE] = scale * weights.distance * sign * s * (1.0f - s);

  // Normal: 1 - cos(n, n*).
  const glm::vec3 n(raw[LSNIF_OUT_NORMAL], raw[LSNIF_OUT_NORMAL + 1], raw[LSNIF_OUT_NORMAL + 2]);
  const float len = std::max(glm::length(n), 1e-8f);
  const glm::vec3 nt = glm::normalize(target.normal);
  const float cosine = glm::dot(n, nt) / len;
  // d(cos)/dn = (nt - cos n/|n|) / |n|
  glm::vec3 dn = (nt - cosine * n / len) / len;
  if (weights.normal_loss == NormalLoss::Cosine) {
    terms.normal = weights.normal * (1.0f - cosine);
    dn = -dn;
  } else {
    // theta = acos(cos); clamped away from +-1 where d(theta)/d(cos) is infinite.
    const float cc = std::clamp(cosine, -0.999999f, 0.999999f);
    terms.normal = weights.normal * std::acos(cc);
    dn *= -1.0f / std::sqrt(1.0f - cc * cc);
  }
  for (int c = 0; c < 3; ++c) d_raw[LSNIF_OUT_NORMAL + c] = scale * weights.normal * dn[c];

  // Albedo: relative L2, mean over channels, denominator (a^2 + 0.01) held constant.
  double albedo_loss = 0;
  for (int c = 0; c < 3; ++c) {
    const float a = sigmoid(raw[LSNIF_OUT_ALBEDO + c]);
    const float denom = a * a + 0.01f;
    const float e = a - target.albedo[c];
    albedo_loss += e * e / denom;
    d_raw[LSNIF_OUT_ALBEDO + c] = scale * weights.albedo * (2.0f * e / denom / 3.0f) * a * (1.0f - a);
  }
  terms.albedo = weights.albedo * albedo_loss / 3.0;

  // Surface channels: squared error on metallic, roughness and ambient occlusion, relative L2 (as the
  // albedo's) on the emission in units of the emission scale; the mean of the six.
  if (config.surface_channels) {
    const uint32_t base = config.surface_output();
    const float targets[LSNIF_OUT_SURFACE_COUNT] = {
        target.metallic, target.roughness, target.ambient_occlusion,
        config.emission_scale > 0.0f ? target.emission.r / config.emission_scale : 0.0f,
        config.emission_scale > 0.0f ? target.emission.g / config.emission_scale : 0.0f,
        config.emission_scale > 0.0f ? target.emission.b / config.emission_scale : 0.0f};
    double surface_loss = 0;
    for (uint32_t c = 0; c < LSNIF_OUT_SURFACE_COUNT; ++c) {
      const float a = sigmoid(raw[base + c]);
      const float e = a - targets[c];
      const float denom = c >= LSNIF_OUT_SURFACE_EMISSION ? a * a + 0.01f : 1.0f;
      surface_loss += e * e / denom;
      d_raw[base + c] = scale * weights.surface * (2.0f * e / denom / float(LSNIF_OUT_SURFACE_COUNT)) * a * (1.0f - a);
    }
    terms.surface = weights.surface * surface_loss / double(LSNIF_OUT_SURFACE_COUNT);
  }

  // Material: softmax cross-entropy.
  if (config.material_count > 1) {
    const float* logits = raw + LSNIF_OUT_MATERIAL;
    float mx = logits[0];
    for (uint32_t m = 1; m < config.material_count; ++m) mx = std::max(mx, logits[m]);
    double sum = 0;
    for (uint32_t m = 0; m < config.material_count; ++m) sum += std::exp(double(logits[m] - mx));
    const double log_sum = std::log(sum) + mx;
    terms.material = weights.material * (log_sum - logits[target.material]);
    for (uint32_t m = 0; m < config.material_count; ++m) {
      const double p = std::exp(double(logits[m]) - log_sum);
      d_raw[LSNIF_OUT_MATERIAL + m] =
          scale * weights.material * float(p - (m == target.material ? 1.0 : 0.0));
    }
  }
  return terms;
}

}  // namespace lsnif
