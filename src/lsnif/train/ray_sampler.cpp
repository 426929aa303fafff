// ray_sampler.cpp -- training and evaluation rays (paper 5.2). Candidate i draws all its random
// numbers from Rng(seed, stream, i); candidates are evaluated in parallel blocks and kept in
// candidate order, so the output never depends on the thread count.
#include "lsnif/train/ray_sampler.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <omp.h>

#include "lsnif/core/rng.h"

namespace lsnif {
namespace {

// Surface candidates retry their finding ray this many times before falling back to an outer ray.
constexpr uint32_t kSurfaceAttempts = 16;
// Candidates per parallel block: at most kMaxSlots / surface_rays (a candidate holds surface_rays
// rays and walks: bounds a block's memory), at least kMinBlock
// (one scheduling chunk). A call's first block is sized to fall a little short of the samples asked
// for (kFirstBlockShare of the candidates the keep rate predicts they need), later ones to what is
// missing with a margin (kLaterBlockMargin), so that few kept candidates beyond the last sample
// are drawn, walked and traced in vain. The output does not depend on the sizes.
constexpr size_t kMinBlock = 32;
// Candidates whose rays are walked together (one scheduling chunk), and kept rays traced together.
constexpr size_t kChunk = 64;
constexpr size_t kMaxSlots = 65536;
constexpr double kFirstBlockShare = 0.98, kLaterBlockMargin = 1.25;
// The least number of candidates tried before a call gives up (see generate).
constexpr uint64_t kMinCandidateCap = 1024;

// Ray from a uniform point on the sphere (centre, radius), cosine-weighted about the direction
// toward the centre.
Ray sample_outer_ray(Rng& rng, const glm::vec3& centre, float radius) {
  const float u1 = rng.next_float(), u2 = rng.next_float();
  const glm::vec3 outward = sample_uniform_sphere(u1, u2);
  const float u3 = rng.next_float(), u4 = rng.next_float();
  Ray ray;
  ray.origin = centre + radius * outward;
  ray.direction = sample_cosine_hemisphere(-outward, u3, u4);
  return ray;
}

// The same kind of ray among the lines through `body` (inside the sphere): a uniform point on the
// body's surface (a face by area, a uniform point on it), a cosine-weighted direction into the
// body, the origin moved back along the line to where it enters the sphere. Lines through the
// sphere drawn as in sample_outer_ray are uniform in the measure of lines; those of them that cross
// a convex body inside it enter that body exactly once, through its surface, with the same
// point-and-cosine law, so this draws sample_outer_ray's rays conditioned on crossing the body.
Ray sample_line_through_body(Rng& rng, const LineBody& body, const glm::vec3& centre, float radius) {
  // The face: std::upper_bound's index in the cdf (the first entry > u0), searched without branches
  // (the halving's comparisons are a coin toss each, their mispredictions dearer than the search).
  const float u0 = rng.next_float();
  const float* cdf = body.cdf.data();
  size_t base = 0;
  for (size_t n = body.cdf.size(); n > 1; n -= n / 2) base = cdf[base + n / 2] <= u0 ? base + n / 2 : base;
  const size_t f = std::min(base + size_t(cdf[base] <= u0), body.faces.size() - 1);
  const LineBody::Face& face = body.faces[f];
  const float r = std::sqrt(rng.next_float()), u2 = rng.next_float();
  const glm::vec3 point = face.p0 + (r * (1.0f - u2)) * face.e1 + (r * u2) * face.e2;
  const float u3 = rng.next_float(), u4 = rng.next_float();
  Ray ray;
  ray.direction = sample_cosine_hemisphere(face.inward, u3, u4);
  // The line point - s * direction meets the sphere at the roots of s^2 - 2 s (w.d) + |w|^2 - R^2;
  // `point` lies inside, so one root is <= 0 (ahead) and the other >= 0 (behind: the entry).
  const glm::vec3 w = point - centre;
  const float wd = glm::dot(w, ray.direction);
  const float s = wd + std::sqrt(std::fmax(0.0f, wd * wd - glm::dot(w, w) + radius * radius));
  ray.origin = point - s * ray.direction;
  return ray;
}

// dst = src in what a walk holds: its header and its recorded points (the ~5 of a walk's 32 slots
// that it uses, not the whole 560 bytes).
void copy_walk(const RayWalk& src, RayWalk& dst) {
  dst.count = src.count;
  dst.truncated = src.truncated;
  dst.hits_aabb = src.hits_aabb;
  dst.t_enter = src.t_enter;
  dst.t_exit = src.t_exit;
  std::copy(src.t, src.t + src.count, dst.t);
  std::copy(src.p, src.p + src.count, dst.p);
  std::copy(src.axis, src.axis + src.count, dst.axis);
}

// The reference hits of the samples at `slots[0, n)` (n <= kChunk), traced in one call
// (GroundTruth traces them in Embree's packets).
void trace_chunk(const GroundTruth& truth, const size_t* slots, size_t n, Sample* samples) {
  Ray rays[kChunk];
  ReferenceHit hits[kChunk];
  for (size_t i = 0; i < n; ++i) rays[i] = samples[slots[i]].ray;
  truth.trace(rays, n, hits);
  for (size_t i = 0; i < n; ++i) samples[slots[i]].reference = hits[i];
}

// The reference hits of samples[i] for i in `which`, kChunk at a time. Uses OpenMP.
void trace_references(const GroundTruth& truth, const std::vector<size_t>& which, std::vector<Sample>& samples) {
  const size_t count = which.size();
  const int64_t chunks = int64_t((count + kChunk - 1) / kChunk);
#pragma omp parallel for schedule(dynamic, 1)
  for (int64_t c = 0; c < chunks; ++c) {
    const size_t first = size_t(c) * kChunk;
    trace_chunk(truth, which.data() + first, std::min(kChunk, count - first), samples.data());
  }
}

// The random draws of one generate call's candidates: candidate `index` draws from
// Rng(seed, stream, index) and fills its k = surface_rays slots.
struct CandidateDraws {
  CandidateDraws(uint64_t seed_, uint64_t stream_, const SamplerSettings& settings, const LineBody& body_,
                 const GroundTruth& truth_, const Aabb& bounds, float surface_share_)
      : seed(seed_), stream(stream_), body(body_), truth(truth_), centre(bounds.center()),
        radius(settings.sphere_scale * 0.5f * bounds.diagonal()), offset(settings.surface_offset * bounds.diagonal()),
        surface_share(surface_share_), k(settings.surface_rays) {}
  uint64_t seed, stream;
  const LineBody& body;  // valid: the first kind's rays drawn through it, else on the whole sphere
  const GroundTruth& truth;
  glm::vec3 centre;
  float radius, offset, surface_share;
  uint32_t k;

