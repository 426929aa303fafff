// convert_blas.h -- the triangle BLAS memory a converted mesh gives back, as the converter's
// memory rule (ConvertWhen::Memory, docs/convert.md) weighs it against the model: the renderer
// (src/lsnif/renderer/renderer.cpp) builds one BLAS per triangle primitive of a mesh, with one
// OPAQUE geometry of float3 positions and uint32 indices and PREFER_FAST_TRACE
// (vk::RayTracer::build_triangle_blas), and keeps none for the nodes it draws as LSNIF objects.
// The bytes come from a BlasSizeQuery (the device's vkGetAccelerationStructureBuildSizesKHR:
// convert_blas_device.h) or, without a device, from a calibrated estimate.
#pragma once
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "lsnif/format/status.h"

namespace lsnif::convert {

// One BLAS as the renderer builds it for a primitive: its vertices (the POSITION count, the
// geometry's maxVertex + 1) and triangles (strips and fans as triangle lists).
struct BlasPrimitive {
  uint64_t vertices = 0;
  uint64_t triangles = 0;
};

// The accelerationStructureSize of the BLAS of `primitive` (built as above), or an error.
using BlasSizeQuery = std::function<Status(const BlasPrimitive& primitive, uint64_t& bytes)>;

// Where the BLAS bytes come from: `query` (empty: estimated_blas_bytes) and how the report names it.
struct BlasSizer {
  BlasSizeQuery query;
  std::string source;  // e.g. "device query on 'NAME'"; empty: the calibrated estimate's name
};

// The calibrated estimate of one BLAS of `triangles` triangles (0 for none): the least-squares fit
// bytes = a + b * triangles + c * vertices to lavapipe's accelerationStructureSize on real meshes
// (docs/convert.md, "BLAS sizes"), which gave c = 0 (the size does not depend on the vertices) and
// an affine function of the triangles, exact on every mesh measured: a 40-byte header, a 48-byte
// leaf per triangle and a 56-byte box per internal node of the binary tree (triangles - 1, at
// least 1). Other drivers lay their BVHs out differently: query the target device for them.
uint64_t estimated_blas_bytes(uint64_t triangles);

// The report's name of the estimate.
const char* estimated_blas_source();

// The BLAS bytes of a mesh's primitives, summed (primitives without triangles build no BLAS);
// the query's error names the primitive.
Status blas_bytes(const BlasSizer& sizer, const std::vector<BlasPrimitive>& primitives, uint64_t& bytes);

}  // namespace lsnif::convert
