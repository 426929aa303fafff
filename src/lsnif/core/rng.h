// rng.h -- a small counter-based random number generator and the warps the ray sampler needs.
// Rng(seed, stream, index) is a xoshiro256** generator whose state is a SplitMix64 hash of the
// triple, so the numbers drawn for item `index` depend only on (seed, stream, index): work split
// across any number of threads reproduces the same values.
#pragma once
#include <cmath>
#include <cstdint>

#include <glm/glm.hpp>

namespace lsnif {

// SplitMix64 finalizer (Steele, Lea, Flood 2014): a bijective 64-bit mix.
inline uint64_t splitmix64(uint64_t& state) {
  uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

class Rng {
 public:
  // Generator for item `index` of stream `stream` under `seed`. Distinct triples give
  // statistically independent sequences.
  Rng(uint64_t seed, uint64_t stream, uint64_t index) {
    uint64_t h = seed;
    uint64_t key = splitmix64(h);
    h = key ^ stream;
    key = splitmix64(h);
    h = key ^ index;
    key = splitmix64(h);
    // Four outputs of a bijection on distinct inputs: never all zero, as xoshiro requires.
    for (uint64_t& s : s_) s = splitmix64(key);
  }

  // Next 64 uniformly distributed bits (xoshiro256**, Blackman and Vigna 2018).
  uint64_t next_u64() {
    const uint64_t result = rotl(s_[1] * 5u, 7) * 9u;
    const uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = rotl(s_[3], 45);
    return result;
  }
  uint32_t next_u32() { return uint32_t(next_u64() >> 32); }
  // Uniform float in [0, 1) with 24 random bits.
  float next_float() { return float(next_u64() >> 40) * 0x1.0p-24f; }

 private:
  static uint64_t rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  uint64_t s_[4];
};

// Uniform direction on the unit sphere from two uniforms in [0, 1).
inline glm::vec3 sample_uniform_sphere(float u1, float u2) {
  const float z = 1.0f - 2.0f * u1;
  const float r = std::sqrt(std::fmax(0.0f, 1.0f - z * z));
  const float phi = 6.28318530717958647692f * u2;
  return {r * std::cos(phi), r * std::sin(phi), z};
}

// Orthonormal basis (t, b) completing the unit vector n (Duff et al. 2017, branchless).
inline void orthonormal_basis(const glm::vec3& n, glm::vec3& t, glm::vec3& b) {
  const float sign = std::copysign(1.0f, n.z);
  const float a = -1.0f / (sign + n.z);
  const float c = n.x * n.y * a;
  t = {1.0f + sign * n.x * n.x * a, sign * c, -sign * n.x};
  b = {c, sign + n.y * n.y * a, -n.y};
}

// Cosine-weighted direction about the unit vector `axis` (pdf cos(theta)/pi), normalized.
inline glm::vec3 sample_cosine_hemisphere(const glm::vec3& axis, float u1, float u2) {
  const float r = std::sqrt(u1);
  const float phi = 6.28318530717958647692f * u2;
  const float z = std::sqrt(std::fmax(0.0f, 1.0f - u1));
  glm::vec3 t, b;
  orthonormal_basis(axis, t, b);
  return glm::normalize(r * std::cos(phi) * t + r * std::sin(phi) * b + z * axis);
}

}  // namespace lsnif