  // A ray of the first kind (tmin = 0, tmax = inf).
  Ray outer_ray(Rng& rng) const {
    return body.valid() ? sample_line_through_body(rng, body, centre, radius) : sample_outer_ray(rng, centre, radius);
  }
  // Pass 1 (generate): the candidate's kind from its first number; an outer candidate's ray into
  // its first slot.
  CandidateKind first_pass(uint64_t index, Sample* sample, uint8_t* keep) const {
    Rng rng(seed, stream, index);
    for (uint32_t r = 0; r < k; ++r) keep[r] = 0;
    if (rng.next_float() < surface_share) return kSurfaceCandidate;
    sample[0].ray = outer_ray(rng);
    sample[0].from_surface = false;
    keep[0] = 1;
    return kOuterCandidate;
  }
  // Pass 3, a surface candidate: k surface rays from `given` (a hit of an earlier candidate's ray)
  // or else from the first hit of its own finding rays, each with its own direction; an outer ray
  // in its first slot when kSurfaceAttempts finding rays all miss.
  void surface_pass(uint64_t index, const SurfacePoint* given, Sample* sample, uint8_t* keep) const {
    Rng rng(seed, stream, index);
    rng.next_float();  // the kind's number (pass 1)
    SurfacePoint at{};
    bool found = given != nullptr;
    if (given) at = *given;
    for (uint32_t attempt = 0; !found && attempt < kSurfaceAttempts; ++attempt) {
      const Ray finder = outer_ray(rng);
      const ReferenceHit hit = truth.trace_geometry(finder);
      if (hit.hit) {
        at = SurfacePoint::of(finder, hit);
        found = true;
      }
    }
    if (!found) {
      sample[0].ray = outer_ray(rng);
      sample[0].from_surface = false;
      keep[0] = 1;
      return;
    }
    for (uint32_t r = 0; r < k; ++r) {
      const float u1 = rng.next_float(), u2 = rng.next_float();
      Ray ray;
      ray.origin = at.point + offset * at.normal;
      ray.direction = sample_cosine_hemisphere(at.normal, u1, u2);
      sample[r].ray = ray;
      sample[r].from_surface = true;
      keep[r] = 1;
    }
  }
};

}  // namespace

LineBody::LineBody() {
  // The axes, the face diagonals and the body diagonals, one of each pair of opposite directions.
  const int d[kDirections][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1},  {1, 1, 0},  {1, -1, 0},  {0, 1, 1}, {0, 1, -1},
                                 {1, 0, 1}, {1, 0, -1}, {1, 1, 1}, {1, 1, -1}, {1, -1, 1}, {-1, 1, 1}};
  for (int k = 0; k < kDirections; ++k) direction[k] = glm::normalize(glm::vec3(d[k][0], d[k][1], d[k][2]));
}

