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

namespace lsnif::cli::bench_trace {

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

namespace {

// A JSON string literal of `s` (quotes, backslashes and control characters escaped).
std::string quoted(const std::string& s) {
  std::string out = "\"";
  for (const char c : s) {
    const auto u = static_cast<unsigned char>(c);
    if (c == '"' || c == '\\') out += std::string("\\") + c;
    else if (u < 0x20) out += format("\\u%04x", unsigned(u));
    else out += c;
  }
  return out + "\"";
}

// "-" for a missing device time.
std::string seconds_text(double s) { return s < 0 ? std::string("-") : format("%.4f", s); }
std::string json_number(double v) { return v < 0 || !std::isfinite(v) ? std::string("null") : format("%.6g", v); }

std::string timings_json(const Report& r, const Timings& t) {
  auto list = [](const std::vector<double>& v) {
    std::string out = "[";
    for (size_t i = 0; i < v.size(); ++i) out += (i ? ", " : "") + format("%.6g", v[i]);
    return out + "]";
  };
  return format("{\"first_trace_seconds\": %.6g, \"first_trace_device_seconds\": %s, "
                "\"first_trace_cpu_seconds\": %.6g, \"median_trace_seconds\": %.6g, "
                "\"min_trace_seconds\": %.6g, \"median_trace_device_seconds\": %s, "
                "\"median_trace_cpu_seconds\": %.6g, \"rays_per_second\": %.6g, \"trace_seconds\": %s, "
                "\"trace_device_seconds\": %s, \"trace_cpu_seconds\": %s}",
                t.first_host, json_number(t.first_device).c_str(), t.first_cpu, t.median_host(), t.min_host(),
                json_number(t.median_device()).c_str(), t.median_cpu(), r.rays_per_second(t), list(t.host).c_str(),
                list(t.device).c_str(), list(t.cpu).c_str());
}

std::string stages_json(const StageTimes& s, bool valid) {
  if (!valid) return "null";
  return format("{\"narrow_seconds\": %.6g, \"mlp_seconds\": %.6g, \"decode_seconds\": %.6g}", s.narrow, s.mlp,
                s.decode);
}

// The batched path: its timings (the keys of the traces' objects) and its stages.
std::string batched_json(const Report& r) {
  std::string t = timings_json(r, r.batched);
  t.pop_back();  // the closing brace
  auto list = [&](double StageTimes::*stage) {
    std::string out = "[";
    for (size_t i = 0; i < r.batched_stages.size(); ++i)
      out += (i ? ", " : "") + format("%.6g", r.batched_stages[i].*stage);
    return out + "]";
  };
  return t + format(", \"calls_per_run\": %u, \"first_run_stages\": %s, \"median_narrow_seconds\": %s, "
                    "\"median_mlp_seconds\": %s, \"median_decode_seconds\": %s, \"narrow_seconds\": %s, "
                    "\"mlp_seconds\": %s, \"decode_seconds\": %s}",
                    r.batched_calls, stages_json(r.batched_first_stages, r.batched.first_device >= 0).c_str(),
                    json_number(r.median_stage(&StageTimes::narrow)).c_str(),
                    json_number(r.median_stage(&StageTimes::mlp)).c_str(),
                    json_number(r.median_stage(&StageTimes::decode)).c_str(), list(&StageTimes::narrow).c_str(),
                    list(&StageTimes::mlp).c_str(), list(&StageTimes::decode).c_str());
}

std::string gemm_json(const GemmReport& g) {
  std::string widths = "[";
  for (size_t i = 0; i < g.widths.size(); ++i) widths += format(i ? ", %u" : "%u", g.widths[i]);
  widths += "]";
  return format("{\"layer_widths\": %s, \"float32\": true, \"bias_and_activation\": true, \"threads\": %u, "
                "\"columns_per_thread\": %u, \"passes\": %llu, \"seconds\": %.6g, \"cpu_seconds\": %.6g, "
                "\"flops_per_evaluation\": %.6g, \"evaluations_per_second\": %.6g}",
                widths.c_str(), g.threads, g.batch, static_cast<unsigned long long>(g.passes), g.seconds,
                g.cpu_seconds, g.flops_per_column, g.evaluations_per_second());
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
  std::printf("query status                    %u candidates, capacity %u, %u dropped, %u not evaluated\n",
              r.query_status.candidates, r.query_status.capacity, r.query_status.dropped,
              r.query_status.unevaluated);
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
  std::printf(
      "{\"device\": %s, \"mesh\": %s, \"model\": %s, \"intersection_shader\": %s, \"mesh_triangles\": %u, "
      "\"triangle_order\": \"%s\", \"rays\": %u, \"seed\": %llu, "
      "\"repeat\": %u, \"timer\": \"host wall time around submit + wait, median of the repeats\", "
      "\"device_timestamps\": %s, \"pipeline_create_seconds\": %.6g, \"lsnif\": %s, \"triangles\": %s, "
      "\"lsnif_hits\": %u, \"triangle_hits\": %u, \"intersection_shader_rays\": %u, "
      "\"network_evaluations\": %u, \"network_evaluations_per_second\": %.6g, "
      "\"triangle_over_lsnif_rays_per_second\": %.6g, \"hit_agreement\": %.6g, \"both_hit\": %u, "
      "\"median_t_difference_over_diagonal\": %.6g, \"walk_points_mismatches\": %u, "
      "\"query_pipeline_create_seconds\": %.6g, \"batched\": %s, \"batched_hits\": %u, "
      "\"batched_network_evaluations\": %u, \"batched_network_evaluations_per_second\": %.6g, "
      "\"batched_over_inline_network_evaluations_per_second\": %s, \"batched_inline_hit_agreement\": %.6g, "
      "\"batched_inline_both_hit\": %u, \"batched_inline_max_t_difference_over_diagonal\": %.6g, "
      "\"batched_inline_points_mismatches\": %u, \"batched_walk_points_mismatches\": %u, \"gemm\": %s, "
      "\"batched_over_gemm_network_evaluations_per_second\": %s, "
      "\"batched_mlp_stage_evaluations_per_second\": %s, \"query\": %s, \"query_hits\": %u, "
      "\"query_incomplete_rays\": %u, \"query_candidates\": %u, \"query_dropped\": %u, "
      "\"query_unevaluated\": %u, \"query_network_evaluations_per_second\": %.6g, "
      "\"query_over_inline_network_evaluations_per_second\": %s, \"query_inline_hit_agreement\": %.6g, "
      "\"query_inline_both_hit\": %u, \"query_inline_max_t_difference_over_diagonal\": %.6g, "
      "\"validation\": %s, "
      "\"validation_errors\": %u, \"validation_warnings\": %u}\n",
      quoted(r.device).c_str(), quoted(r.mesh_path).c_str(), quoted(r.model_path).c_str(),
      quoted(r.intersection_spv).c_str(), r.triangles,
      r.morton_order ? "morton" : "file", r.rays,
      static_cast<unsigned long long>(r.seed), r.repeat, r.device_timestamps ? "true" : "false",
      r.pipeline_create_seconds, timings_json(r, r.lsnif).c_str(), timings_json(r, r.tri).c_str(), r.lsnif_hits,
      r.triangle_hits, r.aabb_rays, r.network_rays, r.evaluations_per_second(), r.ratio(),
      double(r.agree) / double(r.rays), r.both_hit, r.median_t_difference, r.points_mismatch,
      r.query_pipeline_create_seconds, batched_json(r).c_str(), r.batched_hits, r.batched_network_rays,
      r.batched_evaluations_per_second(), json_number(r.batched_over_inline()).c_str(),
      double(r.batched_agree) / double(r.rays),
      r.batched_both_hit, r.batched_max_t_difference, r.batched_points_mismatch, r.batched_walk_mismatch,
      gemm_json(r.gemm).c_str(), json_number(r.batched_over_gemm()).c_str(),
      json_number(r.mlp_stage_evaluations_per_second()).c_str(), timings_json(r, r.query).c_str(), r.query_hits,
      r.query_incomplete, r.query_status.candidates, r.query_status.dropped, r.query_status.unevaluated,
      r.query_evaluations_per_second(), json_number(r.query_over_inline()).c_str(),
      double(r.query_agree) / double(r.rays), r.query_both_hit, r.query_max_t_difference,
      r.validation ? "true" : "false", r.validation_errors,
      r.validation_warnings);
}

}  // namespace lsnif::cli::bench_trace
