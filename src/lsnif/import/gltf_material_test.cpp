// gltf_material_test.cpp -- the material reader of gltf_material.h against values worked out by
// hand: clamping, emissive strength, texture slots to images, the uv set, every error and warning.
#include "lsnif/import/gltf_material.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <tuple>
#include <utility>

namespace lsnif {
namespace {

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

bool any_warning(const std::vector<GltfWarning>& w, const std::string& part, const std::string& kind = "") {
  for (const GltfWarning& x : w)
    if (contains(x.text, part) && x.kind == kind) return true;
  return false;
}

// Two images, three textures (texture 2 without a source), one material to edit.
tinygltf::Model one_material() {
  tinygltf::Model g;
  g.images.resize(2);
  g.textures.resize(3);
  g.textures[0].source = 1;
  g.textures[1].source = 0;
  g.textures[2].source = -1;
  g.materials.resize(1);
  g.materials[0].name = "paint";
  return g;
}

TEST(GltfMaterial, FactorsAreClampedAndEmissionScaled) {
  tinygltf::Model g = one_material();
  tinygltf::Material& m = g.materials[0];
  m.pbrMetallicRoughness.baseColorFactor = {0.25, 1.5, -0.5, 1.0};
  m.pbrMetallicRoughness.metallicFactor = 0.75;
  m.pbrMetallicRoughness.roughnessFactor = 2.0;
  m.emissiveFactor = {1.0, -1.0, 0.5};
  tinygltf::Value::Object strength;
  strength["emissiveStrength"] = tinygltf::Value(4.0);
  m.extensions["KHR_materials_emissive_strength"] = tinygltf::Value(strength);
  GltfMaterial out;
  std::vector<GltfWarning> w;
  ASSERT_TRUE(read_gltf_material(g, 0, "f.gltf", out, w));
  EXPECT_EQ(out.material.name, "paint");
  EXPECT_EQ(glm::vec4(out.material.base_color, out.material.alpha), glm::vec4(0.25f, 1.0f, 0.0f, 1.0f));
  EXPECT_EQ(out.material.metallic, 0.75f);
  EXPECT_EQ(out.material.roughness, 1.0f);
  EXPECT_EQ(out.material.emission, glm::vec3(4.0f, 0.0f, 2.0f));
  EXPECT_TRUE(any_warning(w, "material 0 ('paint'): factors outside their range were clamped"));
  EXPECT_EQ(out.material.base_color_texture, -1);
  EXPECT_EQ(out.uv_set, 0);
}

TEST(GltfMaterial, DefaultsOfAnEmptyMaterial) {
  tinygltf::Model g = one_material();
  g.materials[0].name.clear();
  GltfMaterial out;
  std::vector<GltfWarning> w;
  ASSERT_TRUE(read_gltf_material(g, 0, "f.gltf", out, w));
  EXPECT_EQ(out.material.name, "material_0");
  EXPECT_EQ(glm::vec4(out.material.base_color, out.material.alpha), glm::vec4(1.0f));  // glTF's defaults
  EXPECT_EQ(out.material.metallic, 1.0f);
  EXPECT_EQ(out.material.roughness, 1.0f);
  EXPECT_EQ(out.material.emission, glm::vec3(0.0f));
  EXPECT_TRUE(w.empty());
}

TEST(GltfMaterial, SlotsResolveToImagesAndTheUvSet) {
  tinygltf::Model g = one_material();
  tinygltf::Material& m = g.materials[0];
  m.pbrMetallicRoughness.metallicRoughnessTexture.index = 0;  // image 1
  m.pbrMetallicRoughness.metallicRoughnessTexture.texCoord = 1;
  m.emissiveTexture.index = 1;  // image 0
  m.emissiveTexture.texCoord = 2;
  m.normalTexture.index = 0;
  m.occlusionTexture.index = 0;  // image 1
  m.occlusionTexture.texCoord = 2;
  m.occlusionTexture.strength = 0.25;
  m.pbrMetallicRoughness.baseColorTexture.index = 2;  // no source: warned, untextured
  GltfMaterial out;
  std::vector<GltfWarning> w;
  ASSERT_TRUE(read_gltf_material(g, 0, "f.gltf", out, w));
  EXPECT_EQ(out.material.base_color_texture, -1);
  EXPECT_EQ(out.material.metallic_roughness_texture, 1);
  EXPECT_EQ(out.material.emission_texture, 0);
  EXPECT_EQ(out.uv_set, 0);  // the base colour texture's (set 0), though it has no image
  EXPECT_TRUE(any_warning(w, "baseColorTexture: texture 2 has no PNG/JPEG source"));
  EXPECT_EQ(out.material.occlusion_texture, 1);
  EXPECT_EQ(out.material.occlusion_strength, 0.25f);
  EXPECT_EQ(out.material.normal_texture, 1);
  EXPECT_FALSE(any_warning(w, "occlusion"));
  EXPECT_FALSE(any_warning(w, "normal"));
  EXPECT_TRUE(any_warning(w, "different TEXCOORD sets; TEXCOORD_0 used for all"));
  m.pbrMetallicRoughness.baseColorTexture.index = -1;
  w.clear();
  ASSERT_TRUE(read_gltf_material(g, 0, "f.gltf", out, w));
  EXPECT_EQ(out.uv_set, 1);  // the first textured slot's
  m.pbrMetallicRoughness.metallicRoughnessTexture.texCoord = 20;
  m.emissiveTexture.index = -1;
  w.clear();
  ASSERT_TRUE(read_gltf_material(g, 0, "f.gltf", out, w));
  EXPECT_EQ(out.uv_set, 0);
  EXPECT_TRUE(any_warning(w, "texCoord 20 unsupported; TEXCOORD_0 used"));
}

// KHR_texture_transform: uv' = T(offset) R(rotation) S(scale) uv per slot, the extension's matrices
// multiplied out by hand; its texCoord overrides the slot's uv set.
TEST(GltfMaterial, TextureTransformsAreTheExtensionsAffineMaps) {
  tinygltf::Model g = one_material();
  tinygltf::Material& m = g.materials[0];
  m.emissiveTexture.index = 1;
  m.pbrMetallicRoughness.metallicRoughnessTexture.index = 0;
  tinygltf::Value::Object ext;
  ext["offset"] = tinygltf::Value(tinygltf::Value::Array{tinygltf::Value(0.5), tinygltf::Value(-0.25)});
  ext["rotation"] = tinygltf::Value(0.5);
  ext["scale"] = tinygltf::Value(tinygltf::Value::Array{tinygltf::Value(2.0), tinygltf::Value(3.0)});
  m.emissiveTexture.extensions["KHR_texture_transform"] = tinygltf::Value(ext);
  GltfMaterial out;
  std::vector<GltfWarning> w;
  ASSERT_TRUE(read_gltf_material(g, 0, "f.gltf", out, w));
  EXPECT_TRUE(w.empty());
  const glm::vec2 uv(0.3f, 0.7f), s(2.0f * uv.x, 3.0f * uv.y);
  const float c = std::cos(0.5f), sn = std::sin(0.5f);
  const glm::vec2 expected(c * s.x + sn * s.y + 0.5f, -sn * s.x + c * s.y - 0.25f);
  const glm::vec2 got = apply_uv_transform(out.material.uv_transform[kSlotEmission], uv);
  EXPECT_NEAR(got.x, expected.x, 1e-6f);
  EXPECT_NEAR(got.y, expected.y, 1e-6f);
  const glm::vec2 same = apply_uv_transform(out.material.uv_transform[kSlotMetallicRoughness], uv);  // no extension
  EXPECT_EQ(same, uv);
  // texCoord in the extension: the slot's set.
  ext["texCoord"] = tinygltf::Value(1);
  m.emissiveTexture.extensions["KHR_texture_transform"] = tinygltf::Value(ext);
  m.pbrMetallicRoughness.metallicRoughnessTexture.index = -1;
  ASSERT_TRUE(read_gltf_material(g, 0, "f.gltf", out, w));
  EXPECT_EQ(out.uv_set, 1);
  // Malformed transforms are errors naming the slot.
  for (const auto& [key, value, message] :
       {std::tuple{"offset", tinygltf::Value(1.0), "emissiveTexture: KHR_texture_transform offset must be 2 finite numbers"},
        std::tuple{"rotation", tinygltf::Value(std::string("x")), "rotation must be a finite number"},
        std::tuple{"scale", tinygltf::Value(tinygltf::Value::Array{tinygltf::Value(1.0)}), "scale must be 2 finite numbers"},
        std::tuple{"texCoord", tinygltf::Value(-1), "texCoord must be an integer >= 0"}}) {
    tinygltf::Value::Object bad = ext;
    bad[key] = value;
    m.emissiveTexture.extensions["KHR_texture_transform"] = tinygltf::Value(bad);
    const Status st = read_gltf_material(g, 0, "f.gltf", out, w);
    EXPECT_FALSE(st) << key;
    EXPECT_NE(st.message().find(message), std::string::npos) << st.message();
  }
}

// alphaMode, alphaCutoff (the default 0.5, clamped above 1) and doubleSided; a mode glTF does not
// define and a negative or non-finite cutoff are errors naming the material.
TEST(GltfMaterial, AlphaModeCutoffAndDoubleSided) {
  tinygltf::Model g = one_material();
  GltfMaterial out;
  std::vector<GltfWarning> w;
  ASSERT_TRUE(read_gltf_material(g, 0, "f.gltf", out, w));
  EXPECT_EQ(out.material.alpha_mode, AlphaMode::Opaque);
  EXPECT_EQ(out.material.alpha_cutoff, 0.5f);
  EXPECT_FALSE(out.double_sided);
  for (const auto& [mode, expected] : {std::pair{"OPAQUE", AlphaMode::Opaque}, std::pair{"MASK", AlphaMode::Mask},
                                       std::pair{"BLEND", AlphaMode::Blend}}) {
    g.materials[0].alphaMode = mode;
    g.materials[0].alphaCutoff = 0.25;
    g.materials[0].doubleSided = true;
    w.clear();
    ASSERT_TRUE(read_gltf_material(g, 0, "f.gltf", out, w));
    EXPECT_EQ(out.material.alpha_mode, expected) << mode;
    EXPECT_EQ(out.material.alpha_cutoff, 0.25f);
    EXPECT_TRUE(out.double_sided);
    // BLEND has no blending here, and says so.
    EXPECT_EQ(any_warning(w, "alphaMode BLEND is read as a cut-out at alpha 0.5"), expected == AlphaMode::Blend) << mode;
  }
  g.materials[0].alphaCutoff = 3.0;
  w.clear();
  ASSERT_TRUE(read_gltf_material(g, 0, "f.gltf", out, w));
  EXPECT_EQ(out.material.alpha_cutoff, 1.0f);
  EXPECT_TRUE(any_warning(w, "alphaCutoff above 1 was clamped"));
  for (double bad : {-0.1, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    g.materials[0].alphaCutoff = bad;
    const Status s = read_gltf_material(g, 0, "f.gltf", out, w);
    ASSERT_FALSE(s);
    EXPECT_TRUE(contains(s.message(), "f.gltf: material 0 ('paint'): alphaCutoff must be a finite number")) << s.message();
  }
  g.materials[0].alphaCutoff = 0.5;
  g.materials[0].alphaMode = "CUTOUT";
  const Status s = read_gltf_material(g, 0, "f.gltf", out, w);
  ASSERT_FALSE(s);
  EXPECT_TRUE(contains(s.message(), "alphaMode 'CUTOUT' is none of OPAQUE, MASK and BLEND")) << s.message();
}

TEST(GltfMaterial, ErrorsNameTheFileTheMaterialAndTheProblem) {
  struct Case {
    const char* what;
    void (*edit)(tinygltf::Material&);
    const char* expected;
  };
  const Case cases[] = {
      {"three base colour numbers", [](tinygltf::Material& m) { m.pbrMetallicRoughness.baseColorFactor = {1, 1, 1}; },
       "baseColorFactor must be 4 finite numbers"},
      {"NaN base colour",
       [](tinygltf::Material& m) {
         m.pbrMetallicRoughness.baseColorFactor = {1, std::numeric_limits<double>::quiet_NaN(), 1, 1};
       },
       "baseColorFactor must be 4 finite numbers"},
      {"infinite emission",
       [](tinygltf::Material& m) { m.emissiveFactor = {std::numeric_limits<double>::infinity(), 0, 0}; },
       "emissiveFactor must be 3 finite numbers"},
      {"NaN roughness",
       [](tinygltf::Material& m) { m.pbrMetallicRoughness.roughnessFactor = std::numeric_limits<double>::quiet_NaN(); },
       "metallicFactor / roughnessFactor must be finite"},
      {"negative strength",
       [](tinygltf::Material& m) {
         tinygltf::Value::Object o;
         o["emissiveStrength"] = tinygltf::Value(-1.0);
         m.extensions["KHR_materials_emissive_strength"] = tinygltf::Value(o);
       },
       "emissiveStrength must be a finite number >= 0"},
      {"overflowing emission",
       [](tinygltf::Material& m) {
         m.emissiveFactor = {1, 1, 1};
         tinygltf::Value::Object o;
         o["emissiveStrength"] = tinygltf::Value(1e300);
         m.extensions["KHR_materials_emissive_strength"] = tinygltf::Value(o);
       },
       "emission overflows a float"},
      {"missing texture", [](tinygltf::Material& m) { m.emissiveTexture.index = 7; },
       "emissiveTexture references missing texture 7 (3 textures)"},
  };
  for (const Case& c : cases) {
    tinygltf::Model g = one_material();
    c.edit(g.materials[0]);
    GltfMaterial out;
    std::vector<GltfWarning> w;
    const Status s = read_gltf_material(g, 0, "f.gltf", out, w);
    EXPECT_FALSE(s) << c.what;
    EXPECT_TRUE(contains(s.message(), c.expected)) << c.what << ": " << s.message();
    EXPECT_TRUE(contains(s.message(), "f.gltf: material 0 ('paint')")) << c.what << ": " << s.message();
  }
  tinygltf::Model g = one_material();
  g.textures[0].source = 5;
  g.materials[0].pbrMetallicRoughness.baseColorTexture.index = 0;
  GltfMaterial out;
  std::vector<GltfWarning> w;
  const Status s = read_gltf_material(g, 0, "f.gltf", out, w);
  EXPECT_FALSE(s);
  EXPECT_TRUE(contains(s.message(), "texture 0 references missing image 5 (2 images)")) << s.message();
}

}  // namespace
}  // namespace lsnif
