// bench_scenes.cpp -- see bench_scenes.h; the scenes are described in docs/bench-scenes.md.
#include "lsnif/apps/lsnif/bench_scenes.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <utility>

#include <glm/gtc/matrix_transform.hpp>

#include "lsnif/core/rng.h"
#include "lsnif/format/crc32.h"
#include "lsnif/import/gltf_access.h"
#include "lsnif/import/gltf_material.h"
#include "lsnif/scene/gltf_build.h"
#include "lsnif/renderer/render_defaults.h"
#include "lsnif/import/mesh_subdivide.h"

namespace lsnif::cli {
namespace {

namespace fs = std::filesystem;

// The framing assumes the shape of the default image.
// The grid scene: kGridSide x kGridSide bunnies, kGridSpacing apart (a bunny is 1 across).
constexpr uint32_t kGridSide = 32;
constexpr float kGridSpacing = 1.3f;
constexpr float kAspect = float(render::kDefaultImageWidth) / float(render::kDefaultImageHeight);

struct Source {
  const char* file;  // under data/meshes
  glm::vec3 color;
  float roughness;
  float x_rotation_degrees;  // turns the file's up axis into +y
};
const Source kBunny{"bunny00.off", {0.80f, 0.45f, 0.30f}, 0.5f, 0.0f};
const Source kDragon{"ChineseDragon-10kv.off", {0.30f, 0.62f, 0.42f}, 0.35f, 0.0f};
const Source kArmadillo{"armadillo.off", {0.55f, 0.58f, 0.80f}, 0.5f, 0.0f};
const Source kElephant{"elephant.off", {0.35f, 0.60f, 0.22f}, 0.6f, -90.0f};

// Alpha-tested plant sprites (data/textures, from Debian's minetest-data: Minetest Game's textures,
// CC BY-SA 3.0): a tileable cluster of leaves with holes (16 x 16) and a fern (32 x 32), RGBA.
constexpr const char* kLeavesTexture = "default_aspen_leaves.png";
constexpr const char* kFernTexture = "default_fern_3.png";
constexpr float kCardCutoff = 0.5f;  // glTF's default alphaCutoff

std::string mesh_path(const std::string& data_dir, const char* file) { return data_dir + "/meshes/" + file; }
std::string texture_path(const std::string& data_dir, const char* file) { return data_dir + "/textures/" + file; }
// DATA/hdr/FILE; where that EXR is absent but the same image as Radiance HDR (.hdr) is there, that
// one: the GPU check folder carries its environments as .hdr, which its portable image reader reads.
std::string hdr_path(const std::string& data_dir, const char* file) {
  const std::string exr = data_dir + "/hdr/" + file;
  if (exr.size() > 4 && exr.compare(exr.size() - 4, 4, ".exr") == 0 && !fs::exists(exr)) {
    const std::string hdr = exr.substr(0, exr.size() - 4) + ".hdr";
    if (fs::exists(hdr)) return hdr;
  }
  return exr;
}

const char* scene_hdr(const std::string& name) {
  if (name == "bunny") return "forest.exr";
  if (name == "dragons") return "sunset.exr";
  if (name == "heavy") return "city.exr";
  if (name == "foliage") return "courtyard.exr";
  if (name == "grid") return "forest.exr";
  return "sunrise.exr";
}

std::vector<const Source*> scene_sources(const std::string& name) {
  if (name == "bunny") return {&kBunny};
  if (name == "dragons") return {&kDragon};
  if (name == "heavy") return {&kBunny, &kArmadillo, &kDragon};
  if (name == "strands") return {&kElephant};
  if (name == "grid") return {&kBunny};
  return {};
}

// Loads a source mesh, turns it upright, gives it the source's color as its only material and scales and moves it
// so that it stands on y = 0, centred on the y axis, its largest extent `size`.
Status load_source(const std::string& data_dir, const Source& src, float size, Mesh& out) {
  MeshImportReport report;
  if (Status s = load_mesh(mesh_path(data_dir, src.file), out, &report); !s) return s;
  if (src.x_rotation_degrees != 0.0f) {
    const glm::mat3 r(glm::rotate(glm::mat4(1.0f), glm::radians(src.x_rotation_degrees), glm::vec3(1, 0, 0)));
    for (glm::vec3& p : out.positions) p = r * p;
    for (glm::vec3& n : out.normals) n = r * n;
  }
  const Aabb b = out.bounds();
  const glm::vec3 extent = b.hi - b.lo;
  const float scale = size / std::max({extent.x, extent.y, extent.z});
  const glm::vec3 base(0.5f * (b.lo.x + b.hi.x), b.lo.y, 0.5f * (b.lo.z + b.hi.z));
  for (glm::vec3& p : out.positions) p = (p - base) * scale;
  out.colors.clear();
  out.uvs.clear();
  out.textures.clear();
  Material m;
  m.name = fs::path(src.file).stem().string();
  m.base_color = src.color;
  out.materials = {m};
  out.triangle_material.assign(out.triangles.size(), 0);
  return Status::ok();
}

scene::Material scene_material(const Source& src) {
  scene::Material m;
  m.name = fs::path(src.file).stem().string();
  m.base_color = src.color;
  m.metallic = 0.0f;
  m.roughness = src.roughness;
  return m;
}

glm::mat4 placement(glm::vec3 translation, float degrees_about_y, float scale) {
  glm::mat4 m = glm::translate(glm::mat4(1.0f), translation);
  m = glm::rotate(m, glm::radians(degrees_about_y), glm::vec3(0, 1, 0));
  return glm::scale(m, glm::vec3(scale));
}

// World bounds of every instance's mesh bounds.
void world_bounds(const std::vector<BenchObject>& objects, glm::vec3& lo, glm::vec3& hi) {
  lo = glm::vec3(std::numeric_limits<float>::infinity());
  hi = -lo;
  for (const BenchObject& o : objects) {
    const Aabb b = o.mesh.bounds();
    for (const glm::mat4& m : o.placements)
      for (int corner = 0; corner < 8; ++corner) {
        const glm::vec3 p((corner & 1) ? b.hi.x : b.lo.x, (corner & 2) ? b.hi.y : b.lo.y,
                          (corner & 4) ? b.hi.z : b.lo.z);
        const glm::vec3 w(m * glm::vec4(p, 1.0f));
        lo = glm::min(lo, w);
        hi = glm::max(hi, w);
      }
  }
}

// A camera looking at the centre of [lo, hi] from `direction`, far enough that the box's bounding
// sphere (times `fill`) fits the narrower field of view of a kAspect image.
scene::Camera framing_camera(glm::vec3 lo, glm::vec3 hi, glm::vec3 direction, float yfov, float fill) {
  const glm::vec3 c = 0.5f * (lo + hi);
  const float radius = 0.5f * glm::length(hi - lo) * fill;
  const float xfov = 2.0f * std::atan(kAspect * std::tan(0.5f * yfov));
  const float distance = radius / std::sin(0.5f * std::min(yfov, xfov));
  const glm::vec3 eye = c + distance * glm::normalize(direction);
  scene::Camera cam;
  cam.name = "bench";
  cam.yfov = yfov;
  cam.camera_to_world = glm::inverse(glm::lookAt(eye, c, glm::vec3(0, 1, 0)));
  return cam;
}

template <typename T>
uint32_t crc_of(const std::vector<T>& v, uint32_t crc) {
  return v.empty() ? crc : crc32(reinterpret_cast<const uint8_t*>(v.data()), v.size() * sizeof(T), crc);
}

template <typename T>
uint32_t crc_of_value(const T& v, uint32_t crc) {
  return crc32(reinterpret_cast<const uint8_t*>(&v), sizeof(T), crc);
}

std::string hex(uint32_t v) { return format("%08x", v); }

Status require_files(const std::vector<std::string>& files) {
  for (const std::string& f : files)
    if (!fs::is_regular_file(f))
      return Status::error("%s not found: run scripts/setup.sh first (it fetches the meshes, textures and HDR environments)",
                           f.c_str());
  return Status::ok();
}

// Reads a sprite with the glTF loader's image decoder: the texels the renderer reads from the copy
// beside the scene file.
Status load_sprite(const std::string& path, Texture& out) {
  tinygltf::Image image;
  if (Status s = gltf::decode_image_file(path, kGltfMaxImagePixels, image); !s) return s;
  out.width = uint32_t(image.width);
  out.height = uint32_t(image.height);
  out.rgba = std::move(image.image);
  return Status::ok();
}

// A bush: `count` square leaf cards of half-size `half`, centres uniform in the ellipsoid of
// semi-axes `radii` about `center`, facing uniformly random directions, each turned by a random
// angle about its normal (the numbers of card i depend only on (seed, i)).
std::vector<Card> bush_cards(uint32_t count, glm::vec3 center, glm::vec3 radii, float half, uint64_t seed) {
  constexpr float kTwoPi = 6.28318530718f;
  std::vector<Card> cards;
  cards.reserve(count);
  for (uint32_t i = 0; i < count; ++i) {
    Rng rng(seed, 0, i);
    glm::vec3 u;
    do {
      u = 2.0f * glm::vec3(rng.next_float(), rng.next_float(), rng.next_float()) - 1.0f;
    } while (glm::dot(u, u) > 1.0f);
    const float u1 = rng.next_float(), u2 = rng.next_float();
    const glm::vec3 n = sample_uniform_sphere(u1, u2);
    const glm::vec3 helper = std::abs(n.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
    const glm::vec3 a = glm::normalize(glm::cross(n, helper)), b = glm::cross(n, a);
    const float angle = kTwoPi * rng.next_float();
    const glm::vec3 right = half * (std::cos(angle) * a + std::sin(angle) * b);
    cards.push_back({center + radii * u, right, glm::cross(n, right)});
  }
  return cards;
}

// A plant sprite as game engines draw one: three upright cards `width` x `height` crossed at 60
// degrees about the y axis, standing on y = 0.
std::vector<Card> crossed_cards(float width, float height) {
  std::vector<Card> cards;
  for (int k = 0; k < 3; ++k) {
    const float a = glm::radians(60.0f * float(k));
    cards.push_back({glm::vec3(0.0f, 0.5f * height, 0.0f), 0.5f * width * glm::vec3(std::cos(a), 0.0f, std::sin(a)),
                     glm::vec3(0.0f, 0.5f * height, 0.0f)});
  }
  return cards;
}

}  // namespace

Mesh card_mesh(const std::vector<Card>& cards, Texture texture, const std::string& name, float cutoff) {
  Mesh out;
  for (const Card& c : cards) {
    const uint32_t base = uint32_t(out.positions.size());
    const glm::vec3 n = glm::normalize(glm::cross(c.right, c.up));
    out.positions.insert(out.positions.end(), {c.center - c.right + c.up, c.center + c.right + c.up,
                                               c.center + c.right - c.up, c.center - c.right - c.up});
    out.uvs.insert(out.uvs.end(), {{0.0f, 0.0f}, {1.0f, 0.0f}, {1.0f, 1.0f}, {0.0f, 1.0f}});
    out.normals.insert(out.normals.end(), 4, n);
    // Counter-clockwise seen from the side n points to.
    out.triangles.push_back(glm::uvec3(base + 3, base + 2, base + 1));
    out.triangles.push_back(glm::uvec3(base + 3, base + 1, base + 0));
  }
  Material m;
  m.name = name;
  m.base_color = glm::vec3(1.0f);
  m.base_color_texture = 0;
  m.alpha_mode = AlphaMode::Mask;
  m.alpha_cutoff = cutoff;
  out.materials = {m};
  out.textures = {std::move(texture)};
  out.triangle_material.assign(out.triangles.size(), 0);
  return out;
}

const std::vector<std::string>& bench_scene_names() {
  static const std::vector<std::string> names = {"bunny", "dragons", "heavy", "strands", "foliage", "grid"};
  return names;
}

std::vector<std::string> bench_scene_inputs(const std::string& name, const std::string& data_dir) {
  std::vector<std::string> files;
  for (const Source* s : scene_sources(name)) files.push_back(mesh_path(data_dir, s->file));
  if (name == "foliage") files = {texture_path(data_dir, kLeavesTexture), texture_path(data_dir, kFernTexture)};
  if (!files.empty()) files.push_back(hdr_path(data_dir, scene_hdr(name)));
  return files;
}

namespace {

// The source of a bench mesh and the scene whose environment lights it; nullptr for an unknown name.
const Source* mesh_source(const std::string& name, const char** scene) {
  if (name == "bunny") return *scene = "bunny", &kBunny;
  if (name == "armadillo") return *scene = "heavy", &kArmadillo;
  if (name == "dragon") return *scene = "dragons", &kDragon;
  return nullptr;
}

}  // namespace

const std::vector<std::string>& bench_mesh_names() {
  static const std::vector<std::string> names = {"bunny", "armadillo", "dragon"};
  return names;
}

std::vector<std::string> bench_mesh_inputs(const std::string& name, const std::string& data_dir) {
  const char* scene = nullptr;
  const Source* src = mesh_source(name, &scene);
  if (!src) return {};
  return {mesh_path(data_dir, src->file), hdr_path(data_dir, scene_hdr(scene))};
}

Status load_bench_mesh(const std::string& name, const std::string& data_dir, Mesh& out, std::string& hdr) {
  const char* scene = nullptr;
  const Source* src = mesh_source(name, &scene);
  if (!src) {
    std::string known;
    for (const std::string& n : bench_mesh_names()) known += (known.empty() ? "" : ", ") + n;
    return Status::error("unknown mesh '%s' (meshes: %s)", name.c_str(), known.c_str());
  }
  if (Status s = require_files(bench_mesh_inputs(name, data_dir)); !s) return s;
  hdr = hdr_path(data_dir, scene_hdr(scene));
  return load_source(data_dir, *src, 1.0f, out);
}

Mesh wireframe_mesh(const Mesh& mesh, float radius) {
  std::vector<std::pair<uint32_t, uint32_t>> edges;
  edges.reserve(3 * mesh.triangles.size());
  for (const glm::uvec3& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = t[k], b = t[(k + 1) % 3];
      edges.emplace_back(std::min(a, b), std::max(a, b));
    }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());

