// gltf_access.cpp -- checked glTF access (gltf_access.h). The implementations of tinygltf and of
// the stb_image functions it needs live in this file only, once in any program.
#include <algorithm>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <type_traits>

// Third-party single-header libraries. The stb functions are static (no clash with another
// stb_image in the same program) and limited to the two image formats core glTF allows.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wconversion"
#pragma GCC diagnostic ignored "-Wsign-conversion"
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wpedantic"
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Wunused-variable"
#pragma GCC diagnostic ignored "-Wunused-but-set-variable"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wimplicit-fallthrough"
#pragma GCC diagnostic ignored "-Wtype-limits"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wdouble-promotion"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#define STB_IMAGE_STATIC
#define STBI_ONLY_PNG
#define STBI_ONLY_JPEG
#define STBI_MAX_DIMENSIONS (1 << 15)
#define STB_IMAGE_IMPLEMENTATION
#define TINYGLTF_IMPLEMENTATION
// gltf_access.h sets TINYGLTF_NO_STB_IMAGE_WRITE and includes tiny_gltf.h, which includes
// <stb_image.h> itself (found through the stb system include folder).
#include "lsnif/import/gltf_access.h"
#pragma GCC diagnostic pop

#include "lsnif/format/file_io.h"
#include "lsnif/import/json_text.h"
#include "lsnif/import/resolve_path.h"

namespace lsnif::gltf {
namespace {

constexpr size_t kMaxSparseOnlyCount = size_t(1) << 20;  // accessor without a bufferView

// Decodes PNG/JPEG bytes to RGBA8 into `image` (at most `max_pixels` pixels). A failure leaves
// the image empty and explains why in `why`.
bool decode_image(tinygltf::Image& image, const unsigned char* bytes, size_t size,
                  uint64_t max_pixels, std::string& why) {
  image.image.clear();
  if (size == 0 || size > size_t(std::numeric_limits<int>::max())) {
    why = "empty or oversized image data";
    return false;
  }
  int w = 0, h = 0, comp = 0;
  const int n = static_cast<int>(size);
  if (!stbi_info_from_memory(bytes, n, &w, &h, &comp)) {
    // stb reports a PNG too large for it as "unknown image type" (its JPEG reader has the last
    // word): the size from the PNG's own header says what is wrong.
    static const unsigned char kPngSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    if (size >= 24 && std::memcmp(bytes, kPngSignature, 8) == 0 && std::memcmp(bytes + 12, "IHDR", 4) == 0) {
      const auto be32 = [](const unsigned char* p) {
        return uint32_t(p[0]) << 24 | uint32_t(p[1]) << 16 | uint32_t(p[2]) << 8 | uint32_t(p[3]);
      };
      const uint32_t pw = be32(bytes + 16), ph = be32(bytes + 20);
      if (pw > STBI_MAX_DIMENSIONS || ph > STBI_MAX_DIMENSIONS) {
        why = format("a PNG of %ux%u pixels, more than the %d a side that can be decoded", pw, ph, STBI_MAX_DIMENSIONS);
        return false;
      }
    }
    why = std::string("not a decodable PNG/JPEG (") + stbi_failure_reason() + ")";
    return false;
  }
  if (w <= 0 || h <= 0 || uint64_t(w) * uint64_t(h) > max_pixels) {
    why = format("unsupported image size %dx%d", w, h);
    return false;
  }
  unsigned char* px = stbi_load_from_memory(bytes, n, &w, &h, &comp, 4);
  if (!px) {
    why = std::string("decoding failed (") + stbi_failure_reason() + ")";
    return false;
  }
  image.image.assign(px, px + size_t(w) * size_t(h) * 4);
  stbi_image_free(px);
  image.width = w;
  image.height = h;
  image.component = 4;
  image.bits = 8;
  image.pixel_type = TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE;
  return true;
}

// tinygltf image callback (data URIs, external files, GLB-embedded images); `user` points to the
// LoadOptions. Images stored in a bufferView are left for resolve_image(): tinygltf 2.7 hands
// them over without checking the view against its buffer. Undecodable images are not fatal: they
// stay empty and are reported when a material uses them.
bool load_image_callback(tinygltf::Image* image, const int index, std::string* /*err*/,
                         std::string* warn, int, int, const unsigned char* bytes, int size,
                         void* user) {
  if (image->bufferView >= 0) return true;
  const uint64_t max_pixels = static_cast<const LoadOptions*>(user)->max_pixels;
  std::string why;
  if (size < 0 || !decode_image(*image, bytes, size_t(size), max_pixels, why))
    if (warn) *warn += format("image %d: %s\n", index, why.c_str());
  return true;
}

// Checks the GLB container's header and chunk table against the data (tinygltf 2.7 reads the BIN
// chunk header without checking it lies inside the file). Returns the container length.
Status check_glb(std::string_view data, const char* file, uint32_t& length) {
  auto u32 = [&](size_t o) {
    uint32_t v;
    std::memcpy(&v, data.data() + o, 4);
    return v;
  };
  if (data.size() < 20 || std::memcmp(data.data(), "glTF", 4) != 0)
    return Status::error("%s: not a binary glTF file (bad magic or shorter than 20 bytes)", file);
  if (u32(4) != 2) return Status::error("%s: unsupported GLB version %u", file, u32(4));
  length = u32(8);
  if (length > data.size() || length < 20)
    return Status::error("%s: GLB length %u does not match the file size %zu", file, length,
                         data.size());
  const uint64_t json_end = 20ull + u32(12);
  if (u32(16) != 0x4E4F534Au || json_end > length)
    return Status::error("%s: bad GLB JSON chunk", file);
  if (json_end < length) {
    if (json_end + 8 > length) return Status::error("%s: truncated GLB chunk header", file);
    const uint64_t bin_end = json_end + 8 + u32(size_t(json_end));
    if (bin_end > length)
      return Status::error("%s: GLB chunk of %u bytes runs past the end of the file", file,
                           u32(size_t(json_end)));
  }
  return Status::ok();
}

size_t component_size(int ct) {
  switch (ct) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT: case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return 2;
    case TINYGLTF_COMPONENT_TYPE_INT: case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return 4;
    case TINYGLTF_COMPONENT_TYPE_DOUBLE: return 8;
    default: return 0;
  }
}

bool is_integer_type(int ct) {
  return ct != TINYGLTF_COMPONENT_TYPE_FLOAT && ct != TINYGLTF_COMPONENT_TYPE_DOUBLE;
}

// An integer component of type T at `p` as a double; normalized, unsigned values map to [0, 1]
// and signed ones to [-1, 1] (the most negative value clamped to -1).
template <typename T>
double read_integer(const unsigned char* p, bool normalized) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  if (!normalized) return v;
  constexpr double kMax = static_cast<double>(std::numeric_limits<T>::max());
  if constexpr (std::is_signed_v<T>) return std::max(v / kMax, -1.0);
  else return v / kMax;
}

