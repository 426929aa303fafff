// bench_secondary -- rays leaving an LSNIF surface: how each self-intersection rule does on
// secondary visibility (a benchmark, not a test).
//
//   bench_secondary MESH MODEL [--rays N] [--seed S]
//
// Primary rays from a sphere around the object hit the LSNIF model (CPU reference intersector) at
// the predicted point p with predicted normal n; Embree gives the true point p* and normal n* of the
// same primary ray. Secondary directions are cosine-weighted about n (what a renderer would do).
// Truth: a direction below the true surface (dot(d, n*) <= 0) is occluded; otherwise Embree traces
// from p* (pushed 1e-6 of the diagonal off along n*). Each rule spawns the LSNIF secondary ray from
// p and reports visibility agreement, false occlusion ("acne") and missed occlusion:
//   none                 origin p, tmin 0
//   offset E diag        the paper's fixed epsilon: origin p + E * diagonal * n (E fixed per run)
//   tmin K voxel         origin p, tmin = K voxel edges in object space (leaving_tmin scaled)
//   cull back            origin p, ray flag CullBackFacingTriangles
//   cull back+tmin K     both; K = LSNIF_LEAVING_TMIN_VOXELS (0.5) is the rule we ship
// The last columns histogram the acne hits by their t in voxel edges.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "lsnif/train/ground_truth.h"
#include "lsnif/host_device.h"
#include "lsnif/core/intersector.h"
#include "lsnif/import/mesh.h"
#include "lsnif/core/model.h"
#include "lsnif/core/rng.h"

using namespace lsnif;

