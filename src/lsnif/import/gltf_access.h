// gltf_access.h -- checked access to glTF 2.0 files through tinygltf, shared by the training mesh
// importer (src/lsnif/import/mesh_gltf.cpp, which flattens a file into one triangle soup) and the renderer's
// scene loader (src/lsnif/scene/scene_gltf.cpp, which keeps the node hierarchy). Library
// `lsnif_import`: no Vulkan, no training code; gltf_access.cpp is the only translation unit of the
// project with TINYGLTF_IMPLEMENTATION and the stb_image implementation tinygltf needs.
//
// tinygltf 2.7 leaves most validation to the user: it reads a GLB's BIN chunk header without
// checking that it lies inside the file, and hands over bufferViews and accessors unchecked. Every
// function here checks indices and byte ranges before it reads a byte, so malformed files yield an
// error or a warning, never an out-of-bounds read.
#pragma once
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <string>
#include <string_view>
#include <vector>

// Image writing is never used; the macro changes tinygltf's class definitions, so it is set here,
// before the only inclusion of tiny_gltf.h that every user of this header (and gltf_access.cpp)
// shares.
#ifndef TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#endif
#include <tiny_gltf.h>

#include "lsnif/format/status.h"

namespace lsnif::gltf {

// Limits and message style of one loader.
struct LoadOptions {
  // Images larger than this many pixels are not decoded (they stay empty, with a warning).
  uint64_t max_pixels = uint64_t(1) << 27;
  // tinygltf's error and warning text (which quotes the file: a data URI of megabytes) is made
  // printable and shortened to about this many characters (elided in the middle, status.h);
  // std::string::npos: never shortened.
  size_t max_message_chars = 600;
  // External buffers and images may lie outside `base_dir` (resolve_path.h); default: an error.
  bool allow_outside_refs = false;
  // Keep each object's "extensions" JSON text (tinygltf's extensions_json_string), so that the
  // caller can see extension values tinygltf drops (it keeps only those that are JSON objects).
  bool keep_extension_json = false;
};

// tinygltf's multi-line message text on one line: trailing newlines and spaces dropped, inner
// newlines turned into ';', then printable() (status.h), or elided() to its first and last
// characters when longer than `max_chars`.
std::string trim_message(std::string s, size_t max_chars = std::string::npos);

// Reads a whole regular file (no devices or FIFOs, at most 4 GiB) into `out` with read_file
// (lsnif/format/file_io.h). On failure returns false, leaves `out` as it was and appends a one-line
// reason naming `path` to `err` (when not null). Has the signature of tinygltf's ReadWholeFile
// callback (`user` is ignored); load_model's callback reads through it the files the reference
// policy resolved.
bool read_whole_file(std::vector<unsigned char>* out, std::string* err, const std::string& path,
                     void* user);

// Parses glTF from memory into `model`: `binary` selects a .glb container (whose header and chunk
// table are checked first), else .gltf JSON; the JSON's nesting depth is bounded first
// (json_text.h). `name` names the input in messages; external buffers and images are resolved
// against `base_dir` ("" = the working folder) under the reference policy of resolve_path.h (an
// error when one leaves the folder, unless options.allow_outside_refs; never looked up in the
// working folder instead) and must be regular files. PNG/JPEG images given by
// URI or GLB are decoded to RGBA8 (an undecodable one stays empty and adds a warning); images
// stored in a bufferView are left empty for decode_image_in_view(). tinygltf's warnings are
// appended to `warnings` as one line "NAME: ...". Errors: "NAME: not a binary glTF file ...",
// "NAME: invalid glTF: DETAILS" (mentioning KHR_draco_mesh_compression when the file uses it), ...
Status load_model(std::string_view data, bool binary, const std::string& name,
                  const std::string& base_dir, const LoadOptions& options, tinygltf::Model& model,
                  std::vector<std::string>& warnings);

// Pixels of `image`, a copy of one of the model's images, ready to use: an image stored in a
// bufferView (left undecoded by load_model) has its view range-checked and is decoded here to
// RGBA8 with at most `max_pixels` pixels. Returns true when `image` then holds width x height RGBA8
// pixels; false otherwise, with `why` set to the reason when a decode was attempted (left as the
// caller set it when the image simply has no data).
bool resolve_image(const tinygltf::Model& model, tinygltf::Image& image, uint64_t max_pixels,
                   std::string& why);

// Reads the PNG or JPEG file `path` (read_file, lsnif/format/file_io.h) and decodes it to RGBA8 with the decoder
// load_model uses for glTF images (palette and grey images expanded, a missing alpha set to 255):
// `image` then holds width x height x 4 bytes, top row first. Errors name the file: unreadable,
// not a decodable PNG/JPEG, more than `max_pixels` pixels.
Status decode_image_file(const std::string& path, uint64_t max_pixels, tinygltf::Image& image);

// Bytes [offset, offset + needed) of bufferView `view` in `out`, after checking that the view
// exists, its buffer exists, the view lies inside the buffer and the range inside the view;
// otherwise an error naming what was out of range.
Status view_range(const tinygltf::Model& model, int view, size_t offset, uint64_t needed,
                  const unsigned char*& out);

// Number of components of an accessor type: 1..4 for SCALAR and VEC2..VEC4, 0 for matrices and
// unknown types.
int components_of(int type);

// Accessor index of attribute `key` of a primitive, -1 when it has none.
int find_attribute(const tinygltf::Primitive& prim, const std::string& key);

// Name of a primitive mode for messages ("POINTS", "LINES", ..., "unknown").
const char* mode_name(int mode);

// True for the modes that draw triangles: TRIANGLES, TRIANGLE_STRIP, TRIANGLE_FAN (-1, absent,
// means TRIANGLES).
bool is_triangle_mode(int mode);

// The triangles a primitive of triangle mode `mode` draws from `indices`, as a list of index
// triples, the glTF specification's rules: TRIANGLES takes consecutive triples (a remainder is
// ignored), TRIANGLE_STRIP triangle i is (i, i+1, i+2) with every odd one reversed to (i, i+2, i+1)
// so all keep the first one's winding, TRIANGLE_FAN triangle i is (0, i+1, i+2) (written as
// (i+1, i+2, 0), the same winding). The one expansion of the renderer and the converter.
std::vector<uint32_t> triangle_list(int mode, const std::vector<uint32_t>& indices);

// What a triangle primitive will be read as, from its accessors' counts alone (no data read): its
// vertices (POSITION's count) and the triangles triangle_list makes of its indices (the index
// accessor's count, else one per vertex). Zero for a primitive of another mode; an accessor index
// out of range counts 0 (reading it is the error).
struct PrimitiveSize {
  uint64_t vertices = 0, triangles = 0;
};
PrimitiveSize primitive_size(const tinygltf::Model& model, const tinygltf::Primitive& prim);

// Nodes that are no node's child (the roots when a file has no scenes), in index order.
std::vector<int> parentless_nodes(const tinygltf::Model& model);

// Reads accessors of `model` as doubles, checking every byte range first. Accessors with more than
// `max_count` elements are rejected ("accessor N: count C too large"); sparse accessors without a
// bufferView are limited to 2^20 elements.
struct AccessorReader {
  const tinygltf::Model& model;
  size_t max_count;

