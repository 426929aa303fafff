// Every loss term's gradient w.r.t. the raw outputs against central finite differences (double-
// checked on many random inputs), plus the masking rule and known values.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "lsnif/train/loss.h"

namespace lsnif {
namespace {

Config config_with_materials(uint32_t n, bool surface = false) {
  Config c;
  c.material_count = n;
  c.surface_channels = surface ? 1u : 0u;
  c.emission_scale = surface ? 4.0f : 0.0f;
  return c;
}

void check_gradient(const Config& c, const LossTarget& target, const LossSettings& w, std::vector<float> raw) {
  std::vector<float> grad(c.output_dim());
  ray_loss(c, raw.data(), target, w, 1.0f, grad.data());
  std::vector<float> scratch(c.output_dim());
  auto sig = [](double x) { return 1.0 / (1.0 + std::exp(-x)); };
  for (uint32_t i = 0; i < c.output_dim(); ++i) {
    if (i >= LSNIF_OUT_ALBEDO && i < LSNIF_OUT_ALBEDO + 3) {
      // Relative L2 holds its denominator (a^2 + 0.01) constant: differentiate that frozen form.
      if (!target.hit) {
        EXPECT_EQ(grad[i], 0.0f);
        continue;
      }
      const int ch = int(i - LSNIF_OUT_ALBEDO);
      const double a0 = sig(raw[i]), denom = a0 * a0 + 0.01, h = 1e-3;
      auto frozen = [&](double x) {
        double e = sig(x) - target.albedo[ch];
        return w.albedo * e * e / denom / 3.0;
      };
      double fd = (frozen(raw[i] + h) - frozen(raw[i] - h)) / (2 * h);
      ASSERT_NEAR(grad[i], fd, 1e-4 + 1e-3 * std::fabs(fd)) << "albedo output " << i;
      continue;
    }
    const uint32_t emission = c.surface_output() + LSNIF_OUT_SURFACE_EMISSION;
    if (c.surface_channels && i >= emission && i < emission + 3) {
      // The emission's relative L2 (in units of the emission scale) freezes its denominator too.
      if (!target.hit) {
        EXPECT_EQ(grad[i], 0.0f);
        continue;
      }
      const int ch = int(i - emission);
      const double y = target.emission[ch] / c.emission_scale, a0 = sig(raw[i]), denom = a0 * a0 + 0.01, h = 1e-3;
      auto frozen = [&](double x) {
        double e = sig(x) - y;
        return w.surface * e * e / denom / LSNIF_OUT_SURFACE_COUNT;
      };
      double fd = (frozen(raw[i] + h) - frozen(raw[i] - h)) / (2 * h);
      ASSERT_NEAR(grad[i], fd, 1e-4 + 1e-3 * std::fabs(fd)) << "emission output " << i;
      continue;
    }
    const float h = 1e-3f;
    std::vector<float> rp = raw, rm = raw;
    rp[i] += h;
    rm[i] -= h;
    double lp = ray_loss(c, rp.data(), target, w, 1.0f, scratch.data()).total();
    double lm = ray_loss(c, rm.data(), target, w, 1.0f, scratch.data()).total();
    double fd = (lp - lm) / (2.0 * h);
    ASSERT_NEAR(grad[i], fd, 3e-3 + 1e-2 * std::fabs(fd)) << "output " << i;
  }
}

TEST(Loss, GradientsMatchFiniteDifferences) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> u(-2, 2), u01(0.05f, 0.95f);
  for (uint32_t nmat : {1u, 4u, 2u}) {
    Config c = config_with_materials(nmat, nmat == 2);
    for (int trial = 0; trial < 300; ++trial) {
      std::vector<float> raw(c.output_dim());
      for (float& v : raw) v = u(rng);
      LossTarget t;
      t.hit = trial % 3 != 0;
      t.s = u01(rng);
      // keep away from the MAE kink |s - s*| = 0, where the derivative is undefined
      const float s = 1.0f / (1.0f + std::exp(-raw[LSNIF_OUT_DISTANCE]));
      if (std::fabs(s - t.s) < 0.02f) t.s = s > 0.5f ? s - 0.2f : s + 0.2f;
      t.normal = glm::vec3(u(rng), u(rng), u(rng));
      t.albedo = glm::vec3(u01(rng), u01(rng), u01(rng));
      t.material = uint32_t(trial) % nmat;
      t.metallic = u01(rng);
      t.roughness = u01(rng);
      t.ambient_occlusion = u01(rng);
      t.emission = 4.0f * glm::vec3(u01(rng), u01(rng), u01(rng));
      LossSettings w;
      w.surface = 0.8f;
      w.distance = 0.7f;
      w.normal = 1.3f;
      w.normal_loss = trial % 2 ? NormalLoss::Angle : NormalLoss::Cosine;
      check_gradient(c, t, w, raw);
    }
  }
}

TEST(Loss, MissesOnlyTrainOcclusion) {
  Config c = config_with_materials(3);
  std::vector<float> raw(c.output_dim(), 0.3f), grad(c.output_dim());
  LossTarget miss;  // hit = false
  LossTerms t = ray_loss(c, raw.data(), miss, LossSettings(), 1.0f, grad.data());
  EXPECT_GT(t.occlusion, 0.0);
  EXPECT_EQ(t.distance + t.normal + t.albedo + t.material, 0.0);
  for (uint32_t i = 1; i < c.output_dim(); ++i) EXPECT_EQ(grad[i], 0.0f);
}

TEST(Loss, SurfaceChannelsKnownValues) {
  Config c = config_with_materials(3, true);
  ASSERT_EQ(c.output_dim(), LSNIF_OUT_FIXED + 3 + LSNIF_OUT_SURFACE_COUNT);
  std::vector<float> raw(c.output_dim(), 0.0f), grad(c.output_dim());  // every sigmoid 0.5
  LossTarget t;
  t.hit = true;
  t.normal = glm::vec3(0, 0, 1);
  t.metallic = 1.0f;                       // (0.5 - 1)^2 = 0.25
  t.roughness = 0.5f;                      // 0
  t.ambient_occlusion = 0.0f;              // 0.25
  t.emission = glm::vec3(2.0f, 0.0f, 2.0f);  // / scale 4: 0.5, 0, 0.5 -> 0, 0.25 / 0.26, 0
  LossSettings w;
  w.surface = 2.0f;
  const LossTerms l = ray_loss(c, raw.data(), t, w, 1.0f, grad.data());
  EXPECT_NEAR(l.surface, 2.0 * (0.25 + 0.25 + 0.25 / 0.26) / 6.0, 1e-6);
  // A miss trains none of them; a model without surface channels has no such term.
  LossTarget miss;
  EXPECT_EQ(ray_loss(c, raw.data(), miss, w, 1.0f, grad.data()).surface, 0.0);
  Config plain = config_with_materials(3);
  std::vector<float> raw_plain(plain.output_dim(), 0.0f), grad_plain(plain.output_dim());
  EXPECT_EQ(ray_loss(plain, raw_plain.data(), t, w, 1.0f, grad_plain.data()).surface, 0.0);
}

TEST(Loss, KnownValues) {
  Config c = config_with_materials(2);
  std::vector<float> raw(c.output_dim(), 0.0f), grad(c.output_dim());
  raw[LSNIF_OUT_NORMAL] = 2.0f;  // normal (2,0,0) vs target (0,0,1): cos = 0 -> loss 1
  LossTarget t;
  t.hit = true;
  t.s = 0.25f;                   // sigmoid(0) = 0.5 -> MAE 0.25
  t.normal = glm::vec3(0, 0, 1);
  t.albedo = glm::vec3(0.5f);    // sigmoid(0) = 0.5 -> rel L2 0
  t.material = 1;                // two equal logits -> CE log 2
  LossSettings cosine;
  cosine.normal_loss = NormalLoss::Cosine;
  LossTerms l = ray_loss(c, raw.data(), t, cosine, 1.0f, grad.data());
  EXPECT_NEAR(l.occlusion, std::log(2.0), 1e-6);
  EXPECT_NEAR(l.distance, 0.25, 1e-6);
  EXPECT_NEAR(l.normal, 1.0, 1e-6);
  LossSettings angle;
  angle.normal_loss = NormalLoss::Angle;
  EXPECT_NEAR(ray_loss(c, raw.data(), t, angle, 1.0f, grad.data()).normal, 3.14159265 / 2, 1e-5);
  EXPECT_NEAR(l.albedo, 0.0, 1e-9);
  EXPECT_NEAR(l.material, std::log(2.0), 1e-6);
}

}  // namespace
}  // namespace lsnif