bool LineBody::contains(const glm::vec3& p, float tolerance) const {
  for (int k = 0; k < kDirections; ++k) {
    const float x = glm::dot(direction[k], p);
    if (!(x >= lo[k] - tolerance && x <= hi[k] + tolerance)) return false;
  }
  return true;
}

bool LineBody::crossed_by(const Ray& ray) const {
  float t0 = ray.tmin, t1 = ray.tmax;
  for (int k = 0; k < kDirections; ++k) {
    const float o = glm::dot(direction[k], ray.origin), v = glm::dot(direction[k], ray.direction);
    if (v == 0.0f) {
      if (o < lo[k] || o > hi[k]) return false;
      continue;
    }
    const float ta = (lo[k] - o) / v, tb = (hi[k] - o) / v;
    t0 = std::max(t0, std::min(ta, tb));
    t1 = std::min(t1, std::max(ta, tb));
  }
  return t0 <= t1;
}

// Each slab from the points' extent along its direction; each of the 2 x kDirections planes' face
// as a square on the plane clipped by every other plane's half-space (in double precision), then
// cut into a fan of triangles.
void LineBody::build(const std::vector<glm::vec3>& points, float margin, const Aabb& clip) {
  faces.clear();
  cdf.clear();
  corners.clear();
  area = 0;
  bounds = Aabb{};
  if (points.empty()) return;
  for (int k = 0; k < kDirections; ++k) {
    lo[k] = std::numeric_limits<float>::infinity();
    hi[k] = -lo[k];
    for (const glm::vec3& p : points) {
      const float x = glm::dot(direction[k], p);
      lo[k] = std::min(lo[k], x);
      hi[k] = std::max(hi[k], x);
    }
    lo[k] -= margin;
    hi[k] += margin;
  }
  for (int a = 0; a < 3; ++a) {  // the axis slabs (directions 0-2) within `clip`
    lo[a] = std::max(lo[a], clip.lo[a]);
    hi[a] = std::min(hi[a], clip.hi[a]);
    bounds.lo[a] = lo[a];
    bounds.hi[a] = hi[a];
  }
  if (!bounds.valid()) return;
  // Plane j: dot(normal_j, x) <= offset_j.
  glm::dvec3 normal[2 * kDirections];
  double offset[2 * kDirections];
  for (int k = 0; k < kDirections; ++k) {
    normal[2 * k] = glm::dvec3(direction[k]);
    offset[2 * k] = double(hi[k]);
    normal[2 * k + 1] = -glm::dvec3(direction[k]);
    offset[2 * k + 1] = -double(lo[k]);
  }
  const glm::dvec3 middle(bounds.center());
  const double size = 4.0 * double(bounds.diagonal()) + 1.0;
  const double eps = 1e-9 * (double(bounds.diagonal()) + 1e-30);
  std::vector<double> face_area;
  for (int j = 0; j < 2 * kDirections; ++j) {
    const glm::dvec3 n = normal[j];
    const glm::dvec3 q = middle + (offset[j] - glm::dot(n, middle)) * n;  // on the plane
    glm::vec3 tf, bf;
    orthonormal_basis(glm::vec3(n), tf, bf);
    glm::dvec3 t(tf), b(bf);
    t = glm::normalize(t - glm::dot(t, n) * n);
    b = glm::normalize(glm::cross(n, t));
    std::vector<glm::dvec3> poly = {q - size * t - size * b, q + size * t - size * b, q + size * t + size * b,
                                    q - size * t + size * b};
    for (int i = 0; i < 2 * kDirections && poly.size() >= 3; ++i) {
      if (i == j) continue;
      std::vector<glm::dvec3> kept;
      for (size_t v = 0; v < poly.size(); ++v) {
        const glm::dvec3& p0 = poly[v];
        const glm::dvec3& p1 = poly[(v + 1) % poly.size()];
        const double d0 = glm::dot(normal[i], p0) - offset[i], d1 = glm::dot(normal[i], p1) - offset[i];
        if (d0 <= eps) kept.push_back(p0);
        if ((d0 < -eps && d1 > eps) || (d0 > eps && d1 < -eps)) kept.push_back(p0 + (d0 / (d0 - d1)) * (p1 - p0));
      }
      poly.swap(kept);
    }
    if (poly.size() < 3) continue;
    for (size_t v = 1; v + 1 < poly.size(); ++v) {
      const glm::dvec3 e1 = poly[v] - poly[0], e2 = poly[v + 1] - poly[0];
      const double a = 0.5 * glm::length(glm::cross(e1, e2));
      if (!(a > 0.0)) continue;
      faces.push_back({glm::vec3(poly[0]), glm::vec3(e1), glm::vec3(e2), glm::vec3(-n)});
      face_area.push_back(a);
      area += a;
    }
    for (const glm::dvec3& p : poly) corners.push_back(glm::vec3(p));
  }
  if (!(area > 0.0)) {
    faces.clear();
    return;
  }
  double sum = 0;
  for (const double a : face_area) {
    sum += a;
    cdf.push_back(float(sum / area));
  }
  cdf.back() = 1.0f;
}

