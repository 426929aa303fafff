#include "lsnif/train/trainer.h"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <numeric>
#include <random>
#include <thread>

#include "lsnif/core/grid_usage.h"
#include "lsnif/train/ground_truth.h"
#include "lsnif/train/settings_io.h"
#include "lsnif/core/hash_grid.h"
#include "lsnif/core/rng.h"
#include "lsnif/core/head.h"
#include "lsnif/core/mlp_gemm.h"
#include "lsnif/core/network.h"
#include "lsnif/train/uv_materials.h"
#include "lsnif/train/voxelizer.h"

namespace lsnif {

std::string TrainSettings::describe() const {
  return format("%s | steps=%u batch=%u ray_reuse=%u seed=%llu | %s, %s | %s", config.describe().c_str(), steps,
                batch_size, ray_reuse, (unsigned long long)seed, adam.describe().c_str(),
                lr_schedule.describe().c_str(), loss_settings.describe().c_str());
}

Status model_layout(const Mesh& mesh, const TrainSettings& settings, Config& config, VoxelGrid& voxels,
                    std::vector<uint16_t>& grid_index) {
  // Cut-outs: only the voxels of their opaque parts (docs/convert.md, "Materials": measured smaller and
  // no worse).
  voxels = voxelize(mesh, config.voxel_resolution, pad_aabb(mesh.bounds()), /*opaque_cells_only=*/true);
  return index_grid_levels(voxels, settings.indexed, config, grid_index);
}

Status check_training_inputs(const Mesh& mesh, const TrainSettings& settings, Config& config,
                             std::vector<std::string>* warnings) {
  config = settings.config;
  if (settings.mlp_precision == kMlpPrecisionBf16 && !mlp_gemm_bf16_native())
    return Status::error("mlp-precision bf16: this build's MLP kernel (%s) has no bf16 instructions (AVX512_BF16); "
                         "use auto or fp32",
                         mlp_gemm_isa());
  if (mesh.materials.empty()) return Status::error("mesh has no material table");
  if (mesh.materials.size() > LSNIF_MAX_MATERIALS)
    return Status::error("mesh has %zu materials; an LSNIF model supports at most %u",
                         mesh.materials.size(), LSNIF_MAX_MATERIALS);
  config.material_count = uint32_t(mesh.materials.size());
  config.surface_channels = learns_surface_channels(mesh, settings.surface_maps) ? 1u : 0u;
  config.emission_scale = 0.0f;
  if (config.surface_channels) {
    const float emission = mesh.max_emission();
    if (!(emission <= float(LSNIF_MAX_EMISSION_SCALE)))
      return Status::error("a material's emission %g exceeds the %g an LSNIF model can learn", double(emission),
                           LSNIF_MAX_EMISSION_SCALE);
    config.emission_scale = emission;
  }
  const UvMaterialChoice uv = choose_uv_materials(mesh, settings.texture_coordinates);
  config.uv_materials = uv.materials;
  config.uv_cells = uv.materials ? settings.uv_cells : 0u;
  if (warnings) warnings->insert(warnings->end(), uv.warnings.begin(), uv.warnings.end());
  if (Status s = check_train_settings(settings); !s) return s;
  if (!(settings.time_budget >= 0 && settings.time_budget <= kMaxTimeBudget))
    return Status::error("time budget %g s out of range [0, %g] (0: no limit)", settings.time_budget, kMaxTimeBudget);
  // The config with the mesh's materials and surface channels.
  if (Status s = config.validate(); !s) return s.context("training config");
  return Status::ok();
}

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Per ray and input slot (point j, level l): the 4 table entries and weights of its face cell,
// the rays' slots one after another (ray r's from start[r]: a walk has ~5 of the H = 18 points,
// so the arrays are ~1/4 of H * L * 4 per ray, and the encoder's passes touch that much less memory).
struct BatchCorners {
  std::vector<uint32_t> entry;
  std::vector<float> weight;
  std::vector<size_t> start;  // B + 1 offsets into entry and weight
};

// Encodes a batch into X (input_dim x B), column r from walks[order[r]] (rows[r] its encoded rows,
// order_by_point_count's), and remembers the corners for the backward pass. The table lookups are
// the encoder's cost (cache misses into a table larger than the core's cache), so the work is
// pipelined across rays: while ray r's features are summed, ray r + 1's corners are computed and
// their table rows prefetched.
constexpr long kEncodeBlock = 64;  // rays per block; the blocks go to the threads as they come free

void encode_batch(const Config& config, const GridLayout& layout, const float* table,
                  const std::vector<RayWalk>& walks, const std::vector<size_t>& order,
                  const std::vector<uint32_t>& rows, Matrix& X, BatchCorners& corners, std::vector<double>& pace) {
  const uint32_t H = config.max_points, L = config.grid_levels, F = config.features;
  const long B = long(order.size());
  // Only the slots of recorded points are stored (and later read); each column of X is zeroed
  // beyond them. The offsets come from the rays' encoded rows (n points x L x F), not from their
  // walks: those are scattered in memory, and this pass is serial.
  corners.start.resize(size_t(B) + 1);
  corners.start[0] = 0;
  for (long r = 0; r < B; ++r) corners.start[size_t(r) + 1] = corners.start[size_t(r)] + size_t(rows[size_t(r)] / F) * 4;
  corners.entry.resize(corners.start.back());
  corners.weight.resize(corners.start.back());
  X.resize(config.input_dim(), B);
  // Ray r's corners into the corner arrays, its table rows prefetched.
  auto find_corners = [&](long r) {
    const RayWalk& w = walks[order[size_t(r)]];
    uint32_t* ce = corners.entry.data() + corners.start[size_t(r)];
    float* cw = corners.weight.data() + corners.start[size_t(r)];
    const uint32_t slots = std::min(w.count, H) * L;
    FaceCorners fc;
    for (uint32_t s = 0; s < slots; ++s) {
      face_corners(config, s % L, w.p[s / L], w.axis[s / L], fc, layout);
      for (uint32_t k = 0; k < 4; ++k) {
        ce[s * 4 + k] = fc.entry[k];
        cw[s * 4 + k] = fc.weight[k];
        __builtin_prefetch(table + size_t(fc.entry[k]) * F);
      }
    }
  };
  // The lines of a walk that find_corners reads (its count and points; a walk is ~9 cache lines).
  auto prefetch_walk = [](const RayWalk& w) {
    const char* at = reinterpret_cast<const char*>(&w);
    for (size_t b = 0; b < sizeof(RayWalk); b += 64) __builtin_prefetch(at + b);
  };
  // The dense slots find_corners will read for ray r (its walk already in the cache).
  auto prefetch_slots = [&](long r) {
    const RayWalk& w = walks[order[size_t(r)]];
    const uint32_t slots = std::min(w.count, H) * L;
    for (uint32_t s = 0; s < slots; ++s) prefetch_face_corners(config, s % L, w.p[s / L], w.axis[s / L], layout);
  };
  // The block's rays into their columns of X.
  auto encode_block = [&](long blk) {
    const long r0 = blk * kEncodeBlock, r1 = std::min(B, r0 + kEncodeBlock);
    // A pipeline over the block's rays: ray r + 3's walk is fetched, ray r + 2's dense slots, ray
    // r + 1's corners found and their table rows fetched while ray r's features are summed.
    for (long r = r0; r < std::min(r1, r0 + 3); ++r) prefetch_walk(walks[order[size_t(r)]]);
    if (r0 + 1 < r1) prefetch_slots(r0 + 1);
    find_corners(r0);
    for (long r = r0; r < r1; ++r) {
      if (r + 3 < r1) prefetch_walk(walks[order[size_t(r + 3)]]);
      if (r + 2 < r1) prefetch_slots(r + 2);
      if (r + 1 < r1) find_corners(r + 1);
      const RayWalk& w = walks[order[size_t(r)]];
      float* x = X.data() + size_t(r) * config.input_dim();
      const uint32_t* ce = corners.entry.data() + corners.start[size_t(r)];
      const float* cw = corners.weight.data() + corners.start[size_t(r)];
      const uint32_t slots = std::min(w.count, H) * L;
      std::fill(x + size_t(slots) * F, x + config.input_dim(), 0.0f);  // the slots are written below
      for (uint32_t s = 0; s < slots; ++s) {
        float sum[LSNIF_MAX_FEATURES] = {};  // in registers: x is written once per slot
        for (uint32_t k = 0; k < 4; ++k) {
          const float* t = table + size_t(ce[s * 4 + k]) * F;
          for (uint32_t f = 0; f < F; ++f) sum[f] += cw[s * 4 + k] * t[f];
        }
        for (uint32_t f = 0; f < F; ++f) x[s * F + f] = sum[f];
      }
    }
  };
  // The blocks go to the threads as they come free: a host's cores may differ in pace (on one
  // 2-core host one took 1.3x the other's time for the same work), which a fixed deal (it was
  // round robin in serpentine order) left the faster waiting for. Each column is its own, so which
  // thread encodes it changes nothing. Each thread's pace (table lookups a second) goes to `pace`.
  const long blocks = (B + kEncodeBlock - 1) / kEncodeBlock;
#pragma omp parallel
  {
    const auto start = Clock::now();
    size_t lookups = 0;
#pragma omp for schedule(dynamic, 1) nowait
    for (long blk = 0; blk < blocks; ++blk) {
      encode_block(blk);
      lookups += corners.start[size_t(std::min(B, (blk + 1) * kEncodeBlock))] - corners.start[size_t(blk * kEncodeBlock)];
    }
    const double seconds = since(start);
    const size_t t = size_t(omp_get_thread_num());
    if (t < pace.size()) pace[t] = seconds > 0 ? double(lookups) / seconds : 0.0;
  }
}

// Range q of the nt ranges of table entries [lo, hi) the backward scatter splits the table into: whole
// levels when there are no more threads than levels (every point has one lookup per level, so the
// counts of lookups are even: each of the default 2 threads owns one of the 2 levels), else equal
// shares of the entries.
void scatter_range(const Config& config, size_t entries, uint32_t q, uint32_t nt, uint32_t& lo, uint32_t& hi) {
  const uint32_t L = config.grid_levels;
  if (nt <= L) {
    const uint32_t first = q * L / nt, last = (q + 1) * L / nt;  // levels [first, last)
    lo = uint32_t(config.level_entry_offset(first));
    hi = last < L ? uint32_t(config.level_entry_offset(last)) : uint32_t(entries);
  } else {
    lo = uint32_t(entries * q / nt);
    hi = uint32_t(entries * (q + 1) / nt);
  }
}

// Scatters dX into the entries [lo, hi) of d_table (zeroed first); column r has rows[r] / (L * F)
// points (its encoded_rows). The calling thread owns the range and scans all lookups in batch
// order, so sums are race-free and bit-identical for any thread count. The gradient rows of the
// next ray's lookups are prefetched while the current ray's are summed (the misses are the cost,
// as in encode_batch).
void encode_batch_backward(const Config& config, const std::vector<uint32_t>& rows, const BatchCorners& corners,
                           const Matrix& dX, std::vector<float>& d_table, uint32_t lo, uint32_t hi) {
  const uint32_t L = config.grid_levels, F = config.features;
  // The range is its thread's alone, so the thread zeroes it (into its cache).
  std::fill(d_table.begin() + ptrdiff_t(size_t(lo) * F), d_table.begin() + ptrdiff_t(size_t(hi) * F), 0.0f);
  if (lo >= hi) return;
  // The levels whose entries overlap [lo, hi).
  const uint32_t l_first = config.level_of_entry(lo), l_last = std::min(L - 1, config.level_of_entry(hi - 1));
  auto prefetch_ray = [&](size_t r) {
    const uint32_t n = rows[r] / (L * F);
    const uint32_t* ce = corners.entry.data() + corners.start[r];
    for (uint32_t j = 0; j < n; ++j)
      for (uint32_t l = l_first; l <= l_last; ++l)
        for (uint32_t k = 0; k < 4; ++k) {
          const uint32_t e = ce[(j * L + l) * 4 + k];
          if (e >= lo && e < hi) __builtin_prefetch(d_table.data() + size_t(e) * F, 1);
        }
  };
  if (!rows.empty()) prefetch_ray(0);
  for (size_t r = 0; r < rows.size(); ++r) {
    if (r + 1 < rows.size()) prefetch_ray(r + 1);
    const uint32_t n = rows[r] / (L * F);
    const uint32_t* ce = corners.entry.data() + corners.start[r];
    const float* cw = corners.weight.data() + corners.start[r];
    const float* dx = dX.data() + r * config.input_dim();
    for (uint32_t j = 0; j < n; ++j)
      for (uint32_t l = l_first; l <= l_last; ++l) {
        const uint32_t s = j * L + l;
        for (uint32_t k = 0; k < 4; ++k) {
          const uint32_t e = ce[s * 4 + k];
          if (e < lo || e >= hi) continue;
          const float w = cw[s * 4 + k];
          float* d = d_table.data() + size_t(e) * F;
          for (uint32_t f = 0; f < F; ++f) d[f] += w * dx[s * F + f];
        }
      }
  }
}

// Starts `model` afresh with `config`, the mesh's voxels (in its padded bounds), its materials and
// the grid index of the indexed levels (which completes `config`); `occupied` receives the number
// of occupied voxels (an error when there is none).
Status build_model_frame(const Mesh& mesh, const TrainSettings& settings, Config& config, Model& model,
                         uint32_t& occupied) {
  model = Model();
  if (Status s = model_layout(mesh, settings, config, model.voxels, model.grid_index); !s) return s;
  occupied = model.voxels.count_occupied();
  if (occupied == 0) return Status::error("voxelization produced no occupied voxel");
  for (const Material& m : mesh.materials) model.materials.push_back({m.name, m.base_color});
  model.config = config;
  return Status::ok();
}

// The initial parameters: hash-grid entries uniform in +-grid_init_range, the MLP Kaiming's.
void init_parameters(const Config& config, const TrainSettings& settings, Model& model) {
  model.grid.resize(config.grid_parameter_count());
  {
    std::mt19937_64 rng(settings.seed ^ 0x9e3779b97f4a7c15ull);
    std::uniform_real_distribution<float> u(-settings.grid_init_range, settings.grid_init_range);
    for (float& g : model.grid) g = u(rng);
  }
  model.mlp.resize(config.mlp_parameter_count());
  mlp_init_kaiming(config, settings.seed, model.mlp.data());
}

// Fresh rays are cast for up to this many steps at a time, at most kRaysSampledTogether rays (each
// step's own rays, as if cast on its own): the sampler's data (Embree's BVH, the voxels) stays in
// the caches from one step's rays to the next instead of being evicted by the encoding and the
// network in between (docs/results.md, "Training time").
constexpr uint32_t kStepsSampledTogether = 8;
constexpr size_t kRaysSampledTogether = size_t(1) << 15;

// Who scatters and updates which range of grid entries in backward_and_update. Per thread: its
// pace in this step's encoding (table lookups a second, from encode_batch) and the range it
// scatters. Per range (scatter_range): whether it is scattered, the counter of its update chunks
// (one more counter for the MLP's), when it was done, and its cost (seconds times the pace of the
// thread that took it, averaged over the steps).
struct ScatterPlan {
  uint32_t threads = uint32_t(std::max(1, omp_get_max_threads()));
  std::vector<double> pace = std::vector<double>(threads);
  std::vector<uint32_t> range_of_thread = std::vector<uint32_t>(threads);
  std::unique_ptr<std::atomic<bool>[]> scattered{new std::atomic<bool>[threads]};
  std::unique_ptr<std::atomic<size_t>[]> next_chunk{new std::atomic<size_t>[threads + 1]};
  std::vector<double> scatter_done = std::vector<double>(threads), range_cost = std::vector<double>(threads);
  std::vector<uint32_t> by_pace = std::vector<uint32_t>(threads), by_cost = std::vector<uint32_t>(threads);  // assign's sort scratch
  void assign();
};

// What every step reuses, allocated once: gradients, optimizer moments, the batch (rays and their
// walks), its encoding, activations and corners.
struct StepState {
  StepState(const Model& model, const TrainSettings& settings)
      : d_grid(model.grid.size()), d_mlp(model.mlp.size()), grid_adam(model.grid.size(), settings.adam),
        mlp_adam(model.mlp.size(), settings.adam),
        grid_average(settings.ema_decay > 0 ? model.grid.size() : 0),
        mlp_average(settings.ema_decay > 0 ? model.mlp.size() : 0) {
    trace.layer_input.resize(1);  // the encoder's output, the MLP's input
    trace.bf16_layers = settings.mlp_precision == kMlpPrecisionBf16 ||
                        (settings.mlp_precision == kMlpPrecisionAuto && mlp_gemm_bf16_native());
  }
  std::vector<float> d_grid, d_mlp;
  Adam grid_adam, mlp_adam;
  // The ray pool (ray_pool_size rays with their walks and ground truth); a step trains on
  // batch_size of them, st.order indexing the pool.
  std::vector<Sample> samples, fresh_samples;
  std::vector<RayWalk> walks, fresh_walks;
  // The fresh rays of the steps after the current one, cast together with its own (draw_batch).
  std::vector<Sample> ahead_samples[kStepsSampledTogether];
  std::vector<RayWalk> ahead_walks[kStepsSampledTogether];
  uint32_t ahead_first = 0, ahead_count = 0;  // steps [ahead_first, ahead_first + ahead_count) are in ahead_*
  SamplerScratch sampler_scratch;   // the sampler's candidates
  std::vector<size_t> order;        // draw_batch
  std::vector<uint32_t> batch_rows;
  Matrix O, dO, dX;
  MlpTrace trace;
  BatchCorners corners;
  std::vector<LossTerms> loss_blocks;  // batch_loss's sums per block
  ScatterPlan plan;
  // The parameters' average (settings.ema_decay > 0) and what this step does with it.
  ParameterAverage grid_average, mlp_average;
  enum class Averaging { kNone, kStart, kUpdate } averaging = Averaging::kNone;
  uint32_t average_updates = 0;  // steps that went into the average so far
};

// Which thread scatters which range: the costliest range to the thread that encoded fastest in
// this step, and so on down (threads keep their cores between regions, so the encoding's pace
// foretells the scatter's). With the default two levels the hashed level's rows miss the cache
// where the indexed level's do not (its range costs ~2.3x the other's on the bunny); on a host
// whose second core ran single-threaded training at 0.75-0.8x the first's pace, the hashed level
// on the slower core took 0.86 s of 1,500 bunny steps, the indexed level on the other 0.28 s.
void ScatterPlan::assign() {
  std::iota(by_pace.begin(), by_pace.end(), 0u);
  std::iota(by_cost.begin(), by_cost.end(), 0u);
  std::stable_sort(by_pace.begin(), by_pace.end(), [&](uint32_t a, uint32_t b) { return pace[a] > pace[b]; });
  std::stable_sort(by_cost.begin(), by_cost.end(), [&](uint32_t a, uint32_t b) { return range_cost[a] > range_cost[b]; });
  for (uint32_t i = 0; i < threads; ++i) range_of_thread[by_pace[i]] = by_cost[i];
}

// The encoder's backward scatter and the Adam updates of model.mlp and model.grid in one parallel
// region. The threads scatter their ranges of entries (scatter_range: one level each by default)
// at different paces: a hashed level's gradient rows miss the cache while an indexed level's lie
// in a dense table, so the indexed level's thread used to finish first and wait (on the bunny it
// took 0.6x the other's time). Now a thread that is done updates what is ready: its own entries
// (still in its cache), then the MLP's parameters (their gradient is complete before the region),
// then the other threads' entries as soon as each is marked scattered. The updates go out in
// chunks of kUpdateChunk parameters from per-range counters; each parameter is updated once by
// Adam::update, so the model is the same bit for bit as after a scatter and two Adam steps. The
// report books the region until the last scatter as encoding, the rest as the optimizer. The
// parameters' average (st.averaging) is updated chunk by chunk right after Adam's update, while the
// chunk is in the cache.
constexpr size_t kUpdateChunk = 8192;
constexpr double kCostMemory = 0.9;  // a range's cost: the weight of the steps before in its average

void backward_and_update(const Config& config, float lr, float average_decay, Model& model, StepState& st,
                         TrainReport& rep) {
  const auto t0 = Clock::now();
  ScatterPlan& plan = st.plan;
  const uint32_t F = config.features, max_threads = plan.threads;
  const size_t entries = st.d_grid.size() / F;
  plan.assign();
  const Adam::Step grid_step = st.grid_adam.begin_step(lr), mlp_step = st.mlp_adam.begin_step(lr);
  for (uint32_t q = 0; q < max_threads; ++q) {
    plan.scattered[q].store(false);
    plan.next_chunk[q].store(0);
    plan.scatter_done[q] = 0;
  }
  std::atomic<size_t>& mlp_next = plan.next_chunk[max_threads];
  mlp_next.store(0);
  // The chunks of parameters [begin, end) that `next` hands out, updated with `step` of `adam`,
  // then averaged into `average`.
  const StepState::Averaging averaging = st.averaging;
  auto update = [averaging, average_decay](Adam& adam, const Adam::Step& step, float* params, const float* grads,
                                       size_t begin, size_t end, std::atomic<size_t>& next, ParameterAverage& average) {
    for (size_t c = next.fetch_add(1); c < (end - begin + kUpdateChunk - 1) / kUpdateChunk; c = next.fetch_add(1)) {
      const size_t b = begin + c * kUpdateChunk, e = std::min(end, begin + (c + 1) * kUpdateChunk);
      adam.update(step, params, grads, b, e);
      if (averaging != StepState::Averaging::kNone)
        average.update(params, b, e, average_decay, averaging == StepState::Averaging::kStart);
    }
  };
#pragma omp parallel num_threads(max_threads)
  {
    const uint32_t nt = uint32_t(omp_get_num_threads()), t = uint32_t(omp_get_thread_num());
    auto update_entries_of = [&](uint32_t q) {
      uint32_t lo, hi;
      scatter_range(config, entries, q, nt, lo, hi);
      update(st.grid_adam, grid_step, model.grid.data(), st.d_grid.data(), size_t(lo) * F, size_t(hi) * F,
             plan.next_chunk[q], st.grid_average);
    };
    // The range of this thread (its own number should the region have fewer threads than planned).
    const uint32_t own = nt == max_threads ? plan.range_of_thread[t] : t;
    uint32_t lo, hi;
    scatter_range(config, entries, own, nt, lo, hi);
    const auto start = Clock::now();
    encode_batch_backward(config, st.batch_rows, st.corners, st.dX, st.d_grid, lo, hi);
    plan.scatter_done[own] = since(t0);
    if (nt == max_threads) plan.range_cost[own] = kCostMemory * plan.range_cost[own] + (1.0 - kCostMemory) * since(start) * plan.pace[t];
    plan.scattered[own].store(true, std::memory_order_release);
    update_entries_of(own);
    update(st.mlp_adam, mlp_step, model.mlp.data(), st.d_mlp.data(), 0, model.mlp.size(), mlp_next, st.mlp_average);
    for (uint32_t i = 1; i < nt; ++i) {
      const uint32_t q = (own + i) % nt;
      while (!plan.scattered[q].load(std::memory_order_acquire)) std::this_thread::yield();
      update_entries_of(q);
    }
  }
  const double scatter = *std::max_element(plan.scatter_done.begin(), plan.scatter_done.end());
  rep.seconds_encoding += scatter;
  rep.seconds_optimizer += since(t0) - scatter;
}

// The batch of `step`: the pool's rays (st.samples, st.walks) it trains on, in st.order, each with
// its encoded_rows in st.batch_rows, ordered by order_by_point_count (a walk has about 5 of the 18
// points on the bunny). The sampling is timed in `rep`; an error when the sampler cannot find
// enough rays.
//
// Ground-truth reuse (ray_reuse R > 1): the pool holds ray_pool_size rays, cast on the first step;
// every later step replaces batch / R of them (the oldest, round robin) with fresh rays and trains
// on batch rays drawn from the pool without replacement, so that a ray serves R steps on average,
// spread over its life in the pool instead of consecutive steps (consecutive batches then share
// about batch / pool of their rays). With R = 1 the pool is the batch: fresh rays every step.
Status draw_batch(const RaySampler& sampler, const Config& config, const TrainSettings& settings, uint32_t occupied,
                  uint32_t step, uint32_t steps, StepState& st, TrainReport& rep) {
  const auto t0 = Clock::now();
  const uint32_t B = settings.batch_size, R = settings.ray_reuse;
  const size_t pool = ray_pool_size(B, R);
  const size_t fresh_per_step = std::max<size_t>(1, B / R);
  // The pool's slots this step refreshes: all of them on the first step, then fresh_per_step
  // slots round robin from the oldest.
  const size_t count = step == 1 ? pool : fresh_per_step;
  const size_t first = step == 1 ? 0 : (size_t(step - 2) * fresh_per_step) % pool;
  const uint32_t together =
      uint32_t(std::clamp<size_t>(kRaysSampledTogether / std::max<size_t>(count, 1), 1, kStepsSampledTogether));
  if (step == 1 || together == 1) {
    sampler.generate(settings.seed, step, count, st.fresh_samples, st.fresh_walks, &st.sampler_scratch);
  } else {
    if (step < st.ahead_first || step >= st.ahead_first + st.ahead_count) {
      st.ahead_first = step;
      st.ahead_count = std::min(together, steps - step + 1);
      for (uint32_t k = 0; k < st.ahead_count; ++k)
        sampler.generate(settings.seed, step + k, count, st.ahead_samples[k], st.ahead_walks[k],
                         &st.sampler_scratch);
    }
    st.fresh_samples.swap(st.ahead_samples[step - st.ahead_first]);
    st.fresh_walks.swap(st.ahead_walks[step - st.ahead_first]);
  }
  rep.rays_cast += st.fresh_samples.size();
  if (st.fresh_samples.size() != count) {
    rep.seconds_sampling += since(t0);
    return Status::error("the ray sampler found only %zu of %zu rays crossing an occupied voxel (%u of %u voxels "
                         "occupied: is the mesh degenerate, or a small part of its bounding box, e.g. beside "
                         "far-away stray triangles?)", st.fresh_samples.size(), count, occupied,
                         config.voxel_resolution * config.voxel_resolution * config.voxel_resolution);
  }
  if (count == pool) {
    st.samples.swap(st.fresh_samples);
    st.walks.swap(st.fresh_walks);
  } else {
    for (size_t k = 0; k < count; ++k) {  // wraps around the pool's end
      st.samples[(first + k) % pool] = st.fresh_samples[k];
      st.walks[(first + k) % pool] = st.fresh_walks[k];
    }
  }
  // The batch: the whole pool when it is the batch, else B of its rays without replacement (a
  // partial Fisher-Yates shuffle of the slots, its random numbers from the seed and the step).
  st.order.resize(pool);
  std::iota(st.order.begin(), st.order.end(), size_t(0));
  if (pool > B) {
    Rng rng(settings.seed ^ 0x5bd1e9955bd1e995ull, step, 0);
    for (size_t k = 0; k < B; ++k) {
      const size_t j = k + size_t((uint64_t(rng.next_u32()) * (pool - k)) >> 32);
      std::swap(st.order[k], st.order[j]);
    }
    st.order.resize(B);
  }
  order_by_point_count(config, st.walks, st.order, st.batch_rows);
  rep.seconds_sampling += since(t0);
  return Status::ok();
}

// The batch's mean loss terms from the outputs st.O; their gradient (scaled by 1 / batch size)
// goes to st.dO. Blocks of kLossBlock rays go to the threads as they come free (a host's cores may
// differ in pace); each block's sum lands in st.loss_blocks, summed in block order, so the mean does
// not depend on which thread took which block.
constexpr long kLossBlock = 64;

LossTerms batch_loss(const Config& config, const TrainSettings& settings, StepState& st) {
  const uint32_t B = settings.batch_size, out_dim = config.output_dim();
  st.dO.resize(out_dim, B);
  const float scale = 1.0f / float(B);
  const long blocks = (long(B) + kLossBlock - 1) / kLossBlock;
  st.loss_blocks.resize(size_t(blocks));
#pragma omp parallel for schedule(dynamic, 1)
  for (long b = 0; b < blocks; ++b) {
    LossTerms sum;
    for (long r = b * kLossBlock; r < std::min(long(B), (b + 1) * kLossBlock); ++r) {
      const size_t i = st.order[size_t(r)];
      const Sample& smp = st.samples[i];
      LossTarget target;
      target.hit = smp.reference.hit;
      if (target.hit) {
        target.s = unit_from_distance(config, st.walks[i], smp.reference.t);
        target.normal = bakes_normal_maps(settings.surface_maps) ? smp.reference.surface.normal : smp.reference.normal;
        target.albedo = smp.reference.albedo;
        target.material = smp.reference.material;
        target.metallic = smp.reference.surface.metallic;
        target.roughness = smp.reference.surface.roughness;
        target.ambient_occlusion = smp.reference.surface.ambient_occlusion;
        target.emission = smp.reference.surface.emission;
      }
      sum += ray_loss(config, st.O.data() + size_t(r) * out_dim, target, settings.loss_settings, scale,
                      st.dO.data() + size_t(r) * out_dim);
    }
    st.loss_blocks[size_t(b)] = sum;
  }
  LossTerms total;
  for (const LossTerms& t : st.loss_blocks) total += t;
  LossTerms mean;
  mean.occlusion = total.occlusion / B; mean.distance = total.distance / B; mean.normal = total.normal / B;
  mean.albedo = total.albedo / B; mean.material = total.material / B; mean.surface = total.surface / B;
  return mean;
}

// What step `step` of a run of `steps` steps does with the parameters' average
// (TrainSettings::ema_decay): every kAverageInterval-th step counted back from the last goes into it,
// from the first after the learning rate's held share (the whole run when that share is 0),
// whatever the schedule.
StepState::Averaging averaging_of_step(const TrainSettings& settings, uint32_t step, uint32_t steps) {
  const uint32_t after_held = uint32_t(std::floor(double(settings.lr_schedule.warm_fraction) * double(steps))) + 1;
  const uint32_t first = after_held + (steps - after_held) % kAverageInterval;
  if (settings.ema_decay <= 0 || step < first || (steps - step) % kAverageInterval != 0)
    return StepState::Averaging::kNone;
  return step == first ? StepState::Averaging::kStart : StepState::Averaging::kUpdate;
}

// The decay of the average's update after `updates` earlier ones: the setting's per-step decay to
// the kAverageInterval-th power, but at most (1 + updates) / (10 + updates), so that the first
// updates weigh more and a short run (a few dozen steps) keeps an average of its last steps, not of
// its first averaged ones (60 steps at a decay of 0.99 kept 0.75 of step 32's parameters).
float average_decay(float ema_decay, uint32_t updates) {
  const double n = double(updates);
  return float(std::min(std::pow(double(ema_decay), double(kAverageInterval)), (1.0 + n) / (10.0 + n)));
}

// One training step: the batch, forward, loss, backward and the Adam updates of model.grid and
// model.mlp (and of their average), each phase timed in `rep`; `mean` receives the step's mean loss terms. An error when
// the sampler runs short or the loss is not finite.
Status train_step(const RaySampler& sampler, const Config& config, const GridLayout& layout,
                  const TrainSettings& settings, uint32_t occupied, uint32_t step, uint32_t steps, Model& model,
                  StepState& st, TrainReport& rep, LossTerms& mean) {
  if (Status s = draw_batch(sampler, config, settings, occupied, step, steps, st, rep); !s) return s;

  auto t0 = Clock::now();
  // Encoded straight into the trace that keeps the MLP's input for the backward pass (no copy).
  Matrix& X = st.trace.layer_input[0];
  encode_batch(config, layout, model.grid.data(), st.walks, st.order, st.batch_rows, X, st.corners, st.plan.pace);
  rep.seconds_encoding += since(t0);

  t0 = Clock::now();
  mlp_forward(config, model.mlp.data(), X, st.O, &st.trace, st.batch_rows.data());
  rep.seconds_mlp += since(t0);

  t0 = Clock::now();
  mean = batch_loss(config, settings, st);
  rep.seconds_loss += since(t0);
  if (!std::isfinite(mean.total()))
    return Status::error("training diverged: the loss of step %u is %g (occlusion %g, distance %g, normal %g, "
                         "albedo %g, material %g, surface %g); lower the learning rate (Adam lr %g)",
                         step, mean.total(), mean.occlusion, mean.distance, mean.normal, mean.albedo,
                         mean.material, mean.surface, double(settings.adam.learning_rate));

  t0 = Clock::now();
  mlp_backward(config, model.mlp.data(), st.trace, st.dO, st.d_mlp.data(), &st.dX);
  rep.seconds_mlp += since(t0);

  const float lr = scheduled_learning_rate(settings.lr_schedule, settings.adam.learning_rate, step, steps);
  st.averaging = averaging_of_step(settings, step, steps);
  const float decay = average_decay(settings.ema_decay, st.average_updates);
  if (st.averaging != StepState::Averaging::kNone) ++st.average_updates;
  backward_and_update(config, lr, decay, model, st, rep);
  return Status::ok();
}

// The sum of the loss terms over the last steps (after `start`), for the final loss.
struct TailLoss {
  uint32_t start = 0, steps = 0;
  LossTerms sum;
};

// Books a finished step in the report: its rays, the tail's sum and, with settings.loss_curve, its
// row of the loss curve (its time: since `t_start`, when the loop started).
void record_step(const TrainSettings& settings, uint32_t step, const LossTerms& mean, Clock::time_point t_start,
                 TailLoss& tail, TrainReport& rep) {
  rep.rays += settings.batch_size;
  if (step > tail.start) {
    tail.sum += mean;
    ++tail.steps;
  }
  if (settings.loss_curve)
    rep.loss_curve += format("%u,%.3f,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g\n", step, since(t_start), mean.total(),
                             mean.occlusion, mean.distance, mean.normal, mean.albedo, mean.material, mean.surface);
}

// The steps of a run under settings.time_budget, planned after `step` steps, `elapsed` seconds into
// the loop, the steps after the first having taken `per_step` seconds each: as many as the rest of
// the budget holds at that pace, less a margin (kBudgetMargin) for a host that slows, at least
// `step`, at most settings.steps. (On the bunny the pace of steps 2-256 foresaw 632 steps in 10 s
// where 626 ran.)
// With a decaying schedule never fewer than the steps whose held share covers the `step` steps run
// (they ran at the full rate), so that a run the budget does not cut equals the run of the planned
// steps; the budget then stops the run, should those not fit.
constexpr double kBudgetMargin = 0.05;
uint32_t budget_steps(const TrainSettings& settings, uint32_t step, double elapsed, double per_step) {
  const double rest = (1.0 - kBudgetMargin) * settings.time_budget - elapsed;
  const double more = per_step > 0 ? std::floor(rest / per_step) : 0.0;
  double least = double(step);
  const double warm = double(settings.lr_schedule.warm_fraction);
  if (settings.lr_schedule.schedule != LrSchedule::Constant && warm > 0) {
    least = std::ceil(double(step) / warm);
    while (std::floor(warm * least) < double(step)) ++least;
  }
  const double planned = std::max(double(step) + std::max(0.0, more), least);
  return uint32_t(std::clamp(planned, double(step), double(settings.steps)));
}

// Whether a run of `steps` steps may still change its length after `step` without a jump in its
// learning rate: always with a constant rate, else while the rate is held (the schedule's warm share).
bool steps_still_open(const TrainSettings& settings, uint32_t step, uint32_t steps) {
  if (settings.lr_schedule.schedule == LrSchedule::Constant) return true;
  return double(step) < std::floor(double(settings.lr_schedule.warm_fraction) * double(steps));
}

// rep.final_loss: the mean of the tail's steps (left 0 when none ran).
void set_final_loss(const TailLoss& tail, TrainReport& rep) {
  if (tail.steps) {
    const double k = 1.0 / tail.steps;
    rep.final_loss.occlusion = tail.sum.occlusion * k; rep.final_loss.distance = tail.sum.distance * k;
    rep.final_loss.normal = tail.sum.normal * k; rep.final_loss.albedo = tail.sum.albedo * k;
    rep.final_loss.material = tail.sum.material * k; rep.final_loss.surface = tail.sum.surface * k;
  }
}

// An error naming the first trained parameter that cannot be saved. fp16 holds magnitudes up to
// 65504; a parameter beyond that (or NaN) cannot be saved.
Status check_fp16_range(const Model& model, uint64_t rays, float learning_rate) {
  for (const std::vector<float>* params : {&model.grid, &model.mlp})
    for (size_t i = 0; i < params->size(); ++i)
      if (!(std::abs((*params)[i]) <= 65504.0f))
        return Status::error("training diverged: %s parameter %zu is %g after %llu rays, beyond the fp16 range of "
                             "the model file; lower the learning rate (Adam lr %g)",
                             params == &model.grid ? "hash-grid" : "MLP", i, double((*params)[i]),
                             (unsigned long long)rays, double(learning_rate));
  return Status::ok();
}

}  // namespace

