// lsnif-gpu check OUT --folder DIR: the GPU check (docs/gpu-check.md). Runs, each as a child process
// of the folder scripts/gpu-check.sh built, on one Vulkan device: `lsnif-gpu devices`, the portable
// GPU conformance tests (their prepared models and meshes from the folder), `lsnif-gpu bench-trace`
// (again with the cooperative-matrix MLP kernel where the device offers it) and `lsnif-gpu bench` (Table 1 on the prepared scenes' models), then writes OUT/report.json (every
// step's result, the device, driver, broad phase and MLP kernel) and at most six images. Each step's
// files go to OUT/work/ (removed at the end unless --keep-work), the children's temporary files too:
// nothing outside OUT is written.
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "lsnif/apps/lsnif/args.h"
#include "lsnif/apps/lsnif/bench_options.h"
#include "lsnif/apps/lsnif/commands.h"
#include "lsnif/apps/lsnif/device_option.h"
#include "lsnif/format/atomic_file.h"
#include "lsnif/format/output_folder.h"
#include "lsnif/format/status.h"
#include "lsnif/lsnif_version.h"

extern char** environ;

namespace lsnif::cli {

namespace {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

// The conformance tests the folder carries (bin/NAME), in the order they run.
const char* const kTests[] = {"gpu_reference_test", "rt_conformance_test", "plugin_test", "render_test"};
// At most this many images come back (the lent GPU machine returns 8 files: these and report.json).
constexpr size_t kMaxImages = 6;

struct CheckOptions {
  std::string out, folder, device, scenes = "bunny,dragons,heavy,foliage,grid", quality = "default,low";
  uint32_t width = 1920, height = 1080, spp = 4, rays = 1u << 20, step_timeout = 300;
  bool quick = false, validation = false, keep_work = false;
};

struct Child {
  int exit_code = -1;  // the child's exit status; 128 + N when signal N ended it
  bool timed_out = false;
  double seconds = 0;
};

// Runs `argv` with `env` added to this process's environment, stdout to `out_path`, stderr to
// `err_path`; kills it after `timeout_s` seconds. An error when it cannot be started.
Status run_child(const std::vector<std::string>& argv, const std::vector<std::pair<std::string, std::string>>& env,
                 const std::string& out_path, const std::string& err_path, uint32_t timeout_s, Child& child) {
  std::vector<std::string> env_text;
  for (char** e = environ; e && *e; ++e) {
    bool replaced = false;
    for (const auto& [k, v] : env) replaced |= std::string(*e).rfind(k + "=", 0) == 0;
    if (!replaced) env_text.emplace_back(*e);
  }
  for (const auto& [k, v] : env) env_text.push_back(k + "=" + v);
  std::vector<char*> args, envp;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  for (const std::string& e : env_text) envp.push_back(const_cast<char*>(e.c_str()));
  args.push_back(nullptr);
  envp.push_back(nullptr);
  const int out_fd = ::open(out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  const int err_fd = ::open(err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (out_fd < 0 || err_fd < 0) {
    if (out_fd >= 0) ::close(out_fd);
    if (err_fd >= 0) ::close(err_fd);
    return Status::error("cannot create %s or %s", out_path.c_str(), err_path.c_str());
  }
  const auto t0 = std::chrono::steady_clock::now();
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::dup2(out_fd, 1);
    ::dup2(err_fd, 2);
    ::execve(args[0], args.data(), envp.data());
    std::fprintf(stderr, "cannot run %s\n", args[0]);
    ::_exit(127);
  }
  ::close(out_fd);
  ::close(err_fd);
  if (pid < 0) return Status::error("cannot start %s (fork failed)", argv[0].c_str());
  int status = 0;
  for (;;) {
    const pid_t done = ::waitpid(pid, &status, WNOHANG);
    if (done == pid) break;
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!child.timed_out && elapsed > double(timeout_s)) {
      child.timed_out = true;
      ::kill(pid, SIGKILL);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  child.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  child.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
  return Status::ok();
}

std::string read_text(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

// The last `lines` lines of the file at `path`.
std::string tail_lines(const std::string& path, size_t lines) {
  const std::string t = read_text(path);
  size_t at = t.size();
  for (size_t n = 0; at > 0 && n <= lines; --at)
    if (t[at - 1] == '\n') ++n;
  return t.substr(at);
}

// The JSON document in the file at `path`; null (and `why`) when it is missing or not JSON.
Json read_json(const std::string& path, std::string& why) {
  const Json j = Json::parse(read_text(path), nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) why = path + " is missing or not JSON";
  return j.is_discarded() ? Json() : j;
}

// One conformance test's entry of the report, from its gtest JSON output: counts, the failed and
// skipped tests with their messages.
Json test_entry(const std::string& name, const Child& child, const std::string& gtest_json, const std::string& log) {
  Json e = {{"name", name}, {"exit_code", child.exit_code}, {"timed_out", child.timed_out}, {"seconds", child.seconds}};
  std::string why;
  const Json g = read_json(gtest_json, why);
  uint32_t tests = 0, failed = 0, skipped = 0;
  Json failures = Json::array(), skips = Json::array();
  if (!g.is_null())
    for (const Json& suite : g.value("testsuites", Json::array()))
      for (const Json& t : suite.value("testsuite", Json::array())) {
        ++tests;
        const std::string full = suite.value("name", "") + "." + t.value("name", "");
        if (t.value("result", "") == "SKIPPED") {
          ++skipped;
          skips.push_back(full);
        }
        if (t.contains("failures")) {
          ++failed;
          std::string msg;
          for (const Json& f : t["failures"]) msg += f.value("failure", "") + "\n";
          failures.push_back({{"test", full}, {"message", msg}});
        }
      }
  e["tests"] = tests;
  e["failed"] = failed;
  e["skipped"] = skipped;
  e["failures"] = failures;
  e["skipped_tests"] = skips;
  e["passed"] = child.exit_code == 0 && !child.timed_out && !g.is_null() && failed == 0;
  if (!e["passed"].get<bool>()) e["log_tail"] = tail_lines(log, 40);
  if (g.is_null()) e["error"] = why;
  return e;
}

std::optional<int> parse(int argc, char** argv, CheckOptions& o) {
  Args args("check",
            "The GPU check (docs/gpu-check.md) from the folder scripts/gpu-check.sh built (--folder): on one\n"
            "Vulkan device, `lsnif-gpu devices`, the GPU conformance tests (bin/*_test with the folder's prepared\n"
            "models and meshes), bench-trace on the bunny and bench (Table 1: LSNIF vs triangles, inline and\n"
            "wavefront, the default model and the paper's low one) on the prepared scenes. Writes OUT/report.json and at most 6\n"
            "images (SCENE.PIPELINE.png: reference | LSNIF | FLIP); exit 0 only when every step passed.\n"
            "The device: --device, else the environment variable LSNIF_DEVICE, else the automatic choice.");
  args.positional("OUT", "output folder (report.json, images; its work/ subfolder is removed at the end)", &o.out);
  args.option("folder", "the GPU check folder (bin/, lib/, data/, models/)", &o.folder);
  args.option("scenes", "bench scenes, a list of bunny, dragons, heavy, strands, foliage, grid", &o.scenes);
  args.option("quality", "bench models, a list of default, high, low", &o.quality);
  args.option("width", "bench image width", &o.width, 16, 7680);
  args.option("height", "bench image height", &o.height, 16, 4320);
  args.option("spp", "bench samples per pixel", &o.spp, 1, 1024);
  args.option("rays", "bench-trace rays per trace", &o.rays, 1, 1u << 24);
  args.option("step-timeout", "seconds each step may run before it is stopped and failed", &o.step_timeout, 10,
              3600);
  args.flag("quick",
            "a smoke run (CI, lavapipe): the first test binary runs and the others only list their tests, the "
            "bunny scene only at 96x54 and 1 spp, 2^14 rays",
            &o.quick);
  args.flag("validation", "run the tests with the Khronos validation layer (it must be installed there)",
            &o.validation);
  args.flag("keep-work", "keep OUT/work/ (logs, gtest JSON, bench outputs)", &o.keep_work);
  add_device_option(args, &o.device);
  if (int r = args.parse(argc, argv)) return r == 1 ? 0 : 2;
  if (o.folder.empty() || !fs::is_regular_file(fs::path(o.folder) / "bin" / "lsnif-gpu")) {
    std::fprintf(stderr, "lsnif-gpu check: --folder must name the GPU check folder (it has bin/lsnif-gpu): %s\n",
                 o.folder.empty() ? "not given" : o.folder.c_str());
    return 2;
  }
  if (o.device.empty())
    if (const char* d = std::getenv("LSNIF_DEVICE"); d && *d) o.device = d;
  if (o.quick) {
    o.scenes = "bunny";
    o.width = 96, o.height = 54, o.spp = 1, o.rays = 1u << 14;
  }
  return std::nullopt;
}

// The state of one check run: where things are, and the report as it grows.
struct Check {
  CheckOptions o;
  OutputFolder out;  // OUT: what this run writes there is listed before it is written
  fs::path folder, bin, work;
  Json report;
  bool passed = true;

  std::vector<std::string> device_args() const {
    return o.device.empty() ? std::vector<std::string>{} : std::vector<std::string>{"--device", o.device};
  }
  // Runs one step (its stdout in work/NAME.out, stderr in work/NAME.log); false when it did not
  // start, failed or timed out.
  bool step(const std::string& name, std::vector<std::string> argv,
            const std::vector<std::pair<std::string, std::string>>& env, Child& child) {
    std::printf("-- %s\n", name.c_str());
    std::fflush(stdout);
    const Status s = run_child(argv, env, (work / (name + ".out")).string(), (work / (name + ".log")).string(),
                               o.step_timeout, child);
    if (!s) {
      std::printf("   %s\n", s.message().c_str());
      return false;
    }
    std::printf("   exit %d%s after %.1f s\n", child.exit_code, child.timed_out ? " (timed out)" : "", child.seconds);
    return child.exit_code == 0 && !child.timed_out;
  }
};

// devices: the device, driver, broad phase and MLP kernel into report["device"]; false when no
// device is selected. `index` receives the selected device's index for the tests.
bool run_devices(Check& c, std::string& index) {
  std::vector<std::string> argv = {(c.bin / "lsnif-gpu").string(), "devices", "--json"};
  for (const std::string& a : c.device_args()) argv.push_back(a);
  Child child;
  const bool ok = c.step("devices", argv, {}, child);
  std::string why;
  const Json d = read_json((c.work / "devices.out").string(), why);
  if (!ok || d.is_null() || !d.contains("selected_index") || d["selected_index"].is_null()) {
    c.report["device"] = {{"error", "no usable device: " + tail_lines((c.work / "devices.log").string(), 10)}};
    return false;
  }
  const size_t sel = d["selected_index"].get<size_t>();
  for (const Json& dev : d["devices"])
    if (dev.value("index", size_t(0)) == sel) c.report["device"] = dev;
  c.report["devices"] = d;
  index = std::to_string(sel);
  const Json& dev = c.report["device"];
  std::printf("   device %s (%s; %s %s), broad phase %s, MLP kernel %s\n", dev.value("name", "?").c_str(),
              dev.value("type", "?").c_str(), dev.value("driver", "?").c_str(), dev.value("driver_info", "").c_str(),
              dev.value("query_broad_phase", "?").c_str(), dev.value("mlp_kernel", "?").c_str());
  return true;
}

void run_tests(Check& c, const std::string& index) {
  Json list = Json::array();
  for (const char* name : kTests) {
    const std::string gtest_json = (c.work / (std::string(name) + ".json")).string();
    // --quick (CI's smoke run in the minimal root, after the whole suite ran outside it): the first
    // binary runs, the others only list their tests (they load and link there, nothing more).
    const bool list_only = c.o.quick && name != kTests[0];
    std::vector<std::string> argv = {(c.bin / name).string(), "--gtest_output=json:" + gtest_json};
    if (list_only) argv.push_back("--gtest_list_tests");
    Child child;
    c.step(name, argv,
           {{"LSNIF_TEST_DEVICE", index},
            {"LSNIF_TEST_MODELS", (c.folder / "models" / "tests").string()},
            {"LSNIF_TEST_DATA", (c.folder / "data").string()},
            {"LSNIF_TEST_VALIDATION", c.o.validation ? "1" : "0"},
            {"TMPDIR", (c.work / "tmp").string()}},
           child);
    Json e = test_entry(name, child, gtest_json, (c.work / (std::string(name) + ".out")).string());
    if (list_only) e["listed_only"] = true;
    if (list_only)
      std::printf("   listed %u tests (not run: --quick)\n", e["tests"].get<uint32_t>());
    else
      std::printf("   %u tests, %u failed, %u skipped\n", e["tests"].get<uint32_t>(), e["failed"].get<uint32_t>(),
                  e["skipped"].get<uint32_t>());
    c.passed &= e["passed"].get<bool>();
    list.push_back(std::move(e));
  }
  c.report["tests"] = std::move(list);
}

// bench-trace of the bunny with the MLP kernel `kernel` ("portable", "cooperative-matrix"): its JSON
// report into report[key].
void run_bench_trace(Check& c, const std::string& kernel, const std::string& key) {
  std::vector<std::string> argv = {(c.bin / "lsnif-gpu").string(), "bench-trace",
                                   (c.folder / "data" / "meshes" / "bunny00.off").string(),
                                   (c.folder / "models" / "trace" / "bunny.lsnif").string(),
                                   "--json",
                                   "--rays",
                                   std::to_string(c.o.rays),
                                   "--gemm-seconds",
                                   c.o.quick ? "0.05" : "0.5",
                                   "--mlp-kernel",
                                   kernel};
  for (const std::string& a : c.device_args()) argv.push_back(a);
  Child child;
  const std::string step = "bench-trace-" + kernel;
  const bool ok = c.step(step, argv, {}, child);
  std::string why;
  Json j = read_json((c.work / (step + ".out")).string(), why);
  if (!ok || j.is_null()) {
    c.passed = false;
    c.report[key] = {{"exit_code", child.exit_code}, {"error", why},
                     {"log_tail", tail_lines((c.work / (step + ".log")).string(), 30)}};
    return;
  }
  c.report[key] = std::move(j);
}

// bench on the prepared scenes: its results.json into report["bench"], its images into OUT.
void run_bench(Check& c) {
  const fs::path out = c.work / "bench";
  std::vector<std::string> argv = {(c.bin / "lsnif-gpu").string(), "bench", "--models",
                                   (c.folder / "models" / "bench").string(), "--data", (c.folder / "data").string(),
                                   "--out", out.string(), "--quality", c.o.quality, "--width",
                                   std::to_string(c.o.width), "--height", std::to_string(c.o.height), "--spp",
                                   std::to_string(c.o.spp),
                                   // Both pipelines, traced: the measurement behind the automatic choice.
                                   "--pipeline", "both", "--primary", "traced"};
  size_t position = 2;  // after "bench", in the order --scenes lists them
  for (size_t at = 0; at <= c.o.scenes.size();) {
    const size_t comma = std::min(c.o.scenes.find(',', at), c.o.scenes.size());
    argv.insert(argv.begin() + long(position++), c.o.scenes.substr(at, comma - at));
    at = comma + 1;
  }
  for (const std::string& a : c.device_args()) argv.push_back(a);
  Child child;
  const bool ok = c.step("bench", argv, {}, child);
  std::string why;
  Json j = read_json((out / "results.json").string(), why);
  if (!ok || j.is_null()) {
    c.passed = false;
    c.report["bench"] = {{"exit_code", child.exit_code}, {"error", why},
                         {"log_tail", tail_lines((c.work / "bench.log").string(), 30)}};
    return;
  }
  Json images = Json::array();
  for (const Json& row : j["rows"]) {
    const std::string image = row.value("image", "");
    if (row.value("quality", "") != "default" || images.size() >= kMaxImages || image.empty()) continue;
    // A plain file name (the child's results.json is read, not trusted), listed before it is copied.
    if (Status s = c.out.will_write(image); !s || fs::path(image).extension() != ".png") {
      std::fprintf(stderr, "lsnif-gpu check: bench image '%s' left out: %s\n", printable(image).c_str(),
                   s ? "not a PNG" : s.message().c_str());
      c.passed = false;
      continue;
    }
    std::error_code ec;
    fs::copy_file(out / image, fs::path(c.o.out) / image, fs::copy_options::overwrite_existing, ec);
    if (!ec) images.push_back(image);
  }
  for (const Json& row : j["rows"])
    std::printf("   %-8s %-4s %-9s T LSNIF / T reference %.2f, BLAS / LSNIF %.2f, FLIP %.4f\n",
                row.value("scene", "").c_str(), row.value("quality", "").c_str(), row.value("pipeline", "").c_str(),
                row.value("lsnif_over_reference", 0.0), row.value("blas_over_lsnif", 0.0), row.value("flip_mean", 0.0));
  c.report["bench"] = std::move(j);
  c.report["images"] = std::move(images);
}

}  // namespace

int cmd_check(int argc, char** argv) {
  Check c;
  if (const std::optional<int> r = parse(argc, argv, c.o)) return *r;
  c.folder = fs::absolute(c.o.folder);
  c.bin = c.folder / "bin";
  std::error_code ec;
  // OUT is created, or an earlier check's outputs there are removed; a folder holding anything else
  // is refused (the check removes and replaces only what it wrote: output_folder.h).
  if (Status s = OutputFolder::claim(c.o.out, "lsnif-gpu check", c.out); !s) {
    std::fprintf(stderr, "lsnif-gpu check: %s\n", s.message().c_str());
    return 1;
  }
  for (const char* name : {"work", "report.json"})
    if (Status s = c.out.will_write(name); !s) {
      std::fprintf(stderr, "lsnif-gpu check: %s\n", s.message().c_str());
      return 1;
    }
  c.work = fs::absolute(c.o.out) / "work";
  fs::create_directories(c.work / "tmp", ec);
  if (ec) {
    std::fprintf(stderr, "lsnif-gpu check: cannot create %s: %s\n", (c.work / "tmp").c_str(), ec.message().c_str());
    return 1;
  }
  const auto t0 = std::chrono::steady_clock::now();
  c.report = {{"lsnif_version", LSNIF_VERSION_STRING},
              {"options",
               {{"scenes", c.o.scenes}, {"quality", c.o.quality}, {"width", c.o.width}, {"height", c.o.height},
                {"spp", c.o.spp}, {"rays", c.o.rays}, {"quick", c.o.quick}, {"validation", c.o.validation},
                {"device", c.o.device}}}};
  std::string index;
  if (run_devices(c, index)) {
    run_tests(c, index);
    run_bench_trace(c, "portable", "bench_trace");
    // The unverified cooperative-matrix MLP kernel wherever the device could run it.
    if (c.report["device"].value("cooperative_matrix_mlp", "") != "unavailable")
      run_bench_trace(c, "cooperative-matrix", "bench_trace_cooperative_matrix");
    run_bench(c);
  } else {
    c.passed = false;
  }
  c.report["seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  c.report["passed"] = c.passed;
  const std::string path = (fs::path(c.o.out) / "report.json").string();
  if (!write_text_file("gpu check", path, c.report.dump(2) + "\n")) return 1;
  if (!c.o.keep_work) fs::remove_all(c.work, ec);
  std::printf("%s: wrote %s (%.0f s)\n", c.passed ? "PASSED" : "FAILED", path.c_str(),
              c.report["seconds"].get<double>());
  return c.passed ? 0 : 1;
}

}  // namespace lsnif::cli