// One component at `p` as a double; normalized integers map to [0, 1] or [-1, 1].
double read_component(const unsigned char* p, int ct, bool normalized) {
  switch (ct) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: return read_integer<int8_t>(p, normalized);
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return read_integer<uint8_t>(p, normalized);
    case TINYGLTF_COMPONENT_TYPE_SHORT: return read_integer<int16_t>(p, normalized);
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return read_integer<uint16_t>(p, normalized);
    case TINYGLTF_COMPONENT_TYPE_INT: return read_integer<int32_t>(p, normalized);
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: return read_integer<uint32_t>(p, normalized);
    case TINYGLTF_COMPONENT_TYPE_FLOAT: { float v; std::memcpy(&v, p, 4); return v; }
    case TINYGLTF_COMPONENT_TYPE_DOUBLE: { double v; std::memcpy(&v, p, 8); return v; }
    default: return 0.0;
  }
}

// What the file-system callbacks of one load know: the folder external files are resolved against,
// the reference policy, and the references it refused.
struct FsContext {
  std::string base_dir;
  bool allow_outside = false;
  std::vector<std::string> refused;
  std::map<std::string, std::string> resolved;  // tinygltf's joined path -> the file it names
};

// tinygltf's FileExists callback. tinygltf joins the folder and the (URL-decoded) URI and also
// tries the working folder ("./URI"); only the first is a file of the scene, so the URI is taken
// back from the joined path and checked against the reference policy, and nothing else exists.
bool file_exists_callback(const std::string& joined, void* user) {
  FsContext& ctx = *static_cast<FsContext*>(user);
  const std::string prefix = ctx.base_dir.back() == '/' ? ctx.base_dir : ctx.base_dir + "/";
  if (joined.compare(0, prefix.size(), prefix) != 0) return false;
  std::string resolved;
  Status s = resolve_reference(ctx.base_dir, joined.substr(prefix.size()), ctx.allow_outside, "external file",
                               resolved);
  if (!s) {
    if (std::find(ctx.refused.begin(), ctx.refused.end(), s.message()) == ctx.refused.end())
      ctx.refused.push_back(s.message());
    return false;
  }
  // Whatever exists is "found", so that reading it names what is wrong with it (a folder, a
  // device: read_whole_file) instead of tinygltf's "File not found".
  std::error_code ec;
  if (!std::filesystem::exists(resolved, ec)) return false;
  ctx.resolved[joined] = resolved;
  return true;
}