RaySampler::RaySampler(const Mesh& mesh, const GroundTruth& truth, const VoxelGrid& grid,
                       uint32_t max_points, SamplerSettings settings)
    : mesh_(mesh), truth_(truth), grid_(grid), max_points_(max_points), settings_(settings) {
  // The settings table checks --surface-rays where it enters (1-16); a caller that fills the
  // struct itself with 0 gets one ray a point, never an empty candidate.
  settings_.surface_rays = std::max(1u, settings_.surface_rays);
  set_surface_share();
  const uint32_t V = grid_.resolution;
  if (!settings_.lines_through_body || V == 0) return;
  // The body holds the mesh and every occupied voxel (a kept ray crosses an occupied voxel, a
  // finding ray's hit lies on the mesh): their vertices, grown by a hair for rounding, its axis
  // slabs within the grid's bounds (which hold both).
  std::vector<glm::vec3> points(mesh_.positions.begin(), mesh_.positions.end());
  const glm::vec3 cell = grid_.bounds.extent() / float(V);
  bool any = false;
  for (uint32_t k = 0; k < V; ++k)
    for (uint32_t j = 0; j < V; ++j)
      for (uint32_t i = 0; i < V; ++i)
        if (grid_.occupied(int(i), int(j), int(k))) {
          any = true;
          for (uint32_t c = 0; c < 8; ++c)
            points.push_back(grid_.bounds.lo + glm::vec3(i + (c & 1), j + ((c >> 1) & 1), k + (c >> 2)) * cell);
        }
  if (!any) return;
  LineBody body;
  body.build(points, 1e-5f * grid_.bounds.diagonal(), grid_.bounds);
  if (!body.valid()) return;
  // Only a body inside the sphere (the default sphere passes through the grid's corners; a
  // --sphere-scale below 1 may cut it): else the whole sphere.
  const glm::vec3 centre = grid_.bounds.center();
  const float radius = settings_.sphere_scale * 0.5f * grid_.bounds.diagonal();
  for (const glm::vec3& corner : body.corners)
    if (!(glm::distance(corner, centre) <= radius * (1.0f + 1e-5f))) return;
  line_body_share_ = std::min(1.0, body.area / (4.0 * 3.14159265358979323846 * double(radius) * double(radius)));
  line_body_ = std::move(body);
  set_surface_share();
}

// Surface candidates are (almost) always kept and give settings_.surface_rays rays each; outer ones are kept
// 1 / line_body_share_ times as often through the body as on the whole sphere. Surface candidates at
// the share f' whose odds are f's over (share x rays per hit) keep the kept rays' mix that the
// paper's candidates (one ray each, on the whole sphere, surface_fraction f) give:
// f' / (1 - f') = f / (1 - f) / (share x rays per hit).
void RaySampler::set_surface_share() {
  const double f = settings_.surface_fraction;
  surface_share_ = f;
  if (f > 0 && f < 1) surface_share_ = f / (f + (1.0 - f) * line_body_share_ * double(settings_.surface_rays));
}

