// test_support.h -- pieces shared by the end-to-end, GPU and command-line tests: the device they
// ask for, the tiny training settings they train with, one skewed instance transform, running a
// command with its output and exit code captured, a per-test temporary folder, and reading the
// Markdown tables the benchmark commands write.
#pragma once
#include <gtest/gtest.h>
#include <poll.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <cstdlib>
#include <sstream>
#include <string>
#include <system_error>
#include <vector>

#include <glm/glm.hpp>

#include "lsnif/core/intersector.h"
#include "lsnif/testing/scoped_test_dir.h"
#include "lsnif/train/settings_io.h"
#include "lsnif/train/trainer.h"

namespace lsnif::test {

#ifdef LSNIF_DATA_DIR
// The folder of the test meshes: the environment variable LSNIF_TEST_DATA (the GPU check folder sets
// it to the meshes it carries), else the build's LSNIF_DATA_DIR (scripts/setup.sh fetched them there).
inline std::string data_dir() {
  const char* chosen = std::getenv("LSNIF_TEST_DATA");
  return chosen && *chosen ? chosen : LSNIF_DATA_DIR;
}
#endif

// The device selector (vk::ContextOptions::device, `lsnif ... --device`) of the GPU tests: the
// environment variable LSNIF_TEST_DEVICE (a part of a device name or an index in `lsnif devices`
// order, device_choice.h), else lavapipe ("llvmpipe"), their reference platform, also on a machine
// with a GPU that the automatic choice would prefer. A test that needs what the device lacks skips
// itself naming it.
inline std::string test_device() {
  const char* chosen = std::getenv("LSNIF_TEST_DEVICE");
  return chosen && *chosen ? chosen : "llvmpipe";
}

// Whether the GPU tests run with the Khronos validation layer (and fail on anything it reports): yes
// unless the environment variable LSNIF_TEST_VALIDATION is "0" (the GPU check folder, which does not
// carry the layer, says so in its report). Tests that provoke a message to see it counted skip
// themselves without it.
inline bool test_validation() {
  const char* v = std::getenv("LSNIF_TEST_VALIDATION");
  return !(v && std::string(v) == "0");
}

// True when LSNIF_TEST_DEVICE is unset or empty: the tests run on lavapipe, where CI runs them.
inline bool default_test_device() {
  const char* chosen = std::getenv("LSNIF_TEST_DEVICE");
  return !(chosen && *chosen);
}

// In a test that needs something of the device (`offered` false: it lacks `what`, e.g. "feature
// rayQuery"): skips the test naming it on a device chosen with LSNIF_TEST_DEVICE; fails it on the
// default device (lavapipe offers everything the tests need, so there a missing piece is a fault,
// never a silent pass).
#define LSNIF_TEST_NEEDS(offered, device_name, what)                                                  \
  do {                                                                                               \
    if (!(offered)) {                                                                                \
      if (::lsnif::test::default_test_device()) FAIL() << "device '" << (device_name) << "' lacks " << (what); \
      GTEST_SKIP() << "device '" << (device_name) << "' lacks " << (what);                           \
    }                                                                                                \
  } while (0)

// The tiny preset (`lsnif train --tiny`, settings_table.h kTinyPreset) as TrainSettings: V=16, grid
// 32..64 with 2^12 entries, 2x32 MLP, 30 steps of 1024 rays, no progress bar. The command-line
// tests pass --tiny for the same model.
inline TrainSettings tiny_preset_settings() {
  TrainSettings s;
  const Status status = preset_train_settings(kTinyPreset, s);
  EXPECT_TRUE(status) << status.message();
  return s;
}

// The in-process tests' model: the tiny preset with, deliberately, more capacity and a larger batch
// (H=12, 2^14 entries, 2x64 MLP, batches of 2048): the quality floors of train_e2e_test and
// materials_e2e_test and the GPU tests' models were set for these. Callers set the steps, seed and
// hit parametrization they need.
inline TrainSettings tiny_train_settings() {
  TrainSettings s = tiny_preset_settings();
  s.config.max_points = 12;
  set_table_log2(s.config, 14);
  s.config.hidden_width = 64;
  s.batch_size = 2048;
  return s;
}

// Object-to-world rotation * non-uniform scale (2, 0.5, 1.3), then a translation (3, -1, 7).
inline glm::mat3 skewed_linear() {
  const glm::mat3 R = glm::mat3(glm::vec3(0.36f, 0.48f, -0.8f), glm::vec3(-0.8f, 0.6f, 0.0f),
                                glm::vec3(0.48f, 0.64f, 0.6f));
  return R * glm::mat3(glm::vec3(2, 0, 0), glm::vec3(0, 0.5f, 0), glm::vec3(0, 0, 1.3f));
}
inline glm::vec3 skewed_translation() { return glm::vec3(3, -1, 7); }
inline Transform3x4 skewed_instance() {
  const glm::mat3 A = skewed_linear();
  const glm::vec3 T = skewed_translation();
  Transform3x4 xf;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) xf.m[r][c] = A[c][r];
    xf.m[r][3] = T[r];
  }
  return xf;
}

