#include "lsnif/core/network.h"

#include <algorithm>
#include <cmath>
#include <random>

namespace lsnif {

namespace {
using RowMajorMap = Eigen::Map<const Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>;
using RowMajorMapMut = Eigen::Map<Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>;

}  // namespace

namespace {
// The batch is processed in fixed chunks of columns, one single-threaded GEMM per chunk and
// thread: on 2 cores this beats Eigen's own threaded GEMM several times over for these shapes,
// and because chunk boundaries depend on the batch size alone, never on the thread count, the
// summed weight gradients are bit-identical for any number of threads. Chunks are 512 columns, so
// that the default training batch (4,096 rays) gives every thread work (with 4,096-column chunks it
// ran on one core: the bunny's default training took 61.2 s with the MLP at 32.7 s; with 512,
// 42.8 s and 16.5 s; 1,024 and 2,048 the same within noise), and wider for batches beyond 32,768
// columns, so that there are at most 64 chunks: mlp_backward keeps a gradient per chunk.
constexpr Eigen::Index kMinChunk = 512, kMaxChunks = 64;
Eigen::Index chunk_size(Eigen::Index cols) { return std::max(kMinChunk, (cols + kMaxChunks - 1) / kMaxChunks); }
long chunk_count(Eigen::Index cols) { return long((cols + chunk_size(cols) - 1) / chunk_size(cols)); }
}  // namespace

void mlp_forward(const Config& config, const float* params, const Matrix& input, Matrix& out,
                 MlpTrace* trace, const uint32_t* input_rows) {
  const std::vector<LayerView> layers = mlp_layers(config);
  const Eigen::Index B = input.cols();
  const Eigen::Index chunk = chunk_size(B);
  const long chunks = chunk_count(B);
  // Per chunk, the leading input rows any of its columns may use.
  std::vector<Eigen::Index> rows(size_t(chunks), input.rows());
  if (input_rows)
    for (long c = 0; c < chunks; ++c) {
      const Eigen::Index c0 = c * chunk, n = std::min(chunk, B - c0);
      rows[size_t(c)] = Eigen::Index(*std::max_element(input_rows + c0, input_rows + c0 + n));
      rows[size_t(c)] = std::min(rows[size_t(c)], input.rows());
    }
  if (trace) {
    // The input may already be trace->layer_input[0] (kept, not copied; moved across the resize,
    // which may reallocate the vector).
    const bool in_trace = !trace->layer_input.empty() && &trace->layer_input[0] == &input;
    Matrix kept;
    if (in_trace) kept = std::move(trace->layer_input[0]);
    trace->layer_input.resize(layers.size());
    if (in_trace)
      trace->layer_input[0] = std::move(kept);
    else
      trace->layer_input[0] = input;
    for (size_t l = 1; l < layers.size(); ++l) trace->layer_input[l].resize(layers[l].in, B);
    trace->chunk_input_rows = rows;
  }
  const Matrix& x0 = trace ? trace->layer_input[0] : input;  // `input` may have moved (above)
  out.resize(layers.back().out, B);
  const float slope = config.leaky_slope;
#pragma omp parallel
  {
    Matrix a, b;  // per-thread activations of one chunk when no trace is kept
    // Dynamic: chunks of a batch ordered by point count differ in cost; each chunk's result is
    // its own, so which thread runs it changes nothing.
#pragma omp for schedule(dynamic, 1)
    for (long c = 0; c < chunks; ++c) {
      const Eigen::Index c0 = c * chunk, n = std::min(chunk, B - c0);
      for (size_t l = 0; l < layers.size(); ++l) {
        const LayerView& v = layers[l];
        RowMajorMap W(params + v.weight_offset, v.out, v.in);
        Eigen::Map<const Eigen::VectorXf> bias(params + v.bias_offset, v.out);
        const bool last = l + 1 == layers.size();
        // Input of this layer for the chunk.
        const float* in_ptr = l == 0 ? x0.data() + c0 * x0.rows()
                              : trace ? trace->layer_input[l].data() + c0 * v.in
                                      : a.data();
        Eigen::Map<const Matrix> x(in_ptr, v.in, n);
        float* out_ptr;
        if (last) {
          out_ptr = out.data() + c0 * v.out;
        } else if (trace) {
          out_ptr = trace->layer_input[l + 1].data() + c0 * v.out;
        } else {
          b.resize(v.out, n);
          out_ptr = b.data();
        }
        Eigen::Map<Matrix> y(out_ptr, v.out, n);
        if (l == 0) {
          const Eigen::Index k = rows[size_t(c)];
          if (k > 0)
            y.noalias() = W.leftCols(k) * x.topRows(k);
          else
            y.setZero();
        } else {
          y.noalias() = W * x;
        }
        y.colwise() += bias;
        if (!last) {
          y = y.cwiseMax(slope * y);  // leaky ReLU (0 <= slope < 1)
          if (!trace) a.swap(b);
        }
      }
    }
  }
}

namespace {
// dz = dx * leaky'(z), written from the activation x = leaky(z) (x > 0 exactly where z > 0). A
// separate function with restrict parameters so that GCC vectorizes it.
void leaky_backward(float* __restrict dz, const float* __restrict dx, const float* __restrict x,
                    float slope, Eigen::Index n) {
  for (Eigen::Index i = 0; i < n; ++i) {
    const float gain = x[i] > 0.0f ? 1.0f : slope;  // this form vectorizes, "? dx : slope*dx" does not
    dz[i] = dx[i] * gain;
  }
}
// out[r] = sum over columns c of m(r, c), summed in column order for every r. Eigen's
// rowwise().sum() treats an alignment-dependent head and tail of rows with another summation
// order, which made gradients depend on where the heap put the buffers (caught by the
// determinism test); this loop vectorizes across rows without changing any row's order.
void sum_columns(float* __restrict out, const float* __restrict m, Eigen::Index rows, Eigen::Index cols) {
  for (Eigen::Index r = 0; r < rows; ++r) out[r] = 0.0f;
  for (Eigen::Index c = 0; c < cols; ++c)
    for (Eigen::Index r = 0; r < rows; ++r) out[r] += m[c * rows + r];
}
}  // namespace

void mlp_backward(const Config& config, const float* params, const MlpTrace& trace,
                  const Matrix& d_out, float* d_params, Matrix* d_input) {
  const std::vector<LayerView> layers = mlp_layers(config);
  const Eigen::Index B = d_out.cols();
  const size_t P = config.mlp_parameter_count();
  const Eigen::Index chunk = chunk_size(B);
  const long chunks = chunk_count(B);
  std::vector<float> partial(size_t(chunks) * P);
  const float slope = config.leaky_slope;
  Eigen::Index widest = 0;
  for (const LayerView& v : layers) widest = std::max<Eigen::Index>(widest, std::max(v.in, v.out));
  if (d_input) d_input->resize(config.input_dim(), B);
#pragma omp parallel
  {
    // Per-thread scratch, allocated once: the gradient w.r.t. the current layer's pre-activation
    // (delta) and w.r.t. its input (prev).
    std::vector<float> delta_buf(size_t(widest * chunk)), prev_buf(size_t(widest * chunk));
#pragma omp for schedule(dynamic, 1)
    for (long c = 0; c < chunks; ++c) {
      const Eigen::Index c0 = c * chunk, n = std::min(chunk, B - c0);
      float* dp = partial.data() + size_t(c) * P;
      const float* delta_ptr = d_out.data() + c0 * d_out.rows();
      for (size_t li = layers.size(); li-- > 0;) {
        const LayerView& v = layers[li];
        Eigen::Map<const Matrix> delta(delta_ptr, v.out, n);
        Eigen::Map<const Matrix> x(trace.layer_input[li].data() + c0 * v.in, v.in, n);
        RowMajorMapMut dW(dp + v.weight_offset, v.out, v.in);
        RowMajorMap W(params + v.weight_offset, v.out, v.in);
        sum_columns(dp + v.bias_offset, delta_ptr, v.out, n);
        if (li == 0) {  // only the input rows the forward pass read (the others are zero)
          const Eigen::Index k = trace.chunk_input_rows.empty() ? v.in : trace.chunk_input_rows[size_t(c)];
          dW.leftCols(k).noalias() = delta * x.topRows(k).transpose();
          dW.rightCols(v.in - k).setZero();
          if (d_input) {
            d_input->middleCols(c0, n).topRows(k).noalias() = W.leftCols(k).transpose() * delta;
            d_input->middleCols(c0, n).bottomRows(v.in - k).setZero();
          }
          break;
        }
        dW.noalias() = delta * x.transpose();
        Eigen::Map<Matrix> prev(prev_buf.data(), v.in, n);
        prev.noalias() = W.transpose() * delta;
        leaky_backward(delta_buf.data(), prev_buf.data(), x.data(), slope, v.in * n);
        delta_ptr = delta_buf.data();
      }
    }
    // Sum the chunks' gradients in chunk order (deterministic), split over parameters.
#pragma omp for schedule(static)
    for (long i = 0; i < long(P); ++i) {
      float sum = 0.0f;
      for (long c = 0; c < chunks; ++c) sum += partial[size_t(c) * P + size_t(i)];
      d_params[i] += sum;
    }
  }
}

void mlp_init_kaiming(const Config& config, uint64_t seed, float* params) {
  std::mt19937_64 rng(seed);
  const float a = config.leaky_slope;
  const float gain = std::sqrt(2.0f / (1.0f + a * a));
  for (const LayerView& v : mlp_layers(config)) {
    std::normal_distribution<float> normal(0.0f, gain / std::sqrt(float(v.in)));
    for (size_t i = 0; i < size_t(v.in) * v.out; ++i) params[v.weight_offset + i] = normal(rng);
    for (uint32_t i = 0; i < v.out; ++i) params[v.bias_offset + i] = 0.0f;
  }
}

}  // namespace lsnif
