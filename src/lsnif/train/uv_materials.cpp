// uv_materials.cpp -- choose_uv_materials (uv_materials.h).
#include "lsnif/train/uv_materials.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>
#include <vector>

#include "lsnif/format/settings_table.h"
#include "lsnif/format/status.h"
#include "lsnif/format/uv_cell_layout.h"
#include "lsnif/core/uv_cells.h"
#include "lsnif/import/uv_layout.h"
#include "lsnif/train/evaluate.h"

namespace lsnif {

namespace {

// Why material `m`'s triangles cannot report a texture coordinate, or "" when they can.
std::string uv_obstacle(const Mesh& mesh, uint32_t m) {
  if (mesh.uvs.size() != mesh.positions.size() || mesh.uvs.empty())
    return "the mesh has no texture coordinates";
  const bool has_colors = mesh.colors.size() == mesh.positions.size();
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    if ((mesh.triangle_material.empty() ? 0u : mesh.triangle_material[t]) != m) continue;
    const glm::uvec3 tri = mesh.triangles[t];
    for (int k = 0; k < 3; ++k) {
      const glm::vec2 uv = mesh.uvs[tri[k]];
      if (!std::isfinite(uv.x) || !std::isfinite(uv.y))
        return format("triangle %zu has a non-finite texture coordinate", t);
      if (std::fabs(uv.x) > float(LSNIF_MAX_UV) || std::fabs(uv.y) > float(LSNIF_MAX_UV))
        return format("triangle %zu's texture coordinate (%g, %g) lies beyond +-%g", t, double(uv.x), double(uv.y),
                      LSNIF_MAX_UV);
      if (has_colors && mesh.colors[tri[k]] != glm::vec3(1.0f))
        return "its vertex colours tint the texture";
    }
  }
  return "";
}

}  // namespace

UvMaterialChoice choose_uv_materials(const Mesh& mesh, uint32_t texture_coordinates) {
  UvMaterialChoice out;
  if (texture_coordinates != kTextureCoordinatesAuto) return out;
  for (uint32_t m = 0; m < mesh.materials.size() && m < LSNIF_MAX_MATERIALS; ++m) {
    const Material& mat = mesh.materials[m];
    if (!mat.has_textures()) continue;
    const std::string why = uv_obstacle(mesh, m);
    if (!why.empty()) {
      out.warnings.push_back(format("material %u '%s' keeps learned colours, not its textures: %s", m,
                                    printable(mat.name).c_str(), why.c_str()));
      continue;
    }
    out.materials |= uint64_t(1) << m;
  }
  return out;
}

namespace {

// The weighted moments of one surface piece's samples in one cell.
struct Moments {
  double w = 0;
  glm::dvec3 x{0.0}, n{0.0};
  glm::dvec2 uv{0.0};
  glm::dmat3 xx{0.0};
  glm::dmat3x2 uvx{0.0};  // sum w uv x^T (2 rows, 3 columns)
  void add(double weight, glm::dvec3 p, glm::dvec2 t, glm::dvec3 normal) {
    w += weight;
    x += weight * p;
    uv += weight * t;
    n += weight * normal;
    xx += weight * glm::outerProduct(p, p);
    uvx += weight * glm::outerProduct(t, p);
  }
};

// The map of one piece: coordinates relative to the cell's centre (`r` = sample - centre in cells).
UvMap fit_map(const Moments& m) {
  const glm::dvec3 mean = m.x / m.w;
  const glm::dvec2 uv_mean = m.uv / m.w;
  // Centred covariances: sum w (x - mean)(x - mean)^T and sum w (uv - uv_mean)(x - mean)^T.
  glm::dmat3 cxx = m.xx / m.w - glm::outerProduct(mean, mean);
  const glm::dmat3x2 cux = m.uvx / m.w - glm::outerProduct(uv_mean, mean);
  const double trace = cxx[0][0] + cxx[1][1] + cxx[2][2];
  cxx += glm::dmat3(1e-6 * trace + 1e-12);  // ridge: a flat piece has no extent along its normal
  const glm::dmat3x2 g = cux * glm::inverse(cxx);  // uv - uv_mean = g (x - mean)
  UvMap out;
  const glm::dvec2 at_centre = uv_mean - g * mean;
  out.uv0 = glm::vec2(at_centre);
  out.du = glm::vec3(g[0][0], g[1][0], g[2][0]);
  out.dv = glm::vec3(g[0][1], g[1][1], g[2][1]);
  const double len = glm::length(m.n);
  const glm::dvec3 n = len > 0.0 ? m.n / len : glm::dvec3(0.0, 0.0, 1.0);
  out.normal = glm::vec3(n);
  out.offset = float(glm::dot(n, mean));
  return out;
}

}  // namespace

