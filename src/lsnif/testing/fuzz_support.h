// fuzz_support.h -- helpers shared by the mutation-fuzz and synthetic-file tests of the glTF
// readers (src/lsnif/import/mesh_fuzz_test.cpp, src/lsnif/scene/gltf_fuzz_test.cpp, src/lsnif/scene/gltf_test.cpp).
// Header-only and used by tests only: building binary payloads, base64, the GLB container, a
// 2x2 PNG, reading files, and the deterministic byte mutator.
#pragma once
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <initializer_list>
#include <iterator>
#include <random>
#include <span>
#include <string>

namespace lsnif::fuzz {

// The whole file at `path` as bytes; empty when it cannot be opened.
inline std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// The floats' bytes in native (little-endian) order, 4 per value.
inline std::string put_floats(std::initializer_list<float> v) {
  std::string s(v.size() * 4, '\0');
  size_t i = 0;
  for (float f : v) std::memcpy(&s[4 * i++], &f, 4);
  return s;
}

// Standard base64 (with '=' padding) of `in`.
inline std::string base64(const std::string& in) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    uint32_t v = uint32_t(uint8_t(in[i])) << 16 | uint32_t(uint8_t(in[i + 1])) << 8 | uint8_t(in[i + 2]);
    for (int sh = 18; sh >= 0; sh -= 6) out += k[(v >> sh) & 63];
  }
  if (i < in.size()) {
    uint32_t v = uint32_t(uint8_t(in[i])) << 16 | (i + 1 < in.size() ? uint32_t(uint8_t(in[i + 1])) << 8 : 0u);
    out += k[(v >> 18) & 63];
    out += k[(v >> 12) & 63];
    out += i + 1 < in.size() ? k[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

// Bytes of valid base64 text `b64` (decoding stops at the end or at the first '=').
inline std::string base64_decode(const char* b64) {
  auto dec = [](char c) -> int {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    return c == '+' ? 62 : 63;
  };
  std::string out;
  uint32_t acc = 0;
  int bits = 0;
  for (const char* p = b64; *p && *p != '='; ++p) {
    acc = acc << 6 | uint32_t(dec(*p));
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out += char((acc >> bits) & 0xff);
    }
  }
  return out;
}

// 2x2 RGBA PNG as base64: red, green / blue, gray.
inline constexpr const char* kPngBase64 =
    "iVBORw0KGgoAAAANSUhEUgAAAAIAAAACCAYAAABytg0kAAAAFUlEQVR42mP4z8DwHwyB9P+Ghob/AEVRCHrNY6F/AAAAAElFTkSuQmCC";

// The bytes of that PNG.
inline std::string png_bytes() { return base64_decode(kPngBase64); }

// A GLB container (version 2) of JSON `js` (padded with spaces) and BIN chunk `bin` (padded with
// zeros).
inline std::string glb(std::string js, std::string bin) {
  while (js.size() % 4) js += ' ';
  while (bin.size() % 4) bin += '\0';
  std::string g = "glTF";
  auto u32 = [&](uint32_t v) { g.append(reinterpret_cast<const char*>(&v), 4); };
  u32(2);
  u32(uint32_t(28 + js.size() + bin.size()));
  u32(uint32_t(js.size()));
  u32(0x4E4F534A);
  g += js;
  u32(uint32_t(bin.size()));
  u32(0x004E4942);
  g += bin;
  return g;
}

// 130 opening brackets: JSON nested past the readers' bound (src/lsnif/import/json_text.h).
inline constexpr const char kDeepNesting[] = "[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[";

// Troublesome tokens the mutator inserts; the first kNumericTokens are numbers (used to replace
// numbers in the input).
inline constexpr const char* kMutationTokens[] = {
    "-1", "0", "4294967295", "4294967296", "2147483648", "-2147483649", "nan", "inf", "-inf", "1e39",
    "1e-45", "99999999999999999999", "3", "255", "65535", "1.5", "/", "//", " ", "\n", "#", "\"", "{",
    "}", "[", "]", ",", ":", "null", "true", "-0", "1e308", kDeepNesting};
inline constexpr size_t kNumericTokens = 16;

// Damages `data` with 1-4 random edits drawn from `rng`: bit flips, random bytes, truncation,
// insertion of random bytes, insertion or overwrite with one of `tokens`, deletion or duplication
// of a range, and replacement of the next number by one of the first kNumericTokens tokens
// (`tokens` must start with kMutationTokens' numeric ones). Deterministic for a given rng state.
inline void mutate(std::string& data, std::mt19937_64& rng,
                   std::span<const char* const> tokens = kMutationTokens) {
  const int edits = rng() % 4 == 0 ? 2 + int(rng() % 3) : 1;
  for (int e = 0; e < edits; ++e) {
    const size_t n = data.size();
    const size_t pos = n ? size_t(rng() % n) : 0;
    switch (rng() % 10) {
      case 0:  // bit flip
        if (n) data[pos] = char(uint8_t(data[pos]) ^ uint8_t(1u << (rng() % 8)));
        break;
      case 1:  // random byte
        if (n) data[pos] = char(rng() & 0xff);
        break;
      case 2:  // truncate
        data.resize(pos);
        break;
      case 3: {  // insert random bytes
        std::string ins(1 + rng() % 8, '\0');
        for (char& c : ins) c = char(rng() & 0xff);
        data.insert(pos, ins);
        break;
      }
      case 4:
      case 5: {  // insert or overwrite with a troublesome token
        const char* t = tokens[rng() % tokens.size()];
        if (rng() % 2 == 0 || pos + std::strlen(t) > n)
          data.insert(pos, t);
        else
          data.replace(pos, std::strlen(t), t);
        break;
      }
      case 6:  // delete a range
        data.erase(pos, 1 + rng() % 16);
        break;
      case 7: {  // duplicate a range
        std::string chunk = data.substr(pos, 1 + rng() % 32);
        data.insert(size_t(rng() % (data.size() + 1)), chunk);
        break;
      }
      case 8:
      case 9: {  // replace the next number (count, index, offset, coordinate) by a numeric token
        size_t b = pos;
        while (b < n && !(data[b] >= '0' && data[b] <= '9')) ++b;
        if (b == n) break;
        size_t end = b;
        while (end < n && ((data[end] >= '0' && data[end] <= '9') || data[end] == '.' || data[end] == 'e')) ++end;
        if (b > 0 && data[b - 1] == '-') --b;
        data.replace(b, end - b, tokens[rng() % kNumericTokens]);
        break;
      }
    }
  }
}

// The fuzz tests' random generator: seeded from LSNIF_FUZZ_SEED when set (for longer explorations
// by hand), else from `default_seed`, so that runs are reproducible.
inline std::mt19937_64 fuzz_rng(uint64_t default_seed) {
  const char* seed_env = std::getenv("LSNIF_FUZZ_SEED");
  return std::mt19937_64(seed_env ? std::strtoull(seed_env, nullptr, 0) : default_seed);
}

}  // namespace lsnif::fuzz
