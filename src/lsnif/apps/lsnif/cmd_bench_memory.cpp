// lsnif bench-memory MESH MODEL: device memory of an LSNIF model (GPU block + its AABB BLAS, as the
// plugin uploads it) against the triangle BLAS the driver builds for MESH and for subdivided
// versions of it (uncompacted size, build scratch, compacted size from a query after a build with
// ALLOW_COMPACTION, and the vertex + index buffers a renderer keeps beside the BLAS).
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "lsnif/apps/lsnif/args.h"
#include "lsnif/apps/lsnif/commands.h"
#include "lsnif/apps/lsnif/train_options.h"
#include "lsnif/apps/lsnif/device_option.h"
#include <volk.h>  // before lsnif.h, which then uses volk's Vulkan declarations

#include "lsnif/lsnif.hpp"
#include "lsnif/import/json_text.h"
#include "lsnif/import/mesh.h"
#include "lsnif/import/mesh_subdivide.h"
#include "lsnif/core/model.h"
#include "lsnif/vulkan/plugin_device.h"
#include "lsnif/apps/lsnif/report_text.h"
#include "lsnif/vulkan/raytracing.h"

namespace lsnif::cli {

namespace {

// Largest triangle count measured (host copies and the BLAS of bigger meshes outgrow ordinary
// machines).
constexpr uint64_t kMaxTriangles = uint64_t(1) << 27;

// What one built model occupies on the device (lsnifGetModelMemory once its build resources are freed).
struct ModelDeviceMemory {
  uint64_t block_bytes = 0;      // the GPU block
  uint64_t blas_bytes = 0;       // the AABB BLAS (the driver's accelerationStructureSize)
  uint64_t allocated_bytes = 0;  // device memory allocated for both
  uint64_t total() const { return block_bytes + blas_bytes; }
};

struct LsnifMemory {
  uint64_t model_bytes = 0;  // memory_breakdown(model).total(): the model's parameters and header
  ModelDeviceMemory device;
};

// One measured version of the mesh: the original (level 0) or a subdivision.
struct TriangleVersion {
  std::vector<uint64_t> targets;  // the --subdivide-targets that chose this level
  uint32_t level = 0;
  uint64_t vertices = 0, triangles = 0;
  vk::BlasSizes sizes;             // PREFER_FAST_TRACE (how build_triangle_blas and the plugin build)
  vk::CompactionReport compaction;  // PREFER_FAST_TRACE | ALLOW_COMPACTION, built and compacted
  uint64_t vertex_bytes = 0, index_bytes = 0;
};

// "1000000,5000000" -> {1000000, 5000000}; "" -> {}. False on anything but positive integers.
bool parse_targets(const std::string& text, std::vector<uint64_t>& out) {
  out.clear();
  size_t at = 0;
  while (at < text.size()) {
    size_t comma = text.find(',', at);
    if (comma == std::string::npos) comma = text.size();
    const std::string item = text.substr(at, comma - at);
    if (item.empty() || item.find_first_not_of("0123456789") != std::string::npos) return false;
    char* end = nullptr;
    const unsigned long long v = std::strtoull(item.c_str(), &end, 10);
    if (*end || v == 0 || v > kMaxTriangles) return false;
    out.push_back(uint64_t(v));
    at = comma + 1;
    if (comma + 1 == text.size()) return false;  // trailing comma
  }
  return true;
}


double ratio(uint64_t a, uint64_t b) { return b ? double(a) / double(b) : 0.0; }


// Uploads `model` with the plugin on `vk`'s device, builds it, reads what it occupies, releases it.
Status measure_lsnif(vk::Context& vk, const Model& model, LsnifMemory& out) {
  out.model_bytes = memory_breakdown(model).total();
  std::vector<uint8_t> bytes;
  if (Status s = save_model_to_memory(model, bytes); !s) return s;
  plugin::Context ctx;
  plugin::Model m;
  LsnifModelMemory mem{};
  LsnifModel handle = nullptr;
  const bool ok = ctx.create(vk::plugin_create_info(vk)) == LSNIF_SUCCESS &&
                  m.create_from_memory(ctx.get(), bytes.data(), bytes.size()) == LSNIF_SUCCESS &&
                  (handle = m.get(), lsnifBuildModels(ctx.get(), 1, &handle) == LSNIF_SUCCESS) &&
                  lsnifGetModelMemory(ctx.get(), handle, &mem) == LSNIF_SUCCESS;
  if (!ok) return Status::error("plugin: %s", lsnifGetLastErrorMessage());
  out.device.block_bytes = mem.blockBytes;
  out.device.blas_bytes = mem.blasBytes;
  out.device.allocated_bytes = mem.allocatedBytes;
  return Status::ok();
}

// Fills `v` (level and targets set by the caller) for `mesh`: sizes, then a build with compaction
// (a progress line on stderr while it runs).
Status measure_triangles(vk::RayTracer& rt, const Mesh& mesh, TriangleVersion& v) {
  v.vertices = mesh.positions.size();
  v.triangles = mesh.triangles.size();
  v.vertex_bytes = v.vertices * 3 * sizeof(float);
  v.index_bytes = v.triangles * 3 * sizeof(uint32_t);
  Status s = rt.triangle_blas_sizes(uint32_t(v.vertices), uint32_t(v.triangles),
                                    VK_BUILD_ACCELERATION_STRUCTURE_PREFER_FAST_TRACE_BIT_KHR, v.sizes);
  if (!s) return s;
  std::vector<float> positions(3 * mesh.positions.size());
  for (size_t i = 0; i < mesh.positions.size(); ++i)
    for (int k = 0; k < 3; ++k) positions[3 * i + size_t(k)] = mesh.positions[i][k];
  std::vector<uint32_t> indices(3 * mesh.triangles.size());
  for (size_t i = 0; i < mesh.triangles.size(); ++i)
    for (int k = 0; k < 3; ++k) indices[3 * i + size_t(k)] = mesh.triangles[i][k];
  std::fprintf(stderr, "lsnif bench-memory: level %u, %s triangles: building the triangle BLAS ...",
               v.level, grouped(v.triangles).c_str());
  std::fflush(stderr);
  vk::AccelerationStructure blas;
  s = rt.build_compacted_triangle_blas(positions, indices, blas, v.compaction);
  rt.destroy(blas);
  if (s)
    std::fprintf(stderr, " built in %.2f s, compacted in %.2f s\n", v.compaction.build_seconds,
                 v.compaction.compact_seconds);
  else
    std::fprintf(stderr, " failed\n");
  return s;
}

std::string targets_text(const std::vector<uint64_t>& targets) {
  std::string s;
  for (const uint64_t t : targets) {
    if (!s.empty()) s += ',';
    s += std::to_string(t);
  }
  return s;
}

void print_text(const std::string& mesh_path, const std::string& model_path, const std::string& device,
                const LsnifMemory& l, const std::vector<TriangleVersion>& versions) {
  const uint64_t total = l.device.total();
  std::printf("device   %s\n", device.c_str());
  std::printf("model    %s (%s B = %.3f MiB of parameters and header)\n", model_path.c_str(),
              grouped(l.model_bytes).c_str(), mib(l.model_bytes));
  std::printf("mesh     %s\n\n", mesh_path.c_str());
  std::printf("LSNIF on the device                    bytes        MiB\n");
  std::printf("  model block (GPU layout)     %14s %10.3f\n", grouped(l.device.block_bytes).c_str(),
              mib(l.device.block_bytes));
  std::printf("  AABB BLAS                    %14s %10.3f\n", grouped(l.device.blas_bytes).c_str(),
              mib(l.device.blas_bytes));
  std::printf("  total                        %14s %10.3f  (allocated %s B)\n\n", grouped(total).c_str(), mib(total),
              grouped(l.device.allocated_bytes).c_str());
  std::printf("triangle BLAS (one opaque geometry, float3 positions, uint32 indices), MiB\n");
  std::printf("%-5s %11s %11s %10s %10s %10s %10s %12s | %9s %9s %9s\n", "level", "triangles", "vertices",
              "BLAS", "scratch", "compacted", "vtx+idx", "target", "BLAS/L", "compact/L", "(c+vi)/L");
  for (const TriangleVersion& v : versions) {
    const uint64_t geometry = v.vertex_bytes + v.index_bytes;
    std::printf("%-5u %11s %11s %10.2f %10.2f %10.2f %10.2f %12s | %9.2f %9.2f %9.2f\n", v.level,
                grouped(v.triangles).c_str(), grouped(v.vertices).c_str(), mib(v.sizes.acceleration_structure),
                mib(v.sizes.build_scratch), mib(v.compaction.compacted), mib(geometry),
                v.targets.empty() ? "-" : targets_text(v.targets).c_str(),
                ratio(v.sizes.acceleration_structure, total), ratio(v.compaction.compacted, total),
                ratio(v.compaction.compacted + geometry, total));
  }
  std::printf("\nL = LSNIF total (model block + AABB BLAS). BLAS: accelerationStructureSize for PREFER_FAST_TRACE;\n"
              "compacted: compacted-size query after a PREFER_FAST_TRACE | ALLOW_COMPACTION build; vtx+idx: the\n"
              "vertex (12 B) and index (12 B per triangle) buffers a renderer keeps beside the BLAS.\n");
}

void print_json(const std::string& mesh_path, const std::string& model_path, const std::string& device,
                const LsnifMemory& l, const std::vector<TriangleVersion>& versions) {
  const uint64_t total = l.device.total();
  nlohmann::ordered_json j;
  j["mesh"] = mesh_path;
  j["model"] = model_path;
  j["device"] = device;
  j["lsnif"] = {{"model_bytes", l.model_bytes},
                {"block_bytes", l.device.block_bytes},
                {"aabb_blas_bytes", l.device.blas_bytes},
                {"total_bytes", total},
                {"allocated_bytes", l.device.allocated_bytes}};
  nlohmann::ordered_json& blas = j["triangle_blas"] = nlohmann::ordered_json::array();
  for (const TriangleVersion& v : versions) {
    const uint64_t geometry = v.vertex_bytes + v.index_bytes;
    blas.push_back({{"level", v.level},
                    {"targets", v.targets},
                    {"triangles", v.triangles},
                    {"vertices", v.vertices},
                    {"blas_bytes", v.sizes.acceleration_structure},
                    {"build_scratch_bytes", v.sizes.build_scratch},
                    {"update_scratch_bytes", v.sizes.update_scratch},
                    {"blas_bytes_allow_compaction", v.compaction.sizes.acceleration_structure},
                    {"build_scratch_bytes_allow_compaction", v.compaction.sizes.build_scratch},
                    {"compacted_bytes", v.compaction.compacted},
                    {"vertex_bytes", v.vertex_bytes},
                    {"index_bytes", v.index_bytes},
                    {"build_seconds", v.compaction.build_seconds},
                    {"compact_seconds", v.compaction.compact_seconds},
                    {"ratio_blas", ratio(v.sizes.acceleration_structure, total)},
                    {"ratio_compacted", ratio(v.compaction.compacted, total)},
                    {"ratio_compacted_with_geometry", ratio(v.compaction.compacted + geometry, total)}});
  }
  std::printf("%s\n", json::dump(j).c_str());
}

// Whether the mesh lies inside the model's (padded) bounds, with 1% of the diagonal to spare.
bool mesh_fits_model(const Mesh& mesh, const Model& model) {
  const Aabb m = mesh.bounds(), b = model.bounds();
  const float slack = 0.01f * b.diagonal();
  for (int k = 0; k < 3; ++k)
    if (m.lo[k] < b.lo[k] - slack || m.hi[k] > b.hi[k] + slack) return false;
  return true;
}

}  // namespace

int cmd_bench_memory(int argc, char** argv) {
  std::string mesh_path, model_path, targets_arg = "1000000,5000000", device;
  bool json = false;
  MeshImportOptions import_options;
  Args args("bench-memory",
            "Device memory of an LSNIF model against the triangle BLAS of its mesh. LSNIF: the model's GPU\n"
            "block plus its AABB BLAS, uploaded by the plugin. Triangles: for MESH and for each midpoint\n"
            "subdivision (1-to-4 per level) closest to a --subdivide-targets count, the driver's BLAS size\n"
            "and build scratch, the compacted size after a build with ALLOW_COMPACTION, and the vertex and\n"
            "index buffers; then the ratios to the LSNIF total. Needs a Vulkan device with\n"
            "VK_KHR_acceleration_structure and VK_KHR_ray_tracing_pipeline (exit code 1 otherwise).");
  args.positional("MESH", "triangle mesh (.off .obj .ply .gltf .glb)", &mesh_path);
  args.positional("MODEL", "LSNIF model of it (.lsnif)", &model_path);
  args.option("subdivide-targets", "comma-separated triangle counts ('' for none)", &targets_arg);
  args.flag("json", "print one JSON object instead of the table", &json);
  add_device_option(args, &device);
  add_import_flags(args, &import_options);
  if (int r = args.parse(argc, argv)) return r == 1 ? 0 : 2;
  std::vector<uint64_t> targets;
  if (!parse_targets(targets_arg, targets)) {
    std::fprintf(stderr, "lsnif bench-memory: invalid value '%s' for --subdivide-targets (comma-separated "
                         "triangle counts from 1 to %llu expected)\n",
                 targets_arg.c_str(), static_cast<unsigned long long>(kMaxTriangles));
    return 2;
  }

  Model model;
  if (Status s = load_model(model_path, model); !s) {
    std::fprintf(stderr, "lsnif bench-memory: %s\n", s.message().c_str());
    return 1;
  }
  Mesh mesh;
  if (Status s = load_mesh(mesh_path, mesh, nullptr, import_options); !s) {
    std::fprintf(stderr, "lsnif bench-memory: %s\n", s.message().c_str());
    return 1;
  }
  if (!mesh_fits_model(mesh, model))
    std::fprintf(stderr, "lsnif bench-memory: warning: %s does not fit the bounds of %s (a model of another "
                         "mesh?)\n", mesh_path.c_str(), model_path.c_str());

  // Versions to measure: level 0, then each target's level (ascending, once each).
  std::vector<TriangleVersion> versions(1);
  for (const uint64_t t : targets) {
    const uint32_t level = subdivision_level_for(mesh.triangles.size(), t);
    if ((uint64_t(mesh.triangles.size()) << (2 * level)) > kMaxTriangles) {
      std::fprintf(stderr, "lsnif bench-memory: target %llu needs %llu triangles (level %u); at most %llu are "
                           "supported\n", static_cast<unsigned long long>(t),
                   static_cast<unsigned long long>(uint64_t(mesh.triangles.size()) << (2 * level)), level,
                   static_cast<unsigned long long>(kMaxTriangles));
      return 2;
    }
    size_t at = 0;
    while (at < versions.size() && versions[at].level < level) ++at;
    if (at == versions.size() || versions[at].level != level) {
      versions.insert(versions.begin() + static_cast<std::ptrdiff_t>(at), TriangleVersion());
      versions[at].level = level;
    }
    versions[at].targets.push_back(t);
  }

  vk::Context vk;
  if (Status s = vk.init(/*ray_tracing=*/true, /*validation=*/false, device); !s) {
    std::fprintf(stderr, "lsnif bench-memory: no usable Vulkan ray-tracing device (`lsnif devices` tells what is "
                         "missing): %s\n", s.message().c_str());
    return 1;
  }
  vk::RayTracer rt(vk);
  LsnifMemory lsnif_memory;
  Status s = rt.init();
  for (const TriangleVersion& v : versions) {
    const uint64_t triangles = uint64_t(mesh.triangles.size()) << (2 * v.level);
    if (s && triangles > rt.max_primitive_count())
      s = Status::error("level %u has %s triangles, more than the device's maxPrimitiveCount %s (lower "
                        "--subdivide-targets)", v.level, grouped(triangles).c_str(),
                        grouped(rt.max_primitive_count()).c_str());
  }
  if (s) s = measure_lsnif(vk, model, lsnif_memory);
  uint32_t level = 0;
  for (size_t i = 0; i < versions.size() && s; ++i) {
    if (versions[i].level > level) {
      std::fprintf(stderr, "lsnif bench-memory: subdividing to level %u ...", versions[i].level);
      std::fflush(stderr);
      const auto t0 = std::chrono::steady_clock::now();
      s = subdivide_midpoint(mesh, versions[i].level - level, mesh);
      if (s)
        std::fprintf(stderr, " %.2f s\n", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      else
        std::fprintf(stderr, " failed\n");
      level = versions[i].level;
    }
    if (s) s = measure_triangles(rt, mesh, versions[i]);
  }
  if (!s) {
    std::fprintf(stderr, "lsnif bench-memory: %s\n", s.message().c_str());
    return 1;
  }
  if (json)
    print_json(mesh_path, model_path, vk.device_name(), lsnif_memory, versions);
  else
    print_text(mesh_path, model_path, vk.device_name(), lsnif_memory, versions);
  return 0;
}

}  // namespace lsnif::cli
