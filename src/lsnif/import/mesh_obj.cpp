// mesh_obj.cpp -- Wavefront OBJ reader: v (with the optional "v x y z r g b" color extension),
// vt, vn, f with v, v/t, v//n and v/t/n corners, 1-based or negative (relative) indices, polygons
// fan-triangulated. usemtl names give per-triangle materials; Kd of a material is read as its base
// color when the file's mtllib is found next to it. Corners that reference no valid vertex make
// their triangle invalid (finalize_mesh drops and counts it).
#include <filesystem>
#include <unordered_map>

#include "lsnif/format/file_io.h"
#include "lsnif/import/mesh_formats.h"
#include "lsnif/import/resolve_path.h"

namespace lsnif::mesh_io {
namespace {

constexpr int64_t kAbsent = -1;  // corner without a texture coordinate / normal
constexpr int64_t kBad = -2;     // corner with an out-of-range or zero index

struct Corner {
  int64_t p, t, n;
  bool operator==(const Corner&) const = default;
};

struct CornerHash {
  size_t operator()(const Corner& c) const {
    uint64_t h = static_cast<uint64_t>(c.p) * 0x9E3779B97F4A7C15ull;
    h ^= static_cast<uint64_t>(c.t) + 0x7F4A7C159E3779B9ull + (h << 6) + (h >> 2);
    h ^= static_cast<uint64_t>(c.n) + 0x165667B19E3779F9ull + (h << 6) + (h >> 2);
    return static_cast<size_t>(h);
  }
};

// OBJ index (1-based, or negative relative to the `count` elements defined so far) -> 0-based.
int64_t resolve(int64_t i, size_t count) {
  int64_t c = static_cast<int64_t>(count);
  if (i > 0 && i <= c) return i - 1;
  if (i < 0 && -i <= c) return c + i;
  return kBad;
}

// Parses one "p", "p/t", "p//n" or "p/t/n" corner.
bool parse_corner(std::string_view tok, size_t np, size_t nt, size_t nn, Corner& c) {
  std::string_view part[3];
  int parts = 0;
  size_t start = 0;
  for (size_t i = 0; i <= tok.size(); ++i) {
    if (i == tok.size() || tok[i] == '/') {
      if (parts == 3) return false;
      part[parts++] = tok.substr(start, i - start);
      start = i + 1;
    }
  }
  int64_t v = 0;
  if (!parse_int64(part[0], v)) return false;
  c.p = resolve(v, np);
  c.t = c.n = kAbsent;
  if (parts >= 2 && !part[1].empty()) {
    if (!parse_int64(part[1], v)) return false;
    c.t = resolve(v, nt);
  }
  if (parts == 3 && !part[2].empty()) {
    if (!parse_int64(part[2], v)) return false;
    c.n = resolve(v, nn);
  }
  return true;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && TextCursor::is_space(s.front())) s.remove_prefix(1);
  while (!s.empty() && TextCursor::is_space(s.back())) s.remove_suffix(1);
  return s;
}

// Reads "newmtl name" / "Kd r g b" pairs of a .mtl file into `kd`; a file that cannot be read (or
// is larger than a mesh file may be) gives none.
void read_mtl(const std::string& path, std::unordered_map<std::string, glm::vec3>& kd) {
  std::string text;
  if (!read_file(path, text, kMaxMeshFileBytes)) return;
  TextCursor cur(text);
  std::string current;
  while (!cur.at_end()) {
    std::string_view key = cur.line_token();
    if (key == "newmtl") {
      const char* b = cur.p;
      while (!cur.at_line_end()) ++cur.p;
      current = std::string(trim(std::string_view(b, static_cast<size_t>(cur.p - b))));
      kd.emplace(current, glm::vec3(1.0f));
    } else if (key == "Kd" && !current.empty()) {
      double rgb[3];
      bool ok = true;
      for (double& c : rgb) ok = ok && parse_double(cur.line_token(), c);
      if (ok) kd[current] = glm::vec3(to_float(rgb[0]), to_float(rgb[1]), to_float(rgb[2]));
    }
    cur.skip_line();
  }
}

// What the statements of an OBJ file define, before it becomes the mesh.
struct ObjData {
  std::vector<glm::vec3> pos, col, nrm;
  std::vector<glm::vec2> tex;
  bool any_color = false;
  std::vector<Corner> corners;       // three per triangle
  std::vector<uint32_t> tri_material;
  std::vector<std::string> material_names;
  std::unordered_map<std::string, uint32_t> material_index;
  std::vector<std::string> mtllibs;
  uint32_t current_material = kInvalidIndex;  // none yet: "default" on first use
  uint32_t short_faces = 0, ignored_elements = 0;
  std::vector<Corner> poly;
};

// The rest of a "v" line (on `line`): x y z, with r g b when the color extension is used.
Status parse_v(TextCursor& in, const char* file, int line, ObjData& obj) {
  double v[7];
  int count = 0;
  for (std::string_view tok = in.line_token(); !tok.empty() && count < 7; tok = in.line_token()) {
    if (!parse_double(tok, v[count]))
      return Status::error("%s: line %d: bad vertex coordinate '%s'", file, line,
                           excerpt(tok).c_str());
    ++count;
  }
  if (count < 3) return Status::error("%s: line %d: vertex needs 3 coordinates", file, line);
  obj.pos.emplace_back(to_float(v[0]), to_float(v[1]), to_float(v[2]));
  if (count >= 6) {
    obj.any_color = true;
    obj.col.resize(obj.pos.size() - 1, glm::vec3(1.0f));
    obj.col.emplace_back(to_float(v[3]), to_float(v[4]), to_float(v[5]));
  }
  return Status::ok();
}

// The rest of a "vt" or "vn" line (`key`, on `line`).
Status parse_vt_vn(TextCursor& in, std::string_view key, const char* file, int line, ObjData& obj) {
  double v[3] = {0.0, 0.0, 0.0};
  int count = 0;
  for (std::string_view tok = in.line_token(); !tok.empty() && count < 3; tok = in.line_token()) {
    if (!parse_double(tok, v[count]))
      return Status::error("%s: line %d: bad %s value '%s'", file, line,
                           std::string(key).c_str(), excerpt(tok).c_str());
    ++count;
  }
  if (key == "vt") {
    if (count < 1) return Status::error("%s: line %d: empty texture coordinate", file, line);
    obj.tex.emplace_back(to_float(v[0]), to_float(v[1]));
  } else {
    if (count < 3) return Status::error("%s: line %d: normal needs 3 components", file, line);
    obj.nrm.emplace_back(to_float(v[0]), to_float(v[1]), to_float(v[2]));
  }
  return Status::ok();
}

// The rest of an "f" line (on `line`): its corners fan-triangulated with the current material (a face
// of fewer than 3 corners counts in short_faces).
Status parse_f(TextCursor& in, const char* file, int line, ObjData& obj) {
  obj.poly.clear();
  for (std::string_view tok = in.line_token(); !tok.empty(); tok = in.line_token()) {
    Corner c{};
    if (!parse_corner(tok, obj.pos.size(), obj.tex.size(), obj.nrm.size(), c))
      return Status::error("%s: line %d: bad face corner '%s'", file, line, excerpt(tok).c_str());
    obj.poly.push_back(c);
  }
  if (obj.poly.size() < 3) {
    ++obj.short_faces;
    return Status::ok();
  }
  if (obj.current_material == kInvalidIndex) {
    obj.current_material = static_cast<uint32_t>(obj.material_names.size());
    obj.material_names.push_back("default");
    obj.material_index.emplace("default", obj.current_material);
  }
  for (size_t k = 1; k + 1 < obj.poly.size(); ++k) {
    obj.corners.push_back(obj.poly[0]);
    obj.corners.push_back(obj.poly[k]);
    obj.corners.push_back(obj.poly[k + 1]);
    obj.tri_material.push_back(obj.current_material);
  }
  return Status::ok();
}

// The rest of a "usemtl" line (the current material, added on first use) or an "mtllib" line (`key`).
void parse_material_line(TextCursor& in, std::string_view key, ObjData& obj) {
  const char* b = in.p;
  while (!in.at_line_end()) ++in.p;
  std::string arg(trim(std::string_view(b, static_cast<size_t>(in.p - b))));
  if (key == "mtllib") {
    if (!arg.empty()) obj.mtllibs.push_back(arg);
  } else {
    auto [it, inserted] = obj.material_index.emplace(arg, static_cast<uint32_t>(obj.material_names.size()));
    if (inserted) obj.material_names.push_back(arg);
    obj.current_material = it->second;
  }
}

// Every statement of the file, line by line (unknown statements are skipped); then vertices without a
// color get white when any has one.
Status parse_statements(std::string_view data, const char* file, ObjData& obj) {
  TextCursor in(data);
  while (!in.at_end()) {
    std::string_view key = in.line_token();
    const int line = in.line;
    Status s;
    if (key == "v") {
      s = parse_v(in, file, line, obj);
    } else if (key == "vt" || key == "vn") {
      s = parse_vt_vn(in, key, file, line, obj);
    } else if (key == "f") {
      s = parse_f(in, file, line, obj);
    } else if (key == "usemtl" || key == "mtllib") {
      parse_material_line(in, key, obj);
    } else if (key == "l" || key == "p") {
      ++obj.ignored_elements;
    }
    if (!s) return s;
    in.skip_line();  // comments, groups, smoothing groups, and the rest of handled lines
  }
  if (obj.any_color) obj.col.resize(obj.pos.size(), glm::vec3(1.0f));
  return Status::ok();
}

// Corners -> mesh vertices, when no corner has a texture coordinate or normal: the OBJ vertices are the
// mesh vertices (moved out of `obj`).
void take_obj_vertices(ObjData& obj, Mesh& mesh) {
  const std::vector<Corner>& corners = obj.corners;
  mesh.positions = std::move(obj.pos);
  if (obj.any_color) mesh.colors = std::move(obj.col);
  mesh.triangles.reserve(corners.size() / 3);
  for (size_t i = 0; i + 2 < corners.size(); i += 3) {
    glm::uvec3 t;
    for (int k = 0; k < 3; ++k) {
      int64_t p = corners[i + size_t(k)].p;
      t[k] = p >= 0 ? static_cast<uint32_t>(p) : kInvalidIndex;
    }
    mesh.triangles.push_back(t);
  }
}

// Corners -> mesh vertices, when some corner has a texture coordinate or normal: each distinct (p, t, n)
// triple becomes one.
void split_corner_vertices(const ObjData& obj, Mesh& mesh) {
  const std::vector<Corner>& corners = obj.corners;
  bool any_t = false, any_n = false;
  for (const Corner& c : corners) {
    any_t = any_t || c.t >= 0;
    any_n = any_n || c.n >= 0;
  }
  std::unordered_map<Corner, uint32_t, CornerHash> vertex_of;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  mesh.triangles.reserve(corners.size() / 3);
  for (size_t i = 0; i + 2 < corners.size(); i += 3) {
    glm::uvec3 t;
    for (int k = 0; k < 3; ++k) {
      const Corner& c = corners[i + size_t(k)];
      if (c.p < 0 || c.t == kBad || c.n == kBad) {
        t[k] = kInvalidIndex;
        continue;
      }
      auto [it, inserted] = vertex_of.emplace(c, static_cast<uint32_t>(mesh.positions.size()));
      if (inserted) {
        mesh.positions.push_back(obj.pos[size_t(c.p)]);
        if (obj.any_color) mesh.colors.push_back(obj.col[size_t(c.p)]);
        if (any_t) mesh.uvs.push_back(c.t >= 0 ? obj.tex[size_t(c.t)] : glm::vec2(0.0f));
        // A corner without a normal gets NaN: finalize_mesh recomputes (and counts) it.
        if (any_n) mesh.normals.push_back(c.n >= 0 ? obj.nrm[size_t(c.n)] : glm::vec3(nan));
      }
      t[k] = it->second;
    }
    mesh.triangles.push_back(t);
  }
}

// The mesh's materials in order of first use, with Kd from the mtllib files that exist next to the OBJ
// (a missing one is a warning).
Status add_materials(const ObjData& obj, const std::string& name, const std::string& base_dir,
                     const MeshImportOptions& options, Mesh& mesh, MeshImportReport& report) {
  const char* file = name.c_str();
  std::unordered_map<std::string, glm::vec3> kd;
  for (const std::string& lib : obj.mtllibs) {
    std::string path;
    if (Status s = resolve_reference(base_dir, lib, options.allow_outside_refs, "mtllib", path); !s)
      return s.context(name);
    std::error_code ec;
    if (std::filesystem::is_regular_file(path, ec))
      read_mtl(path, kd);
    else
      report.warnings.push_back(format("%s: material library '%s' not found; using white",
                                       file, excerpt(lib).c_str()));
  }
  for (const std::string& m : obj.material_names) {
    auto it = kd.find(m);
    mesh.materials.push_back(Material{m, it != kd.end() ? it->second : glm::vec3(1.0f), -1});
  }
  return Status::ok();
}

}  // namespace

