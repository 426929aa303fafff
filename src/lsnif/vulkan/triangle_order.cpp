// triangle_order.cpp -- the Morton ordering of triangle_order.h.
#include "lsnif/vulkan/triangle_order.h"

#include <algorithm>
#include <limits>

namespace lsnif::vk {

namespace {

// Spreads the low 10 bits of `v` to every third bit (bit i -> bit 3i).
uint32_t spread_bits(uint32_t v) {
  v &= 0x3ffu;
  v = (v | (v << 16)) & 0x030000ffu;
  v = (v | (v << 8)) & 0x0300f00fu;
  v = (v | (v << 4)) & 0x030c30c3u;
  v = (v | (v << 2)) & 0x09249249u;
  return v;
}

}  // namespace

std::vector<uint32_t> morton_triangle_order(const std::vector<glm::vec3>& positions,
                                            const std::vector<uint32_t>& indices) {
  const size_t count = indices.size() / 3;
  std::vector<uint32_t> order(count);
  for (uint32_t i = 0; i < count; ++i) order[i] = i;
  glm::vec3 lo(std::numeric_limits<float>::infinity()), hi(-std::numeric_limits<float>::infinity());
  for (const glm::vec3& p : positions) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  const glm::vec3 ext = glm::max(hi - lo, glm::vec3(1e-30f));
  std::vector<uint32_t> code(count);
  for (size_t i = 0; i < count; ++i) {
    const glm::vec3 c = (positions[indices[3 * i]] + positions[indices[3 * i + 1]] + positions[indices[3 * i + 2]]) / 3.0f;
    const glm::vec3 q = glm::clamp((c - lo) / ext, 0.0f, 1.0f) * 1023.0f;
    code[i] = spread_bits(uint32_t(q.x)) | (spread_bits(uint32_t(q.y)) << 1) | (spread_bits(uint32_t(q.z)) << 2);
  }
  std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) { return code[a] < code[b]; });
  return order;
}

}  // namespace lsnif::vk
