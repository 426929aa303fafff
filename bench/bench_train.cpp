// bench_train -- training time and time to quality targets of training recipes, side by side (a
// benchmark, not a test).
//
//   bench_train [MESH] [--recipe NAME=JSON]... [--eval-every K] [--eval-rays R] [--tol-acc A] [--tol-rel R]
//
// Trains each recipe on the same mesh, one after the other in this one process (so that they share
// the host's load), evaluates a quantized snapshot every K steps and at the last step on the same
// held-out rays (evaluation time is excluded from the training clock), and reports per recipe its
// training time, the ratio to the first recipe's (the reference), and the first training time at
// which each target holds, as a fraction of the reference's training time:
//   paper    occlusion accuracy >= 99.3%, median t error <= 2% of the diagonal, median normal
//            error <= 10 deg (the paper-level quality);
//   ref      the reference's final quality within the noise tolerance: accuracy >= its final
//            accuracy - A, median t and median normal error <= its final value * (1 + R).
// A recipe is a `--config` JSON object applied over the defaults ({} = the defaults). Without
// --recipe: `baseline` (2000 steps of 2^14 rays at the paper's constant learning rate: the default
// before the learning-rate schedule and the smaller batch) and `default` (the defaults).
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "lsnif/train/evaluate.h"
#include "lsnif/import/mesh.h"
#include "lsnif/train/settings_io.h"
#include "lsnif/train/trainer.h"

using namespace lsnif;

namespace {

struct Recipe {
  std::string name, json;
  TrainSettings settings;
  std::vector<std::pair<double, EvalMetrics>> evals;  // (training seconds, metrics)
  double seconds = 0;
  TrainReport report;
};

bool meets(const EvalMetrics& m, double acc, double t, double n) {
  return m.accuracy >= acc && m.t_error_median <= t && m.normal_error_median <= n;
}

// The first training time at which the targets hold, or -1.
double time_to(const Recipe& r, double acc, double t, double n) {
  for (const auto& [s, m] : r.evals)
    if (meets(m, acc, t, n)) return s;
  return -1;
}

std::string fraction(double seconds, double of) {
  if (seconds < 0) return "not reached";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.1f s = %.0f%%", seconds, 100.0 * seconds / of);
  return buf;
}

[[noreturn]] void fail(const std::string& message) {
  std::fprintf(stderr, "bench_train: %s\n", message.c_str());
  std::exit(1);
}

}  // namespace

