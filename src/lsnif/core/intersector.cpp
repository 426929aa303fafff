#include "lsnif/core/intersector.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "lsnif/core/hash_grid.h"
#include "lsnif/core/head.h"
#include "lsnif/host_device.h"
#include "lsnif/core/network.h"
#include "lsnif/core/ray_walk.h"
#include "lsnif/core/uv_cells.h"

namespace lsnif {

namespace {
bool finite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

bool facing_culled(const glm::vec3& object_normal, const glm::vec3& object_direction, uint32_t ray_flags) {
  const float facing = glm::dot(object_normal, object_direction);
  return ((ray_flags & LSNIF_RAY_FLAG_CULL_BACK_FACING) && facing > 0.0f) ||
         ((ray_flags & LSNIF_RAY_FLAG_CULL_FRONT_FACING) && facing < 0.0f);
}

}  // namespace

Status split_transform(const Transform3x4& xf, glm::mat3& A, glm::vec3& T, glm::mat3& A_inv) {
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      if (!std::isfinite(xf.m[r][c])) return Status::error("instance transform has a non-finite entry");
      A[c][r] = xf.m[r][c];  // glm is column-major
    }
    if (!std::isfinite(xf.m[r][3])) return Status::error("instance transform has a non-finite entry");
    T[r] = xf.m[r][3];
  }
  const float det = glm::determinant(A);
  if (!(std::fabs(det) > 1e-20f)) return Status::error("instance transform is singular (det %g)", double(det));
  A_inv = glm::inverse(A);
  return Status::ok();
}

float leaving_tmin(const Model& model, const Transform3x4& xf, glm::vec3 world_direction) {
  glm::mat3 A, A_inv;
  glm::vec3 T;
  if (!split_transform(xf, A, T, A_inv) || !finite(world_direction)) return 0.0f;
  const float len = glm::length(A_inv * world_direction);
  if (!(len > 0.0f) || model.config.voxel_resolution == 0) return 0.0f;
  const float edge = model.voxels.bounds.diagonal() / (float(model.config.voxel_resolution) * std::sqrt(3.0f));
  return float(LSNIF_LEAVING_TMIN_VOXELS) * edge / len;
}

Status intersect(const Model& model, const Transform3x4& xf, const Ray* rays, size_t count,
                 LsnifHit* hits, uint32_t ray_flags) {
  if (Status s = model.validate(); !s) return s.context("intersect");
  glm::mat3 A, A_inv;
  glm::vec3 T;
  if (Status s = split_transform(xf, A, T, A_inv); !s) return s;
  const glm::mat3 normal_to_world = glm::transpose(A_inv);

  const Config& config = model.config;
  std::vector<RayWalk> walks(count);
  std::vector<size_t> active;
  // The rays in object space, walked together (walk_rays) a chunk at a time. (Every buffer is
  // allocated here: an allocation failing inside the parallel region could not reach the caller.)
  std::vector<Ray> object_rays(count);
  constexpr size_t kChunk = 256;
  const long chunks = long((count + kChunk - 1) / kChunk);
#pragma omp parallel for schedule(dynamic, 1)
  for (long c = 0; c < chunks; ++c) {
    const size_t first = size_t(c) * kChunk, last = std::min(count, first + kChunk);
    for (size_t i = first; i < last; ++i) {
      const Ray& ray = rays[i];
      Ray& o = object_rays[i];
      hits[i] = LsnifHit();
      if (!finite(ray.origin) || !finite(ray.direction) || ray.direction == glm::vec3(0.0f) ||
          std::isnan(ray.tmin) || std::isnan(ray.tmax)) {
        o = kNoWalkRay;
        continue;
      }
      o.origin = A_inv * (ray.origin - T);
      o.direction = A_inv * ray.direction;
      o.tmin = ray.tmin;
      o.tmax = std::numeric_limits<float>::infinity();
    }
    walk_rays(model.voxels, object_rays.data() + first, last - first, config.max_points, walks.data() + first);
  }
  for (size_t i = 0; i < count; ++i)
    if (walks[i].count > 0) active.push_back(i);
  if (active.empty()) return Status::ok();
  // By descending point count, so that the network's first layer skips the empty slots of whole
  // column chunks; each ray's result does not depend on the order.
  std::vector<uint32_t> rows;
  order_by_point_count(config, walks, active, rows);

  Matrix X(config.input_dim(), long(active.size())), O;
  const GridLayout layout = model.layout();
#pragma omp parallel for schedule(static, 64)  // interleaved: the columns are ordered by cost
  for (long k = 0; k < long(active.size()); ++k)
    encode(config, model.grid.data(), walks[active[size_t(k)]], X.data() + size_t(k) * config.input_dim(), layout);
  mlp_forward(config, model.mlp.data(), X, O, nullptr, rows.data());

  const UvCells cells(model);
#pragma omp parallel for schedule(static)
  for (long k = 0; k < long(active.size()); ++k) {
    const size_t i = active[size_t(k)];
    const Prediction p = decode(config, O.data() + size_t(k) * config.output_dim(), walks[i]);
    LsnifHit& h = hits[i];
    h.occlusion = p.occlusion;
    if (!p.hit || !(p.t >= rays[i].tmin && p.t <= rays[i].tmax)) continue;
    if (ray_flags && facing_culled(p.normal, A_inv * rays[i].direction, ray_flags)) continue;
    h.hit = true;
    h.t = p.t;
    const glm::vec3 nw = normal_to_world * p.normal;
    const float len = glm::length(nw);
    h.normal = len > 0.0f ? nw / len : glm::vec3(0.0f);
    h.albedo = p.albedo;
    h.material = p.material;
    h.surface_learned = p.surface_learned;
    h.metallic = p.metallic;
    h.roughness = p.roughness;
    h.ambient_occlusion = p.ambient_occlusion;
    h.emission = p.emission;
    if (config.reports_uv(p.material)) {
      const glm::vec3 origin = A_inv * (rays[i].origin - T), direction = A_inv * rays[i].direction;
      h.reports_uv = cells.lookup(origin + p.t * direction, p.normal, direction, h.uv);
    }
  }
  return Status::ok();
}

}  // namespace lsnif
