// ground_truth.cpp -- exact closest-hit ray casting with Embree 3: one triangle geometry over the
// mesh (robust, watertight traversal), queried one ray at a time or in packets of 16 from any
// thread; materials with cut-outs alpha-tested by an intersection filter.
#include "lsnif/train/ground_truth.h"

#include <embree3/rtcore.h>

#include <cmath>
#include <algorithm>
#include <cstring>
#include <mutex>
#include <string>

namespace lsnif {

struct GroundTruth::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  const Mesh* mesh = nullptr;
  std::mutex error_mutex;
  std::string last_error;  // message of the most recent Embree error (empty if none)

  ~Impl() { release(); }
  void release() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
    scene = nullptr;
    device = nullptr;
    mesh = nullptr;
  }
  // Embree error callback: keeps the message so build() can report it.
  static void on_error(void* user, RTCError code, const char* message) {
    auto* self = static_cast<Impl*>(user);
    std::lock_guard<std::mutex> lock(self->error_mutex);
    self->last_error = format("Embree error %d: %s", int(code), message ? message : "(no message)");
  }
  // Error status for a failed Embree call `what`, naming Embree's message.
  Status embree_error(const char* what) {
    std::string message;
    {
      std::lock_guard<std::mutex> lock(error_mutex);
      message = last_error;
    }
    if (message.empty() && device) message = format("Embree error code %d", int(rtcGetDeviceError(device)));
    release();
    return Status::error("ground truth: %s failed: %s", what, message.c_str());
  }
};

namespace {

// Embree's intersection filter for meshes with cut-outs (Mesh::has_cutouts): a candidate hit where
// the material's alpha test fails (Mesh::opaque_at) is rejected and traversal goes on behind it.
void alpha_test_filter(const RTCFilterFunctionNArguments* args) {
  const Mesh& mesh = *static_cast<const Mesh*>(args->geometryUserPtr);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] == 0) continue;
    const uint32_t prim = RTCHitN_primID(args->hit, args->N, i);
    if (!mesh.opaque_at(prim, RTCHitN_u(args->hit, args->N, i), RTCHitN_v(args->hit, args->N, i))) args->valid[i] = 0;
  }
}

}  // namespace

GroundTruth::GroundTruth() : impl_(std::make_unique<Impl>()) {}
GroundTruth::~GroundTruth() = default;

// Checks that every triangle indexes finite positions and a valid material; builds the scene.
// On error nothing is kept (trace() then reports misses).
Status GroundTruth::build(const Mesh& mesh) {
  impl_->release();
  impl_->last_error.clear();

  if (mesh.triangles.empty())
    return Status::error("ground truth: mesh has no triangles (%zu positions)", mesh.positions.size());
  if (mesh.positions.size() > size_t(UINT32_MAX))
    return Status::error("ground truth: mesh has %zu positions, more than Embree's 32-bit indices allow",
                         mesh.positions.size());
  if (mesh.triangle_material.size() != mesh.triangles.size())
    return Status::error("ground truth: mesh has %zu triangles but %zu triangle materials",
                         mesh.triangles.size(), mesh.triangle_material.size());
  for (size_t i = 0; i < mesh.positions.size(); ++i) {
    const glm::vec3& p = mesh.positions[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      return Status::error("ground truth: position %zu is not finite (%g, %g, %g)", i, double(p.x),
                           double(p.y), double(p.z));
  }
  for (size_t i = 0; i < mesh.triangles.size(); ++i) {
    const glm::uvec3& t = mesh.triangles[i];
    for (int k = 0; k < 3; ++k)
      if (t[k] >= mesh.positions.size())
        return Status::error("ground truth: triangle %zu references vertex %u of %zu", i, t[k],
                             mesh.positions.size());
    if (mesh.triangle_material[i] >= mesh.materials.size())
      return Status::error("ground truth: triangle %zu uses material %u of %zu", i,
                           mesh.triangle_material[i], mesh.materials.size());
  }

  impl_->device = rtcNewDevice(nullptr);
  if (!impl_->device)
    return Status::error("ground truth: rtcNewDevice failed: Embree error code %d",
                         int(rtcGetDeviceError(nullptr)));
  rtcSetDeviceErrorFunction(impl_->device, &Impl::on_error, impl_.get());

  impl_->scene = rtcNewScene(impl_->device);
  if (!impl_->scene) return impl_->embree_error("rtcNewScene");
  rtcSetSceneFlags(impl_->scene, RTC_SCENE_FLAG_ROBUST);
  rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_HIGH);

  RTCGeometry geometry = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
  if (!geometry) return impl_->embree_error("rtcNewGeometry");
  // Copies into Embree-owned buffers: Embree pads them for its 16-byte vertex loads, which a
  // std::vector<glm::vec3> does not guarantee.
  auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(
      geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), mesh.positions.size()));
  auto* indices = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(
      geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(uint32_t), mesh.triangles.size()));
  if (!vertices || !indices) {
    rtcReleaseGeometry(geometry);
    return impl_->embree_error("rtcSetNewGeometryBuffer");
  }
  for (size_t i = 0; i < mesh.positions.size(); ++i)
    for (int k = 0; k < 3; ++k) vertices[3 * i + size_t(k)] = mesh.positions[i][k];
  for (size_t i = 0; i < mesh.triangles.size(); ++i)
    for (int k = 0; k < 3; ++k) indices[3 * i + size_t(k)] = mesh.triangles[i][k];
  if (mesh.has_cutouts()) {  // the alpha test: holes are not surface
    rtcSetGeometryUserData(geometry, const_cast<Mesh*>(&mesh));
    rtcSetGeometryIntersectFilterFunction(geometry, &alpha_test_filter);
  }
  rtcCommitGeometry(geometry);
  rtcAttachGeometry(impl_->scene, geometry);
  rtcReleaseGeometry(geometry);
  rtcCommitScene(impl_->scene);
  if (rtcGetDeviceError(impl_->device) != RTC_ERROR_NONE || !impl_->last_error.empty())
    return impl_->embree_error("building the scene");
  impl_->mesh = &mesh;
  return Status::ok();
}