// The base64 payload of a data URI tinygltf decodes holds this many bytes: tinygltf's decoder
// stops at the first '=' or other byte outside the alphabet, and a last group of k characters
// gives k - 1 bytes.
uint64_t base64_payload_bytes(std::string_view uri) {
  const size_t comma = uri.find(";base64,");
  if (comma == std::string_view::npos) return 0;
  uint64_t chars = 0;
  for (size_t i = comma + 8; i < uri.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(uri[i]);
    if (!(std::isalnum(c) || c == '+' || c == '/')) break;
    ++chars;
  }
  return chars / 4 * 3 + (chars % 4 ? chars % 4 - 1 : 0);
}

// Why tinygltf refused a buffer's data URI, in the file's terms ("buffer 0: data URI holds 96 bytes,
// byteLength says 100"), or "" when no buffer's data URI is at fault. tinygltf says only "Failed to
// decode 'uri'" followed by the whole URI (megabytes of base64).
std::string data_uri_problem(std::string_view json_text) {
  const nlohmann::json doc = nlohmann::json::parse(json_text.begin(), json_text.end(), nullptr, false);
  if (!doc.is_object() || !doc.contains("buffers") || !doc["buffers"].is_array()) return "";
  const nlohmann::json& buffers = doc["buffers"];
  for (size_t i = 0; i < buffers.size(); ++i) {
    const nlohmann::json& b = buffers[i];
    if (!b.is_object() || !b.contains("uri") || !b["uri"].is_string()) continue;
    const std::string& uri = b["uri"].get_ref<const std::string&>();
    if (!tinygltf::IsDataURI(uri)) continue;
    const uint64_t holds = base64_payload_bytes(uri);
    if (holds == 0) return format("buffer %zu: data URI holds no base64 data", i);
    if (b.contains("byteLength") && b["byteLength"].is_number_unsigned() &&
        b["byteLength"].get<uint64_t>() != holds)
      return format("buffer %zu: data URI holds %llu bytes, byteLength says %llu", i, (unsigned long long)holds,
                    (unsigned long long)b["byteLength"].get<uint64_t>());
  }
  return "";
}

// The first integer of the document that tinygltf would narrow to an int, as "PATH is VALUE, ..."
// ("" when there is none). tinygltf reads every index and enum that way (an index 4294967296 would
// read as 0, 2^64-1 as -1: no index), so every integer literal must fit one, checked here as the
// 64-bit value the JSON gives, before any narrowing. Left alone: sizes (byteLength, byteOffset, count,
// byteStride: tinygltf reads them as size_t and view_range checks them), accessor bounds (min, max:
// doubles) and extras (the application's data, never read). `path` is the JSON pointer of `j`.
std::string narrowed_integer(const nlohmann::json& j, const std::string& path) {
  if (j.is_number_unsigned() && j.get<uint64_t>() > uint64_t(std::numeric_limits<int>::max()))
    return format("%s is %llu, beyond any glTF index or enum (at most %d)", path.c_str(),
                  (unsigned long long)j.get<uint64_t>(), std::numeric_limits<int>::max());
  if (j.is_number_integer() && !j.is_number_unsigned() && j.get<int64_t>() < std::numeric_limits<int>::min())
    return format("%s is %lld, beyond any glTF index or enum", path.c_str(), (long long)j.get<int64_t>());
  if (j.is_array()) {
    for (size_t i = 0; i < j.size(); ++i)
      if (std::string p = narrowed_integer(j[i], path + "/" + std::to_string(i)); !p.empty()) return p;
  } else if (j.is_object()) {
    for (const auto& [key, value] : j.items()) {
      if (key == "extras" || key == "byteLength" || key == "byteOffset" || key == "count" || key == "byteStride" ||
          key == "min" || key == "max")
        continue;
      if (std::string p = narrowed_integer(value, path + "/" + printable(key)); !p.empty()) return p;
    }
  }
  return "";
}

