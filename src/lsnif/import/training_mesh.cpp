// training_mesh.cpp -- the training mesh file (.lsmesh, training_mesh.h): writer, and the reader
// load_mesh dispatches to (mesh_formats.h parse_training_mesh).
#include "lsnif/import/training_mesh.h"

#include <array>
#include <bit>
#include <cstring>
#include <type_traits>

#include "lsnif/format/atomic_file.h"
#include "lsnif/format/crc32.h"
#include "lsnif/import/gltf_material.h"
#include "lsnif/import/gltf_scene.h"
#include "lsnif/import/mesh_formats.h"

namespace lsnif {
namespace {

constexpr char kMagic[8] = {'L', 'S', 'N', 'I', 'F', 'M', 'S', 'H'};
constexpr uint32_t kVersion = 1;
constexpr uint32_t kMaxNameBytes = 4096;  // a material name
constexpr size_t kCounts = 7;             // positions, normals, uvs, colours, triangles, materials, textures

// Appends values as little-endian bytes (the hosts we build for are little-endian: checked below).
static_assert(std::endian::native == std::endian::little, "the training mesh writer assumes a little-endian host");

class ByteWriter {
 public:
  explicit ByteWriter(std::string& out) : out_(out) {}
  template <class T>
  void pod(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    out_.append(reinterpret_cast<const char*>(&v), sizeof(T));
  }
  template <class T>
  void array(const std::vector<T>& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    if (!v.empty()) out_.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
  }

 private:
  std::string& out_;
};

// Reads packed values from [p, end); every read is checked against the end.
class ByteReader {
 public:
  ByteReader(std::string_view data, const std::string& name) : p_(data.data()), end_(data.data() + data.size()), name_(name) {}
  size_t left() const { return size_t(end_ - p_); }
  template <class T>
  Status pod(T& v, const char* what) {
    if (left() < sizeof(T)) return truncated(what);
    std::memcpy(&v, p_, sizeof(T));
    p_ += sizeof(T);
    return Status::ok();
  }
  // `count` elements, refused before allocating when the file cannot hold them.
  template <class T>
  Status array(std::vector<T>& v, uint64_t count, const char* what) {
    if (count > left() / sizeof(T)) return truncated(what);
    v.resize(size_t(count));
    if (count) std::memcpy(v.data(), p_, size_t(count) * sizeof(T));
    p_ += size_t(count) * sizeof(T);
    return Status::ok();
  }
  Status bytes(std::string& s, uint32_t count, const char* what) {
    if (count > left()) return truncated(what);
    s.assign(p_, count);
    p_ += count;
    return Status::ok();
  }