namespace {

struct Rule {
  std::string name;
  float origin_offset = 0;  // along the predicted normal, object units (the paper's fixed epsilon)
  float tmin_voxels = 0;    // tmin = this x leaving_tmin / LSNIF_LEAVING_TMIN_VOXELS (voxel edges)
  uint32_t flags = 0;       // LSNIF_RAY_FLAG_*
};

glm::vec3 cosine_about(Rng& rng, glm::vec3 n) {
  const float u1 = rng.next_float(), u2 = rng.next_float();
  const float r = std::sqrt(u1), phi = 6.2831853f * u2;
  const glm::vec3 local(r * std::cos(phi), r * std::sin(phi), std::sqrt(std::max(0.0f, 1.0f - u1)));
  const glm::vec3 a = std::fabs(n.x) > 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0);
  const glm::vec3 t = glm::normalize(glm::cross(a, n)), b = glm::cross(n, t);
  return glm::normalize(local.x * t + local.y * b + local.z * n);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: bench_secondary MESH MODEL [--rays N] [--seed S]\n");
    return 2;
  }
  const std::string mesh_path = argv[1], model_path = argv[2];
  size_t rays = 100000;
  uint64_t seed = 7;
  for (int i = 3; i < argc; i += 2) {
    if (i + 1 >= argc) return std::fprintf(stderr, "bench_secondary: %s needs a value\n", argv[i]), 2;
    if (!std::strcmp(argv[i], "--rays")) rays = size_t(std::atoll(argv[i + 1]));
    else if (!std::strcmp(argv[i], "--seed")) seed = uint64_t(std::atoll(argv[i + 1]));
    else return std::fprintf(stderr, "bench_secondary: unknown option %s\n", argv[i]), 2;
  }
  if (rays == 0) return std::fprintf(stderr, "bench_secondary: --rays must be positive\n"), 2;
  Mesh mesh;
  Model model;
  if (Status s = load_mesh(mesh_path, mesh); !s) return std::fprintf(stderr, "bench_secondary: %s\n", s.message().c_str()), 1;
  if (Status s = load_model(model_path, model); !s) return std::fprintf(stderr, "bench_secondary: %s\n", s.message().c_str()), 1;
  GroundTruth truth;
  if (Status s = truth.build(mesh); !s) return std::fprintf(stderr, "bench_secondary: %s\n", s.message().c_str()), 1;
  const Aabb box = model.voxels.bounds;
  const float diag = box.diagonal();
  const glm::vec3 centre = 0.5f * (box.lo + box.hi);
  const float voxel = diag / (float(model.config.voxel_resolution) * std::sqrt(3.0f));  // voxel edge
  Transform3x4 identity;

  // Primary rays.
  std::vector<Ray> primary(rays);
  for (size_t i = 0; i < rays; ++i) {
    Rng rng(seed, 1, i);
    glm::vec3 dir;
    do dir = glm::vec3(rng.next_float(), rng.next_float(), rng.next_float()) * 2.0f - 1.0f;
    while (glm::dot(dir, dir) > 1.0f || glm::dot(dir, dir) < 1e-4f);
    const glm::vec3 origin = centre + glm::normalize(dir) * diag;
    const glm::vec3 target = box.lo + glm::vec3(rng.next_float(), rng.next_float(), rng.next_float()) * (box.hi - box.lo);
    primary[i].origin = origin;
    primary[i].direction = glm::normalize(target - origin);
  }
  std::vector<LsnifHit> lp(rays);
  if (Status s = intersect(model, identity, primary.data(), rays, lp.data()); !s)
    return std::fprintf(stderr, "bench_secondary: %s\n", s.message().c_str()), 1;

  // Secondary rays where both hit.
  std::vector<glm::vec3> p, n, d;
  std::vector<char> truth_occluded;
  std::vector<float> truth_t;
  for (size_t i = 0; i < rays; ++i) {
    const ReferenceHit th = truth.trace(primary[i]);
    if (!lp[i].hit || !th.hit) continue;
    Rng rng(seed, 2, i);
    const glm::vec3 ph = primary[i].origin + lp[i].t * primary[i].direction;
    const glm::vec3 ps = primary[i].origin + th.t * primary[i].direction;
    const glm::vec3 dir = cosine_about(rng, lp[i].normal);
    bool occ = true;
    float t = 0;
    if (glm::dot(dir, th.geometric_normal) > 0) {
      Ray r;
      r.origin = ps + 1e-6f * diag * th.geometric_normal;
      r.direction = dir;
      const ReferenceHit s = truth.trace(r);
      occ = s.hit;
      t = s.t;
    }
    p.push_back(ph);
    n.push_back(lp[i].normal);
    d.push_back(dir);
    truth_occluded.push_back(occ);
    truth_t.push_back(t);
  }
  const size_t m = p.size();
  size_t truth_occ = 0;
  for (char c : truth_occluded) truth_occ += c;
  std::printf("%zu secondary rays, %.2f%% truly occluded; voxel = %.4g (%.3f%% of diag)\n", m,
              100.0 * double(truth_occ) / double(m), double(voxel), 100.0 * double(voxel / diag));

  std::vector<Rule> rules;
  rules.push_back({"none", 0, 0, 0});
  for (float e : {1e-4f, 3e-4f, 1e-3f, 3e-3f, 1e-2f, 3e-2f}) {
    char name[64];
    std::snprintf(name, sizeof(name), "offset %.0e diag", double(e));
    rules.push_back({name, e * diag, 0, 0});
  }
  for (float v : {0.5f, 1.0f, 2.0f}) {
    char name[64];
    std::snprintf(name, sizeof(name), "tmin %.1f voxel", double(v));
    rules.push_back({name, 0, v, 0});
  }
  rules.push_back({"cull back", 0, 0, LSNIF_RAY_FLAG_CULL_BACK_FACING});
  for (float v : {0.25f, 0.5f, 1.0f}) {
    char name[64];
    std::snprintf(name, sizeof(name), "cull back+tmin %.2f", double(v));
    rules.push_back({name, 0, v, LSNIF_RAY_FLAG_CULL_BACK_FACING});
  }
  std::printf("%-22s %9s %9s %9s  acne t/voxel: <0.1 <0.3 <1 <3 >=3\n", "rule", "agree%", "acne%", "missed%");
  std::vector<Ray> sec(m);
  std::vector<LsnifHit> sh(m);
  for (const Rule& rule : rules) {
    for (size_t i = 0; i < m; ++i) {
      sec[i].origin = p[i] + rule.origin_offset * n[i];
      sec[i].direction = d[i];
      sec[i].tmin = rule.tmin_voxels / float(LSNIF_LEAVING_TMIN_VOXELS) * leaving_tmin(model, identity, d[i]);
    }
    if (Status s = intersect(model, identity, sec.data(), m, sh.data(), rule.flags); !s)
      return std::fprintf(stderr, "bench_secondary: %s\n", s.message().c_str()), 1;
    size_t agree = 0, acne = 0, missed = 0, bucket[5] = {};
    for (size_t i = 0; i < m; ++i) {
      const bool o = sh[i].hit;
      agree += o == bool(truth_occluded[i]);
      acne += o && !truth_occluded[i];
      missed += !o && truth_occluded[i];
      if (o && !truth_occluded[i]) {
        const float tv = sh[i].t / (leaving_tmin(model, identity, d[i]) / float(LSNIF_LEAVING_TMIN_VOXELS));
        bucket[tv < 0.1f ? 0 : tv < 0.3f ? 1 : tv < 1 ? 2 : tv < 3 ? 3 : 4]++;
      }
    }
    std::printf("%-22s %9.3f %9.3f %9.3f  %zu %zu %zu %zu %zu\n", rule.name.c_str(), 100.0 * double(agree) / double(m),
                100.0 * double(acne) / double(m), 100.0 * double(missed) / double(m), bucket[0], bucket[1],
                bucket[2], bucket[3], bucket[4]);
  }
  return 0;
}
