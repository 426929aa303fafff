// Output heads: the two hit-distance parametrizations invert each other on random walks, map the
// ends of [0,1] to the right knots, and decode() applies the documented activations.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

#include "lsnif/core/head.h"

namespace lsnif {
namespace {

RayWalk random_walk(std::mt19937& rng, uint32_t count) {
  std::uniform_real_distribution<float> u(0.01f, 0.3f);
  RayWalk w;
  w.t_enter = 1.0f;
  float t = w.t_enter;
  w.count = count;
  for (uint32_t j = 0; j < count; ++j) {
    t += u(rng);
    w.t[j] = t;
  }
  w.t_exit = t + u(rng);
  w.hits_aabb = true;
  return w;
}

TEST(Head, DistanceMapsInvertEachOther) {
  std::mt19937 rng(8);
  for (HitParam param : {HitParam::AabbInterval, HitParam::VoxelSegments}) {
    Config c;
    c.hit_param = param;
    for (int trial = 0; trial < 2000; ++trial) {
      RayWalk w = random_walk(rng, 1 + uint32_t(trial) % c.max_points);
      const float end = param == HitParam::AabbInterval ? w.t_exit : w.t[w.count - 1];
      std::uniform_real_distribution<float> ut(w.t_enter, end);
      float t = ut(rng);
      float s = unit_from_distance(c, w, t);
      ASSERT_GE(s, 0.0f);
      ASSERT_LE(s, 1.0f);
      ASSERT_NEAR(distance_from_unit(c, w, s), t, 2e-5f) << to_string(param);
    }
  }
}

TEST(Head, SegmentKnots) {
  Config c;  // H = 18, segments
  RayWalk w;
  w.t_enter = 2.0f;
  w.count = 3;
  w.t[0] = 3.0f;
  w.t[1] = 3.5f;
  w.t[2] = 5.0f;
  w.t_exit = 9.0f;
  const float H = float(c.max_points);
  EXPECT_FLOAT_EQ(distance_from_unit(c, w, 0.0f), 2.0f);
  EXPECT_FLOAT_EQ(distance_from_unit(c, w, 1.0f / H), 3.0f);
  EXPECT_FLOAT_EQ(distance_from_unit(c, w, 1.5f / H), 3.25f);
  EXPECT_FLOAT_EQ(distance_from_unit(c, w, 3.0f / H), 5.0f);
  EXPECT_FLOAT_EQ(distance_from_unit(c, w, 1.0f), 5.0f);  // clamped to the last knot
  EXPECT_FLOAT_EQ(unit_from_distance(c, w, 3.25f), 1.5f / H);
  EXPECT_FLOAT_EQ(unit_from_distance(c, w, 4.25f), 2.5f / H);
  c.hit_param = HitParam::AabbInterval;
  EXPECT_FLOAT_EQ(distance_from_unit(c, w, 0.5f), 5.5f);
}

TEST(Head, DecodeActivations) {
  Config c;
  c.material_count = 3;
  std::vector<float> raw(c.output_dim(), 0.0f);
  raw[LSNIF_OUT_OCCLUSION] = 0.0f;  // probability exactly 0.5 -> hit (threshold is >= 0.5)
  raw[LSNIF_OUT_NORMAL + 1] = -3.0f;
  raw[LSNIF_OUT_ALBEDO + 2] = 100.0f;
  raw[LSNIF_OUT_MATERIAL + 2] = 1.0f;
  RayWalk w;
  w.count = 1;
  w.t_enter = 0.0f;
  w.t[0] = 1.0f;
  w.t_exit = 2.0f;
  Prediction p = decode(c, raw.data(), w);
  EXPECT_TRUE(p.hit);
  EXPECT_FLOAT_EQ(p.occlusion, 0.5f);
  EXPECT_FLOAT_EQ(p.normal.y, -1.0f);
  EXPECT_FLOAT_EQ(p.albedo.x, 0.5f);
  EXPECT_NEAR(p.albedo.z, 1.0f, 1e-6f);
  EXPECT_EQ(p.material, 2u);
  raw[LSNIF_OUT_OCCLUSION] = -0.01f;
  EXPECT_FALSE(decode(c, raw.data(), w).hit);
}

}  // namespace
}  // namespace lsnif