// Values tinygltf drops without a word, keeping its default: a property of the wrong JSON type (an
// alphaCutoff "0.9" would read as 0.5, an alphaMode 1 as OPAQUE), a texture's sampler that does not
// exist, a sampler's wrap or filter outside glTF's enums. Samplers are then not read (textures repeat
// and filter bilinearly: docs/scene-format.md), but a file that names a missing one or an unknown
// mode is invalid all the same. Returns the first as "PATH ..." ("" when there is none).
std::string dropped_value(const nlohmann::json& doc) {
  enum Kind { String, Number, Boolean, Integer };
  static const struct {
    const char* array;
    const char* key;
    Kind kind;
    std::initializer_list<int64_t> allowed;  // empty: any value of the kind
  } rules[] = {{"materials", "name", String, {}},
               {"materials", "alphaMode", String, {}},
               {"materials", "alphaCutoff", Number, {}},
               {"materials", "doubleSided", Boolean, {}},
               {"samplers", "magFilter", Integer, {9728, 9729}},
               {"samplers", "minFilter", Integer, {9728, 9729, 9984, 9985, 9986, 9987}},
               {"samplers", "wrapS", Integer, {33071, 33648, 10497}},
               {"samplers", "wrapT", Integer, {33071, 33648, 10497}},
               {"textures", "sampler", Integer, {}},
               {"textures", "source", Integer, {}},
               {"nodes", "name", String, {}},
               {"nodes", "mesh", Integer, {}},
               {"nodes", "camera", Integer, {}},
               {"meshes", "name", String, {}}};
  static const char* const kKindNames[] = {"a string", "a number", "true or false", "an integer"};
  if (!doc.is_object()) return "";
  for (const auto& rule : rules) {
    if (!doc.contains(rule.array) || !doc[rule.array].is_array()) continue;
    const nlohmann::json& items = doc[rule.array];
    for (size_t i = 0; i < items.size(); ++i) {
      if (!items[i].is_object() || !items[i].contains(rule.key)) continue;
      const nlohmann::json& v = items[i][rule.key];
      const std::string path = format("/%s/%zu/%s", rule.array, i, rule.key);
      const bool typed = rule.kind == String    ? v.is_string()
                         : rule.kind == Number  ? v.is_number()
                         : rule.kind == Boolean ? v.is_boolean()
                                                : v.is_number_integer();
      if (!typed) return format("%s must be %s, not %s", path.c_str(), kKindNames[rule.kind], excerpt(v.dump()).c_str());
      if (rule.allowed.size() &&
          std::find(rule.allowed.begin(), rule.allowed.end(), v.get<int64_t>()) == rule.allowed.end()) {
        std::string list;
        for (int64_t a : rule.allowed) list += (list.empty() ? "" : ", ") + std::to_string(a);
        return format("%s is %lld, none of glTF's values for it (%s)", path.c_str(), (long long)v.get<int64_t>(),
                      list.c_str());
      }
    }
  }
  // A texture's sampler must exist (tinygltf keeps the index; nothing reads it).
  const size_t samplers = doc.contains("samplers") && doc["samplers"].is_array() ? doc["samplers"].size() : 0;
  if (doc.contains("textures") && doc["textures"].is_array())
    for (size_t i = 0; i < doc["textures"].size(); ++i) {
      const nlohmann::json& t = doc["textures"][i];
      if (t.is_object() && t.contains("sampler") && (t["sampler"].get<int64_t>() < 0 ||
                                                      uint64_t(t["sampler"].get<int64_t>()) >= samplers))
        return format("/textures/%zu/sampler is %lld, but the file has %zu samplers", i,
                      (long long)t["sampler"].get<int64_t>(), samplers);
    }
  return "";
}