  // Accessor `index` into `out` (count x components doubles, row-major; `components` is set from
  // its type). `types` lists the accepted accessor types. Integer components are mapped to [0, 1]
  // or [-1, 1] when the accessor is normalized or `normalize_ints` is set (colors). Sparse
  // accessors are applied on top of their base data (or of zeros without a bufferView).
  Status read(int index, std::initializer_list<int> types, bool normalize_ints,
              std::vector<double>& out, int& components) const;

  // Vertex attribute `key` (accessor `index`) of a primitive with `vertex_count` vertices, as
  // read(); errors are prefixed "WHERE: KEY", and an element count other than `vertex_count` is
  // the error "WHERE: KEY has N elements, POSITION M".
  Status read_attribute(int index, const std::string& key, std::initializer_list<int> types,
                        bool normalize_ints, size_t vertex_count, const std::string& where,
                        std::vector<double>& out, int& components) const;

  // The POSITION attribute (VEC3) of `prim` into `out`, 3 doubles per vertex. Errors: "WHERE: no
  // POSITION attribute", or read()'s prefixed "WHERE: POSITION".
  Status read_positions(const tinygltf::Primitive& prim, const std::string& where,
                        std::vector<double>& out) const;

  // Index accessor `index` of a primitive with `vertex_count` vertices into `out`: the accessor
  // must be SCALAR of an unsigned integer type (and not normalized when `reject_normalized`), and
  // every index must be < `vertex_count`. Errors are prefixed "WHERE".
  Status read_indices(int index, size_t vertex_count, bool reject_normalized,
                      const std::string& where, std::vector<uint32_t>& out) const;
};

}  // namespace lsnif::gltf
