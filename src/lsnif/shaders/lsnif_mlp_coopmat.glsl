// lsnif_mlp_coopmat.glsl -- the batched MLP on VK_NV_cooperative_matrix (GL_NV_cooperative_matrix):
// the same network as lsnif_mlp.glsl (src/lsnif/core/network.cpp mlp_forward) behind the same
// interface (the batch rows of lsnif_batch_rows.glsl: input rows in, raw output rows out), with the
// activations in fp16 and fp32 accumulation, for a workgroup of LSNIF_BATCH_GROUP_SIZE (64) slots at
// once. UNVERIFIED: no GPU has run it yet (lavapipe has no cooperative matrices); the plugin builds it
// only when a query pipeline asks for it (LSNIF_QUERY_PIPELINE_CREATE_COOPERATIVE_MATRIX_MLP_BIT_NV).
//
// Per half of the workgroup's slots (32 slots, 4 tiles of 8), per layer: the layer's weights are
// unpacked from the model block (the portable kernel's interleaved octs, host_device.h) into shared
// memory as a row-major fp16 matrix padded to multiples of 16; each subgroup multiplies 16x16 weight
// tiles with 16x8 activation tiles of its slot tiles (the 16x8x16 fp16 x fp16 + fp32 shape), stores
// the 16x8 fp32 results of all output rows of a tile to its own shared staging, and then its lanes
// add the bias, apply leaky ReLU and write the tile's activations back in place (hidden layers) or
// the raw outputs to the batch rows (last layer). Shared memory: 32 KiB weights + 8 KiB
// activations + 8 KiB staging = 48 KiB (the plugin checks maxComputeSharedMemorySize).
// Limits: input and hidden width at most 128, output at most 32 (every configuration of the paper);
// other models take lsnif_mlp_forward per slot in the same stage (lsnif_rows_mlp_block).
// Needs: VK_NV_cooperative_matrix (cooperativeMatrix), shaderFloat16, subgroup size 32 or 64.
#ifndef LSNIF_MLP_COOPMAT_GLSL
#define LSNIF_MLP_COOPMAT_GLSL

#extension GL_NV_cooperative_matrix : require
#extension GL_KHR_memory_scope_semantics : require
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_EXT_shader_explicit_arithmetic_types_float16 : require

#include "lsnif/shaders/lsnif_batch_rows.glsl"

#define LSNIF_COOPMAT_MAX_DIM 128u  // input and hidden width, padded
#define LSNIF_COOPMAT_MAX_OUT 32u   // output rows, padded
#define LSNIF_COOPMAT_HALF 32u      // slots per pass (4 tiles of 8)
#define LSNIF_COOPMAT_TILE 8u       // slots per tile (N of the 16x8x16 shape)

shared float16_t lsnif_coopmat_w[LSNIF_COOPMAT_MAX_DIM * LSNIF_COOPMAT_MAX_DIM];  // [out_pad][in_pad]
shared float16_t lsnif_coopmat_h[LSNIF_COOPMAT_MAX_DIM * LSNIF_COOPMAT_HALF];     // [k][32 slots]
shared float lsnif_coopmat_t[2u * LSNIF_COOPMAT_MAX_DIM * LSNIF_COOPMAT_TILE];    // per subgroup [row][8]

uint lsnif_coopmat_pad(uint n) { return (n + 15u) & ~15u; }

// True when the model's network fits this kernel's shared memory.
bool lsnif_coopmat_fits(LsnifModel m) {
  return lsnif_coopmat_pad(lsnif_input_dim(m)) <= LSNIF_COOPMAT_MAX_DIM &&
         lsnif_coopmat_pad(m.h.hidden_width) <= LSNIF_COOPMAT_MAX_DIM &&
         lsnif_coopmat_pad(lsnif_output_dim(m)) <= LSNIF_COOPMAT_MAX_OUT;
}

// Weight (row r, input c) of the layer whose octs start at `oct` (P input pairs): word r % 8 of oct
// oct + (r / 8) * P + c / 2, half c % 2 (host_device.h, lsnif_mlp.glsl).
float lsnif_coopmat_weight(LsnifModel m, uint oct, uint pairs, uint r, uint c) {
  const uint word = m.words.w[(oct + (r >> 3) * pairs + (c >> 1)) * 8u + (r & 7u)];
  return unpackHalf2x16(word)[c & 1u];
}

// Bias of row r of the layer whose bias octs start at `bias_oct`: word (r % 8) / 2, half r % 2.
float lsnif_coopmat_bias(LsnifModel m, uint bias_oct, uint r) {
  const uint word = m.words.w[(bias_oct + (r >> 3)) * 8u + ((r & 7u) >> 1)];
  return unpackHalf2x16(word)[r & 1u];
}