// tinygltf's ReadWholeFile callback: reads the file file_exists_callback resolved the joined path to
// (an absolute URI is not under the folder; "out/../in/a.bin" reads in/a.bin even before "out"
// exists). Nothing else is read.
bool read_file_callback(std::vector<unsigned char>* out, std::string* err, const std::string& joined, void* user) {
  const FsContext& ctx = *static_cast<const FsContext*>(user);
  const auto it = ctx.resolved.find(joined);
  if (it == ctx.resolved.end()) {
    if (err) *err += "not resolved: " + joined + "\n";
    return false;
  }
  return read_whole_file(out, err, it->second, nullptr);
}

}  // namespace

std::string trim_message(std::string s, size_t max_chars) {
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  for (char& c : s)
    if (c == '\n') c = ';';
  if (s.size() <= max_chars) return printable(s);
  const size_t tail = std::min<size_t>(max_chars / 4, 100);
  return elided(s, max_chars - tail, tail);
}

bool read_whole_file(std::vector<unsigned char>* out, std::string* err, const std::string& path,
                     void* /*user*/) {
  const Status s = read_file(path, *out, uint64_t(1) << 32);
  if (!s && err) *err += s.message() + "\n";
  return s.is_ok();
}

Status load_model(std::string_view data, bool binary, const std::string& name,
                  const std::string& base_dir, const LoadOptions& options, tinygltf::Model& model,
                  std::vector<std::string>& warnings) {
  const char* file = name.c_str();
  if (data.size() >= std::numeric_limits<uint32_t>::max())
    return Status::error("%s: file too large for glTF", file);
  uint32_t length = static_cast<uint32_t>(data.size());
  std::string_view json_text = data;
  if (binary) {
    Status s = check_glb(data, file, length);
    if (!s) return s;
    uint32_t json_length;
    std::memcpy(&json_length, data.data() + 12, 4);
    json_text = data.substr(20, json_length);
  }
  if (Status d = json::check_depth(json_text, name); !d) return d;
  // JSON that does not parse is left to tinygltf, whose message says where.
  if (const nlohmann::json doc = nlohmann::json::parse(json_text.begin(), json_text.end(), nullptr, false);
      !doc.is_discarded())
    for (const std::string& problem : {narrowed_integer(doc, ""), dropped_value(doc)})
      if (!problem.empty()) return Status::error("%s: invalid glTF: %s", file, problem.c_str());
  FsContext context;
  context.base_dir = base_dir.empty() ? std::string(".") : base_dir;
  context.allow_outside = options.allow_outside_refs;
  tinygltf::TinyGLTF loader;
  tinygltf::FsCallbacks fs{&file_exists_callback, &tinygltf::ExpandFilePath, &read_file_callback,
                           &tinygltf::WriteWholeFile, &context};
  loader.SetFsCallbacks(fs);
  loader.SetStoreOriginalJSONForExtrasAndExtensions(options.keep_extension_json);
  // tinygltf keeps the pointer only for the duration of the Load call below.
  loader.SetImageLoader(&load_image_callback, const_cast<LoadOptions*>(&options));
  std::string err, warn;
  const bool ok =
      binary ? loader.LoadBinaryFromMemory(&model, &err, &warn,
                                           reinterpret_cast<const unsigned char*>(data.data()), length,
                                           context.base_dir)
             : loader.LoadASCIIFromString(&model, &err, &warn, data.data(), length, context.base_dir);
  // A refused reference is an error even where tinygltf only warns (images).
  if (!context.refused.empty()) return Status::error("%s: %s", file, context.refused.front().c_str());
  if (!warn.empty()) warnings.push_back(name + ": " + trim_message(warn, options.max_message_chars));
  if (!ok) {
    if (const std::string problem = data_uri_problem(json_text); !problem.empty())
      return Status::error("%s: invalid glTF: %s", file, problem.c_str());
    // tinygltf rejects Draco primitives' bufferView-less accessors before we can name the cause.
    const bool draco = data.find("KHR_draco_mesh_compression") != std::string_view::npos;
    return Status::error("%s: invalid glTF: %s%s", file,
                         err.empty() ? "(no details)"
                                     : trim_message(err, options.max_message_chars).c_str(),
                         draco ? " (the file uses KHR_draco_mesh_compression, which is not supported)"
                               : "");
  }
  return Status::ok();
}

