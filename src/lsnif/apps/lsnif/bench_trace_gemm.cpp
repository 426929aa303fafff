// bench_trace_gemm.cpp -- the CPU reference of `lsnif bench-trace` (bench_trace.h): the model's MLP
// as Eigen GEMMs on the trainer's OpenMP threads, the CPU limit of the network evaluations/s.
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <new>
#include <random>
#include <vector>

#include "lsnif/apps/lsnif/bench_trace.h"
#include "lsnif/core/network.h"

namespace lsnif::cli::bench_trace {

GemmReport run_gemm(const Model& model, uint32_t batch, double min_seconds) {
  const Config& config = model.config;
  const std::vector<LayerView> layers = mlp_layers(config);
  GemmReport g;
  g.threads = uint32_t(std::max(1, omp_get_max_threads()));
  g.batch = batch;
  std::vector<Matrix> weights;
  std::vector<Eigen::VectorXf> biases;
  for (size_t l = 0; l < layers.size(); ++l) {
    const LayerView& v = layers[l];
    const uint32_t in = l == 0 ? 2u * LSNIF_GPU_ROW_WORDS(v.in) : v.in;
    Matrix w = Matrix::Zero(v.out, in);
    for (uint32_t r = 0; r < v.out; ++r)
      for (uint32_t c = 0; c < v.in; ++c) w(r, c) = model.mlp[v.weight_offset + size_t(r) * v.in + c];
    weights.push_back(std::move(w));
    biases.push_back(Eigen::Map<const Eigen::VectorXf>(model.mlp.data() + v.bias_offset, v.out));
    if (l == 0) g.widths.push_back(in);
    g.widths.push_back(v.out);
    g.flops_per_column += 2.0 * double(in) * double(v.out);
  }
  // Per thread: the input and one output per layer, allocated once (the passes allocate only Eigen's workspace).
  std::vector<std::vector<Matrix>> acts(g.threads);
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (std::vector<Matrix>& a : acts) {
    for (const uint32_t w : g.widths) a.emplace_back(w, batch);
    for (Eigen::Index i = 0; i < a[0].size(); ++i) a[0].data()[i] = u(rng);
  }
  const float slope = config.leaky_slope;
  // Eigen's products allocate their blocking workspace on the heap: a failure there is caught in
  // its thread (an exception cannot leave the parallel region) and thrown again after it.
  auto pass = [&]() {
    bool out_of_memory = false;
#pragma omp parallel num_threads(int(g.threads))
    {
      try {
        std::vector<Matrix>& a = acts[size_t(omp_get_thread_num())];
        for (size_t l = 0; l < weights.size(); ++l) {
          a[l + 1].noalias() = weights[l] * a[l];
          a[l + 1].colwise() += biases[l];
          if (l + 1 < weights.size()) a[l + 1] = a[l + 1].cwiseMax(slope * a[l + 1]);
        }
      } catch (const std::bad_alloc&) {
#pragma omp atomic write
        out_of_memory = true;
      }
    }
    if (out_of_memory) throw std::bad_alloc();
  };
  pass();
  const double cpu0 = process_cpu_seconds();
  const auto t0 = std::chrono::steady_clock::now();
  do {
    pass();
    ++g.passes;
    g.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  } while (g.seconds < min_seconds);
  g.cpu_seconds = process_cpu_seconds() - cpu0;
  return g;
}

}  // namespace lsnif::cli::bench_trace
