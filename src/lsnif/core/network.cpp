#include "lsnif/core/network.h"

#include "lsnif/core/mlp_gemm.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <random>

namespace lsnif {

namespace {
// The batch is processed in fixed chunks of columns, one single-threaded product per chunk, layer
// and thread (mlp_gemm): on 2 cores this beat Eigen's own threaded GEMM several times over for these
// shapes, and because chunk boundaries depend on the batch size alone, never on the thread count,
// the summed weight gradients are bit-identical for any number of threads. Chunks are at most 512
// columns, so that the default training batch (4,096 rays: 8 chunks) gives every thread work (with
// 4,096-column chunks it ran on one core: the bunny's default training took 61.2 s with the MLP at
// 32.7 s; with 512, 42.8 s and 16.5 s; 1,024 and 2,048 the same within noise), an even number of
// them beyond 512 columns (two threads get the same share: a batch of 2,560 columns is 6 chunks of
// 427, not 5 of 512), and at most 64: mlp_backward keeps a gradient per chunk.
constexpr Eigen::Index kMaxChunkColumns = 512, kMaxChunks = 64;
struct ChunkLayout {
  Eigen::Index size;  // columns per chunk (the last may have fewer)
  long count;         // chunks: ceil(cols / size), which may be below the count asked for
};
ChunkLayout chunk_layout(Eigen::Index cols) {
  const long asked = cols <= kMaxChunkColumns
                         ? 1
                         : long(std::min<Eigen::Index>(kMaxChunks, 2 * ((cols + 2 * kMaxChunkColumns - 1) / (2 * kMaxChunkColumns))));
  const Eigen::Index size = std::max<Eigen::Index>(1, (cols + asked - 1) / asked);
  return {size, long((cols + size - 1) / size)};
}

// The offsets in MlpTrace::weights_bf16 of each layer's packed W (forward: pairs of inputs, out x
// ceil(in / 2) words; backward: pairs of outputs, in x ceil(out / 2)); the total in `size`.
struct Bf16Weights {
  std::vector<size_t> forward, backward;
  size_t size = 0;
};
Bf16Weights bf16_weight_layout(const Config& config, const std::vector<LayerView>& layers) {
  Bf16Weights w;
  for (size_t l = 0; l < layers.size(); ++l) {
    const LayerView& v = layers[l];
    w.forward.push_back(w.size);
    if (mlp_layer_bf16(config, l)) w.size += size_t(v.out) * ((v.in + 1) / 2);
    w.backward.push_back(w.size);
    if (mlp_layer_bf16(config, l)) w.size += size_t(v.in) * ((v.out + 1) / 2);
  }
  return w;
}

// A product whose left operand is a layer's weights as an M x K column-major matrix `a` (M values
// per k contiguous): W transposed for the forward product (M outputs, K inputs), W as stored
// (row-major [out][in]) for the input gradient W^T delta (M inputs, K outputs). The caller sets B,
// N and C, and may cut M or K.
GemmOperands weight_product(const float* a, uint32_t M, uint32_t K) {
  return GemmOperands{.M = M, .N = 0, .K = K, .A = a, .a_k = M};
}

// Two packed operands of `words` each per thread of a parallel region, allocated before the region
// (an allocation failing inside it could not reach the caller).
void reserve_packed(MlpTrace& trace, size_t words) {
  trace.packed.resize(size_t(omp_get_max_threads()));
  for (std::vector<uint32_t>& b : trace.packed)
    if (b.size() < 2 * words) b.resize(2 * words);
}
// The calling thread's two packed operands (reserve_packed sized them).
uint32_t* packed_buffers(MlpTrace& trace) { return trace.packed[size_t(omp_get_thread_num())].data(); }
}  // namespace

bool mlp_layer_bf16(const Config& config, size_t layer) {
  return layer < config.hidden_layers;  // every layer that feeds a hidden layer: all but the output layer
}

void mlp_forward(const Config& config, const float* params, const Matrix& input, Matrix& out,
                 MlpTrace* trace, const uint32_t* input_rows) {
  const std::vector<LayerView> layers = mlp_layers(config);
  const Eigen::Index B = input.cols();
  const auto [chunk, chunks] = chunk_layout(B);
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
  // Every layer's W transposed (column-major: each input's weights of all outputs contiguous), the
  // kernel's left operand: in the trace's workspace, else for this call.
  std::vector<float> own_weights_t;
  std::vector<float>& transposed = trace ? trace->weights_t : own_weights_t;
  transposed.resize(config.mlp_parameter_count());
  float* weights_t = transposed.data();
  const Bf16Weights bf16_layout = bf16_weight_layout(config, layers);
  Eigen::Index bf16_words = 0;  // the largest packed input of a chunk
  if (trace && trace->bf16_layers) {
    trace->weights_bf16.resize(bf16_layout.size);
    for (size_t l = 0; l < layers.size(); ++l)
      if (mlp_layer_bf16(config, l)) bf16_words = std::max<Eigen::Index>(bf16_words, (layers[l].in + 1) / 2 * chunk);
    reserve_packed(*trace, size_t(bf16_words));
  }
  // Without a trace, two activations of a chunk per thread (the hidden layers' outputs in turn).
  size_t activation_size = 0;
  for (size_t l = 0; l + 1 < layers.size(); ++l) activation_size = std::max(activation_size, size_t(layers[l].out) * size_t(chunk));
  std::vector<float> activations(trace ? 0 : 2 * activation_size * size_t(omp_get_max_threads()));
#pragma omp parallel
  {
    // Each thread transposes its share of every layer's rows; every product below reads all of it.
    for (const LayerView& v : layers) {
#pragma omp for schedule(static) nowait
      for (long o = 0; o < long(v.out); ++o)
        for (uint32_t i = 0; i < v.in; ++i)
          weights_t[v.weight_offset + size_t(i) * v.out + size_t(o)] = params[v.weight_offset + size_t(o) * v.in + i];
    }
#pragma omp barrier
    const bool bf16 = trace && trace->bf16_layers;
    if (bf16) {  // the bf16 layers' W as pairs of inputs, a layer per thread
#pragma omp for schedule(static)
      for (long l = 0; l < long(layers.size()); ++l)
        if (mlp_layer_bf16(config, size_t(l))) {
          pack_bf16_a(weight_product(weights_t + layers[size_t(l)].weight_offset, layers[size_t(l)].out, layers[size_t(l)].in),
                      trace->weights_bf16.data() + bf16_layout.forward[size_t(l)]);
        }
    }
    uint32_t* packed_x = bf16 ? packed_buffers(*trace) : nullptr;
    // This thread's activations of one chunk when no trace is kept.
    float* a = trace ? nullptr : activations.data() + 2 * activation_size * size_t(omp_get_thread_num());
    float* b = trace ? nullptr : a + activation_size;
    // Dynamic: chunks of a batch ordered by point count differ in cost; each chunk's result is
    // its own, so which thread runs it changes nothing.
#pragma omp for schedule(dynamic, 1)
    for (long c = 0; c < chunks; ++c) {
      const Eigen::Index c0 = c * chunk, n = std::min(chunk, B - c0);
      for (size_t l = 0; l < layers.size(); ++l) {
        const LayerView& v = layers[l];
        const bool last = l + 1 == layers.size();
        // Input of this layer for the chunk.
        const float* in_ptr = l == 0 ? x0.data() + c0 * x0.rows()
                              : trace ? trace->layer_input[l].data() + c0 * v.in
                                      : a;
        float* out_ptr;
        if (last) {
          out_ptr = out.data() + c0 * v.out;
        } else if (trace) {
          out_ptr = trace->layer_input[l + 1].data() + c0 * v.out;
        } else {
          out_ptr = b;
        }
        // y = W x + bias, then the leaky ReLU (0 <= slope < 1) but after the last layer; the first
        // layer reads only the chunk's leading `rows` inputs.
        GemmOperands op = weight_product(weights_t + v.weight_offset, v.out, v.in);
        op.N = n;
        op.K = l == 0 ? rows[size_t(c)] : Eigen::Index(v.in);
        op.B = in_ptr;
        op.b_k = 1;
        op.b_n = l == 0 ? x0.rows() : Eigen::Index(v.in);
        op.C = out_ptr;
        op.c_n = v.out;
        GemmEpilogue e;
        e.bias = params + v.bias_offset;
        e.leaky = !last;
        e.slope = slope;
        if (bf16 && mlp_layer_bf16(config, l))
          mlp_gemm_bf16(op, e, trace->weights_bf16.data() + bf16_layout.forward[l], packed_x);
        else
          mlp_gemm(op, e);
        if (!last && !trace) std::swap(a, b);
      }
    }
  }
}

namespace {
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

void mlp_backward(const Config& config, const float* params, MlpTrace& trace, const Matrix& d_out,
                  float* d_params, Matrix* d_input) {
  const std::vector<LayerView> layers = mlp_layers(config);
  const Eigen::Index B = d_out.cols();
  const size_t P = config.mlp_parameter_count();
  const auto [chunk, chunks] = chunk_layout(B);
  // Each chunk's gradient, every parameter written.
  trace.chunk_gradients.resize(size_t(chunks) * P);
  float* const partial_sums = trace.chunk_gradients.data();
  // Per thread, the gradient w.r.t. the current layer's pre-activation (delta), two of them used in
  // turn (a region has at most omp_get_max_threads() threads).
  trace.deltas.resize(2 * size_t(omp_get_max_threads()));
  const float slope = config.leaky_slope;
  Eigen::Index widest = 0;
  for (const LayerView& v : layers) widest = std::max<Eigen::Index>(widest, std::max(v.in, v.out));
  if (d_input) d_input->resize(config.input_dim(), B);
  const bool bf16 = trace.bf16_layers;
  const Bf16Weights bf16_layout = bf16_weight_layout(config, layers);
  // A chunk's packed operands (two buffers): x as pairs of rays and delta as the weight gradient's
  // B, or delta as the input gradient's B.
  const size_t bf16_words = size_t(widest) * size_t((chunk + 1) / 2) + size_t(chunk);
  for (std::vector<float>& d : trace.deltas) d.resize(size_t(widest * chunk));
  if (bf16) {
    trace.weights_bf16.resize(bf16_layout.size);
    reserve_packed(trace, bf16_words);
  }
#pragma omp parallel
  {
    std::vector<float>* delta_buf = &trace.deltas[2 * size_t(omp_get_thread_num())];
    uint32_t* packed = nullptr;
    if (bf16) {  // the bf16 layers' W as pairs of outputs (W^T's left operand), a layer per thread
      packed = packed_buffers(trace);
#pragma omp for schedule(static)
      for (long l = 0; l < long(layers.size()); ++l)
        if (mlp_layer_bf16(config, size_t(l))) {
          pack_bf16_a(weight_product(params + layers[size_t(l)].weight_offset, layers[size_t(l)].in, layers[size_t(l)].out),
                      trace.weights_bf16.data() + bf16_layout.backward[size_t(l)]);
        }
    }
#pragma omp for schedule(dynamic, 1)
    for (long c = 0; c < chunks; ++c) {
      const Eigen::Index c0 = c * chunk, n = std::min(chunk, B - c0);
      float* dp = partial_sums + size_t(c) * P;
      const float* delta_ptr = d_out.data() + c0 * d_out.rows();
      for (size_t li = layers.size(); li-- > 0;) {
        const LayerView& v = layers[li];
        const float* x = trace.layer_input[li].data() + c0 * v.in;
        // The first layer: only the input rows the forward pass read (the others are zero).
        const Eigen::Index k = li > 0 || trace.chunk_input_rows.empty() ? Eigen::Index(v.in)
                                                                        : trace.chunk_input_rows[size_t(c)];
        sum_columns(dp + v.bias_offset, delta_ptr, v.out, n);
        // dW^T (in x out, column-major: dW row-major) = x delta^T, summed over the chunk's columns.
        GemmOperands gw;
        gw.M = k;
        gw.N = v.out;
        gw.K = n;
        gw.A = x;
        gw.a_k = v.in;
        gw.B = delta_ptr;
        gw.b_k = v.out;
        gw.b_n = 1;
        gw.C = dp + v.weight_offset;
        gw.c_n = v.in;
        const bool in_bf16 = bf16 && mlp_layer_bf16(config, li);  // both products of this layer
        if (in_bf16) {
          pack_bf16_a(gw, packed);
          mlp_gemm_bf16(gw, {}, packed, packed + bf16_words);
        } else {
          mlp_gemm(gw);
        }
        if (k < Eigen::Index(v.in))
          for (uint32_t o = 0; o < v.out; ++o)
            std::fill(dp + v.weight_offset + size_t(o) * v.in + size_t(k), dp + v.weight_offset + size_t(o + 1) * v.in, 0.0f);
        if (li == 0 && !d_input) break;
        // d(input) = W^T delta; below the first layer through the leaky ReLU that made x.
        GemmOperands gx = weight_product(params + v.weight_offset, v.in, v.out);
        gx.M = k;
        gx.N = n;
        gx.B = delta_ptr;
        gx.b_k = 1;
        gx.b_n = v.out;
        GemmEpilogue e;
        float* next = delta_buf[li % 2].data();
        if (li == 0) {
          gx.C = d_input->data() + c0 * d_input->rows();
          gx.c_n = d_input->rows();
        } else {
          gx.C = next;
          gx.c_n = v.in;
          e.gate = x;
          e.gate_n = v.in;
          e.slope = slope;
        }
        if (in_bf16)  // W packed whole (v.in rows), the first layer's cut to the chunk's k
          mlp_gemm_bf16(gx, e, trace.weights_bf16.data() + bf16_layout.backward[li], packed, v.in);
        else
          mlp_gemm(gx, e);
        if (li == 0) {
          for (Eigen::Index col = 0; col < n; ++col)
            std::fill(gx.C + col * gx.c_n + k, gx.C + col * gx.c_n + v.in, 0.0f);
          break;
        }
        delta_ptr = next;
      }
    }
    // Sum the chunks' gradients in chunk order (deterministic), split over parameters.
#pragma omp for schedule(static)
    for (long i = 0; i < long(P); ++i) {
      float sum = 0.0f;
      for (long c = 0; c < chunks; ++c) sum += partial_sums[size_t(c) * P + size_t(i)];
      d_params[i] = 0.0f + sum;  // (as summed into a cleared d_params: -0 becomes +0)
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