bool resolve_image(const tinygltf::Model& model, tinygltf::Image& image, uint64_t max_pixels,
                   std::string& why) {
  if (image.image.empty() && image.bufferView >= 0) {
    const unsigned char* bytes = nullptr;
    const bool view_ok = size_t(image.bufferView) < model.bufferViews.size();
    const size_t length = view_ok ? model.bufferViews[size_t(image.bufferView)].byteLength : 0;
    Status s = view_ok ? view_range(model, image.bufferView, 0, length, bytes)
                       : Status::error("bufferView %d does not exist", image.bufferView);
    if (!s) why = s.message();
    else decode_image(image, bytes, length, max_pixels, why);
  }
  const size_t expected = size_t(std::max(image.width, 0)) * size_t(std::max(image.height, 0)) * 4;
  return !image.image.empty() && image.component == 4 && image.bits == 8 &&
         image.image.size() == expected && expected != 0;
}

Status decode_image_file(const std::string& path, uint64_t max_pixels, tinygltf::Image& image) {
  std::vector<unsigned char> bytes;
  if (Status s = read_file(path, bytes, uint64_t(1) << 32); !s) return s;
  std::string why;
  if (!decode_image(image, bytes.data(), bytes.size(), max_pixels, why))
    return Status::error("%s: %s", path.c_str(), why.c_str());
  return Status::ok();
}

Status view_range(const tinygltf::Model& model, int view, size_t offset, uint64_t needed,
                  const unsigned char*& out) {
  if (view < 0 || size_t(view) >= model.bufferViews.size())
    return Status::error("bufferView %d does not exist", view);
  const tinygltf::BufferView& bv = model.bufferViews[size_t(view)];
  if (bv.buffer < 0 || size_t(bv.buffer) >= model.buffers.size())
    return Status::error("bufferView %d references missing buffer %d", view, bv.buffer);
  const std::vector<unsigned char>& data = model.buffers[size_t(bv.buffer)].data;
  if (bv.byteOffset > data.size() || bv.byteLength > data.size() - bv.byteOffset)
    return Status::error("bufferView %d (offset %zu, length %zu) exceeds buffer %d of %zu bytes",
                         view, bv.byteOffset, bv.byteLength, bv.buffer, data.size());
  if (offset > bv.byteLength || needed > bv.byteLength - offset)
    return Status::error("%llu bytes at offset %zu exceed bufferView %d of %zu bytes",
                         static_cast<unsigned long long>(needed), offset, view, bv.byteLength);
  out = data.data() + bv.byteOffset + offset;
  return Status::ok();
}

int components_of(int type) {
  switch (type) {
    case TINYGLTF_TYPE_SCALAR: return 1;
    case TINYGLTF_TYPE_VEC2: return 2;
    case TINYGLTF_TYPE_VEC3: return 3;
    case TINYGLTF_TYPE_VEC4: return 4;
    default: return 0;  // matrices: no attribute read here uses them
  }
}

int find_attribute(const tinygltf::Primitive& prim, const std::string& key) {
  auto it = prim.attributes.find(key);
  return it == prim.attributes.end() ? -1 : it->second;
}

bool is_triangle_mode(int mode) {
  return mode < 0 || mode == TINYGLTF_MODE_TRIANGLES || mode == TINYGLTF_MODE_TRIANGLE_STRIP ||
         mode == TINYGLTF_MODE_TRIANGLE_FAN;
}

std::vector<uint32_t> triangle_list(int mode, const std::vector<uint32_t>& idx) {
  std::vector<uint32_t> out;
  if (mode < 0 || mode == TINYGLTF_MODE_TRIANGLES) {
    out.assign(idx.begin(), idx.begin() + std::ptrdiff_t(idx.size() - idx.size() % 3));
  } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
    for (size_t i = 0; i + 2 < idx.size(); ++i)
      out.insert(out.end(), {idx[i], idx[i % 2 == 0 ? i + 1 : i + 2], idx[i % 2 == 0 ? i + 2 : i + 1]});
  } else if (mode == TINYGLTF_MODE_TRIANGLE_FAN) {
    for (size_t i = 0; i + 2 < idx.size(); ++i) out.insert(out.end(), {idx[i + 1], idx[i + 2], idx[0]});
  }
  return out;
}