bool learns_surface_channels(const Mesh& mesh, uint32_t surface_maps) {
  if (surface_maps == kSurfaceMapsOn) return true;
  if (surface_maps != kSurfaceMapsAuto) return false;
  for (const Material& m : mesh.materials)
    if (m.has_surface_textures()) return true;
  return false;
}

Status train_model(const Mesh& mesh, const TrainSettings& settings, Model& model, TrainReport* report,
                   const TrainCallback& callback) {
  Config config;
  if (Status s = check_training_inputs(mesh, settings, config); !s) return s;
  uint32_t occupied = 0;
  if (Status s = build_model_frame(mesh, settings, config, model, occupied); !s) return s;
  GridLayout layout = model.layout();
  const DenseGridIndex dense_index(config, layout);

  GroundTruth truth;
  if (Status s = truth.build(mesh); !s) return s.context("building the Embree reference");
  RaySampler sampler(mesh, truth, model.voxels, config.max_points, settings.sampler);

  // Parameters.
  init_parameters(config, settings, model);
  StepState st(model, settings);

  TrainReport rep;
  if (settings.loss_curve) rep.loss_curve = "step,seconds,total,occlusion,distance,normal,albedo,material,surface\n";
  rep.occupied_voxels = occupied;
  // The run's steps: settings.steps, or under a time budget what it holds (planned after a few steps
  // from their pace, replanned at steps 8, 16, 32, ... while the learning rate is held, then fixed).
  uint32_t steps = settings.steps;
  TailLoss tail;
  tail.start = steps - std::max(1u, steps / 10);
  const auto t_start = Clock::now();
  Clock::time_point t_first{};  // the end of step 1, which casts the whole ray pool

  for (uint32_t step = 1; step <= steps; ++step) {
    LossTerms mean;
    if (Status s = train_step(sampler, config, layout, settings, occupied, step, steps, model, st, rep, mean); !s)
      return s;
    record_step(settings, step, mean, t_start, tail, rep);
    rep.steps = step;
    if (callback && !callback(step, mean, model)) break;
    if (settings.time_budget > 0) {
      const double elapsed = since(t_start);
      if (step == 1) t_first = Clock::now();
      if (step < steps && elapsed >= settings.time_budget) {  // out of time: the model as it stands
        rep.budget_cut = true;
        break;
      }
      if (step >= 5 && (step & (step - 1)) == 0 && steps_still_open(settings, step, steps)) {
        steps = budget_steps(settings, step, elapsed, std::chrono::duration<double>(Clock::now() - t_first).count() /
                                                          double(step - 1));
        tail.start = steps - std::max(1u, steps / 10);
      }
    }
  }
  rep.planned_steps = steps;
  if (st.average_updates > 0) {  // the average kept
    model.grid.swap(st.grid_average.values());
    model.mlp.swap(st.mlp_average.values());
  }
  rep.seconds = since(t_start);
  set_final_loss(tail, rep);
  if (Status s = check_fp16_range(model, rep.rays, settings.adam.learning_rate); !s) return s;
  model.quantize();
  if (Status s = build_uv_cells(mesh, model); !s) return s;
  if (Status s = measure_uv_materials(mesh, model, rep.uv_warnings); !s) return s;
  if (report) *report = rep;
  return model.validate();
}

}  // namespace lsnif