Status build_uv_cells(const Mesh& mesh, Model& model) {
  Config& c = model.config;
  model.uv_cells.clear();
  c.uv_cell_voxels = c.uv_cell_maps = 0;
  if (!c.texture_coordinates()) return Status::ok();
  if (mesh.uvs.size() != mesh.positions.size())
    return Status::error("uv cells: the mesh has no texture coordinates for its texture-coordinate materials");
  const uint32_t V = c.voxel_resolution, S = c.uv_cells, N = V * S;
  const Aabb& box = model.voxels.bounds;
  const glm::dvec3 lo(box.lo), cell = glm::dvec3(box.extent()) / double(N);
  const double spacing = std::min(cell.x, std::min(cell.y, cell.z)) / 4.0;
  std::vector<UvLayout> layouts(mesh.materials.size());
  for (uint32_t m = 0; m < mesh.materials.size(); ++m)
    if (c.reports_uv(m)) layouts[m] = analyze_uv_layout(mesh, m);

  // Per cell (linear index in the N^3 grid): its pieces, keyed by material and chart.
  std::unordered_map<uint64_t, std::vector<std::pair<uint64_t, Moments>>> pieces;
  for (uint32_t t = 0; t < mesh.triangles.size(); ++t) {
    const uint32_t mat = mesh.triangle_material.empty() ? 0u : mesh.triangle_material[t];
    if (!c.reports_uv(mat)) continue;
    const glm::uvec3 tri = mesh.triangles[t];
    const glm::dvec3 p0(mesh.positions[tri.x]), p1(mesh.positions[tri.y]), p2(mesh.positions[tri.z]);
    const glm::dvec3 cross = glm::cross(p1 - p0, p2 - p0);
    const double area = 0.5 * glm::length(cross);
    if (!(area > 0.0) || !std::isfinite(area)) continue;
    const glm::dvec3 normal = cross / (2.0 * area);
    const double longest = std::max(glm::length(p1 - p0), std::max(glm::length(p2 - p0), glm::length(p2 - p1)));
    const uint32_t steps = uint32_t(std::clamp(std::ceil(longest / spacing), 1.0, 4096.0));
    const double weight = area / (0.5 * double(steps + 1) * double(steps + 2));
    const uint32_t chart = layouts[mat].triangle_chart.empty() ? 0u : layouts[mat].triangle_chart[t];
    const uint64_t piece = uint64_t(mat) << 32 | chart;
    for (uint32_t i = 0; i <= steps; ++i)
      for (uint32_t j = 0; i + j <= steps; ++j) {
        // Inside the triangle, off its edges, so that a sample on a shared edge is not counted twice.
        const float bu = (float(i) + 1.0f / 3.0f) / float(steps + 1), bv = (float(j) + 1.0f / 3.0f) / float(steps + 1);
        const glm::dvec3 p = (1.0 - bu - bv) * p0 + double(bu) * p1 + double(bv) * p2;
        const glm::dvec3 u = (p - lo) / cell;
        if (!(u.x >= 0.0 && u.y >= 0.0 && u.z >= 0.0 && u.x < N && u.y < N && u.z < N)) continue;
        const glm::uvec3 q(u);
        const glm::uvec3 vox = q / S;
        if (!model.voxels.occupied(int(vox.x), int(vox.y), int(vox.z))) continue;
        glm::vec2 uv;
        mesh.uv_at(t, bu, bv, uv);
        const uint64_t key = q.x + uint64_t(N) * (q.y + uint64_t(N) * q.z);
        std::vector<std::pair<uint64_t, Moments>>& list = pieces[key];
        auto it = std::find_if(list.begin(), list.end(), [&](const auto& e) { return e.first == piece; });
        if (it == list.end()) {
          list.push_back({piece, Moments()});
          it = list.end() - 1;
        }
        it->second.add(weight, u - (glm::dvec3(q) + 0.5), glm::dvec2(uv), normal * cell);
      }
  }

  // Voxel records and maps, in voxel order, cell by cell.
  std::vector<uint32_t> records, maps;
  for (uint32_t k = 0; k < V; ++k)
    for (uint32_t j = 0; j < V; ++j)
      for (uint32_t i = 0; i < V; ++i) {
        if (!model.voxels.occupied(int(i), int(j), int(k))) continue;
        uint64_t first = 0, second = 0;
        const uint32_t first_map = uint32_t(maps.size() / kUvMapWords);
        for (uint32_t sz = 0; sz < S; ++sz)
          for (uint32_t sy = 0; sy < S; ++sy)
            for (uint32_t sx = 0; sx < S; ++sx) {
              const glm::uvec3 q(i * S + sx, j * S + sy, k * S + sz);
              const auto found = pieces.find(q.x + uint64_t(N) * (q.y + uint64_t(N) * q.z));
              if (found == pieces.end()) continue;
              std::vector<std::pair<uint64_t, Moments>> list = found->second;
              std::stable_sort(list.begin(), list.end(),
                               [](const auto& a, const auto& b) { return a.second.w > b.second.w; });
              const uint32_t cell_bit = sx + S * (sy + S * sz);
              UvMap chosen[2];
              uint32_t count = 0;
              for (const auto& [key, moments] : list) {
                const UvMap m = fit_map(moments);
                if (count == 1 && glm::dot(m.normal, chosen[0].normal) > 0.5f) continue;  // same facing: the first wins
                chosen[count++] = m;
                if (count == 2) break;
              }
              first |= uint64_t(1) << cell_bit;
              if (count == 2) second |= uint64_t(1) << cell_bit;
              for (uint32_t m = 0; m < count; ++m) {
                uint32_t w[kUvMapWords];
                pack_uv_map(chosen[m], w);
                maps.insert(maps.end(), w, w + kUvMapWords);
              }
            }
        records.insert(records.end(), {first_map, uint32_t(first), uint32_t(first >> 32), uint32_t(second),
                                       uint32_t(second >> 32)});
      }
  if (maps.size() / kUvMapWords > LSNIF_MAX_UV_CELL_MAPS)
    return Status::error("uv cells: %zu maps exceed the %u a model may have (fewer --uv-cells per voxel edge)",
                         maps.size() / kUvMapWords, LSNIF_MAX_UV_CELL_MAPS);
  c.uv_cell_voxels = uint32_t(records.size() / kUvVoxelWords);
  c.uv_cell_maps = uint32_t(maps.size() / kUvMapWords);
  model.uv_cells = std::move(records);
  model.uv_cells.insert(model.uv_cells.end(), maps.begin(), maps.end());
  if (Status s = c.validate(); !s) return s.context("uv cells");
  return check_uv_cells(c, model.uv_cells.data());
}