// The MLP of slots first .. first + count - 1 (count <= 64) of the batch `r`; called by every
// invocation of the workgroup (uniform control flow: barriers and cooperative matrices).
void lsnif_rows_mlp_coopmat(LsnifBatchRows r, LsnifModel m, uint first, uint count) {
  const uint lid = gl_LocalInvocationID.x;
  const uint in_dim0 = lsnif_input_dim(m);
  const uint layers = m.h.hidden_layers + 1u;
  const float slope = m.h.leaky_slope;
  const uint staging = gl_SubgroupID * LSNIF_COOPMAT_MAX_DIM * LSNIF_COOPMAT_TILE;
  for (uint half_first = 0u; half_first < count; half_first += LSNIF_COOPMAT_HALF) {
    barrier();
    // The input of the 32 slots, zero beyond the input and beyond the batch.
    const uint in_pad0 = lsnif_coopmat_pad(in_dim0);
    for (uint e = lid; e < in_pad0 * LSNIF_COOPMAT_HALF; e += LSNIF_BATCH_GROUP_SIZE) {
      const uint k = e / LSNIF_COOPMAT_HALF, s = e % LSNIF_COOPMAT_HALF;
      float v = 0.0;
      if (k < in_dim0 && half_first + s < count)
        v = uintBitsToFloat(r.scratch.w[lsnif_rows_input(r, m, k, first + half_first + s)]);
      lsnif_coopmat_h[e] = float16_t(v);
    }
    uint in_dim = in_dim0;
    uint oct = m.h.mlp_offset >> 3;
    for (uint l = 0u; l < layers; ++l) {
      const bool hidden = l < m.h.hidden_layers;
      const uint out_dim = hidden ? m.h.hidden_width : lsnif_output_dim(m);
      const uint pairs = LSNIF_GPU_ROW_WORDS(in_dim), blocks = LSNIF_GPU_ROW_BLOCKS(out_dim);
      const uint bias_oct = oct + blocks * pairs;
      const uint in_pad = lsnif_coopmat_pad(in_dim), out_pad = lsnif_coopmat_pad(out_dim);
      barrier();  // every subgroup is done with the previous layer's weights and activations
      for (uint e = lid; e < out_pad * in_pad; e += LSNIF_BATCH_GROUP_SIZE) {
        const uint row = e / in_pad, c = e % in_pad;
        lsnif_coopmat_w[e] = float16_t(row < out_dim && c < in_dim ? lsnif_coopmat_weight(m, oct, pairs, row, c) : 0.0);
      }
      barrier();
      for (uint t = gl_SubgroupID; t < LSNIF_COOPMAT_HALF / LSNIF_COOPMAT_TILE; t += gl_NumSubgroups) {
        for (uint mb = 0u; mb < out_pad / 16u; ++mb) {
          fcoopmatNV<32, gl_ScopeSubgroup, 16, 8> acc = fcoopmatNV<32, gl_ScopeSubgroup, 16, 8>(0.0);
          for (uint kb = 0u; kb < in_pad / 16u; ++kb) {
            fcoopmatNV<16, gl_ScopeSubgroup, 16, 16> a;
            fcoopmatNV<16, gl_ScopeSubgroup, 16, 8> b;
            coopMatLoadNV(a, lsnif_coopmat_w, mb * 16u * in_pad + kb * 16u, in_pad, false);
            coopMatLoadNV(b, lsnif_coopmat_h, kb * 16u * LSNIF_COOPMAT_HALF + t * LSNIF_COOPMAT_TILE,
                          LSNIF_COOPMAT_HALF, false);
            acc = coopMatMulAddNV(a, b, acc);
          }
          coopMatStoreNV(acc, lsnif_coopmat_t, staging + mb * 16u * LSNIF_COOPMAT_TILE, LSNIF_COOPMAT_TILE, false);
        }
        subgroupMemoryBarrierShared();
        subgroupBarrier();
        // Bias and activation per element; the tile's columns are this subgroup's alone.
        const uint rows = hidden ? out_pad : LSNIF_GPU_ROW_BLOCK * blocks;
        for (uint e = gl_SubgroupInvocationID; e < rows * LSNIF_COOPMAT_TILE; e += gl_SubgroupSize) {
          const uint k = e / LSNIF_COOPMAT_TILE, j = e % LSNIF_COOPMAT_TILE;
          float v = lsnif_coopmat_t[staging + e] + (k < out_dim ? lsnif_coopmat_bias(m, bias_oct, k) : 0.0);
          const uint s = t * LSNIF_COOPMAT_TILE + j;
          if (hidden) {
            lsnif_coopmat_h[k * LSNIF_COOPMAT_HALF + s] = float16_t(max(v, slope * v));
          } else if (half_first + s < count) {
            r.scratch.w[lsnif_rows_output(r, m, k, first + half_first + s)] = floatBitsToUint(v);
          }
        }
        subgroupMemoryBarrierShared();
        subgroupBarrier();
      }
      oct = bias_oct + blocks;
      in_dim = out_dim;
    }
  }
}

// The MLP stage's work of one workgroup: slots first .. first + 63 of a batch of `batch` slots, with
// this kernel, or per slot with lsnif_mlp_forward (lsnif_rows_mlp) for a model beyond its limits.
// Every invocation of the workgroup calls it.
void lsnif_rows_mlp_block(LsnifBatchRows r, LsnifModel m, uint first, uint batch) {
  if (first >= batch) return;  // uniform over the workgroup
  if (lsnif_coopmat_fits(m)) {
    lsnif_rows_mlp_coopmat(r, m, first, min(batch - first, LSNIF_BATCH_GROUP_SIZE));
  } else if (first + gl_LocalInvocationID.x < batch) {
    lsnif_rows_mlp(r, m, first + gl_LocalInvocationID.x);
  }
}

#endif
