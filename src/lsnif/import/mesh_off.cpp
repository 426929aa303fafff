// mesh_off.cpp -- ascii OFF reader (Geomview Object File Format, as used by the bunny, armadillo
// and dragon test meshes). Header keyword [ST][C][N]OFF, optionally followed by the counts on the
// same line; '#' comments anywhere; polygons are fan-triangulated; per-vertex extras (normals,
// colors, texture coordinates of the NOFF/COFF/STOFF variants) and per-face colors are ignored.
#include <algorithm>

#include "lsnif/import/mesh_formats.h"

namespace lsnif::mesh_io {

Status parse_off(std::string_view data, const std::string& name, Mesh& mesh,
                 MeshImportReport& report) {
  const char* file = name.c_str();
  TextCursor in(data);
  std::string_view keyword = in.token('#');
  if (keyword.size() < 3 || keyword.substr(keyword.size() - 3) != "OFF")
    return Status::error("%s: not an OFF file (first token '%s', expected 'OFF')", file,
                         excerpt(keyword).c_str());
  std::string_view prefix = keyword.substr(0, keyword.size() - 3);
  for (char c : prefix) {
    if (c != 'S' && c != 'T' && c != 'C' && c != 'N')
      return Status::error("%s: unsupported OFF variant '%s' (only 3D [ST][C][N]OFF is supported)",
                           file, excerpt(keyword).c_str());
  }
  // "OFF BINARY" would follow on the same line.
  in.skip_blanks();
  if (!in.at_line_end() && (*in.p == 'B' || *in.p == 'b'))
    return Status::error("%s: binary OFF is not supported", file);

  // Counts: on the keyword's line or the next non-comment line; the edge count may be missing.
  if (in.at_line_end() || *in.p == '#') in.skip_space('#');
  int64_t counts[2] = {0, 0};
  const char* what[2] = {"vertex count", "face count"};
  for (int i = 0; i < 2; ++i) {
    std::string_view tok = in.line_token();
    if (!tok.empty() && tok.front() == '#') tok = std::string_view();
    if (!parse_int64(tok, counts[i]) || counts[i] < 0)
      return Status::error("%s: line %d: bad or missing %s '%s'", file, in.line, what[i],
                           excerpt(tok).c_str());
  }
  in.skip_line();
  const int64_t nv = counts[0], nf = counts[1];
  if (nv >= int64_t(kInvalidIndex)) return Status::error("%s: vertex count %lld too large", file,
                                                          static_cast<long long>(nv));
  // Every vertex needs at least 6 bytes ("0 0 0\n"), every face 8: bound the reservations by the
  // data instead of trusting the header.
  mesh.positions.reserve(static_cast<size_t>(std::min<int64_t>(nv, int64_t(data.size() / 6))));
  for (int64_t i = 0; i < nv; ++i) {
    double xyz[3];
    for (int k = 0; k < 3; ++k) {
      std::string_view tok = in.token('#');
      if (tok.empty())
        return Status::error("%s: file ends after %lld of %lld vertices", file,
                             static_cast<long long>(i), static_cast<long long>(nv));
      if (!parse_double(tok, xyz[k]))
        return Status::error("%s: line %d: bad coordinate '%s' in vertex %lld", file, in.line,
                             excerpt(tok).c_str(), static_cast<long long>(i));
    }
    mesh.positions.emplace_back(to_float(xyz[0]), to_float(xyz[1]), to_float(xyz[2]));
    in.skip_line();  // extras of the C/N/ST variants
  }

  mesh.triangles.reserve(static_cast<size_t>(std::min<int64_t>(nf, int64_t(data.size() / 8))));
  uint32_t short_faces = 0;
  std::vector<uint32_t> poly;
  for (int64_t f = 0; f < nf; ++f) {
    std::string_view tok = in.token('#');
    int64_t count = 0;
    if (tok.empty())
      return Status::error("%s: file ends after %lld of %lld faces", file, static_cast<long long>(f),
                           static_cast<long long>(nf));
    if (!parse_int64(tok, count) || count < 0)
      return Status::error("%s: line %d: bad vertex count '%s' in face %lld", file, in.line,
                           excerpt(tok).c_str(), static_cast<long long>(f));
    if (count > int64_t(data.size()))
      return Status::error("%s: line %d: face %lld claims %lld vertices, more than the file holds",
                           file, in.line, static_cast<long long>(f), static_cast<long long>(count));
    poly.clear();
    for (int64_t k = 0; k < count; ++k) {
      tok = in.token('#');
      int64_t index = 0;
      if (tok.empty())
        return Status::error("%s: file ends inside face %lld of %lld", file, static_cast<long long>(f),
                             static_cast<long long>(nf));
      if (!parse_int64(tok, index))
        return Status::error("%s: line %d: bad vertex index '%s' in face %lld", file, in.line,
                             excerpt(tok).c_str(), static_cast<long long>(f));
      poly.push_back(index >= 0 && index < nv ? static_cast<uint32_t>(index) : kInvalidIndex);
    }
    in.skip_line();  // optional face color
    if (poly.size() < 3) {
      ++short_faces;
      continue;
    }
    for (size_t k = 1; k + 1 < poly.size(); ++k)
      mesh.triangles.emplace_back(poly[0], poly[k], poly[k + 1]);
  }
  if (short_faces) {
    report.dropped_degenerate += short_faces;
    report.warnings.push_back(
        format("%s: dropped %u faces with fewer than 3 vertices", file, short_faces));
  }
  return Status::ok();
}

}  // namespace lsnif::mesh_io