PrimitiveSize primitive_size(const tinygltf::Model& model, const tinygltf::Primitive& prim) {
  PrimitiveSize out;
  if (!is_triangle_mode(prim.mode)) return out;
  const auto count = [&](int accessor) -> uint64_t {
    return accessor >= 0 && size_t(accessor) < model.accessors.size() ? model.accessors[size_t(accessor)].count : 0;
  };
  out.vertices = count(find_attribute(prim, "POSITION"));
  const uint64_t indices = prim.indices >= 0 ? count(prim.indices) : out.vertices;
  if (prim.mode < 0 || prim.mode == TINYGLTF_MODE_TRIANGLES) out.triangles = indices / 3;
  else out.triangles = indices >= 3 ? indices - 2 : 0;  // a strip or a fan
  return out;
}

const char* mode_name(int mode) {
  switch (mode) {
    case TINYGLTF_MODE_POINTS: return "POINTS";
    case TINYGLTF_MODE_LINE: return "LINES";
    case TINYGLTF_MODE_LINE_LOOP: return "LINE_LOOP";
    case TINYGLTF_MODE_LINE_STRIP: return "LINE_STRIP";
    case TINYGLTF_MODE_TRIANGLES: return "TRIANGLES";
    case TINYGLTF_MODE_TRIANGLE_STRIP: return "TRIANGLE_STRIP";
    case TINYGLTF_MODE_TRIANGLE_FAN: return "TRIANGLE_FAN";
    default: return "unknown";
  }
}

std::vector<int> parentless_nodes(const tinygltf::Model& model) {
  std::vector<uint8_t> has_parent(model.nodes.size(), 0);
  for (const tinygltf::Node& n : model.nodes)
    for (int c : n.children)
      if (c >= 0 && size_t(c) < has_parent.size()) has_parent[size_t(c)] = 1;
  std::vector<int> roots;
  for (size_t i = 0; i < model.nodes.size(); ++i)
    if (!has_parent[i]) roots.push_back(int(i));
  return roots;
}