Status parse_obj(std::string_view data, const std::string& name, const std::string& base_dir,
                 const MeshImportOptions& options, Mesh& mesh, MeshImportReport& report) {
  const char* file = name.c_str();
  ObjData obj;
  Status s = parse_statements(data, file, obj);
  if (!s) return s;

  // Corners -> mesh vertices. Without texture coordinates or normals the OBJ vertices are the
  // mesh vertices; otherwise each distinct (p, t, n) triple becomes one.
  bool split = false;
  for (const Corner& c : obj.corners) split = split || c.t != kAbsent || c.n != kAbsent;
  if (!split)
    take_obj_vertices(obj, mesh);
  else
    split_corner_vertices(obj, mesh);
  mesh.triangle_material = std::move(obj.tri_material);

  // Materials, with Kd from the mtllib files that exist next to the OBJ.
  s = add_materials(obj, name, base_dir, options, mesh, report);
  if (!s) return s;
  if (obj.short_faces) {
    report.dropped_degenerate += obj.short_faces;
    report.warnings.push_back(
        format("%s: dropped %u faces with fewer than 3 vertices", file, obj.short_faces));
  }
  if (obj.ignored_elements)
    report.warnings.push_back(
        format("%s: ignored %u line/point elements (only faces are imported)", file, obj.ignored_elements));
  return Status::ok();
}

}  // namespace lsnif::mesh_io
