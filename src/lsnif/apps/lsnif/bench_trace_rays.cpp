// bench_trace_rays.cpp -- the host-side inputs of `lsnif bench-trace` (bench_trace.h): the check that
// the model was trained on the mesh, and the ray set aimed at the mesh's box.
#include <algorithm>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "lsnif/apps/lsnif/bench_trace.h"

namespace lsnif::cli::bench_trace {

Status check_same_object(const Mesh& mesh, const Model& model) {
  const Aabb expect = pad_aabb(mesh.bounds()), got = model.bounds();
  const float tol = 1e-3f * expect.diagonal();
  const glm::vec3 d = glm::max(glm::abs(expect.lo - got.lo), glm::abs(expect.hi - got.hi));
  if (std::max(d.x, std::max(d.y, d.z)) <= tol) return Status::ok();
  return Status::error(
      "the mesh does not match the model: the model's AABB is (%g %g %g)..(%g %g %g) but a model trained "
      "on this mesh would have (%g %g %g)..(%g %g %g) (is MODEL trained on MESH?)",
      double(got.lo.x), double(got.lo.y), double(got.lo.z), double(got.hi.x), double(got.hi.y), double(got.hi.z),
      double(expect.lo.x), double(expect.lo.y), double(expect.lo.z), double(expect.hi.x), double(expect.hi.y),
      double(expect.hi.z));
}

std::vector<Ray> make_rays(const Aabb& box, uint32_t count, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const glm::vec3 center = box.center(), ext = box.extent();
  const float radius = 1.5f * 0.5f * box.diagonal();
  std::vector<Ray> rays(count);
  for (Ray& r : rays) {
    glm::vec3 dir;
    for (;;) {  // uniform on the unit sphere by rejection from the cube
      dir = glm::vec3(2.0f * u(rng) - 1.0f, 2.0f * u(rng) - 1.0f, 2.0f * u(rng) - 1.0f);
      const float l = glm::length(dir);
      if (l > 1e-3f && l <= 1.0f) {
        dir /= l;
        break;
      }
    }
    r.origin = center + radius * dir;
    const glm::vec3 target = box.lo + ext * glm::vec3(u(rng), u(rng), u(rng));
    r.direction = glm::normalize(target - r.origin);
    r.tmin = 0.0f;
    r.tmax = std::numeric_limits<float>::infinity();
  }
  return rays;
}

}  // namespace lsnif::cli::bench_trace
