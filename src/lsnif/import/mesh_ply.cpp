// mesh_ply.cpp -- PLY reader (ascii, binary_little_endian and binary_big_endian). The vertex
// element gives x, y, z and optionally nx, ny, nz, red, green, blue (integers scaled by the type's
// maximum, so uchar / 255, kept linear) and s, t / u, v / texture_u, texture_v; the face element's
// vertex_indices (or vertex_index) lists are fan-triangulated. Every other property and element,
// scalar or list of any type, is skipped by its declared size.
#include <algorithm>
#include <cstring>

#include "lsnif/import/mesh_formats.h"

namespace lsnif::mesh_io {
namespace {

enum class Type { I8, U8, I16, U16, I32, U32, F32, F64, None };

Type type_from_name(std::string_view s) {
  if (s == "char" || s == "int8") return Type::I8;
  if (s == "uchar" || s == "uint8") return Type::U8;
  if (s == "short" || s == "int16") return Type::I16;
  if (s == "ushort" || s == "uint16") return Type::U16;
  if (s == "int" || s == "int32") return Type::I32;
  if (s == "uint" || s == "uint32") return Type::U32;
  if (s == "float" || s == "float32") return Type::F32;
  if (s == "double" || s == "float64") return Type::F64;
  return Type::None;
}

size_t type_size(Type t) {
  switch (t) {
    case Type::I8: case Type::U8: return 1;
    case Type::I16: case Type::U16: return 2;
    case Type::I32: case Type::U32: case Type::F32: return 4;
    case Type::F64: return 8;
    case Type::None: return 0;
  }
  return 0;
}

// Scale that maps an integer color channel to [0, 1]; 1 for floating-point types.
double color_scale(Type t) {
  switch (t) {
    case Type::I8: return 1.0 / 127.0;
    case Type::U8: return 1.0 / 255.0;
    case Type::I16: return 1.0 / 32767.0;
    case Type::U16: return 1.0 / 65535.0;
    case Type::I32: return 1.0 / 2147483647.0;
    case Type::U32: return 1.0 / 4294967295.0;
    default: return 1.0;
  }
}

struct Property {
  std::string name;
  Type type = Type::None;        // scalar type, or the item type of a list
  Type count_type = Type::None;  // list count type; None for scalars
};

struct Element {
  std::string name;
  uint64_t count = 0;
  std::vector<Property> properties;
};

enum class Encoding { Ascii, BinaryLittle, BinaryBig };

// Reads one value of the body, ascii or binary, with bounds checks.
class BodyReader {
 public:
  BodyReader(std::string_view body, Encoding enc) : text_(body), enc_(enc), p_(body.data()),
      end_(body.data() + body.size()) {}

  // False at the end of the data or on a malformed ascii number.
  bool read(Type t, double& out) {
    if (enc_ == Encoding::Ascii) return parse_double(text_.token(), out);
    size_t n = type_size(t);
    if (size_t(end_ - p_) < n) return false;
    unsigned char b[8] = {};
    for (size_t i = 0; i < n && i < 8; ++i)
      b[i] = static_cast<unsigned char>(p_[enc_ == Encoding::BinaryBig ? n - 1 - i : i]);
    p_ += n;
    switch (t) {
      case Type::I8: { int8_t v; std::memcpy(&v, b, 1); out = v; break; }
      case Type::U8: out = b[0]; break;
      case Type::I16: { int16_t v; std::memcpy(&v, b, 2); out = v; break; }
      case Type::U16: { uint16_t v; std::memcpy(&v, b, 2); out = v; break; }
      case Type::I32: { int32_t v; std::memcpy(&v, b, 4); out = v; break; }
      case Type::U32: { uint32_t v; std::memcpy(&v, b, 4); out = v; break; }
      case Type::F32: { float v; std::memcpy(&v, b, 4); out = v; break; }
      case Type::F64: { double v; std::memcpy(&v, b, 8); out = v; break; }
      case Type::None: return false;
    }
    return true;
  }
  // Skips `n` values of type t; false if the data ends first.
  bool skip(Type t, uint64_t n) {
    if (enc_ != Encoding::Ascii) {
      uint64_t bytes = n * type_size(t);  // n is bounded by the caller (list counts <= 2^32)
      if (uint64_t(end_ - p_) < bytes) return false;
      p_ += bytes;
      return true;
    }
    double dummy;
    for (uint64_t i = 0; i < n; ++i)
      if (!read(t, dummy)) return false;
    return true;
  }
  size_t remaining() const {
    return enc_ == Encoding::Ascii ? size_t(text_.end - text_.p) : size_t(end_ - p_);
  }
  int line() const { return text_.line; }

