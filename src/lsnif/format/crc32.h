// crc32.h -- CRC-32 (IEEE 802.3 / zlib / PNG: reflected polynomial 0xEDB88320, initial value and
// final xor 0xFFFFFFFF), the checksum that closes every .lsnif file (docs/model-format.md).
#pragma once
#include <cstddef>
#include <cstdint>

namespace lsnif {

// CRC-32 of `size` bytes at `data`. To checksum data in pieces, pass the previous result as `crc`:
// crc32(b, nb, crc32(a, na)) == crc32(a followed by b). crc32(x, 0) == 0; "123456789" -> 0xCBF43926.
// `data` may be null only when `size` is 0.
uint32_t crc32(const uint8_t* data, size_t size, uint32_t crc = 0);

}  // namespace lsnif
