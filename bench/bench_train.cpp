// bench_train -- training throughput and time to quality targets (a benchmark, not a test).
//
//   bench_train [MESH] [--steps N] [--eval-every K] [--eval-rays R] [--hit segments|aabb] [--batch B]
//
// Trains with the default settings, evaluates a quantized snapshot every K steps on held-out rays
// (evaluation time is excluded from the training clock), and reports training rays/s and the first
// training time at which each target holds: the paper-level targets (occlusion accuracy >= 99.3%,
// median t error <= 2% of the diagonal, median normal error <= 10 deg) and our stricter ones
// (t <= 1%, normal <= 5 deg).
#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>

#include "evaluate.h"
#include "mesh.h"
#include "trainer.h"

using namespace lsnif;

int main(int argc, char** argv) {
  std::string mesh_path = std::string(LSNIF_DATA_DIR) + "/meshes/bunny00.off";
  TrainSettings settings;
  uint32_t eval_every = 250, eval_rays = 30000;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    auto next = [&]() -> const char* {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "bench_train: %s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--steps") settings.steps = uint32_t(std::atoi(next()));
    else if (a == "--eval-every") eval_every = uint32_t(std::atoi(next()));
    else if (a == "--eval-rays") eval_rays = uint32_t(std::atoi(next()));
    else if (a == "--batch") settings.batch_size = uint32_t(std::atoi(next()));
    else if (a == "--hit") settings.config.hit_param = std::strcmp(next(), "aabb") ? HitParam::VoxelSegments : HitParam::AabbInterval;
    else if (a == "--help") {
      std::puts("usage: bench_train [MESH] [--steps N] [--eval-every K] [--eval-rays R] [--batch B] [--hit segments|aabb]");
      return 0;
    } else if (a[0] != '-') mesh_path = a;
    else {
      std::fprintf(stderr, "bench_train: unknown option %s\n", a.c_str());
      return 2;
    }
  }
  if (eval_every == 0) eval_every = settings.steps;
  Mesh mesh;
  if (Status s = load_mesh(mesh_path, mesh); !s) {
    std::fprintf(stderr, "bench_train: %s\n", s.message().c_str());
    return 1;
  }
  std::printf("mesh %s (%zu triangles)\nsettings %s\n", mesh_path.c_str(), mesh.triangles.size(),
              settings.describe().c_str());
  std::printf("%6s %9s %9s %9s %9s %9s %9s\n", "step", "train_s", "acc%", "t_med%", "t_p90%", "n_med", "n_p90");

  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  double eval_seconds = 0;
  double t_paper = -1, t_ours = -1;
  EvalSettings es;
  es.rays = eval_rays;
  auto callback = [&](uint32_t step, const LossTerms&, const Model& current) {
    if (step % eval_every != 0 && step != settings.steps) return true;
    const auto e0 = Clock::now();
    Model snapshot = current;
    snapshot.quantize();
    EvalReport r;
    if (Status s = evaluate_model(snapshot, mesh, es, r); !s) {
      std::fprintf(stderr, "bench_train: %s\n", s.message().c_str());
      return false;
    }
    eval_seconds += std::chrono::duration<double>(Clock::now() - e0).count();
    const double train_s = std::chrono::duration<double>(Clock::now() - start).count() - eval_seconds;
    const EvalMetrics& m = r.model;
    std::printf("%6u %9.1f %9.3f %9.3f %9.3f %9.2f %9.2f\n", step, train_s, 100 * m.accuracy,
                100 * m.t_error_median, 100 * m.t_error_p90, m.normal_error_median, m.normal_error_p90);
    std::fflush(stdout);
    if (t_paper < 0 && m.accuracy >= 0.993 && m.t_error_median <= 0.02 && m.normal_error_median <= 10.0) t_paper = train_s;
    if (t_ours < 0 && m.accuracy >= 0.993 && m.t_error_median <= 0.01 && m.normal_error_median <= 5.0) t_ours = train_s;
    return true;
  };
  Model model;
  TrainReport rep;
  if (Status s = train_model(mesh, settings, model, &rep, callback); !s) {
    std::fprintf(stderr, "bench_train: %s\n", s.message().c_str());
    return 1;
  }
  const double train_seconds = rep.seconds - eval_seconds;
  std::printf("\ntraining: %.1f s for %llu rays = %.0f rays/s (sampling %.1f s, encoding %.1f s, MLP %.1f s, "
              "loss %.1f s, Adam %.1f s)\n",
              train_seconds, (unsigned long long)rep.rays, double(rep.rays) / train_seconds, rep.seconds_sampling,
              rep.seconds_encoding, rep.seconds_mlp, rep.seconds_loss, rep.seconds_optimizer);
  std::printf("time to paper-level targets (acc>=99.3%%, t<=2%%, n<=10deg): %s\n",
              t_paper < 0 ? "not reached" : (std::to_string(t_paper) + " s").c_str());
  std::printf("time to our targets (acc>=99.3%%, t<=1%%, n<=5deg): %s\n",
              t_ours < 0 ? "not reached" : (std::to_string(t_ours) + " s").c_str());
  return 0;
}
