// half_test.cpp -- float_to_half / half_to_float (src/lsnif/core/half.h) against independent references:
// an ldexp decode of every binary16 pattern, a nearest-neighbour search with ties to even over the
// table of all halves, and, where GCC provides it, the compiler's own _Float16 conversion.
#include "lsnif/core/half.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

#include "lsnif/core/rng.h"

namespace lsnif {
namespace {

float bits_to_float(uint32_t x) {
  float f;
  std::memcpy(&f, &x, 4);
  return f;
}
uint32_t float_to_bits(float f) {
  uint32_t x;
  std::memcpy(&x, &f, 4);
  return x;
}

bool half_is_nan(uint16_t h) { return (h & 0x7c00u) == 0x7c00u && (h & 0x3ffu) != 0; }

// Value of a finite or infinite binary16 pattern straight from the IEEE 754 definition.
double decode_half_reference(uint16_t h) {
  const int sign = (h >> 15) ? -1 : 1;
  const int exp = (h >> 10) & 0x1f, mant = h & 0x3ff;
  if (exp == 0x1f) return sign * std::numeric_limits<double>::infinity();
  if (exp == 0) return sign * std::ldexp(double(mant), -24);  // 2^-14 * mant / 2^10
  return sign * std::ldexp(1024.0 + mant, exp - 25);          // 2^(exp-15) * (1 + mant / 2^10)
}

// Reference rounding of a non-NaN float to binary16, by search: the two halves around |f| (in the
// table of every non-negative finite half, plus 0x7c00 standing for 2^16, the first value past the
// largest half -- rounding to it means overflow to infinity), the nearer one wins, ties go to the
// even bit pattern (even significand). Distances are computed in long double.
class ReferenceRounding {
 public:
  ReferenceRounding() {
    for (uint32_t h = 0; h < 0x7c00u; ++h) values_.push_back(decode_half_reference(uint16_t(h)));
    values_.push_back(65536.0);  // pattern 0x7c00
  }
  uint16_t operator()(float f) const {
    const uint16_t sign = std::signbit(f) ? 0x8000u : 0u;
    const double a = std::fabs(double(f));
    if (std::isinf(a) || a >= 65536.0) return uint16_t(sign | 0x7c00u);
    // first value > a; the lower neighbour is the one before it
    const size_t hi = size_t(std::upper_bound(values_.begin(), values_.end(), a) - values_.begin());
    const size_t lo = hi - 1;  // values_[0] == 0 <= a
    if (values_[lo] == a) return uint16_t(sign | lo);
    const long double d_lo = (long double)a - values_[lo], d_hi = (long double)values_[hi] - a;
    size_t pick = d_lo < d_hi ? lo : d_hi < d_lo ? hi : (lo % 2 == 0 ? lo : hi);
    return uint16_t(sign | pick);
  }
  const std::vector<double>& values() const { return values_; }