  Mesh out;
  out.materials = mesh.materials;
  constexpr float kTwoPi = 6.28318530718f;
  for (const auto& [ia, ib] : edges) {
    const glm::vec3 a = mesh.positions[ia], b = mesh.positions[ib];
    const float length = glm::length(b - a);
    if (!(length > 0.0f)) continue;
    const glm::vec3 d = (b - a) / length;
    const glm::vec3 helper = std::abs(d.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
    const glm::vec3 u = glm::normalize(glm::cross(d, helper)), v = glm::cross(d, u);
    glm::vec3 radial[3];
    for (int k = 0; k < 3; ++k) radial[k] = std::cos(kTwoPi * float(k) / 3.0f) * u + std::sin(kTwoPi * float(k) / 3.0f) * v;
    const uint32_t base = uint32_t(out.positions.size());
    // 0..2: ring at a, 3..5: ring at b (radial normals); 6..8, 9..11: the caps' copies.
    for (const glm::vec3& end : {a, b})
      for (int k = 0; k < 3; ++k) {
        out.positions.push_back(end + radius * radial[k]);
        out.normals.push_back(radial[k]);
      }
    for (int e = 0; e < 2; ++e)
      for (int k = 0; k < 3; ++k) {
        out.positions.push_back(out.positions[base + uint32_t(3 * e + k)]);
        out.normals.push_back(e == 0 ? -d : d);
      }
    auto add = [&](uint32_t i, uint32_t j, uint32_t l, const glm::vec3& outward) {
      const glm::vec3 n = glm::cross(out.positions[base + j] - out.positions[base + i],
                                     out.positions[base + l] - out.positions[base + i]);
      if (glm::dot(n, outward) < 0.0f) std::swap(j, l);
      out.triangles.push_back(glm::uvec3(base + i, base + j, base + l));
    };
    for (uint32_t k = 0; k < 3; ++k) {
      const uint32_t k1 = (k + 1) % 3;
      const glm::vec3 side = radial[k] + radial[k1];
      add(k, k1, 3 + k1, side);
      add(k, 3 + k1, 3 + k, side);
    }
    add(6, 7, 8, -d);
    add(9, 10, 11, d);
  }
  out.triangle_material.assign(out.triangles.size(), 0);
  return out;
}

Status make_bench_scene(const std::string& name, const std::string& data_dir, BenchScene& out) {
  out = BenchScene();
  const std::vector<std::string>& names = bench_scene_names();
  if (std::find(names.begin(), names.end(), name) == names.end()) {
    std::string known;
    for (const std::string& n : bench_scene_names()) known += (known.empty() ? "" : ", ") + n;
    return Status::error("unknown scene '%s' (scenes: %s)", name.c_str(), known.c_str());
  }
  if (Status s = require_files(bench_scene_inputs(name, data_dir)); !s) return s;
  out.name = name;
  out.hdr = hdr_path(data_dir, scene_hdr(name));
  glm::vec3 view(0.35f, 0.3f, 1.0f);
  float fill = 0.75f;
  auto add = [&](const Source& src, const std::string& object_name, uint32_t levels, float size,
                 std::vector<glm::mat4> placements) -> Status {
    BenchObject o;
    o.name = object_name;
    if (Status s = load_source(data_dir, src, size, o.mesh); !s) return s;
    o.origin = src.file;
    if (levels > 0) {
      Mesh fine;
      if (Status s = subdivide_midpoint(o.mesh, levels, fine); !s) return s.context(src.file);
      o.mesh = std::move(fine);
      o.origin += format(" subdivided %ux (1-to-4 midpoint)", levels);
    }
    o.material = scene_material(src);
    o.placements = std::move(placements);
    out.objects.push_back(std::move(o));
    return Status::ok();
  };
  auto add_cards = [&](const std::string& object_name, const char* texture, const std::vector<Card>& cards,
                       const std::string& origin, std::vector<glm::mat4> placements) -> Status {
    BenchObject o;
    o.name = object_name;
    o.texture = texture_path(data_dir, texture);
    Texture sprite;
    if (Status s = load_sprite(o.texture, sprite); !s) return s;
    o.mesh = card_mesh(cards, std::move(sprite), object_name, kCardCutoff);
    o.origin = origin;
    o.material.name = object_name;
    o.material.base_color = glm::vec3(1.0f);
    o.material.metallic = 0.0f;
    o.material.roughness = 0.6f;
    o.material.alpha_mode = AlphaMode::Mask;
    o.material.alpha_cutoff = kCardCutoff;
    o.placements = std::move(placements);
    out.objects.push_back(std::move(o));
    return Status::ok();
  };
  Status s;
  if (name == "bunny") {
    out.summary = "the Stanford bunny on a ground quad";
    s = add(kBunny, "bunny", 0, 1.0f, {glm::mat4(1.0f)});
  } else if (name == "dragons") {
    out.summary = "one dragon model, instanced three times with different transforms";
    s = add(kDragon, "dragon", 0, 1.0f,
            {placement({0.0f, 0.0f, 0.0f}, -20.0f, 1.0f), placement({-1.05f, 0.0f, -0.75f}, 35.0f, 0.8f),
             placement({1.05f, 0.0f, -0.75f}, -75.0f, 0.8f)});
    view = glm::vec3(0.1f, 0.35f, 1.0f);
    fill = 0.6f;
  } else if (name == "heavy") {
    out.summary = "three meshes subdivided to millions of triangles (one model each, trained on the subdivided mesh)";
    s = add(kBunny, "bunny", 2, 1.0f, {placement({-1.15f, 0.0f, 0.0f}, 10.0f, 1.0f)});
    if (s) s = add(kArmadillo, "armadillo", 2, 1.0f, {placement({0.0f, 0.0f, -0.2f}, 180.0f, 1.0f)});
    if (s) s = add(kDragon, "dragon", 3, 1.0f, {placement({1.15f, 0.0f, 0.0f}, -30.0f, 1.0f)});
    view = glm::vec3(0.05f, 0.3f, 1.0f);
    fill = 0.7f;
    out.env_intensity = 0.6f;  // the overcast city sky would wash the ground out at 1
  } else if (name == "grid") {
    // A field of instances seen at a low angle: a ray crosses many instance boxes before its hit,
    // the case where the cost per ray must not grow with the instance count.
    out.summary = format("one bunny model instanced %u times on a %u x %u grid, seen at a low angle",
                         kGridSide * kGridSide, kGridSide, kGridSide);
    std::vector<glm::mat4> cells;
    for (uint32_t i = 0; i < kGridSide * kGridSide; ++i) {
      const float x = (float(i % kGridSide) - 0.5f * float(kGridSide - 1)) * kGridSpacing;
      const float z = (float(i / kGridSide) - 0.5f * float(kGridSide - 1)) * kGridSpacing;
      cells.push_back(placement({x, 0.0f, z}, float((i * 37u) % 360u), 1.0f));
    }
    s = add(kBunny, "bunny", 0, 1.0f, std::move(cells));
  } else if (name == "foliage") {
    out.summary = "alpha-tested cards: a bush of leaf cards and five instances of a fern (glTF alphaMode MASK)";
    constexpr uint32_t kLeafCards = 900;
    s = add_cards("bush", kLeavesTexture, bush_cards(kLeafCards, {0.0f, 0.5f, 0.0f}, {0.5f, 0.42f, 0.5f}, 0.08f, 7),
                  format("%u cards textured with %s, random in an ellipsoid", kLeafCards, kLeavesTexture),
                  {glm::mat4(1.0f)});
    std::vector<glm::mat4> ferns;
    for (int k = 0; k < 5; ++k) {
      const float a = glm::radians(30.0f + 72.0f * float(k));
      ferns.push_back(placement({0.78f * std::cos(a), 0.0f, 0.78f * std::sin(a)}, 40.0f * float(k), 0.8f + 0.1f * float(k % 3)));
    }
    if (s) s = add_cards("fern", kFernTexture, crossed_cards(0.45f, 0.45f),
                         format("three crossed cards textured with %s", kFernTexture), std::move(ferns));
    view = glm::vec3(0.3f, 0.35f, 1.0f);
    fill = 0.7f;
  } else {
    out.summary = "thin geometry: every edge of the elephant mesh as a thin closed prism (a wire sculpture)";
    BenchObject o;
    o.name = "elephant_wire";
    s = load_source(data_dir, kElephant, 1.0f, o.mesh);
    if (s) {
      o.mesh = wireframe_mesh(o.mesh, 0.0025f);
      o.origin = std::string(kElephant.file) + " edges as prisms of radius 0.25% of its size";
      o.material = scene_material(kElephant);
      o.material.name = o.name;
      o.placements = {placement({0, 0, 0}, 25.0f, 1.0f)};
      out.objects.push_back(std::move(o));
      fill = 0.65f;
    }
  }
  if (!s) {
    out = BenchScene();
    return s;
  }
  glm::vec3 lo, hi;
  world_bounds(out.objects, lo, hi);
  out.camera = framing_camera(lo, hi, view, 0.6f, fill);
  if (name == "grid") {  // from just outside the field's front edge, looking across it at a low angle
    const float front = 0.5f * float(kGridSide) * kGridSpacing;
    out.camera.camera_to_world = glm::inverse(
        glm::lookAt(glm::vec3(0.0f, 2.2f, front + 2.0f), glm::vec3(0.0f, 0.0f, 0.2f * front), glm::vec3(0, 1, 0)));
  }
  out.ground_center = glm::vec3(0.5f * (lo.x + hi.x), 0.0f, 0.5f * (lo.z + hi.z));
  out.ground_half_size = 4.0f * glm::length(hi - lo);
  return Status::ok();
}

Status write_bench_scene(const BenchScene& scene, const std::string& dir) {
  tinygltf::Model model = scene::new_gltf_model("lsnif bench (src/lsnif/apps/lsnif/bench_scenes.cpp)");
  scene::Material ground;
  ground.name = "ground";
  ground.base_color = glm::vec3(0.45f);
  ground.metallic = 0.0f;
  ground.roughness = 0.8f;
  const int ground_material = scene::add_material(model, ground);
  scene::Mesh quad;
  quad.name = "ground";
  scene::Primitive q;
  const glm::vec3 c = scene.ground_center;
  const float r = scene.ground_half_size;
  q.positions = {{c.x - r, 0, c.z - r}, {c.x + r, 0, c.z - r}, {c.x + r, 0, c.z + r}, {c.x - r, 0, c.z + r}};
  q.normals.assign(4, glm::vec3(0, 1, 0));
  q.indices = {0, 2, 1, 0, 3, 2};
  q.material = uint32_t(ground_material);
  quad.primitives = {q};
  int mesh = -1;
  if (Status s = scene::add_mesh(model, quad, mesh); !s) return s;
  scene::add_node(model, "ground", mesh, glm::mat4(1.0f));
  for (const BenchObject& o : scene.objects) {
    scene::Material material_spec = o.material;
    if (!o.texture.empty()) {
      const std::string file = fs::path(o.texture).filename().string();
      std::error_code ec;
      fs::copy_file(o.texture, fs::path(dir) / file, fs::copy_options::overwrite_existing, ec);
      if (ec) return Status::error("copying %s into %s: %s", o.texture.c_str(), dir.c_str(), ec.message().c_str());
      material_spec.base_color_texture = scene::add_image_texture(model, file);
    }
    const int material = scene::add_material(model, material_spec);
    scene::Mesh m;
    m.name = o.name;
    m.primitives = {scene::primitive_from(o.mesh, uint32_t(material))};
    if (Status s = scene::add_mesh(model, m, mesh); !s) return s;
    for (size_t i = 0; i < o.placements.size(); ++i) {
      const int node = scene::add_node(model, i ? format("%s_%zu", o.name.c_str(), i) : o.name, mesh, o.placements[i]);
      scene::set_neural_object(model, node, o.name + ".lsnif", {uint32_t(material)});
    }
  }
  scene::add_camera(model, scene.camera, 0.01f, 1000.0f);
  scene::EnvironmentSpec env;
  env.hdr = fs::path(scene.hdr).filename().string();
  env.intensity = scene.env_intensity;
  env.rotation_degrees = scene.env_rotation_degrees;
  scene::set_environment(model, env);
  std::error_code ec;
  fs::copy_file(scene.hdr, fs::path(dir) / env.hdr, fs::copy_options::overwrite_existing, ec);
  if (ec) return Status::error("copying %s into %s: %s", scene.hdr.c_str(), dir.c_str(), ec.message().c_str());
  return scene::save_gltf(model, (fs::path(dir) / (scene.name + ".gltf")).string());
}

std::string mesh_fingerprint(const Mesh& mesh) {
  uint32_t crc = crc_of(mesh.positions, 0);
  crc = crc_of(mesh.normals, crc);
  crc = crc_of(mesh.uvs, crc);
  crc = crc_of(mesh.triangles, crc);
  for (const Material& m : mesh.materials) {
    crc = crc_of_value(m.base_color, crc);
    if (m.alpha_mode == AlphaMode::Opaque) continue;
    crc = crc_of_value(m.cutoff(), crc);
    if (m.base_color_texture >= 0 && size_t(m.base_color_texture) < mesh.textures.size()) crc = crc_of(mesh.textures[size_t(m.base_color_texture)].rgba, crc);
  }
  return hex(crc);
}

std::string object_fingerprint(const BenchObject& o) { return mesh_fingerprint(o.mesh); }

std::string scene_fingerprint(const BenchScene& scene) {
  uint32_t crc = 0;
  for (const BenchObject& o : scene.objects) {
    crc = crc32(reinterpret_cast<const uint8_t*>(o.name.data()), o.name.size(), crc);
    const std::string f = object_fingerprint(o);
    crc = crc32(reinterpret_cast<const uint8_t*>(f.data()), f.size(), crc);
    crc = crc_of(o.placements, crc);
    crc = crc_of_value(glm::vec4(o.material.base_color, o.material.alpha), crc);  // the RGBA factor
    crc = crc_of_value(o.material.roughness, crc);
    if (!o.texture.empty()) crc = crc_of_value(o.material.alpha_cutoff, crc);
  }
  crc = crc_of_value(scene.ground_center, crc);
  crc = crc_of_value(scene.ground_half_size, crc);
  crc = crc_of_value(scene.camera.camera_to_world, crc);
  crc = crc_of_value(scene.camera.yfov, crc);
  crc = crc32(reinterpret_cast<const uint8_t*>(scene.hdr.data()), scene.hdr.size(), crc);
  crc = crc_of_value(scene.env_intensity, crc);
  crc = crc_of_value(scene.env_rotation_degrees, crc);
  return hex(crc);
}

uint64_t object_triangles(const BenchScene& scene) {
  uint64_t n = 0;
  for (const BenchObject& o : scene.objects) n += uint64_t(o.mesh.triangles.size()) * o.placements.size();
  return n;
}

}  // namespace lsnif::cli