int main(int argc, char** argv) {
  std::string mesh_path = std::string(LSNIF_DATA_DIR) + "/meshes/bunny00.off";
  uint32_t eval_every = 100, eval_rays = 30000;
  double tol_acc = 0.0005, tol_rel = 0.05;
  std::vector<Recipe> recipes;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) fail(a + " needs a value");
      return argv[++i];
    };
    if (a == "--eval-every") eval_every = uint32_t(std::atoi(next().c_str()));
    else if (a == "--eval-rays") eval_rays = uint32_t(std::atoi(next().c_str()));
    else if (a == "--tol-acc") tol_acc = std::atof(next().c_str());
    else if (a == "--tol-rel") tol_rel = std::atof(next().c_str());
    else if (a == "--recipe") {
      const std::string v = next();
      const size_t eq = v.find('=');
      if (eq == std::string::npos || eq == 0) fail("--recipe wants NAME=JSON, not " + v);
      recipes.push_back({v.substr(0, eq), v.substr(eq + 1), {}, {}, 0, {}});
    } else if (a == "--help") {
      std::puts("usage: bench_train [MESH] [--recipe NAME=JSON]... [--eval-every K] [--eval-rays R] [--tol-acc A] "
                "[--tol-rel R]");
      return 0;
    } else if (a[0] != '-') mesh_path = a;
    else fail("unknown option " + a);
  }
  if (eval_every == 0) fail("--eval-every must be at least 1");
  if (recipes.empty()) {
    recipes.push_back({"baseline", R"({"steps": 2000, "batch": 16384, "ray-reuse": 1, "lr": 0.01, "lr-schedule": "constant"})", {}, {}, 0, {}});
    recipes.push_back({"default", "{}", {}, {}, 0, {}});
  }
  for (Recipe& r : recipes) {
    SettingLayer layer;
    if (Status s = parse_settings_json(r.json, "recipe " + r.name, layer); !s) fail(s.message());
    if (Status s = resolve_settings({&layer}, r.settings); !s) fail(s.message());
  }
  Mesh mesh;
  if (Status s = load_mesh(mesh_path, mesh); !s) fail(s.message());
  std::printf("mesh %s (%zu triangles), %u held-out rays, a snapshot every %u steps\n", mesh_path.c_str(),
              mesh.triangles.size(), eval_rays, eval_every);

  using Clock = std::chrono::steady_clock;
  EvalSettings es;
  es.rays = eval_rays;
  long trained = 0;
  // The summary over the recipes trained so far (after each recipe: a cut-short run keeps its rows).
  auto print_summary = [&] {
    const Recipe& ref = recipes.front();
    const EvalMetrics& f = ref.evals.back().second;
    const double ref_acc = f.accuracy - tol_acc, ref_t = f.t_error_median * (1 + tol_rel),
                 ref_n = f.normal_error_median * (1 + tol_rel);
    std::printf("\nreference %s: %.1f s, final acc %.3f%%, median t %.3f%%, median normal %.2f deg\n", ref.name.c_str(),
                ref.seconds, 100 * f.accuracy, 100 * f.t_error_median, f.normal_error_median);
    std::printf("targets: paper = acc >= 99.3%%, t <= 2%%, normal <= 10 deg; ref = acc >= %.3f%%, t <= %.3f%%, "
                "normal <= %.2f deg (the reference's final values, tolerance %.2f points / %.0f%%)\n",
                100 * ref_acc, 100 * ref_t, ref_n, 100 * tol_acc, 100 * tol_rel);
    std::printf("%-12s %6s %9s %7s %8s %8s %8s %20s %20s\n", "recipe", "steps", "train_s", "ratio", "acc%", "t_med%",
                "n_med", "to paper", "to ref");
    for (const Recipe& r : recipes) {
      if (&r - recipes.data() >= trained) break;
      if (r.evals.empty()) {
        std::printf("%-12s %6u   failed\n", r.name.c_str(), r.settings.steps);
        continue;
      }
      const EvalMetrics& m = r.evals.back().second;
      std::printf("%-12s %6u %9.1f %6.0f%% %8.3f %8.3f %8.2f %20s %20s\n", r.name.c_str(), r.settings.steps, r.seconds,
                  100 * r.seconds / ref.seconds, 100 * m.accuracy, 100 * m.t_error_median, m.normal_error_median,
                  fraction(time_to(r, 0.993, 0.02, 10.0), ref.seconds).c_str(),
                  fraction(time_to(r, ref_acc, ref_t, ref_n), ref.seconds).c_str());
    }
  };
  for (Recipe& r : recipes) {
    std::printf("\n%s %s\n  %s\n", r.name.c_str(), r.json.c_str(), r.settings.describe().c_str());
    std::printf("%6s %9s %9s %9s %9s %9s %9s\n", "step", "train_s", "acc%", "t_med%", "t_p90%", "n_med", "n_p90");
    std::fflush(stdout);
    const auto start = Clock::now();
    double eval_seconds = 0;
    // A row per snapshot: the step's parameters quantized (every eval_every steps), and after the
    // last step the model the trainer keeps (with ema-decay, the average of the last steps').
    auto eval_row = [&](uint32_t step, const Model& snapshot) {
      const auto e0 = Clock::now();
      const double train_s = std::chrono::duration<double>(e0 - start).count() - eval_seconds;
      EvalReport e;
      if (Status s = evaluate_model(snapshot, mesh, es, e); !s) fail(s.message());
      eval_seconds += std::chrono::duration<double>(Clock::now() - e0).count();
      const EvalMetrics& m = e.model;
      r.evals.push_back({train_s, m});
      std::printf("%6u %9.1f %9.3f %9.3f %9.3f %9.2f %9.2f\n", step, train_s, 100 * m.accuracy,
                  100 * m.t_error_median, 100 * m.t_error_p90, m.normal_error_median, m.normal_error_p90);
      std::fflush(stdout);
    };
    uint32_t last_step = 0;
    auto callback = [&](uint32_t step, const LossTerms&, const Model& current) {
      last_step = step;
      if (step % eval_every != 0 || step == r.settings.steps) return true;
      Model snapshot = current;
      snapshot.quantize();
      eval_row(step, snapshot);
      return true;
    };
    Model model;
    Status trained_ok = train_model(mesh, r.settings, model, &r.report, callback);
    if (trained_ok) eval_row(last_step, model);
    if (Status s = trained_ok; !s) {
      if (&r == &recipes.front()) fail(s.message());
      std::printf("%s failed: %s\n", r.name.c_str(), s.message().c_str());  // the other recipes still run
      r.evals.clear();
      ++trained;
      continue;
    }
    r.seconds = r.evals.back().first;
    const TrainReport& t = r.report;
    std::printf("training %.1f s, %.0f rays/s (sampling %.1f s, encoding %.1f s, MLP %.1f s, loss %.1f s, "
                "Adam %.1f s)\n",
                r.seconds, double(t.rays) / r.seconds, t.seconds_sampling, t.seconds_encoding, t.seconds_mlp,
                t.seconds_loss, t.seconds_optimizer);
    ++trained;
    print_summary();
  }

  return 0;
}
