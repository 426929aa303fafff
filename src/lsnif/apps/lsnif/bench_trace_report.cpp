// bench_trace_report.cpp -- the output of `lsnif bench-trace` (bench_trace.h): the report as text or
// as one JSON object on stdout.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "lsnif/apps/lsnif/bench_trace.h"
#include "lsnif/import/json_text.h"

namespace lsnif::cli::bench_trace {

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

namespace {

// "-" for a missing device time.
std::string seconds_text(double s) { return s < 0 ? std::string("-") : format("%.4f", s); }

using nlohmann::ordered_json;

ordered_json timings_json(const Report& r, const Timings& t) {
  return {{"first_trace_seconds", t.first_host},
          {"first_trace_device_seconds", json::measured(t.first_device)},
          {"first_trace_cpu_seconds", t.first_cpu},
          {"median_trace_seconds", t.median_host()},
          {"min_trace_seconds", t.min_host()},
          {"median_trace_device_seconds", json::measured(t.median_device())},
          {"median_trace_cpu_seconds", t.median_cpu()},
          {"rays_per_second", r.rays_per_second(t)},
          {"trace_seconds", t.host},
          {"trace_device_seconds", t.device},
          {"trace_cpu_seconds", t.cpu}};
}

ordered_json stages_json(const StageTimes& s, bool valid) {
  if (!valid) return nullptr;
  return {{"narrow_seconds", s.narrow}, {"mlp_seconds", s.mlp}, {"decode_seconds", s.decode}};
}

// The batched path: its timings (the keys of the traces' objects) and its stages.
ordered_json batched_json(const Report& r) {
  auto list = [&](double StageTimes::*stage) {
    ordered_json out = ordered_json::array();
    for (const StageTimes& s : r.batched_stages) out.push_back(s.*stage);
    return out;
  };
  ordered_json j = timings_json(r, r.batched);
  j["calls_per_run"] = r.batched_calls;
  j["first_run_stages"] = stages_json(r.batched_first_stages, r.batched.first_device >= 0);
  j["median_narrow_seconds"] = json::measured(r.median_stage(&StageTimes::narrow));
  j["median_mlp_seconds"] = json::measured(r.median_stage(&StageTimes::mlp));
  j["median_decode_seconds"] = json::measured(r.median_stage(&StageTimes::decode));
  j["narrow_seconds"] = list(&StageTimes::narrow);
  j["mlp_seconds"] = list(&StageTimes::mlp);
  j["decode_seconds"] = list(&StageTimes::decode);
  return j;
}

ordered_json gemm_json(const GemmReport& g) {
  return {{"layer_widths", g.widths},
          {"float32", true},
          {"bias_and_activation", true},
          {"threads", g.threads},
          {"columns_per_thread", g.batch},
          {"passes", g.passes},
          {"seconds", g.seconds},
          {"cpu_seconds", g.cpu_seconds},
          {"flops_per_evaluation", g.flops_per_column},
          {"evaluations_per_second", g.evaluations_per_second()}};
}

}  // namespace

void print_text(const Report& r) {
  const double n = double(r.rays);
  std::printf("bench-trace: LSNIF intersection shader vs triangle BLAS, same rays, same pipeline\n");
  std::printf("device                 %s\n", r.device.c_str());
  std::printf("mesh                   %s (%u triangles; BLAS input in %s order)\n", r.mesh_path.c_str(),
              r.triangles, r.morton_order ? "Morton" : "file");
  std::printf("model                  %s\n", r.model_path.c_str());
  std::printf("intersection shader    %s\n", r.intersection_spv.c_str());
  std::printf("rays                   %u (seed %llu): origins on a sphere (1.5 x half diagonal) around the mesh "
              "AABB, aimed at uniform points inside it\n",
              r.rays, static_cast<unsigned long long>(r.seed));
  std::printf("timer                  host wall time around submit + wait per trace, median of %u repeat%s "
              "(alternating)%s\n",
              r.repeat, r.repeat == 1 ? "" : "s",
              r.device_timestamps ? "; device: timestamps around vkCmdTraceRaysKHR and the batched stages" : "");
  std::printf("pipeline creation      %.3f s (ray tracing), %.3f s (batched path: lsnifCreateQueryPipeline)\n",
              r.pipeline_create_seconds, r.query_pipeline_create_seconds);
  std::printf("query broad phase      %s (lsnifCmdQuery)\n", r.broad_phase.c_str());
  std::printf("batched MLP kernel     %s%s\n", r.mlp_kernel.c_str(),
              r.mlp_kernel == "cooperative-matrix" ? " (VK_NV_cooperative_matrix, unverified)" : " (GLSL, fp32)");
  std::printf("batched path           lsnifCmdIntersectModelRays on the same rays (identity instance: object space "
              "= world space), %u call%s per run, alternating with the traces\n\n",
              r.batched_calls, r.batched_calls == 1 ? "" : "s");
  std::printf("%-32s %14s %14s %14s\n", "", "LSNIF", "triangles", "batched");
  std::printf("%-32s %14.4f %14.4f %14.4f\n", "first trace (s, host)", r.lsnif.first_host, r.tri.first_host,
              r.batched.first_host);
  std::printf("%-32s %14.4f %14.4f %14.4f\n", "median trace (s, host)", r.lsnif.median_host(), r.tri.median_host(),
              r.batched.median_host());
  std::printf("%-32s %14.4f %14.4f %14.4f\n", "fastest trace (s, host)", r.lsnif.min_host(), r.tri.min_host(),
              r.batched.min_host());
  if (r.device_timestamps)
    std::printf("%-32s %14s %14s %14s\n", "median trace (s, device)", seconds_text(r.lsnif.median_device()).c_str(),
                seconds_text(r.tri.median_device()).c_str(), seconds_text(r.batched.median_device()).c_str());
  std::printf("%-32s %14.4f %14.4f %14.4f\n", "median process CPU time (s)", r.lsnif.median_cpu(), r.tri.median_cpu(),
              r.batched.median_cpu());
  std::printf("%-32s %14.4g %14.4g %14.4g\n", "rays/s (host median)", r.rays_per_second(r.lsnif),
              r.rays_per_second(r.tri), r.rays_per_second(r.batched));
  std::printf("%-32s %14u %14u %14u\n", "hits", r.lsnif_hits, r.triangle_hits, r.batched_hits);
  std::printf("\nLSNIF network evaluations       %u rays (%.1f%%; %u rays, %.1f%%, reach the intersection "
              "shader)\n",
              r.network_rays, 100.0 * r.network_rays / n, r.aabb_rays, 100.0 * r.aabb_rays / n);
  std::printf("network evaluations/s           %.4g\n", r.evaluations_per_second());
  std::printf("triangle rays/s / LSNIF rays/s  %.3g\n", r.ratio());
  std::printf("hit agreement                   %.2f%% (LSNIF hit == triangle hit); median |t difference| "
              "%.3g%% of the diagonal over %u rays both hit\n",
              100.0 * r.agree / n, 100.0 * r.median_t_difference, r.both_hit);
  std::printf("walk check                      %u LSNIF hits whose shader walk points differ from the host "
              "walk\n",
              r.points_mismatch);

  std::printf("batched stages (s, device)      ");
  if (r.batched_stages.empty())
    std::printf("- (the queue has no timestamps)\n");
  else
    std::printf("narrow phase %.4f, MLP %.4f, decode %.4f (medians; first run %.4f, %.4f, %.4f)\n",
                r.median_stage(&StageTimes::narrow), r.median_stage(&StageTimes::mlp),
                r.median_stage(&StageTimes::decode), r.batched_first_stages.narrow, r.batched_first_stages.mlp,
                r.batched_first_stages.decode);
  std::printf("batched network evaluations     %u rays (points > 0)\n", r.batched_network_rays);
  std::printf("batched network evaluations/s   %.4g (%s x the inline shader's)\n", r.batched_evaluations_per_second(),
              std::isfinite(r.batched_over_inline()) ? format("%.3g", r.batched_over_inline()).c_str() : "-");
  if (r.mlp_stage_evaluations_per_second() > 0)
    std::printf("MLP stage alone                 %.4g evaluations/s (device median)\n",
                r.mlp_stage_evaluations_per_second());
  std::printf("batched vs inline               hit == hit for %.4f%% of the rays; max |t difference| %.3g%% of the "
              "diagonal over %u rays both hit\n",
              100.0 * r.batched_agree / n, 100.0 * r.batched_max_t_difference, r.batched_both_hit);
  std::printf("batched walk check              %u of the %u inline hits with other points; %u rays whose points "
              "differ from the host walk\n",
              r.batched_points_mismatch, r.lsnif_hits, r.batched_walk_mismatch);
  std::printf("\nquery path                      lsnifCmdQuery on the same rays against the LSNIF TLAS (one identity "
              "instance), alternating with the others\n");
  std::printf("query trace (s, host)           median %.4f, fastest %.4f, first %.4f; process CPU time %.4f (median)\n",
              r.query.median_host(), r.query.min_host(), r.query.first_host, r.query.median_cpu());
  std::printf("query trace (s, device)         %s (median; timestamps around the call)\n",
              seconds_text(r.query.median_device()).c_str());
  std::printf("query rays/s (host median)      %.4g\n", r.rays_per_second(r.query));
  std::printf("query network evaluations/s     %.4g (%s x the inline shader's)\n", r.query_evaluations_per_second(),
              std::isfinite(r.query_over_inline()) ? format("%.3g", r.query_over_inline()).c_str() : "-");
  std::printf("query vs inline                 hit == hit for %.4f%% of the rays; max |t difference| %.3g%% of the "
              "diagonal over %u rays both hit; %u hits, %u incomplete\n",
              100.0 * r.query_agree / n, 100.0 * r.query_max_t_difference, r.query_both_hit, r.query_hits,
              r.query_incomplete);
  std::printf("query status                    %u candidates, capacity %u, %u dropped, %u not evaluated, %u culled\n",
              r.query_status.candidates, r.query_status.capacity, r.query_status.dropped,
              r.query_status.unevaluated, r.query_status.culled);
  std::string widths;
  for (const uint32_t w : r.gemm.widths) widths += format(widths.empty() ? "%u" : "-%u", w);
  std::printf("\nCPU limit                       Eigen GEMM %s float32 (bias + leaky ReLU included), %u OpenMP "
              "thread%s x %u columns, %llu passes in %.3f s (process CPU time %.3f s; %.3g GFLOP/s in the GEMMs)\n",
              widths.c_str(), r.gemm.threads, r.gemm.threads == 1 ? "" : "s", r.gemm.batch,
              static_cast<unsigned long long>(r.gemm.passes), r.gemm.seconds, r.gemm.cpu_seconds,
              r.gemm.evaluations_per_second() * r.gemm.flops_per_column * 1e-9);
  std::printf("GEMM network evaluations/s      %.4g\n", r.gemm.evaluations_per_second());
  std::printf("batched / GEMM evaluations/s    %.3g", r.batched_over_gemm());
  if (r.mlp_stage_evaluations_per_second() > 0)
    std::printf(" (MLP stage alone / GEMM: %.3g)",
                r.mlp_stage_evaluations_per_second() / r.gemm.evaluations_per_second());
  std::printf("\n");
  if (r.validation)
    std::printf("validation                      %u errors, %u warnings\n", r.validation_errors,
                r.validation_warnings);
}

void print_json(const Report& r) {
  ordered_json j;
  j["device"] = r.device;
  j["mesh"] = r.mesh_path;
  j["model"] = r.model_path;
  j["intersection_shader"] = r.intersection_spv;
  j["mesh_triangles"] = r.triangles;
  j["triangle_order"] = r.morton_order ? "morton" : "file";
  j["rays"] = r.rays;
  j["seed"] = r.seed;
  j["repeat"] = r.repeat;
  j["timer"] = "host wall time around submit + wait, median of the repeats";
  j["device_timestamps"] = r.device_timestamps;
  j["pipeline_create_seconds"] = r.pipeline_create_seconds;
  j["lsnif"] = timings_json(r, r.lsnif);
  j["triangles"] = timings_json(r, r.tri);
  j["lsnif_hits"] = r.lsnif_hits;
  j["triangle_hits"] = r.triangle_hits;
  j["intersection_shader_rays"] = r.aabb_rays;
  j["network_evaluations"] = r.network_rays;
  j["network_evaluations_per_second"] = r.evaluations_per_second();
  j["triangle_over_lsnif_rays_per_second"] = r.ratio();
  j["hit_agreement"] = double(r.agree) / double(r.rays);
  j["both_hit"] = r.both_hit;
  j["median_t_difference_over_diagonal"] = r.median_t_difference;
  j["walk_points_mismatches"] = r.points_mismatch;
  j["query_pipeline_create_seconds"] = r.query_pipeline_create_seconds;
  j["query_broad_phase"] = r.broad_phase;
  j["mlp_kernel"] = r.mlp_kernel;
  j["batched"] = batched_json(r);
  j["batched_hits"] = r.batched_hits;
  j["batched_network_evaluations"] = r.batched_network_rays;
  j["batched_network_evaluations_per_second"] = r.batched_evaluations_per_second();
  j["batched_over_inline_network_evaluations_per_second"] = json::measured(r.batched_over_inline());
  j["batched_inline_hit_agreement"] = double(r.batched_agree) / double(r.rays);
  j["batched_inline_both_hit"] = r.batched_both_hit;
  j["batched_inline_max_t_difference_over_diagonal"] = r.batched_max_t_difference;
  j["batched_inline_points_mismatches"] = r.batched_points_mismatch;
  j["batched_walk_points_mismatches"] = r.batched_walk_mismatch;
  j["gemm"] = gemm_json(r.gemm);
  j["batched_over_gemm_network_evaluations_per_second"] = json::measured(r.batched_over_gemm());
  j["batched_mlp_stage_evaluations_per_second"] = json::measured(r.mlp_stage_evaluations_per_second());
  j["query"] = timings_json(r, r.query);
  j["query_hits"] = r.query_hits;
  j["query_incomplete_rays"] = r.query_incomplete;
  j["query_candidates"] = r.query_status.candidates;
  j["query_dropped"] = r.query_status.dropped;
  j["query_unevaluated"] = r.query_status.unevaluated;
  j["query_culled"] = r.query_status.culled;
  j["query_network_evaluations_per_second"] = r.query_evaluations_per_second();
  j["query_over_inline_network_evaluations_per_second"] = json::measured(r.query_over_inline());
  j["query_inline_hit_agreement"] = double(r.query_agree) / double(r.rays);
  j["query_inline_both_hit"] = r.query_both_hit;
  j["query_inline_max_t_difference_over_diagonal"] = r.query_max_t_difference;
  j["validation"] = r.validation;
  j["validation_errors"] = r.validation_errors;
  j["validation_warnings"] = r.validation_warnings;
  std::printf("%s\n", json::dump(j).c_str());
}

}  // namespace lsnif::cli::bench_trace
