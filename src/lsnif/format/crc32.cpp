#include "lsnif/format/crc32.h"

#include <array>

namespace lsnif {
namespace {

// table[b] = CRC register after shifting byte b through the reflected polynomial (8 steps).
constexpr std::array<uint32_t, 256> make_crc32_table() {
  std::array<uint32_t, 256> table{};
  for (uint32_t b = 0; b < 256; ++b) {
    uint32_t r = b;
    for (int k = 0; k < 8; ++k) r = (r & 1u) ? (r >> 1) ^ 0xEDB88320u : r >> 1;
    table[b] = r;
  }
  return table;
}

constexpr std::array<uint32_t, 256> kCrc32Table = make_crc32_table();

}  // namespace

uint32_t crc32(const uint8_t* data, size_t size, uint32_t crc) {
  uint32_t r = ~crc;
  for (size_t i = 0; i < size; ++i) r = kCrc32Table[(r ^ data[i]) & 0xffu] ^ (r >> 8);
  return ~r;
}

}  // namespace lsnif
