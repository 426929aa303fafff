// mesh_gltf.cpp -- glTF 2.0 (.gltf / .glb) reader on top of tinygltf. The default scene's node
// hierarchy is flattened into one object-space triangle soup: node transforms (matrix or TRS) are
// applied to positions, their inverse transpose to normals, and the winding flips under mirroring
// transforms. TRIANGLES, TRIANGLE_STRIP and TRIANGLE_FAN primitives are kept (others are skipped
// with a warning); every accessor is bounds-checked here before a byte is read, since tinygltf
// leaves that to the user.
#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>

#include <glm/gtc/matrix_inverse.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>

#include "mesh_formats.h"

// Third-party single-header libraries: their implementations live in this file only. The stb
// functions are static (no clash with another stb_image in the same program) and limited to the
// two image formats core glTF allows.
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
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_IMPLEMENTATION
// tinygltf includes <stb_image.h> itself (found through the stb system include folder).
#include <tiny_gltf.h>
#pragma GCC diagnostic pop

namespace lsnif::mesh_io {
namespace {

constexpr uint64_t kMaxPixels = uint64_t(1) << 27;       // per texture
constexpr size_t kMaxSparseOnlyCount = size_t(1) << 20;  // accessor without a bufferView
constexpr int kMaxNodeDepth = 256;
constexpr size_t kMaxNodeVisits = size_t(1) << 20;

// Decodes PNG/JPEG bytes to RGBA8 into `image`. A failure leaves the image empty and explains
// why in `why`.
bool decode_image(tinygltf::Image& image, const unsigned char* bytes, size_t size, std::string& why) {
  image.image.clear();
  if (size == 0 || size > size_t(std::numeric_limits<int>::max())) {
    why = "empty or oversized image data";
    return false;
  }
  int w = 0, h = 0, comp = 0;
  const int n = static_cast<int>(size);
  if (!stbi_info_from_memory(bytes, n, &w, &h, &comp)) {
    why = std::string("not a decodable PNG/JPEG (") + stbi_failure_reason() + ")";
    return false;
  }
  if (w <= 0 || h <= 0 || uint64_t(w) * uint64_t(h) > kMaxPixels) {
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

// tinygltf image callback. Images stored in a bufferView are left for make_texture(): tinygltf
// hands those over without checking the view against its buffer. Undecodable images are not
// fatal (the geometry is still good): they stay empty and are reported when a material uses them.
bool load_image_callback(tinygltf::Image* image, const int index, std::string* /*err*/,
                         std::string* warn, int, int, const unsigned char* bytes, int size,
                         void* /*user*/) {
  if (image->bufferView >= 0) return true;
  std::string why;
  if (size < 0 || !decode_image(*image, bytes, size_t(size), why))
    if (warn) *warn += format("image %d: %s\n", index, why.c_str());
  return true;
}

// File reads for external buffers and images: regular files only (no devices or FIFOs).
bool read_whole_file(std::vector<unsigned char>* out, std::string* err, const std::string& path,
                     void*) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    if (err) *err += "not a regular file: " + path + "\n";
    return false;
  }
  uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec || size > (uintmax_t(1) << 32)) {
    if (err) *err += "cannot size or too large: " + path + "\n";
    return false;
  }
  std::ifstream in(path, std::ios::binary);
  out->resize(static_cast<size_t>(size));
  in.read(reinterpret_cast<char*>(out->data()), static_cast<std::streamsize>(size));
  if (!in || static_cast<uintmax_t>(in.gcount()) != size) {
    if (err) *err += "read error: " + path + "\n";
    return false;
  }
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

int components_of(int type) {
  switch (type) {
    case TINYGLTF_TYPE_SCALAR: return 1;
    case TINYGLTF_TYPE_VEC2: return 2;
    case TINYGLTF_TYPE_VEC3: return 3;
    case TINYGLTF_TYPE_VEC4: return 4;
    default: return 0;  // matrices: no vertex attribute we read uses them
  }
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

// One component at `p` as a double; normalized integers map to [0, 1] or [-1, 1].
double read_component(const unsigned char* p, int ct, bool normalized) {
  switch (ct) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: {
      int8_t v; std::memcpy(&v, p, 1);
      return normalized ? std::max(v / 127.0, -1.0) : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return normalized ? p[0] / 255.0 : p[0];
    case TINYGLTF_COMPONENT_TYPE_SHORT: {
      int16_t v; std::memcpy(&v, p, 2);
      return normalized ? std::max(v / 32767.0, -1.0) : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
      uint16_t v; std::memcpy(&v, p, 2);
      return normalized ? v / 65535.0 : v;
    }
    case TINYGLTF_COMPONENT_TYPE_INT: {
      int32_t v; std::memcpy(&v, p, 4);
      return normalized ? std::max(v / 2147483647.0, -1.0) : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
      uint32_t v; std::memcpy(&v, p, 4);
      return normalized ? v / 4294967295.0 : v;
    }
    case TINYGLTF_COMPONENT_TYPE_FLOAT: { float v; std::memcpy(&v, p, 4); return v; }
    case TINYGLTF_COMPONENT_TYPE_DOUBLE: { double v; std::memcpy(&v, p, 8); return v; }
    default: return 0.0;
  }
}

// Bytes [offset, offset + needed) of bufferView `view`, or an error.
Status view_range(const tinygltf::Model& model, int view, size_t offset, uint64_t needed,
                  const unsigned char*& out, uint64_t* view_length = nullptr) {
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
  if (view_length) *view_length = bv.byteLength;
  return Status::ok();
}

// Reads accessor `index` into `out` (count x components doubles, row-major). `types` lists the
// accepted accessor types; integer components are normalized when the accessor says so or
// `normalize_ints` is set (colors). Sparse accessors are applied on top of their base data.
Status read_accessor(const tinygltf::Model& model, int index, std::initializer_list<int> types,
                     bool normalize_ints, std::vector<double>& out, int& components) {
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

  if (a.bufferView >= 0) {
    if (size_t(a.bufferView) >= model.bufferViews.size())
      return Status::error("accessor %d: bufferView %d does not exist", index, a.bufferView);
    const tinygltf::BufferView& bv = model.bufferViews[size_t(a.bufferView)];
    const size_t stride = bv.byteStride ? bv.byteStride : elem;
    if (stride < elem || stride > 4096)
      return Status::error("accessor %d: byteStride %zu invalid for %zu-byte elements", index,
                           bv.byteStride, elem);
    // count <= data size guards the multiplication below against overflow.
    const unsigned char* base = nullptr;
    Status s = count == 0 ? Status::ok()
               : count > (uint64_t(1) << 40)
                   ? Status::error("count %zu too large", count)
                   : view_range(model, a.bufferView, a.byteOffset,
                                uint64_t(stride) * (count - 1) + elem, base);
    if (!s) return s.context(format("accessor %d", index));
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
      double target = read_component(idx + k * isize, sp.indices.componentType, false);
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

glm::dmat4 local_transform(const tinygltf::Node& node) {
  if (node.matrix.size() == 16) return glm::make_mat4(node.matrix.data());  // column-major
  glm::dmat4 m(1.0);
  if (node.translation.size() == 3)
    m = glm::translate(m, glm::dvec3(node.translation[0], node.translation[1], node.translation[2]));
  if (node.rotation.size() == 4)  // glTF stores (x, y, z, w)
    m *= glm::mat4_cast(glm::dquat(node.rotation[3], node.rotation[0], node.rotation[1],
                                   node.rotation[2]));
  if (node.scale.size() == 3)
    m = glm::scale(m, glm::dvec3(node.scale[0], node.scale[1], node.scale[2]));
  return m;
}

const char* mode_name(int mode) {
  switch (mode) {
    case TINYGLTF_MODE_POINTS: return "POINTS";
    case TINYGLTF_MODE_LINE: return "LINES";
    case TINYGLTF_MODE_LINE_LOOP: return "LINE_LOOP";
    case TINYGLTF_MODE_LINE_STRIP: return "LINE_STRIP";
    default: return "unknown";
  }
}

class GltfFlattener {
 public:
  GltfFlattener(const tinygltf::Model& model, const std::string& name, Mesh& mesh,
                MeshImportReport& report)
      : model_(model), name_(name), mesh_(mesh), report_(report),
        material_map_(model.materials.size(), -1), texture_map_(model.images.size(), -2),
        warned_mesh_(model.meshes.size(), 0) {}

  Status run() {
    std::vector<int> roots;
    if (!model_.scenes.empty()) {
      int s = model_.defaultScene >= 0 && size_t(model_.defaultScene) < model_.scenes.size()
                  ? model_.defaultScene : 0;
      roots = model_.scenes[size_t(s)].nodes;
    } else if (!model_.nodes.empty()) {
      std::vector<uint8_t> has_parent(model_.nodes.size(), 0);
      for (const tinygltf::Node& n : model_.nodes)
        for (int c : n.children)
          if (c >= 0 && size_t(c) < has_parent.size()) has_parent[size_t(c)] = 1;
      for (size_t i = 0; i < model_.nodes.size(); ++i)
        if (!has_parent[i]) roots.push_back(int(i));
      if (roots.empty())
        return Status::error("%s: no scene and no root node (every node has a parent)", file());
    } else {
      report_.warnings.push_back(format("%s: no scene and no nodes; importing every mesh untransformed",
                                        file()));
      for (size_t m = 0; m < model_.meshes.size(); ++m) {
        Status s = add_mesh(int(m), glm::dmat4(1.0));
        if (!s) return s;
      }
    }
    on_path_.assign(model_.nodes.size(), 0);
    for (int r : roots) {
      Status s = visit(r, glm::dmat4(1.0), 0);
      if (!s) return s;
    }
    if (skipped_primitives_)
      report_.warnings.push_back(format("%s: skipped %u non-triangle primitives (points/lines)",
                                        file(), skipped_primitives_));
    if (mesh_.triangles.empty())
      return Status::error("%s: the scene contains no triangle primitives%s", file(),
                           skipped_primitives_ ? " (only points/lines)" : "");
    return Status::ok();
  }

 private:
  const char* file() const { return name_.c_str(); }

  Status visit(int index, const glm::dmat4& parent, int depth) {
    if (index < 0 || size_t(index) >= model_.nodes.size())
      return Status::error("%s: node %d does not exist", file(), index);
    if (on_path_[size_t(index)])
      return Status::error("%s: node %d is its own ancestor (cyclic node hierarchy)", file(), index);
    if (depth > kMaxNodeDepth || ++visits_ > kMaxNodeVisits)
      return Status::error("%s: node hierarchy too deep or too many node instances", file());
    const tinygltf::Node& node = model_.nodes[size_t(index)];
    const glm::dmat4 world = parent * local_transform(node);
    if (node.mesh >= 0) {
      if (size_t(node.mesh) >= model_.meshes.size())
        return Status::error("%s: node %d references missing mesh %d", file(), index, node.mesh);
      Status s = add_mesh(node.mesh, world);
      if (!s) return s;
    }
    on_path_[size_t(index)] = 1;
    for (int c : node.children) {
      Status s = visit(c, world, depth + 1);
      if (!s) return s;
    }
    on_path_[size_t(index)] = 0;
    return Status::ok();
  }

  Status add_mesh(int mesh_index, const glm::dmat4& world) {
    const tinygltf::Mesh& m = model_.meshes[size_t(mesh_index)];
    for (size_t p = 0; p < m.primitives.size(); ++p) {
      const std::string where = format("%s: mesh %d ('%s') primitive %zu", file(), mesh_index,
                                       excerpt(m.name).c_str(), p);
      Status s = add_primitive(m.primitives[p], world, where, mesh_index);
      if (!s) return s;
    }
    warned_mesh_[size_t(mesh_index)] = 1;
    return Status::ok();
  }

  int attribute(const tinygltf::Primitive& prim, const std::string& key) const {
    auto it = prim.attributes.find(key);
    return it == prim.attributes.end() ? -1 : it->second;
  }

  Status add_primitive(const tinygltf::Primitive& prim, const glm::dmat4& world,
                       const std::string& where, int mesh_index) {
    const bool first_time = !warned_mesh_[size_t(mesh_index)];
    const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
    if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
        mode != TINYGLTF_MODE_TRIANGLE_FAN) {
      if (first_time) {
        ++skipped_primitives_;
        report_.warnings.push_back(format("%s: mode %d (%s) is not triangles; skipped", where.c_str(),
                                          mode, mode_name(mode)));
      }
      return Status::ok();
    }
    if (prim.extensions.count("KHR_draco_mesh_compression"))
      return Status::error("%s: Draco-compressed primitives are not supported", where.c_str());

    // Attributes.
    std::vector<double> pos, nrm, uv, col;
    int nc = 0;
    const int pos_acc = attribute(prim, "POSITION");
    if (pos_acc < 0) return Status::error("%s: no POSITION attribute", where.c_str());
    Status s = read_accessor(model_, pos_acc, {TINYGLTF_TYPE_VEC3}, false, pos, nc);
    if (!s) return s.context(where + ": POSITION");
    const size_t n = pos.size() / 3;
    if (mesh_.positions.size() + n >= kInvalidIndex)
      return Status::error("%s: too many vertices in the flattened scene", where.c_str());

    if (int acc = attribute(prim, "NORMAL"); acc >= 0) {
      s = read_accessor(model_, acc, {TINYGLTF_TYPE_VEC3}, false, nrm, nc);
      if (!s) return s.context(where + ": NORMAL");
      if (nrm.size() != pos.size())
        return Status::error("%s: NORMAL has %zu elements, POSITION %zu", where.c_str(),
                             nrm.size() / 3, n);
    }
    const int material = material_index(prim.material, where);
    const int texcoord = texcoord_set(prim.material);
    const std::string uv_key = "TEXCOORD_" + std::to_string(texcoord);
    if (int acc = attribute(prim, uv_key); acc >= 0) {
      s = read_accessor(model_, acc, {TINYGLTF_TYPE_VEC2}, false, uv, nc);
      if (!s) return s.context(where + ": " + uv_key);
      if (uv.size() / 2 != n)
        return Status::error("%s: %s has %zu elements, POSITION %zu", where.c_str(), uv_key.c_str(),
                             uv.size() / 2, n);
    } else if (first_time && mesh_.materials[size_t(material)].texture >= 0) {
      report_.warnings.push_back(format("%s: textured material but no %s; texture unused there",
                                        where.c_str(), uv_key.c_str()));
    }
    int color_components = 0;
    if (int acc = attribute(prim, "COLOR_0"); acc >= 0) {
      s = read_accessor(model_, acc, {TINYGLTF_TYPE_VEC3, TINYGLTF_TYPE_VEC4}, true, col,
                        color_components);
      if (!s) return s.context(where + ": COLOR_0");
      if (col.size() / size_t(color_components) != n)
        return Status::error("%s: COLOR_0 has %zu elements, POSITION %zu", where.c_str(),
                             col.size() / size_t(color_components), n);
    }

    // Indices, expanded to triangles by mode.
    std::vector<uint32_t> idx;
    if (prim.indices >= 0) {
      std::vector<double> raw;
      s = read_accessor(model_, prim.indices, {TINYGLTF_TYPE_SCALAR}, false, raw, nc);
      if (!s) return s.context(where + ": indices");
      const int ct = model_.accessors[size_t(prim.indices)].componentType;
      if (ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE && ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
          ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
        return Status::error("%s: indices must be unsigned integers (component type %d)",
                             where.c_str(), ct);
      idx.resize(raw.size());
      for (size_t i = 0; i < raw.size(); ++i) {
        if (!(raw[i] < double(n)))
          return Status::error("%s: index %.0f at position %zu out of range (%zu vertices)",
                               where.c_str(), raw[i], i, n);
        idx[i] = static_cast<uint32_t>(raw[i]);
      }
    } else {
      idx.resize(n);
      for (size_t i = 0; i < n; ++i) idx[i] = static_cast<uint32_t>(i);
    }
    std::vector<glm::uvec3> tris;
    if (mode == TINYGLTF_MODE_TRIANGLES) {
      if (idx.size() % 3 != 0 && first_time)
        report_.warnings.push_back(format("%s: %zu indices is not a multiple of 3; ignored the last %zu",
                                          where.c_str(), idx.size(), idx.size() % 3));
      for (size_t i = 0; i + 2 < idx.size(); i += 3) tris.emplace_back(idx[i], idx[i + 1], idx[i + 2]);
    } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
      for (size_t i = 0; i + 2 < idx.size(); ++i)
        tris.push_back(i % 2 == 0 ? glm::uvec3(idx[i], idx[i + 1], idx[i + 2])
                                  : glm::uvec3(idx[i], idx[i + 2], idx[i + 1]));
    } else {
      for (size_t i = 0; i + 2 < idx.size(); ++i) tris.emplace_back(idx[i + 1], idx[i + 2], idx[0]);
    }

    // Append in object space.
    const uint32_t base = static_cast<uint32_t>(mesh_.positions.size());
    const glm::dmat3 normal_matrix = glm::inverseTranspose(glm::dmat3(world));
    const bool mirror = glm::determinant(glm::dmat3(world)) < 0.0;
    if (!uv.empty() && mesh_.uvs.empty()) mesh_.uvs.resize(base, glm::vec2(0.0f));
    if (!col.empty() && mesh_.colors.empty()) mesh_.colors.resize(base, glm::vec3(1.0f));
    if (!nrm.empty() && mesh_.normals.empty())
      mesh_.normals.resize(base, glm::vec3(std::numeric_limits<float>::quiet_NaN()));
    for (size_t i = 0; i < n; ++i) {
      glm::dvec4 p = world * glm::dvec4(pos[3 * i], pos[3 * i + 1], pos[3 * i + 2], 1.0);
      mesh_.positions.emplace_back(to_float(p.x), to_float(p.y), to_float(p.z));
      if (!nrm.empty()) {
        glm::dvec3 q = normal_matrix * glm::dvec3(nrm[3 * i], nrm[3 * i + 1], nrm[3 * i + 2]);
        double len = glm::length(q);
        q = len > 0.0 ? q / len : q;  // zero stays zero: finalize_mesh recomputes it
        mesh_.normals.emplace_back(to_float(q.x), to_float(q.y), to_float(q.z));
      } else if (!mesh_.normals.empty()) {
        mesh_.normals.emplace_back(std::numeric_limits<float>::quiet_NaN());
      }
      if (!uv.empty())
        mesh_.uvs.emplace_back(to_float(uv[2 * i]), to_float(uv[2 * i + 1]));
      else if (!mesh_.uvs.empty())
        mesh_.uvs.emplace_back(0.0f);
      if (!col.empty()) {
        const size_t o = i * size_t(color_components);
        mesh_.colors.emplace_back(to_float(col[o]), to_float(col[o + 1]), to_float(col[o + 2]));
      } else if (!mesh_.colors.empty()) {
        mesh_.colors.emplace_back(1.0f);
      }
    }
    for (glm::uvec3 t : tris) {
      if (mirror) std::swap(t.y, t.z);
      mesh_.triangles.push_back(t + glm::uvec3(base));
      mesh_.triangle_material.push_back(static_cast<uint32_t>(material));
    }
    return Status::ok();
  }

  // TEXCOORD set the material's base color texture uses (0 without one).
  int texcoord_set(int gltf_material) const {
    if (gltf_material < 0 || size_t(gltf_material) >= model_.materials.size()) return 0;
    const auto& info = model_.materials[size_t(gltf_material)].pbrMetallicRoughness.baseColorTexture;
    return info.index >= 0 && info.texCoord >= 0 && info.texCoord < 8 ? info.texCoord : 0;
  }

  // Mesh material index for a glTF material index (-1: the default material), created on first use.
  int material_index(int gltf_material, const std::string& where) {
    if (gltf_material < 0 || size_t(gltf_material) >= model_.materials.size()) {
      if (gltf_material >= 0)
        report_.warnings.push_back(format("%s: material %d does not exist; using the default",
                                          where.c_str(), gltf_material));
      if (default_material_ < 0) {
        default_material_ = int(mesh_.materials.size());
        mesh_.materials.push_back(Material{"default", glm::vec3(1.0f), -1});
      }
      return default_material_;
    }
    int& mapped = material_map_[size_t(gltf_material)];
    if (mapped >= 0) return mapped;
    const tinygltf::Material& gm = model_.materials[size_t(gltf_material)];
    Material mat;
    mat.name = gm.name.empty() ? format("material_%d", gltf_material) : gm.name;
    const std::vector<double>& f = gm.pbrMetallicRoughness.baseColorFactor;
    if (f.size() >= 3) mat.base_color = glm::vec3(to_float(f[0]), to_float(f[1]), to_float(f[2]));
    const tinygltf::TextureInfo& info = gm.pbrMetallicRoughness.baseColorTexture;
    if (info.index >= 0) {
      mat.texture = texture_index(info.index, mat.name);
      if (info.extensions.count("KHR_texture_transform"))
        report_.warnings.push_back(format("%s: material '%s': KHR_texture_transform ignored", file(),
                                          excerpt(mat.name).c_str()));
    }
    mapped = int(mesh_.materials.size());
    mesh_.materials.push_back(std::move(mat));
    return mapped;
  }

  // Mesh texture index for glTF texture `tex`, or -1 (with a warning) when it cannot be decoded.
  int texture_index(int tex, const std::string& material) {
    if (tex < 0 || size_t(tex) >= model_.textures.size()) {
      report_.warnings.push_back(format("%s: material '%s' references missing texture %d", file(),
                                        excerpt(material).c_str(), tex));
      return -1;
    }
    const int source = model_.textures[size_t(tex)].source;
    if (source < 0 || size_t(source) >= model_.images.size()) {
      report_.warnings.push_back(format("%s: texture %d has no usable image source", file(), tex));
      return -1;
    }
    int& mapped = texture_map_[size_t(source)];
    if (mapped != -2) return mapped;
    mapped = -1;
    tinygltf::Image image = model_.images[size_t(source)];
    std::string why = "image data missing";
    if (image.image.empty() && image.bufferView >= 0) {
      const tinygltf::BufferView* bv = size_t(image.bufferView) < model_.bufferViews.size()
                                           ? &model_.bufferViews[size_t(image.bufferView)] : nullptr;
      const unsigned char* bytes = nullptr;
      Status s = bv ? view_range(model_, image.bufferView, 0, bv->byteLength, bytes)
                    : Status::error("bufferView %d does not exist", image.bufferView);
      if (!s) why = s.message();
      else decode_image(image, bytes, bv->byteLength, why);
    }
    const size_t expected = size_t(std::max(image.width, 0)) * size_t(std::max(image.height, 0)) * 4;
    if (image.image.empty() || image.component != 4 || image.bits != 8 ||
        image.image.size() != expected || expected == 0) {
      report_.warnings.push_back(format("%s: image %d could not be used (%s); material '%s' untextured",
                                        file(), source, why.c_str(), excerpt(material).c_str()));
      return -1;
    }
    Texture t;
    t.width = static_cast<uint32_t>(image.width);
    t.height = static_cast<uint32_t>(image.height);
    t.rgba = std::move(image.image);
    mapped = int(mesh_.textures.size());
    mesh_.textures.push_back(std::move(t));
    return mapped;
  }

  const tinygltf::Model& model_;
  const std::string& name_;
  Mesh& mesh_;
  MeshImportReport& report_;
  std::vector<int> material_map_;  // glTF material -> mesh material (-1: not yet)
  std::vector<int> texture_map_;   // glTF image -> mesh texture (-2: not yet, -1: unusable)
  std::vector<uint8_t> warned_mesh_;
  std::vector<uint8_t> on_path_;
  int default_material_ = -1;
  size_t visits_ = 0;
  uint32_t skipped_primitives_ = 0;
};

std::string trim_message(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  for (char& c : s)
    if (c == '\n') c = ';';
  return s;
}

}  // namespace

Status parse_gltf(std::string_view data, bool binary, const std::string& name,
                  const std::string& base_dir, Mesh& mesh, MeshImportReport& report) {
  const char* file = name.c_str();
  if (data.size() >= std::numeric_limits<uint32_t>::max())
    return Status::error("%s: file too large for glTF", file);
  uint32_t length = static_cast<uint32_t>(data.size());
  if (binary) {
    Status s = check_glb(data, file, length);
    if (!s) return s;
  }
  tinygltf::TinyGLTF loader;
  tinygltf::FsCallbacks fs{&tinygltf::FileExists, &tinygltf::ExpandFilePath, &read_whole_file,
                           &tinygltf::WriteWholeFile, nullptr};
  loader.SetFsCallbacks(fs);
  loader.SetImageLoader(&load_image_callback, nullptr);
  tinygltf::Model model;
  std::string err, warn;
  bool ok = binary ? loader.LoadBinaryFromMemory(&model, &err, &warn,
                                                 reinterpret_cast<const unsigned char*>(data.data()),
                                                 length, base_dir)
                   : loader.LoadASCIIFromString(&model, &err, &warn, data.data(), length, base_dir);
  if (!warn.empty()) report.warnings.push_back(name + ": " + trim_message(warn));
  if (!ok) {
    // tinygltf rejects Draco primitives' bufferView-less accessors before we can name the cause.
    const bool draco = data.find("KHR_draco_mesh_compression") != std::string_view::npos;
    return Status::error("%s: invalid glTF: %s%s", file,
                         err.empty() ? "(no details)" : trim_message(err).c_str(),
                         draco ? " (the file uses KHR_draco_mesh_compression, which is not supported)"
                               : "");
  }
  for (const std::string& ext : model.extensionsRequired)
    if (ext == "KHR_draco_mesh_compression")
      return Status::error("%s: requires KHR_draco_mesh_compression, which is not supported", file);
  return GltfFlattener(model, name, mesh, report).run();
}

}  // namespace lsnif::mesh_io
