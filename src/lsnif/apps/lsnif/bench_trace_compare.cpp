// bench_trace_compare.cpp -- the results of `lsnif bench-trace` ray by ray (bench_trace.h): the LSNIF
// trace against the triangle trace, the batched path and lsnifCmdQuery against the LSNIF trace, and
// the points of each against the host's ray walk.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include "lsnif/apps/lsnif/bench_trace.h"
#include "lsnif/core/ray_walk.h"

namespace lsnif::cli::bench_trace {

void compare_results(const DeviceState& st, const Model& model, const Mesh& mesh, const std::vector<Ray>& rays,
                     Report& report) {
  const auto* lsnif = static_cast<const BenchTraceResult*>(st.lsnif_results.mapped);
  const auto* tri = static_cast<const BenchTraceResult*>(st.tri_results.mapped);
  const double diag = double(mesh.bounds().diagonal());
  std::vector<double> t_diff;
  std::vector<uint32_t> host_points(rays.size());
  RayWalk walk;
  for (size_t i = 0; i < rays.size(); ++i) {
    const uint32_t points = walk_ray(model.voxels, rays[i], model.config.max_points, walk);
    host_points[i] = points;
    report.aabb_rays += walk.hits_aabb;
    report.network_rays += points > 0;
    const bool lh = (lsnif[i].info & kResultHit) != 0, th = (tri[i].info & kResultHit) != 0;
    report.lsnif_hits += lh;
    report.triangle_hits += th;
    report.agree += lh == th;
    if (lh && ((lsnif[i].info >> kResultPointsShift) & 0xffu) != points) ++report.points_mismatch;
    if (lh && th) {
      ++report.both_hit;
      t_diff.push_back(std::fabs(double(lsnif[i].t) - double(tri[i].t)) / diag);
    }
  }
  report.median_t_difference = median(std::move(t_diff));

  // The batched hits against the inline shader's, ray by ray, and their walks against the host's.
  const auto* batched = static_cast<const LsnifQueryHit*>(st.query_hits.mapped);
  for (size_t i = 0; i < rays.size(); ++i) {
    const bool bh = batched[i].kind == LSNIF_QUERY_HIT_LSNIF, lh = (lsnif[i].info & kResultHit) != 0;
    report.batched_hits += bh;
    report.batched_network_rays += batched[i].points > 0;
    report.batched_agree += bh == lh;
    if (lh && ((lsnif[i].info >> kResultPointsShift) & 0xffu) != std::min(batched[i].points, 255u))
      ++report.batched_points_mismatch;
    report.batched_walk_mismatch += batched[i].points != host_points[i];
    if (bh && lh) {
      ++report.batched_both_hit;
      report.batched_max_t_difference =
          std::max(report.batched_max_t_difference, std::fabs(double(batched[i].t) - double(lsnif[i].t)) / diag);
    }
  }

  // The lsnifCmdQuery results against the inline shader's.
  const auto* query = static_cast<const LsnifQueryResult*>(st.query_results.mapped);
  for (size_t i = 0; i < rays.size(); ++i) {
    const bool qh = query[i].kind == LSNIF_QUERY_HIT_LSNIF, lh = (lsnif[i].info & kResultHit) != 0;
    report.query_hits += qh;
    report.query_incomplete += query[i].kind == LSNIF_QUERY_HIT_INCOMPLETE;
    report.query_agree += qh == lh;
    if (qh && lh) {
      ++report.query_both_hit;
      report.query_max_t_difference =
          std::max(report.query_max_t_difference, std::fabs(double(query[i].t) - double(lsnif[i].t)) / diag);
    }
  }
  std::memcpy(&report.query_status, st.query_status.mapped, sizeof report.query_status);
}

}  // namespace lsnif::cli::bench_trace