 private:
  TextCursor text_;
  Encoding enc_;
  const char* p_;
  const char* end_;
};

int find_property(const Element& e, std::initializer_list<const char*> names) {
  for (const char* n : names)
    for (size_t i = 0; i < e.properties.size(); ++i)
      if (e.properties[i].name == n && e.properties[i].count_type == Type::None) return int(i);
  return -1;
}

// The rest of a "property" header line (declared on `line`): a scalar "TYPE NAME" or a "list COUNT_TYPE
// ITEM_TYPE NAME".
Status parse_property(TextCursor& hdr, const char* file, int line, Property& prop) {
  std::string_view t = hdr.line_token();
  if (t == "list") {
    prop.count_type = type_from_name(hdr.line_token());
    prop.type = type_from_name(hdr.line_token());
    if (prop.count_type == Type::None || prop.type == Type::None)
      return Status::error("%s: line %d: bad list property types", file, line);
  } else {
    prop.type = type_from_name(t);
    if (prop.type == Type::None)
      return Status::error("%s: line %d: unknown property type '%s'", file, line,
                           excerpt(t).c_str());
  }
  prop.name = std::string(hdr.line_token());
  return Status::ok();
}

// The header from the "ply" magic through "end_header": the body's encoding and the declared elements;
// `hdr` is left at the body's first byte.
Status parse_header(TextCursor& hdr, const char* file, Encoding& enc, std::vector<Element>& elements) {
  if (hdr.line_token() != "ply") return Status::error("%s: not a PLY file (missing 'ply' magic)", file);
  hdr.skip_line();
  enc = Encoding::Ascii;
  bool have_format = false, have_end = false;
  while (!hdr.at_end()) {
    const int line = hdr.line;
    std::string_view key = hdr.line_token();
    if (key == "format") {
      std::string_view f = hdr.line_token();
      if (f == "ascii") enc = Encoding::Ascii;
      else if (f == "binary_little_endian") enc = Encoding::BinaryLittle;
      else if (f == "binary_big_endian") enc = Encoding::BinaryBig;
      else return Status::error("%s: line %d: unknown PLY format '%s'", file, line, excerpt(f).c_str());
      have_format = true;
    } else if (key == "element") {
      Element e;
      e.name = std::string(hdr.line_token());
      int64_t count = -1;
      std::string_view tok = hdr.line_token();
      if (e.name.empty() || !parse_int64(tok, count) || count < 0)
        return Status::error("%s: line %d: bad element declaration", file, line);
      e.count = static_cast<uint64_t>(count);
      elements.push_back(std::move(e));
    } else if (key == "property") {
      if (elements.empty())
        return Status::error("%s: line %d: property before any element", file, line);
      Property prop;
      Status s = parse_property(hdr, file, line, prop);
      if (!s) return s;
      elements.back().properties.push_back(std::move(prop));
    } else if (key == "end_header") {
      hdr.skip_line();
      have_end = true;
      break;
    } else if (!key.empty() && key != "comment" && key != "obj_info") {
      return Status::error("%s: line %d: unexpected header keyword '%s'", file, line,
                           excerpt(key).c_str());
    }
    hdr.skip_line();
  }
  if (!have_format || !have_end)
    return Status::error("%s: incomplete PLY header (missing %s)", file,
                         have_format ? "end_header" : "format");
  return Status::ok();
}

// Indices of the vertex element's properties (-1: absent); an optional attribute's first index (pnx, pr,
// pu) is -1 unless all its components are present.
struct VertexProperties {
  int px = -1, py = -1, pz = -1, pnx = -1, pny = -1, pnz = -1, pr = -1, pg = -1, pb = -1, pu = -1, pv = -1;
};

// The vertex element's properties: scalar x, y, z are required, and its count must fit an index.
Status find_vertex_properties(const Element& e, const char* file, VertexProperties& v) {
  v.px = find_property(e, {"x"});
  v.py = find_property(e, {"y"});
  v.pz = find_property(e, {"z"});
  if (v.px < 0 || v.py < 0 || v.pz < 0)
    return Status::error("%s: vertex element lacks scalar x, y, z properties", file);
  if (e.count >= kInvalidIndex)
    return Status::error("%s: vertex count %llu too large", file,
                         static_cast<unsigned long long>(e.count));
  v.pnx = find_property(e, {"nx"});
  v.pny = find_property(e, {"ny"});
  v.pnz = find_property(e, {"nz"});
  v.pr = find_property(e, {"red", "r", "diffuse_red"});
  v.pg = find_property(e, {"green", "g", "diffuse_green"});
  v.pb = find_property(e, {"blue", "b", "diffuse_blue"});
  v.pu = find_property(e, {"s", "u", "texture_u", "texture_s"});
  v.pv = find_property(e, {"t", "v", "texture_v", "texture_t"});
  if (v.pnx < 0 || v.pny < 0 || v.pnz < 0) v.pnx = -1;
  if (v.pr < 0 || v.pg < 0 || v.pb < 0) v.pr = -1;
  if (v.pu < 0 || v.pv < 0) v.pu = -1;
  return Status::ok();
}

// Reserves room for `n` vertices in the arrays the vertex element fills.
void reserve_vertices(const VertexProperties& v, size_t n, Mesh& mesh) {
  mesh.positions.reserve(n);
  if (v.pnx >= 0) mesh.normals.reserve(n);
  if (v.pr >= 0) mesh.colors.reserve(n);
  if (v.pu >= 0) mesh.uvs.reserve(n);
}

// Index of the face element's vertex_indices (or vertex_index) list; -1 without one.
int find_face_list(const Element& e) {
  for (size_t i = 0; i < e.properties.size(); ++i) {
    const Property& p = e.properties[i];
    if (p.count_type != Type::None && (p.name == "vertex_indices" || p.name == "vertex_index")) return int(i);
  }
  return -1;
}

// Appends the vertex whose property values are `values` (colors scaled to [0, 1]).
void append_vertex(const Element& e, const VertexProperties& v, const std::vector<double>& values, Mesh& mesh) {
  auto v3 = [&](int a, int b, int c, bool color) {
    auto get = [&](int k) {
      double scale = color ? color_scale(e.properties[size_t(k)].type) : 1.0;
      return to_float(values[size_t(k)] * scale);
    };
    return glm::vec3(get(a), get(b), get(c));
  };
  mesh.positions.push_back(v3(v.px, v.py, v.pz, false));
  if (v.pnx >= 0) mesh.normals.push_back(v3(v.pnx, v.pny, v.pnz, false));
  if (v.pr >= 0) mesh.colors.push_back(v3(v.pr, v.pg, v.pb, true));
  if (v.pu >= 0) mesh.uvs.emplace_back(to_float(values[size_t(v.pu)]), to_float(values[size_t(v.pv)]));
}

// Reads list property p of item `item` of element e: the face list (`is_face_list`) is fan-triangulated
// into mesh.triangles (lists of fewer than 3 indices count in short_faces), any other list skipped.
// `poly` is scratch space.
Status read_list(BodyReader& body, const Element& e, const Property& p, uint64_t item, bool is_face_list,
                 const char* file, std::vector<uint32_t>& poly, Mesh& mesh, uint32_t& short_faces) {
  double count_value = 0.0;
  if (!body.read(p.count_type, count_value) || !(count_value >= 0.0) ||
      count_value != std::floor(count_value) || count_value > double(body.remaining()))
    return Status::error("%s: %s %llu: bad list count for '%s'", file, excerpt(e.name).c_str(),
                         static_cast<unsigned long long>(item), excerpt(p.name).c_str());
  const uint64_t count = static_cast<uint64_t>(count_value);
  if (!is_face_list) {
    if (!body.skip(p.type, count))
      return Status::error("%s: %s %llu: list '%s' runs past the end of the file", file,
                           excerpt(e.name).c_str(), static_cast<unsigned long long>(item),
                           excerpt(p.name).c_str());
    return Status::ok();
  }
  poly.clear();
  for (uint64_t k = 0; k < count; ++k) {
    double index = 0.0;
    if (!body.read(p.type, index))
      return Status::error("%s: face %llu: missing or bad vertex index (file truncated?)", file,
                           static_cast<unsigned long long>(item));
    poly.push_back(to_index(index));
  }
  if (poly.size() < 3) {
    ++short_faces;
  } else {
    for (size_t k = 1; k + 1 < poly.size(); ++k)
      mesh.triangles.emplace_back(poly[0], poly[k], poly[k + 1]);
  }
  return Status::ok();
}

// Reads every item of element e: appends a vertex per item when `vertex` is given (the vertex element)
// and the triangles of the list at index `face_list` (-1: none). `values` and `poly` are scratch space.
Status read_element(BodyReader& body, const Element& e, const char* file, const VertexProperties* vertex,
                    int face_list, std::vector<double>& values, std::vector<uint32_t>& poly, Mesh& mesh,
                    uint32_t& short_faces) {
  values.assign(e.properties.size(), 0.0);
  for (uint64_t item = 0; item < e.count; ++item) {
    for (size_t i = 0; i < e.properties.size(); ++i) {
      const Property& p = e.properties[i];
      if (p.count_type == Type::None) {
        if (!body.read(p.type, values[i]))
          return Status::error("%s: %s %llu: missing or bad value for '%s' (file truncated?)", file,
                               excerpt(e.name).c_str(), static_cast<unsigned long long>(item),
                               excerpt(p.name).c_str());
        continue;
      }
      Status s = read_list(body, e, p, item, int(i) == face_list, file, poly, mesh, short_faces);
      if (!s) return s;
    }
    if (vertex) append_vertex(e, *vertex, values, mesh);
  }
  return Status::ok();
}

}  // namespace

Status parse_ply(std::string_view data, const std::string& name, Mesh& mesh,
                 MeshImportReport& report) {
  const char* file = name.c_str();
  // --- header ---
  TextCursor hdr(data);
  Encoding enc = Encoding::Ascii;
  std::vector<Element> elements;
  Status s = parse_header(hdr, file, enc, elements);
  if (!s) return s;

  // --- body ---
  BodyReader body(std::string_view(hdr.p, size_t(hdr.end - hdr.p)), enc);
  bool have_vertices = false;
  uint32_t short_faces = 0;
  std::vector<double> values;
  std::vector<uint32_t> poly;
  for (const Element& e : elements) {
    if (e.properties.empty()) continue;  // nothing stored per item
    const bool is_vertex = e.name == "vertex" && !have_vertices;
    const bool is_face = e.name == "face";
    VertexProperties vertex;
    int face_list = -1;
    if (is_vertex) {
      have_vertices = true;
      s = find_vertex_properties(e, file, vertex);
      if (!s) return s;
      // Each item takes at least one byte: never reserve beyond what the data can hold.
      reserve_vertices(vertex, static_cast<size_t>(std::min<uint64_t>(e.count, body.remaining())), mesh);
    } else if (is_face) {
      face_list = find_face_list(e);
      if (face_list < 0) report.warnings.push_back(format(
          "%s: face element has no vertex_indices list; its %llu faces are ignored", file,
          static_cast<unsigned long long>(e.count)));
    } else if (e.count > 0) {
      report.warnings.push_back(format("%s: ignored PLY element '%s' (%llu items)", file,
                                       excerpt(e.name).c_str(),
                                       static_cast<unsigned long long>(e.count)));
    }
    s = read_element(body, e, file, is_vertex ? &vertex : nullptr, face_list, values, poly, mesh, short_faces);
    if (!s) return s;
  }
  if (!have_vertices) return Status::error("%s: no vertex element", file);
  if (short_faces) {
    report.dropped_degenerate += short_faces;
    report.warnings.push_back(
        format("%s: dropped %u faces with fewer than 3 vertices", file, short_faces));
  }
  return Status::ok();
}

}  // namespace lsnif::mesh_io
