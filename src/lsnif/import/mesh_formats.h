// mesh_formats.h -- internal interface of the mesh importers (mesh_off.cpp, mesh_obj.cpp,
// mesh_ply.cpp, mesh_gltf.cpp) and the small text scanner they share. Not part of the public API:
// load_mesh() in mesh.h is the entry point; this header exists so that the importers can be run on
// in-memory bytes (the fuzz test does) and so each format stays in its own file.
#pragma once
#include <charconv>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>

#include "lsnif/format/numbers.h"
#include "lsnif/format/status.h"
#include "lsnif/import/mesh.h"

namespace lsnif::mesh_io {

enum class MeshFormat { Off, Obj, Ply, Gltf, Glb, TrainingMesh, Unknown };

// The most bytes load_mesh reads from a mesh file, and mesh_obj.cpp from an OBJ's material library.
inline constexpr uint64_t kMaxMeshFileBytes = uint64_t(1) << 34;

// Format from the file name's extension (case-insensitive); Unknown for anything else.
MeshFormat format_from_path(const std::string& path);

// Marks a triangle corner that references no valid vertex; finalize_mesh drops such triangles
// and counts them as invalid.
inline constexpr uint32_t kInvalidIndex = std::numeric_limits<uint32_t>::max();

// The parsers append the file's geometry to an empty `mesh` without cleaning it (finalize_mesh
// does that). `name` names the input in messages; `base_dir` resolves files the input refers to
// (OBJ mtllib, glTF buffers and images); warnings go to `report`. Malformed input yields an error
// naming `name` and the problem; no input makes them read out of bounds or throw.
Status parse_off(std::string_view data, const std::string& name, Mesh& mesh,
                 MeshImportReport& report);
// `options.allow_outside_refs`: mtllib files and glTF buffers/images may lie outside base_dir.
Status parse_obj(std::string_view data, const std::string& name, const std::string& base_dir,
                 const MeshImportOptions& options, Mesh& mesh, MeshImportReport& report);
Status parse_ply(std::string_view data, const std::string& name, Mesh& mesh,
                 MeshImportReport& report);
// `binary`: the bytes are a .glb container, else .gltf JSON.
Status parse_gltf(std::string_view data, bool binary, const std::string& name,
                  const std::string& base_dir, const MeshImportOptions& options, Mesh& mesh,
                  MeshImportReport& report);
// The training mesh file (training_mesh.h), read as written: its checksum, counts and every index
// are checked, nothing is re-derived.
Status parse_training_mesh(std::string_view data, const std::string& name, Mesh& mesh);

// What load_mesh does once the file is read: clears `mesh`, parses `data` as `format`, then
// finalize_mesh. Exceptions from the standard library (allocation failures) become errors.
Status parse_mesh(std::string_view data, MeshFormat format, const std::string& name,
                  const std::string& base_dir, Mesh& mesh, MeshImportReport* report,
                  const MeshImportOptions& options = {});

// Index from a parsed number: integral values in [0, 2^32-1) map to themselves, everything else
// (negative, fractional, huge, NaN) to kInvalidIndex.
inline uint32_t to_index(double d) {
  if (!(d >= 0.0) || !(d < static_cast<double>(kInvalidIndex)) || d != std::floor(d))
    return kInvalidIndex;
  return static_cast<uint32_t>(d);
}

// Whitespace-separated token scanner over text, used by the OFF, OBJ and ascii PLY readers.
// Never reads outside [p, end).
struct TextCursor {
  const char* p;
  const char* end;
  int line = 1;  // 1-based line of `p`, for messages

  explicit TextCursor(std::string_view text) : p(text.data()), end(text.data() + text.size()) {}

  static bool is_space(char c) {
    return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f';
  }
  // Skips whitespace (newlines included) and, if comment != 0, comments from `comment` to the
  // end of their line.
  void skip_space(char comment = 0) {
    while (p < end) {
      if (*p == '\n') {
        ++line;
        ++p;
      } else if (is_space(*p)) {
        ++p;
      } else if (comment != 0 && *p == comment) {
        skip_line();
      } else {
        break;
      }
    }
  }
  // Skips spaces and tabs only (stays on the current line).
  void skip_blanks() {
    while (p < end && *p != '\n' && is_space(*p)) ++p;
  }
  // Moves past the next newline (or to the end).
  void skip_line() {
    while (p < end && *p != '\n') ++p;
    if (p < end) {
      ++p;
      ++line;
    }
  }
  bool at_end() const { return p >= end; }
  bool at_line_end() const { return p >= end || *p == '\n' || *p == '\r'; }
  // Next token after skipping whitespace/comments; empty at the end of the input.
  std::string_view token(char comment = 0) {
    skip_space(comment);
    const char* b = p;
    while (p < end && !is_space(*p) && !(comment != 0 && *p == comment)) ++p;
    return std::string_view(b, static_cast<size_t>(p - b));
  }
  // Token on the current line only (empty when the line has no more tokens).
  std::string_view line_token() {
    skip_blanks();
    const char* b = p;
    while (p < end && !is_space(*p)) ++p;
    return std::string_view(b, static_cast<size_t>(p - b));
  }
};

// Parses a whole token as a number ("+" prefix, nan and inf accepted). False on anything else,
// including values outside the double range.
inline bool parse_double(std::string_view tok, double& out) {
  if (!tok.empty() && tok.front() == '+') tok.remove_prefix(1);
  if (tok.empty()) return false;
  const char* b = tok.data();
  const char* e = b + tok.size();
  auto [ptr, ec] = std::from_chars(b, e, out);
  return ec == std::errc() && ptr == e;
}

inline bool parse_int64(std::string_view tok, int64_t& out) {
  if (!tok.empty() && tok.front() == '+') tok.remove_prefix(1);
  if (tok.empty()) return false;
  const char* b = tok.data();
  const char* e = b + tok.size();
  auto [ptr, ec] = std::from_chars(b, e, out);
  return ec == std::errc() && ptr == e;
}

// Short printable excerpt of a token for messages (lsnif::excerpt, at most 24 characters).
inline std::string excerpt(std::string_view tok) { return lsnif::excerpt(tok, 24); }

}  // namespace lsnif::mesh_io