Status AccessorReader::read(int index, std::initializer_list<int> types, bool normalize_ints,
                            std::vector<double>& out, int& components) const {
  if (index < 0 || size_t(index) >= model.accessors.size())
    return Status::error("accessor %d does not exist", index);
  const tinygltf::Accessor& a = model.accessors[size_t(index)];
  components = components_of(a.type);
  if (components == 0 || std::find(types.begin(), types.end(), a.type) == types.end())
    return Status::error("accessor %d has unexpected type %d", index, a.type);
  const size_t csize = component_size(a.componentType);
  if (csize == 0)
    return Status::error("accessor %d has unknown component type %d", index, a.componentType);
  const bool normalized = is_integer_type(a.componentType) && (a.normalized || normalize_ints);
  const size_t elem = csize * size_t(components);
  const size_t count = a.count;
  const size_t nc = size_t(components);
  // Also guards the range computation below against overflow (stride <= 4096).
  if (count > max_count) return Status::error("accessor %d: count %zu too large", index, count);

  if (a.bufferView >= 0) {
    if (size_t(a.bufferView) >= model.bufferViews.size())
      return Status::error("accessor %d: bufferView %d does not exist", index, a.bufferView);
    const tinygltf::BufferView& bv = model.bufferViews[size_t(a.bufferView)];
    const size_t stride = bv.byteStride ? bv.byteStride : elem;
    if (stride < elem || stride > 4096)
      return Status::error("accessor %d: byteStride %zu invalid for %zu-byte elements", index,
                           bv.byteStride, elem);
    const unsigned char* base = nullptr;
    if (count > 0) {
      Status s = view_range(model, a.bufferView, a.byteOffset,
                            uint64_t(stride) * (count - 1) + elem, base);
      if (!s) return s.context(format("accessor %d", index));
    }
    out.resize(count * nc);
    for (size_t i = 0; i < count; ++i)
      for (size_t c = 0; c < nc; ++c)
        out[i * nc + c] = read_component(base + i * stride + c * csize, a.componentType, normalized);
  } else {
    if (!a.sparse.isSparse)
      return Status::error("accessor %d has neither a bufferView nor sparse data", index);
    if (count > kMaxSparseOnlyCount)
      return Status::error("accessor %d: sparse accessor without bufferView has %zu elements "
                           "(at most %zu supported)", index, count, kMaxSparseOnlyCount);
    out.assign(count * nc, 0.0);
  }

  if (a.sparse.isSparse) {
    const auto& sp = a.sparse;
    const size_t isize = component_size(sp.indices.componentType);
    if (sp.count <= 0 || size_t(sp.count) > count || sp.indices.byteOffset < 0 ||
        sp.values.byteOffset < 0 || isize == 0 || isize == 8 ||
        !is_integer_type(sp.indices.componentType))
      return Status::error("accessor %d: invalid sparse description", index);
    const size_t n = size_t(sp.count);
    const unsigned char* idx = nullptr;
    const unsigned char* val = nullptr;
    Status s = view_range(model, sp.indices.bufferView, size_t(sp.indices.byteOffset),
                          uint64_t(n) * isize, idx);
    if (!s) return s.context(format("accessor %d sparse indices", index));
    s = view_range(model, sp.values.bufferView, size_t(sp.values.byteOffset), uint64_t(n) * elem, val);
    if (!s) return s.context(format("accessor %d sparse values", index));
    for (size_t k = 0; k < n; ++k) {
      const double target = read_component(idx + k * isize, sp.indices.componentType, false);
      if (!(target >= 0.0) || target >= double(count))
        return Status::error("accessor %d: sparse index %.0f out of range (count %zu)", index, target,
                             count);
      const size_t t = size_t(target);
      for (size_t c = 0; c < nc; ++c)
        out[t * nc + c] = read_component(val + k * elem + c * csize, a.componentType, normalized);
    }
  }
  return Status::ok();
}

Status AccessorReader::read_attribute(int index, const std::string& key,
                                      std::initializer_list<int> types, bool normalize_ints,
                                      size_t vertex_count, const std::string& where,
                                      std::vector<double>& out, int& components) const {
  Status s = read(index, types, normalize_ints, out, components);
  if (!s) return s.context(where + ": " + key);
  const size_t n = out.size() / size_t(components);
  if (n != vertex_count)
    return Status::error("%s: %s has %zu elements, POSITION %zu", where.c_str(), key.c_str(), n,
                         vertex_count);
  return Status::ok();
}

Status AccessorReader::read_positions(const tinygltf::Primitive& prim, const std::string& where,
                                      std::vector<double>& out) const {
  const int index = find_attribute(prim, "POSITION");
  if (index < 0) return Status::error("%s: no POSITION attribute", where.c_str());
  int components = 0;
  Status s = read(index, {TINYGLTF_TYPE_VEC3}, false, out, components);
  if (!s) return s.context(where + ": POSITION");
  return Status::ok();
}

Status AccessorReader::read_indices(int index, size_t vertex_count, bool reject_normalized,
                                    const std::string& where, std::vector<uint32_t>& out) const {
  std::vector<double> raw;
  int nc = 0;
  Status s = read(index, {TINYGLTF_TYPE_SCALAR}, false, raw, nc);
  if (!s) return s.context(where + ": indices");
  const tinygltf::Accessor& a = model.accessors[size_t(index)];
  const int ct = a.componentType;
  if (ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE && ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
      ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
    return Status::error("%s: indices must be unsigned integers (component type %d)", where.c_str(),
                         ct);
  if (reject_normalized && a.normalized)
    return Status::error("%s: indices must not be normalized", where.c_str());
  out.resize(raw.size());
  for (size_t i = 0; i < raw.size(); ++i) {
    if (!(raw[i] < double(vertex_count)))
      return Status::error("%s: index %.0f at position %zu out of range (%zu vertices)",
                           where.c_str(), raw[i], i, vertex_count);
    out[i] = static_cast<uint32_t>(raw[i]);
  }
  return Status::ok();
}

}  // namespace lsnif::gltf