 private:
  std::vector<double> values_;  // values_[h] = value of pattern h, h in [0, 0x7c00]
};

const ReferenceRounding& reference() {
  static const ReferenceRounding r;
  return r;
}

TEST(Half, DecodesEveryPatternLikeTheDefinition) {
  for (uint32_t h = 0; h < 65536; ++h) {
    const float f = half_to_float(uint16_t(h));
    if (half_is_nan(uint16_t(h))) {
      EXPECT_TRUE(std::isnan(f)) << std::hex << h;
      EXPECT_EQ(std::signbit(f), (h & 0x8000u) != 0) << std::hex << h;
    } else {
      ASSERT_EQ(double(f), decode_half_reference(uint16_t(h))) << std::hex << h;
      EXPECT_EQ(std::signbit(f), (h & 0x8000u) != 0) << std::hex << h;  // -0 stays -0
    }
  }
}

TEST(Half, EveryPatternRoundTrips) {
  for (uint32_t h = 0; h < 65536; ++h) {
    const uint16_t back = float_to_half(half_to_float(uint16_t(h)));
    if (half_is_nan(uint16_t(h))) {
      EXPECT_TRUE(half_is_nan(back)) << std::hex << h << " -> " << back;
      EXPECT_EQ(back & 0x8000u, h & 0x8000u) << std::hex << h;
    } else {
      ASSERT_EQ(back, h) << std::hex << h;
    }
  }
}

TEST(Half, ReferenceRoundingAgreesOnExactHalves) {
  // Sanity of the reference itself: exact values map to themselves.
  for (uint32_t h = 0; h < 0x7c00u; h += 7) {
    EXPECT_EQ(reference()(float(decode_half_reference(uint16_t(h)))), h);
    EXPECT_EQ(reference()(-float(decode_half_reference(uint16_t(h)))), h | 0x8000u);
  }
}

TEST(Half, TiesAndNeighboursOfEveryMidpoint) {
  // The midpoint of every pair of consecutive halves (including subnormals and the overflow
  // threshold 65520 between 65504 and "65536") is exact in float: it needs 12 significant bits.
  const std::vector<double>& v = reference().values();
  for (size_t h = 0; h + 1 < v.size(); ++h) {
    const double mid = 0.5 * (v[h] + v[h + 1]);
    const float m = float(mid);
    ASSERT_EQ(double(m), mid);
    const uint16_t even = uint16_t(h % 2 == 0 ? h : h + 1);
    ASSERT_EQ(float_to_half(m), even) << "tie at " << mid;
    ASSERT_EQ(float_to_half(-m), even | 0x8000u) << "tie at " << -mid;
    const float below = std::nextafter(m, 0.0f), above = std::nextafter(m, 1e9f);
    ASSERT_EQ(float_to_half(below), h) << "just below " << mid;
    ASSERT_EQ(float_to_half(above), h + 1) << "just above " << mid;
    ASSERT_EQ(reference()(m), even);
  }
  // Named cases.
  EXPECT_EQ(float_to_half(65504.0f), 0x7bffu);            // largest half
  EXPECT_EQ(float_to_half(65519.99f), 0x7bffu);           // below the overflow threshold
  EXPECT_EQ(float_to_half(65520.0f), 0x7c00u);            // tie -> even -> infinity
  EXPECT_EQ(float_to_half(1e10f), 0x7c00u);
  EXPECT_EQ(float_to_half(-1e10f), 0xfc00u);
  EXPECT_EQ(float_to_half(0x1.0p-24f), 0x0001u);          // smallest subnormal
  EXPECT_EQ(float_to_half(0x1.0p-25f), 0x0000u);          // tie between 0 and 2^-24 -> 0
  EXPECT_EQ(float_to_half(0x1.000002p-25f), 0x0001u);     // just above the tie
  EXPECT_EQ(float_to_half(0x1.8p-24f), 0x0002u);          // 1.5 * 2^-24 tie -> 2 (even)
  EXPECT_EQ(float_to_half(0x1.ff8p-15f), 0x03ffu);        // largest subnormal, exact
  EXPECT_EQ(float_to_half(0x1.ffcp-15f), 0x0400u);        // tie -> even: up out of the subnormals
  EXPECT_EQ(float_to_half(1.0f + 0x1.0p-11f), 0x3c00u);   // tie -> 1.0 (even)
  EXPECT_EQ(float_to_half(1.0f + 0x1.8p-10f), 0x3c02u);   // 1.5 ulp tie -> 2 ulp (even)
  EXPECT_EQ(float_to_half(-0.0f), 0x8000u);
  EXPECT_EQ(float_to_half(std::numeric_limits<float>::infinity()), 0x7c00u);
  EXPECT_TRUE(half_is_nan(float_to_half(std::numeric_limits<float>::quiet_NaN())));
  EXPECT_TRUE(half_is_nan(float_to_half(bits_to_float(0x7f800001u))));  // signalling NaN, low bits only
  EXPECT_EQ(float_to_half(1e-30f), 0x0000u);
  EXPECT_EQ(float_to_half(bits_to_float(1u)), 0x0000u);   // float subnormal
}

TEST(Half, RandomFloatsMatchTheReference) {
  Rng rng(1234, 0, 0);
  const ReferenceRounding& ref = reference();
  for (int i = 0; i < 2000000; ++i) {
    float f;
    if (i % 2 == 0) {
      // any float bit pattern (NaNs skipped)
      f = bits_to_float(rng.next_u32());
      if (std::isnan(f)) continue;
    } else {
      // concentrated on the half range: exponents 2^-27 .. 2^17, random significand and sign
      const int e = int(rng.next_u32() % 45u) - 27;
      f = std::ldexp(1.0f + rng.next_float(), e) * ((rng.next_u32() & 1u) ? -1.0f : 1.0f);
    }
    ASSERT_EQ(float_to_half(f), ref(f)) << std::hexfloat << f << " bits " << std::hex << float_to_bits(f);
  }
}

TEST(Half, RoundToHalfIsIdempotentAndNearest) {
  Rng rng(99, 0, 0);
  for (int i = 0; i < 100000; ++i) {
    const float f = std::ldexp(rng.next_float() * 2.0f - 1.0f, int(rng.next_u32() % 30u) - 14);
    const float r = round_to_half(f);
    EXPECT_EQ(round_to_half(r), r);
    EXPECT_EQ(double(r), decode_half_reference(reference()(f)));
  }
}

#if defined(__FLT16_MANT_DIG__)
// GCC's _Float16 conversion (F16C instructions or libgcc soft-float) as a second oracle.
TEST(Half, MatchesCompilerFloat16) {
  Rng rng(7, 0, 0);
  auto check = [](float f) {
    const _Float16 c = static_cast<_Float16>(f);
    uint16_t bits;
    std::memcpy(&bits, &c, 2);
    if (std::isnan(f)) {
      ASSERT_TRUE(half_is_nan(float_to_half(f)));
      return;
    }
    ASSERT_EQ(float_to_half(f), bits) << std::hexfloat << f;
    ASSERT_EQ(half_to_float(bits), static_cast<float>(c));
  };
  for (int i = 0; i < 4000000; ++i) check(bits_to_float(rng.next_u32()));
  // A sweep over float bit patterns in the half range with a stride coprime to 2^13.
  for (uint32_t x = 0x30000000u; x < 0x47ff0000u; x += 1237u) {
    check(bits_to_float(x));
    check(bits_to_float(x | 0x80000000u));
  }
}
#endif

}  // namespace
}  // namespace lsnif