// What a command wrote to its standard output, and how it ended.
struct CommandResult {
  int code = -1;    // exit status; -1 when it could not be started or did not exit normally
  std::string out;  // stdout (add " 2>&1" to the command for stderr too)
};

// Runs `command` through /bin/sh (popen) and waits for it.
inline CommandResult run_command(const std::string& command) {
  CommandResult r;
  FILE* p = popen(command.c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  const int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

// Recomputes the CRC-32 in the last 4 bytes of .lsnif file bytes `b` (docs/model-format.md), bit by
// bit from the definition, so that a test's change to a field reaches the checks behind the CRC.
inline void fix_model_crc(std::string& b) {
  uint32_t crc = 0xffffffffu;
  for (size_t i = 0; i + 4 < b.size(); ++i) {
    crc ^= uint8_t(b[i]);
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  crc = ~crc;
  for (int k = 0; k < 4; ++k) b[b.size() - 4 + size_t(k)] = char((crc >> (8 * k)) & 0xff);
}

// How a process run by run_process ended.
struct ProcessResult {
  int exit_code = -1;      // when it exited normally, else -1
  int signal = 0;          // the signal that killed it (SIGSEGV, SIGFPE, SIGABRT, ...), else 0
  bool timed_out = false;  // killed by run_process after the time limit
  double seconds = 0;      // wall time from the start to the end of the output
  std::string output;      // stdout and stderr together
  bool crashed() const { return signal != 0 && !timed_out; }
};

// Runs argv[0] with the arguments argv[1..] (no shell: any byte may be in an argument), stdout and
// stderr captured, killed after `timeout_s` seconds. With `file_size_limit` > 0 the child's files
// cannot grow beyond that many bytes (RLIMIT_FSIZE; SIGXFSZ ignored, so a write past it fails with
// EFBIG): a full disk for the program. `env` entries ("NAME=value") are added to the environment.
// With `address_space_limit` > 0 the child's virtual memory is limited to that many bytes
// (RLIMIT_AS, as `prlimit --as`): allocations past it fail (a machine with less memory).
inline ProcessResult run_process(const std::vector<std::string>& argv, double timeout_s,
                                 uint64_t file_size_limit = 0, const std::vector<std::string>& env = {},
                                 uint64_t address_space_limit = 0) {
  ProcessResult r;
  const auto start = std::chrono::steady_clock::now();
  int fds[2];
  if (argv.empty() || ::pipe(fds) != 0) return r;
  const pid_t pid = ::fork();
  if (pid < 0) return r;
  if (pid == 0) {
    ::dup2(fds[1], 1);
    ::dup2(fds[1], 2);
    ::close(fds[0]);
    ::close(fds[1]);
    std::signal(SIGXFSZ, SIG_IGN);  // an ignored signal stays ignored across exec
    if (file_size_limit > 0) {
      struct rlimit limit = {rlim_t(file_size_limit), rlim_t(file_size_limit)};
      ::setrlimit(RLIMIT_FSIZE, &limit);
    }
    if (address_space_limit > 0) {
      struct rlimit limit = {rlim_t(address_space_limit), rlim_t(address_space_limit)};
      ::setrlimit(RLIMIT_AS, &limit);
    }
    for (const std::string& e : env) ::putenv(const_cast<char*>(e.c_str()));
    std::vector<char*> args;
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    ::execv(args[0], args.data());
    ::_exit(127);
  }
  ::close(fds[1]);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  std::array<char, 4096> buf;
  for (;;) {
    const double left = std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
    if (left <= 0) {
      r.timed_out = true;
      ::kill(pid, SIGKILL);
      break;
    }
    struct pollfd p = {fds[0], POLLIN, 0};
    const int ready = ::poll(&p, 1, int(std::min(left, 1.0) * 1000) + 1);
    if (ready < 0 && errno != EINTR) break;
    if (ready <= 0) continue;
    const ssize_t n = ::read(fds[0], buf.data(), buf.size());
    if (n <= 0) break;
    r.output.append(buf.data(), size_t(n));
  }
  ::close(fds[0]);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  int status = 0;
  ::waitpid(pid, &status, 0);
  if (WIFEXITED(status)) r.exit_code = WEXITSTATUS(status);
  if (WIFSIGNALED(status)) r.signal = WTERMSIG(status);
  return r;
}

// The bytes of a file; empty when it cannot be read.
inline std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// The cells of the first Markdown table row that starts with `prefix` (e.g. "| bunny |"), trimmed;
// empty if none.
inline std::vector<std::string> table_row(const std::string& md, const std::string& prefix) {
  std::istringstream in(md);
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind(prefix, 0) != 0) continue;
    std::vector<std::string> cells;
    size_t at = 1;
    for (size_t bar = line.find('|', at); bar != std::string::npos; at = bar + 1, bar = line.find('|', at)) {
      std::string cell = line.substr(at, bar - at);
      cell.erase(0, cell.find_first_not_of(' '));
      cell.erase(cell.find_last_not_of(' ') + 1);
      cells.push_back(cell);
    }
    return cells;
  }
  return {};
}

// A table cell as a number (thousands separators dropped); a test failure when it is not one.
inline double number(std::string cell) {
  cell.erase(std::remove(cell.begin(), cell.end(), ','), cell.end());
  char* end = nullptr;
  const double v = std::strtod(cell.c_str(), &end);
  EXPECT_TRUE(end != cell.c_str() && *end == '\0') << "not a number: '" << cell << "'";
  return v;
}

// Face count from an OFF file's header ("OFF", then "vertices faces edges"); 0 if it is not one.
inline uint64_t off_faces(const std::string& path) {
  std::ifstream in(path);
  std::string magic;
  uint64_t vertices = 0, faces = 0;
  in >> magic >> vertices >> faces;
  return magic == "OFF" ? faces : 0;
}

// ---- a textured mesh whose uv layout has seams and a mirrored half ----

constexpr float kLayoutPi = 3.14159265f;

// The uv of a unit-sphere point: the band |latitude| <= 60 degrees maps to u = |longitude| / pi
// (the half z < 0 mirrors the half z > 0 onto the same texels), v = 0.05 + 0.5 (latitude / (2 pi / 3)
// + 0.5); each cap beyond 60 degrees is its own chart, projected from above into v in [0.6, 1]:
// three charts, seams at +-60 degrees.
inline glm::vec2 sphere_uv(glm::vec3 p, bool cap) {
  const float lat = std::asin(std::clamp(p.y, -1.0f, 1.0f));
  if (!cap) return {std::fabs(std::atan2(p.z, p.x)) / kLayoutPi, 0.05f + 0.5f * (lat / (2.0f * kLayoutPi / 3.0f) + 0.5f)};
  const float side = p.y > 0.0f ? 0.25f : 0.75f;
  return {side + 0.2f * p.x, 0.8f + 0.2f * p.z};
}

// A latitude-longitude sphere with the layout above: quads of `rows` x `columns`, each with its own
// four vertices (a soup, as importers write it), one material with a 256 x 256 texture.
inline Mesh layout_sphere(uint32_t rows, uint32_t columns) {
  Mesh m;
  for (uint32_t r = 0; r < rows; ++r)
    for (uint32_t c = 0; c < columns; ++c) {
      const float mid = (float(r) + 0.5f) / float(rows) * 180.0f - 90.0f;
      const bool cap = std::fabs(mid) > 60.0f;
      const uint32_t b = uint32_t(m.positions.size());
      for (const glm::uvec2 corner : {glm::uvec2(r, c), glm::uvec2(r + 1, c), glm::uvec2(r + 1, c + 1), glm::uvec2(r, c + 1)}) {
        const float lat = -kLayoutPi / 2 + kLayoutPi * float(corner.x) / float(rows);
        const float lon = -kLayoutPi + 2 * kLayoutPi * float(corner.y) / float(columns);
        // The poles exactly: their quads' two pole corners coincide, a triangle the importer drops.
        const float ring = corner.x == 0 || corner.x == rows ? 0.0f : std::cos(lat);
        const glm::vec3 p(ring * std::cos(lon), std::sin(lat), ring * std::sin(lon));
        m.positions.push_back(p);
        m.uvs.push_back(cap ? sphere_uv(p, true)
                            : glm::vec2(std::fabs(lon) / kLayoutPi, 0.05f + 0.5f * (lat / (2.0f * kLayoutPi / 3.0f) + 0.5f)));
      }
      m.triangles.push_back({b, b + 1, b + 2});  // counter-clockwise seen from outside
      m.triangles.push_back({b, b + 2, b + 3});
      m.triangle_material.insert(m.triangle_material.end(), {0u, 0u});
    }
  Texture t;
  t.width = t.height = 256;
  for (uint32_t y = 0; y < 256; ++y)
    for (uint32_t x = 0; x < 256; ++x) t.rgba.insert(t.rgba.end(), {uint8_t(x), uint8_t(y), 128, 255});
  m.textures.push_back(t);
  Material mat;
  mat.name = "painted";
  mat.base_color_texture = 0;
  m.materials = {mat};
  EXPECT_TRUE(finalize_mesh(m, nullptr, "layout sphere"));
  return m;
}

}  // namespace lsnif::test