namespace {

// Embree's closest hit: t, the triangle, its barycentrics and Embree's unnormalized face normal.
struct EmbreeHit {
  bool hit = false;
  float t = 0.0f, u = 0.0f, v = 0.0f;
  uint32_t triangle = 0;
  glm::vec3 ng{0.0f};
};

// The closest hit of `ray` in `scene`; rays with a non-finite origin or direction, a zero
// direction, a NaN range or tmin > tmax miss, as does any ray when `scene` is null (no successful
// build()).
// Whether `ray` can be traced (a finite origin and direction, a direction not zero, a range
// [max(tmin, 0), tmax] that is not empty or NaN); `tnear` receives max(tmin, 0).
bool traceable(const Ray& ray, float& tnear) {
  const glm::vec3& o = ray.origin;
  const glm::vec3& d = ray.direction;
  if (!std::isfinite(o.x) || !std::isfinite(o.y) || !std::isfinite(o.z) || !std::isfinite(d.x) ||
      !std::isfinite(d.y) || !std::isfinite(d.z))
    return false;
  if (d.x == 0.0f && d.y == 0.0f && d.z == 0.0f) return false;
  tnear = std::fmax(ray.tmin, 0.0f);
  return !(std::isnan(ray.tmin) || std::isnan(ray.tmax) || !(tnear <= ray.tmax) || std::isinf(tnear));
}

EmbreeHit closest_hit(RTCScene scene, const Ray& ray) {
  EmbreeHit result;
  float tmin = 0.0f;
  if (!scene || !traceable(ray, tmin)) return result;
  const glm::vec3& o = ray.origin;
  const glm::vec3& d = ray.direction;

  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit rh;
  std::memset(&rh, 0, sizeof(rh));
  rh.ray.org_x = o.x;
  rh.ray.org_y = o.y;
  rh.ray.org_z = o.z;
  rh.ray.dir_x = d.x;
  rh.ray.dir_y = d.y;
  rh.ray.dir_z = d.z;
  rh.ray.tnear = tmin;
  rh.ray.tfar = ray.tmax;
  rh.ray.mask = 0xFFFFFFFFu;
  rh.ray.flags = 0;
  rh.ray.time = 0.0f;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(scene, &context, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return result;
  result.hit = true;
  result.t = rh.ray.tfar;
  result.u = rh.hit.u;
  result.v = rh.hit.v;
  result.triangle = rh.hit.primID;
  result.ng = glm::vec3(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z);
  return result;
}

}  // namespace

// Closest hit with t in [max(ray.tmin, 0), ray.tmax] (t in units of ray.direction, which need not
// be normalized). Rays with a non-finite origin or direction, a zero direction, a NaN range or
// tmin > tmax, and any ray traced before a successful build(), miss.
namespace {

// trace()'s hit from Embree's.
ReferenceHit reference_hit(const Mesh& mesh, const EmbreeHit& h) {
  ReferenceHit result;
  if (!h.hit) return result;
  const uint32_t prim = h.triangle;
  const glm::uvec3& tri = mesh.triangles[prim];
  const glm::vec3 p0 = mesh.positions[tri.x], p1 = mesh.positions[tri.y], p2 = mesh.positions[tri.z];
  result.hit = true;
  result.t = h.t;
  result.triangle = prim;
  result.material = mesh.triangle_material[prim];
  result.normal = mesh.shading_normal(prim, h.u, h.v);
  result.surface = mesh.surface(prim, h.u, h.v);
  mesh.uv_at(prim, h.u, h.v, result.uv);
  result.albedo = result.surface.albedo;
  // Face normal as wound (counter-clockwise p0, p1, p2 seen from its front), independent of
  // Embree's Ng convention. A sliver too thin for float falls back to the shading normal.
  const glm::dvec3 n = glm::cross(glm::dvec3(p1) - glm::dvec3(p0), glm::dvec3(p2) - glm::dvec3(p0));
  const double len = glm::length(n);
  result.geometric_normal = len > 0.0 ? glm::vec3(n / len) : result.normal;
  return result;
}

}  // namespace

ReferenceHit GroundTruth::trace(const Ray& ray) const {
  if (!impl_->scene) return ReferenceHit();
  return reference_hit(*impl_->mesh, closest_hit(impl_->scene, ray));
}

void GroundTruth::trace(const Ray* rays, size_t count, ReferenceHit* hits) const {
  constexpr size_t L = 16;
  if (!impl_->scene) {  // before a successful build(): misses, as trace()
    std::fill(hits, hits + count, ReferenceHit());
    return;
  }
  for (size_t first = 0; first < count; first += L) {
    const size_t n = std::min(L, count - first);
    alignas(64) int valid[L] = {};
    alignas(64) RTCRayHit16 rh;
    for (size_t k = 0; k < L; ++k) {
      float tnear = 0.0f;
      const Ray& ray = rays[first + std::min(k, n - 1)];
      valid[k] = k < n && traceable(ray, tnear) ? -1 : 0;
      rh.ray.org_x[k] = ray.origin.x;
      rh.ray.org_y[k] = ray.origin.y;
      rh.ray.org_z[k] = ray.origin.z;
      rh.ray.dir_x[k] = ray.direction.x;
      rh.ray.dir_y[k] = ray.direction.y;
      rh.ray.dir_z[k] = ray.direction.z;
      rh.ray.tnear[k] = tnear;
      rh.ray.tfar[k] = valid[k] ? ray.tmax : 0.0f;
      rh.ray.mask[k] = 0xFFFFFFFFu;
      rh.ray.flags[k] = 0;
      rh.ray.time[k] = 0.0f;
      rh.ray.id[k] = 0;
      rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
      rh.hit.primID[k] = RTC_INVALID_GEOMETRY_ID;
      rh.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
    }
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    rtcIntersect16(valid, impl_->scene, &context, &rh);
    for (size_t k = 0; k < n; ++k) {
      EmbreeHit h;
      if (valid[k] && rh.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID) {
        h.hit = true;
        h.t = rh.ray.tfar[k];
        h.u = rh.hit.u[k];
        h.v = rh.hit.v[k];
        h.triangle = rh.hit.primID[k];
        h.ng = glm::vec3(rh.hit.Ng_x[k], rh.hit.Ng_y[k], rh.hit.Ng_z[k]);
      }
      hits[first + k] = reference_hit(*impl_->mesh, h);
    }
  }
}

ReferenceHit GroundTruth::trace_geometry(const Ray& ray) const {
  ReferenceHit result;
  const EmbreeHit h = closest_hit(impl_->scene, ray);
  if (!h.hit) return result;
  result.hit = true;
  result.t = h.t;
  result.triangle = h.triangle;
  const float len = glm::length(h.ng);
  if (len > 0.0f && std::isfinite(len)) {
    result.geometric_normal = h.ng / len;
  } else {  // a sliver: Mesh::shading_normal, as trace() falls back to
    result.geometric_normal = impl_->mesh->shading_normal(h.triangle, h.u, h.v);
  }
  return result;
}

}  // namespace lsnif