 private:
  Status truncated(const char* what) const {
    return Status::error("%s: training mesh file ends inside the %s (truncated or corrupt)", name_.c_str(), what);
  }
  const char* p_;
  const char* end_;
  const std::string& name_;
};

void write_material(ByteWriter& w, const Material& m) {
  w.pod(uint32_t(m.name.size()));
  for (char c : m.name) w.pod(c);
  w.pod(m.base_color);
  w.pod(m.metallic);
  w.pod(m.roughness);
  w.pod(m.emission);
  w.pod(m.occlusion_strength);
  w.pod(m.normal_scale);
  for (const int* t : m.textures()) w.pod(int32_t(*t));  // TextureSlot order: the file's
  for (const UvTransform& u : m.uv_transform) w.pod(u);
  w.pod(uint32_t(m.alpha_mode));
  w.pod(m.alpha);
  w.pod(m.alpha_cutoff);
}

Status read_material(ByteReader& r, const std::string& name, size_t textures, Material& m) {
  uint32_t length = 0;
  Status s = r.pod(length, "material name");
  if (s && length > kMaxNameBytes)
    return Status::error("%s: a material name of %u bytes (at most %u)", name.c_str(), length, kMaxNameBytes);
  if (s) s = r.bytes(m.name, length, "material name");
  if (s) s = r.pod(m.base_color, "material");
  if (s) s = r.pod(m.metallic, "material");
  if (s) s = r.pod(m.roughness, "material");
  if (s) s = r.pod(m.emission, "material");
  if (s) s = r.pod(m.occlusion_strength, "material");
  if (s) s = r.pod(m.normal_scale, "material");
  for (int* t : m.textures()) {
    int32_t v = 0;
    if (s) s = r.pod(v, "material");
    if (s && (v < -1 || int64_t(v) >= int64_t(textures)))
      return Status::error("%s: material '%s' refers to texture %d (%zu textures)", name.c_str(),
                           printable(m.name).c_str(), v, textures);
    *t = v;
  }
  for (UvTransform& u : m.uv_transform)
    if (s) s = r.pod(u, "material");
  uint32_t mode = 0;
  if (s) s = r.pod(mode, "material");
  if (s && mode > uint32_t(AlphaMode::Blend))
    return Status::error("%s: material '%s' has alpha mode %u (0 to 2)", name.c_str(), printable(m.name).c_str(), mode);
  m.alpha_mode = AlphaMode(mode);
  if (s) s = r.pod(m.alpha, "material");
  if (s) s = r.pod(m.alpha_cutoff, "material");
  return s;
}

Status read_texture(ByteReader& r, const std::string& name, Texture& t) {
  Status s = r.pod(t.width, "texture");
  if (s) s = r.pod(t.height, "texture");
  if (!s) return s;
  const uint64_t pixels = uint64_t(t.width) * t.height;
  if (pixels == 0 || pixels > kGltfMaxImagePixels)
    return Status::error("%s: a texture of %u x %u pixels (1 to %llu pixels)", name.c_str(), t.width, t.height,
                         (unsigned long long)kGltfMaxImagePixels);
  return r.array(t.rgba, pixels * 4, "texture");
}

}  // namespace

Status training_mesh_bytes(const Mesh& mesh, std::string& out) {
  const size_t n = mesh.positions.size();
  if (mesh.triangles.empty() || mesh.materials.empty() || mesh.normals.size() != n ||
      (!mesh.uvs.empty() && mesh.uvs.size() != n) || (!mesh.colors.empty() && mesh.colors.size() != n) ||
      mesh.triangle_material.size() != mesh.triangles.size())
    return Status::error("the mesh is not finalized (triangles, one normal per vertex, a material per triangle)");
  out.clear();
  ByteWriter w(out);
  for (char c : kMagic) w.pod(c);
  w.pod(kVersion);
  w.pod(uint32_t(0));
  for (uint64_t c : {uint64_t(n), uint64_t(mesh.normals.size()), uint64_t(mesh.uvs.size()),
                     uint64_t(mesh.colors.size()), uint64_t(mesh.triangles.size()), uint64_t(mesh.materials.size()),
                     uint64_t(mesh.textures.size())})
    w.pod(c);
  w.array(mesh.positions);
  w.array(mesh.normals);
  w.array(mesh.uvs);
  w.array(mesh.colors);
  w.array(mesh.triangles);
  w.array(mesh.triangle_material);
  for (const Material& m : mesh.materials) write_material(w, m);
  for (const Texture& t : mesh.textures) {
    w.pod(t.width);
    w.pod(t.height);
    w.array(t.rgba);
  }
  w.pod(crc32(reinterpret_cast<const uint8_t*>(out.data()), out.size()));
  return Status::ok();
}

Status save_training_mesh(const Mesh& mesh, const std::string& path) {
  std::string bytes;
  if (Status s = training_mesh_bytes(mesh, bytes); !s) return s.context(path);
  return write_file_atomic(path, bytes);
}

namespace mesh_io {

Status parse_training_mesh(std::string_view data, const std::string& name, Mesh& mesh) {
  if (data.size() < sizeof(kMagic) + 4 || std::memcmp(data.data(), kMagic, sizeof(kMagic)) != 0)
    return Status::error("%s: not a training mesh file (no LSNIFMSH signature)", name.c_str());
  uint32_t stored_crc = 0;
  std::memcpy(&stored_crc, data.data() + data.size() - 4, 4);
  const std::string_view body = data.substr(0, data.size() - 4);
  if (crc32(reinterpret_cast<const uint8_t*>(body.data()), body.size()) != stored_crc)
    return Status::error("%s: training mesh file is corrupt (checksum mismatch: truncated or damaged)", name.c_str());
  ByteReader r(body.substr(sizeof(kMagic)), name);
  uint32_t version = 0, flags = 0;
  Status s = r.pod(version, "header");
  if (s) s = r.pod(flags, "header");
  if (s && version != kVersion)
    return Status::error("%s: training mesh format version %u (this build reads version %u)", name.c_str(), version,
                         kVersion);
  if (s && flags != 0) return Status::error("%s: unknown training mesh flags 0x%x", name.c_str(), flags);
  uint64_t count[kCounts] = {};
  for (uint64_t& c : count)
    if (s) s = r.pod(c, "header");
  if (!s) return s;
  const uint64_t n = count[0];
  if (n == 0 || n >= kInvalidIndex || count[1] != n || (count[2] != 0 && count[2] != n) ||
      (count[3] != 0 && count[3] != n) || count[4] == 0 || count[4] > kGltfMaxGeometry || count[5] == 0 ||
      count[5] > (uint64_t(1) << 16) || count[6] > (uint64_t(1) << 16))
    return Status::error("%s: training mesh counts out of range (%llu vertices, %llu normals, %llu uvs, %llu colours, "
                         "%llu triangles, %llu materials, %llu textures)",
                         name.c_str(), (unsigned long long)n, (unsigned long long)count[1],
                         (unsigned long long)count[2], (unsigned long long)count[3], (unsigned long long)count[4],
                         (unsigned long long)count[5], (unsigned long long)count[6]);
  s = r.array(mesh.positions, n, "positions");
  if (s) s = r.array(mesh.normals, count[1], "normals");
  if (s) s = r.array(mesh.uvs, count[2], "uvs");
  if (s) s = r.array(mesh.colors, count[3], "colours");
  if (s) s = r.array(mesh.triangles, count[4], "triangles");
  if (s) s = r.array(mesh.triangle_material, count[4], "triangle materials");
  if (!s) return s;
  for (size_t i = 0; i < mesh.triangles.size(); ++i) {
    const glm::uvec3 t = mesh.triangles[i];
    if (t.x >= n || t.y >= n || t.z >= n || mesh.triangle_material[i] >= count[5])
      return Status::error("%s: triangle %zu refers to a vertex or material that does not exist", name.c_str(), i);
  }
  mesh.materials.resize(size_t(count[5]));
  for (Material& m : mesh.materials)
    if (s = read_material(r, name, size_t(count[6]), m); !s) return s;
  mesh.textures.resize(size_t(count[6]));
  for (Texture& t : mesh.textures)
    if (s = read_texture(r, name, t); !s) return s;
  if (r.left() != 0)
    return Status::error("%s: %zu bytes after the training mesh's data", name.c_str(), r.left());
  return Status::ok();
}

}  // namespace mesh_io
}  // namespace lsnif