// Candidate generation: with probability surface_share_ (surface_fraction when the outer rays are
// drawn on the whole sphere, one surface ray per point) surface_rays surface rays (origin on the
// first hit of an outer ray, pushed off along the face normal facing that ray, directions
// cosine-weighted about that normal, one after another); otherwise, or if kSurfaceAttempts outer
// rays all miss the mesh, an outer ray. Rays whose walk has no boundary point are dropped; kept
// ones get their reference hit.
//
// The outer ray a surface candidate needs a hit of (a finding ray) may be an earlier outer
// candidate's own ray (SamplerSettings::surface_points_from_outer_hits): an outer candidate is kept
// whenever its ray hits (a hit lies in an occupied voxel), so its reference hit, traced anyway, is
// a finding ray's hit with the same law. A block of candidates therefore goes through three passes:
// (1, parallel) each candidate's kind, the outer candidates' rays drawn, walked and traced; (2,
// serial, in candidate order) each surface candidate takes the oldest unused hit of the outer
// candidates before it, if any; (3, parallel) the surface candidates' rays, from that hit or from
// their own finding rays, walked. Which hit serves which candidate depends on the candidate order
// alone, so the output still does not depend on the block sizes or the thread count.
//
// Produces exactly `count` samples, except in the degenerate cases where almost no ray can be kept:
// an empty grid or max_points == 0 gives none, and generation stops after 2^20 + 1024 * count
// candidates (fewer than 1 kept per 1024 tried; counted as lines of the whole sphere), so it always
// terminates. Callers check samples.size().
void RaySampler::generate(uint64_t seed, uint64_t stream, size_t count, std::vector<Sample>& samples,
                          std::vector<RayWalk>& walks, SamplerScratch* scratch) const {
  if (count == 0 || max_points_ == 0 || grid_.resolution == 0 || grid_.count_occupied() == 0) {
    samples.clear();
    walks.clear();
    return;
  }
  // Sized once (a caller that reuses its vectors pays no construction), shrunk at the end to what
  // was found.
  samples.resize(count);
  walks.resize(count);
  size_t filled = 0;

  const CandidateDraws draw{seed, stream, settings_, line_body_, truth_, grid_.bounds, float(surface_share_)};
  const uint32_t k = settings_.surface_rays;
  // The cap counts candidates as the whole sphere's lines they stand for (a line through the body
  // stands for 1 / line_body_share_ of them), so that what is too little to train on does not depend
  // on how the rays are drawn.
  const uint64_t max_candidates = std::max<uint64_t>(
      kMinCandidateCap, uint64_t(double((uint64_t(1) << 20) + 1024u * uint64_t(count)) * line_body_share_));

  SamplerScratch own;
  SamplerScratch& sc = scratch ? *scratch : own;
  const bool reuse = settings_.surface_points_from_outer_hits;
  sc.unused.clear();  // pass 2's hits of outer candidates not yet taken (oldest at sc.next_unused)
  sc.next_unused = 0;
  sc.to_trace.clear();
  uint64_t next = 0, tried = 0, kept = 0;
  while (filled < count && next < max_candidates) {
    // Size the block from the keep rate seen so far (the previous call's at first) so that two
    // blocks usually suffice (above). The samples kept are always the first `count` kept
    // candidates in index order, whatever the block sizes, so the result does not depend on this
    // heuristic.
    const size_t remaining = count - filled;
    const double rate = tried ? std::max(double(kept) / double(tried), 0.02) : keep_rate_;
    const double want = double(remaining) / rate;
    const size_t block = std::clamp(size_t(tried ? want * kLaterBlockMargin + double(kMinBlock) / 2 : want * kFirstBlockShare),
                                    kMinBlock, std::max(kMinBlock, kMaxSlots / k));
    const size_t slots = block * k;
    // (Allocated here: a failure inside a parallel region would abort.)
    sc.samples.resize(slots);
    sc.walks.resize(slots);
    sc.keep.resize(slots);
    sc.rays.resize(slots);
    sc.kind.resize(block);
    sc.given.resize(block);
    if (sc.unused.capacity() < sc.unused.size() + block) sc.unused.reserve(2 * (sc.unused.size() + block));  // grows geometrically
    sc.chunk_walks.resize(size_t(omp_get_max_threads()) * kChunk * k);
    sc.to_trace.reserve(count);
    Sample* bs = sc.samples.data();
    RayWalk* bw = sc.walks.data();
    uint8_t* keep = sc.keep.data();
    Ray* rays = sc.rays.data();
    // Walks the chunk's slots [from, to) of the candidates of kind `kind` that hold a ray (16 at a
    // time where the build has AVX-512; the others hold kNoWalkRay) into `into` (`into[r - from]`
    // for slot r); such a slot is kept when its walk has a boundary point.
    auto walk_slots = [&](size_t from, size_t to, CandidateKind kind, RayWalk* into) {
      for (size_t r = from; r < to; ++r) rays[r] = sc.kind[r / k] == kind && keep[r] ? bs[r].ray : kNoWalkRay;
      walk_rays(grid_, rays + from, to - from, max_points_, into);
      for (size_t r = from; r < to; ++r)
        if (sc.kind[r / k] == kind) keep[r] = keep[r] && into[r - from].count > 0;
    };
    const int64_t chunks = int64_t((block + kChunk - 1) / kChunk);
    // Pass 1: kinds; the outer candidates' rays walked and the kept ones traced.
#pragma omp parallel for schedule(dynamic, 1)
    for (int64_t c = 0; c < chunks; ++c) {
      const size_t first = size_t(c) * kChunk, last = std::min(block, first + kChunk);
      for (size_t j = first; j < last; ++j) sc.kind[j] = draw.first_pass(next + j, &bs[j * k], &keep[j * k]);
      walk_slots(first * k, last * k, kOuterCandidate, &bw[first * k]);
      size_t kept_outer[kChunk], n = 0;
      for (size_t j = first; j < last; ++j)
        if (sc.kind[j] == kOuterCandidate && keep[j * k]) kept_outer[n++] = j * k;
      trace_chunk(truth_, kept_outer, n, bs);
    }
    // Pass 2: the hits of earlier outer candidates handed to surface candidates, oldest first.
    for (size_t j = 0; j < block; ++j) {
      sc.given[j] = SIZE_MAX;
      if (!reuse) continue;
      if (sc.kind[j] == kOuterCandidate) {
        if (keep[j * k] && bs[j * k].reference.hit) sc.unused.push_back(SurfacePoint::of(bs[j * k].ray, bs[j * k].reference));
      } else if (sc.next_unused < sc.unused.size()) {
        sc.given[j] = sc.next_unused++;
      }
    }
    // Pass 3: the surface candidates' rays, walked into each thread's chunk of sc.chunk_walks
    // (walking into the block's walks would clear the outer candidates' slots), the kept ones
    // copied into the block's.
#pragma omp parallel
    {
      RayWalk* chunk_walks = sc.chunk_walks.data() + size_t(omp_get_thread_num()) * kChunk * k;
#pragma omp for schedule(dynamic, 1)
      for (int64_t c = 0; c < chunks; ++c) {
        const size_t first = size_t(c) * kChunk, last = std::min(block, first + kChunk);
        for (size_t j = first; j < last; ++j)
          if (sc.kind[j] == kSurfaceCandidate)
            draw.surface_pass(next + j, sc.given[j] == SIZE_MAX ? nullptr : &sc.unused[sc.given[j]], &bs[j * k], &keep[j * k]);
        walk_slots(first * k, last * k, kSurfaceCandidate, chunk_walks);
        for (size_t r = first * k; r < last * k; ++r)
          if (sc.kind[r / k] == kSurfaceCandidate && keep[r]) copy_walk(chunk_walks[r - first * k], bw[r]);
      }
    }
    // Compact the kept slots in order (positions serially, copies in parallel); the surface
    // candidates' samples still need their reference hits (traced at the end: not those of the
    // kept candidates beyond `count`).
    sc.slot.assign(slots, SIZE_MAX);
    for (size_t j = 0; j < slots; ++j) {
      kept += keep[j];
      if (!keep[j] || filled >= count) continue;
      if (sc.kind[j / k] == kSurfaceCandidate) sc.to_trace.push_back(filled);
      sc.slot[j] = filled++;
    }
    tried += block;
    const int64_t m = int64_t(slots);
#pragma omp parallel for schedule(static)
    for (int64_t j = 0; j < m; ++j) {
      const size_t to = sc.slot[size_t(j)];
      if (to == SIZE_MAX) continue;
      samples[to] = bs[size_t(j)];
      copy_walk(bw[size_t(j)], walks[to]);
    }
    next += block;
  }
  trace_references(truth_, sc.to_trace, samples);
  if (tried) keep_rate_ = std::max(double(kept) / double(tried), 0.02);
  samples.resize(filled);
  walks.resize(filled);
}

}  // namespace lsnif