Status measure_uv_materials(const Mesh& mesh, Model& model, std::vector<std::string>& warnings) {
  if (!model.config.texture_coordinates()) return Status::ok();
  EvalSettings es;
  es.rays = kUvMaterialRays;
  EvalReport report;
  if (Status s = evaluate_model(model, mesh, es, report); !s) return s.context("measuring the texture coordinates");
  uint64_t kept = model.config.uv_materials;
  for (const UvMaterialEval& u : report.uv_materials) {
    if (u.hits < kUvMaterialMinHits || u.channel_error_textures <= kUvMaterialGain * u.channel_error_colours) continue;
    kept &= ~(uint64_t(1) << u.material);
    warnings.push_back(format("material %u '%s' keeps learned colours, not its textures: sampled at the predicted "
                              "texture coordinates they shade further from the reference (channels MAE %.4f, "
                              "learned colours %.4f, over %llu held-out hits)",
                              u.material, printable(u.name).c_str(), u.channel_error_textures,
                              u.channel_error_colours, (unsigned long long)u.hits));
  }
  if (kept == model.config.uv_materials) return Status::ok();
  model.config.uv_materials = kept;
  if (!kept) model.config.uv_cells = 0;
  return build_uv_cells(mesh, model);
}

}  // namespace lsnif
