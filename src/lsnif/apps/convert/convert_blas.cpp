// convert_blas.cpp -- triangle BLAS sizes for the memory rule (convert_blas.h).
#include "lsnif/apps/convert/convert_blas.h"

#include <algorithm>

namespace lsnif::convert {

namespace {
// The fit of convert_blas.h (lavapipe, Mesa 25.0; the meshes and the command: docs/convert.md).
constexpr uint64_t kHeaderBytes = 40;
constexpr uint64_t kLeafBytes = 48;      // per triangle
constexpr uint64_t kInternalBytes = 56;  // per internal node: max(triangles, 2) - 1
}  // namespace

uint64_t estimated_blas_bytes(uint64_t triangles) {
  if (triangles == 0) return 0;
  return kHeaderBytes + kLeafBytes * triangles + kInternalBytes * (std::max<uint64_t>(triangles, 2) - 1);
}

const char* estimated_blas_source() { return "calibrated estimate (lavapipe's sizes; --blas-size device queries)"; }

Status blas_bytes(const BlasSizer& sizer, const std::vector<BlasPrimitive>& primitives, uint64_t& bytes) {
  bytes = 0;
  for (size_t i = 0; i < primitives.size(); ++i) {
    const BlasPrimitive& p = primitives[i];
    if (p.triangles == 0 || p.vertices == 0) continue;
    uint64_t one = 0;
    if (!sizer.query) {
      one = estimated_blas_bytes(p.triangles);
    } else if (Status s = sizer.query(p, one); !s) {
      return Status::error("primitive %zu (%llu vertices, %llu triangles): %s", i, (unsigned long long)p.vertices,
                           (unsigned long long)p.triangles, s.message().c_str());
    }
    bytes += one;
  }
  return Status::ok();
}

}  // namespace lsnif::convert
