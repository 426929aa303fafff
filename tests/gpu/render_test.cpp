// The path tracer (samples/render/renderer.h) on lavapipe with validation on: a scene of a ground
// quad and the elephant, whose node carries both its triangle mesh and a tiny LSNIF model trained
// here. Reference and LSNIF renders use the same per-pixel random sequences, so (1) rendering the
// same mode twice gives identical images, (2) a scene without LSNIF objects renders identically in
// both modes, (3) the LSNIF render differs from the reference only where the geometry differs: its
// mean absolute difference stays small against the image's mean, and far below that of a render
// with the object removed.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <filesystem>

#include "flip.h"
#include "gpu_test_support.h"
#include "mesh.h"
#include "model.h"
#include "renderer.h"
#include "trainer.h"

namespace lsnif {
namespace {

using namespace gputest;

const std::string kElephant = std::string(LSNIF_DATA_DIR) + "/meshes/elephant.off";

// Mean over pixels of the absolute difference (all channels) and the mean of `a`.
double mean_abs_diff(const image::Image& a, const image::Image& b) {
  double d = 0;
  for (size_t i = 0; i < a.rgb.size(); ++i) d += std::fabs(double(a.rgb[i]) - double(b.rgb[i]));
  return d / double(a.rgb.size());
}
// With LSNIF_RENDER_TEST_DUMP=DIR set, writes `img` as DIR/name.ppm (clamped, gamma 2.2) to look at.
void dump(const image::Image& img, const char* name) {
  const char* dir = std::getenv("LSNIF_RENDER_TEST_DUMP");
  if (!dir) return;
  FILE* f = std::fopen((std::string(dir) + "/" + name + ".ppm").c_str(), "wb");
  if (!f) return;
  std::fprintf(f, "P6\n%u %u\n255\n", img.width, img.height);
  for (float v : img.rgb) std::fputc(int(255.0f * std::pow(std::clamp(v, 0.0f, 1.0f), 1.0f / 2.2f) + 0.5f), f);
  std::fclose(f);
}
double mean(const image::Image& a) {
  double d = 0;
  for (float v : a.rgb) d += double(v);
  return d / double(a.rgb.size());
}

class RenderTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    vk_status_ = vk_.init(true);
    if (!vk_status_) return;
    Mesh mesh;
    if (!std::filesystem::exists(kElephant) || !load_mesh(kElephant, mesh)) {
      train_status_ = Status::error("%s missing: run scripts/setup.sh", kElephant.c_str());
      return;
    }
    // The color the network learns is the one the scene's material gives the reference.
    const glm::vec3 color(0.6f, 0.3f, 0.15f);
    for (Material& m : mesh.materials) m.base_color = color;
    TrainSettings settings = tiny_settings(HitParam::VoxelSegments);
    settings.steps = 600;
    Model model;
    train_status_ = train_model(mesh, settings, model);
    if (!train_status_) return;
    model_path_ = (std::filesystem::temp_directory_path() / "lsnif_render_test_elephant.lsnif").string();
    train_status_ = save_model(model, model_path_);
    if (!train_status_) return;

    // Scene: the elephant (mesh 0, LSNIF object 0) standing on a quad (mesh 1) under a sky color.
    scene_.path = "(render_test)";
    scene::Material grey, ground;
    grey.base_color = glm::vec4(color, 1.0f);
    grey.metallic = 0.0f;
    grey.roughness = 0.6f;
    ground.base_color = glm::vec4(0.5f, 0.5f, 0.5f, 1.0f);
    ground.metallic = 0.0f;
    scene_.materials = {grey, ground};
    scene::Mesh elephant;
    elephant.name = "elephant";
    scene::Primitive p;
    p.positions = mesh.positions;
    p.normals = mesh.normals;
    for (const glm::uvec3& t : mesh.triangles) p.indices.insert(p.indices.end(), {t.x, t.y, t.z});
    p.material = 0;
    elephant.primitives.push_back(p);
    const Aabb b = mesh.bounds();
    scene::Mesh quad;
    quad.name = "ground";
    scene::Primitive q;
    const float r = 2.0f * b.diagonal(), y = b.lo.y;
    const glm::vec3 c = b.center();
    q.positions = {{c.x - r, y, c.z - r}, {c.x + r, y, c.z - r}, {c.x + r, y, c.z + r}, {c.x - r, y, c.z + r}};
    q.indices = {0, 2, 1, 0, 3, 2};
    q.material = 1;
    quad.primitives.push_back(q);
    scene_.meshes = {elephant, quad};
    scene::LsnifObject obj;
    obj.model_path = model_path_;
    obj.material_map = {0};
    scene_.lsnif_objects = {obj};
    scene::Instance e, g;
    e.node_name = "elephant";
    e.mesh = 0;
    e.lsnif = 0;
    g.node_name = "ground";
    g.mesh = 1;
    scene_.instances = {e, g};
    scene_.environment.color = glm::vec3(0.9f, 0.95f, 1.0f);
    // A camera on the elephant, from the front-right and above, the object filling most of the view.
    scene::Camera cam;
    cam.name = "closeup";
    cam.yfov = 0.7f;
    const glm::vec3 eye = c + 1.3f * b.diagonal() * glm::normalize(glm::vec3(0.7f, 0.45f, 1.0f));
    const glm::vec3 fwd = glm::normalize(c - eye), right = glm::normalize(glm::cross(fwd, glm::vec3(0, 1, 0)));
    cam.camera_to_world = glm::mat4(glm::vec4(right, 0), glm::vec4(glm::cross(right, fwd), 0), glm::vec4(-fwd, 0),
                                    glm::vec4(eye, 1));
    scene_.cameras = {cam};
  }
  static void TearDownTestSuite() {
    if (!model_path_.empty()) std::filesystem::remove(model_path_);
  }
  void SetUp() override {
    ASSERT_TRUE(vk_status_) << "no usable Vulkan ray-tracing device: " << vk_status_.message();
    ASSERT_TRUE(train_status_) << train_status_.message();
  }
  void TearDown() override {
    EXPECT_EQ(vk_.validation_errors(), 0u) << "Vulkan validation errors (printed above)";
    EXPECT_EQ(vk_.validation_warnings(), 0u) << "Vulkan validation warnings (printed above)";
  }
  static render::RenderSettings small(bool reference) {
    render::RenderSettings s;
    s.width = 64;
    s.height = 48;
    s.spp = 8;
    s.reference = reference;
    s.camera = 0;
    return s;
  }

  static vk::ComputeContext vk_;
  static Status vk_status_, train_status_;
  static scene::Scene scene_;
  static std::string model_path_;
};
vk::ComputeContext RenderTest::vk_;
Status RenderTest::vk_status_, RenderTest::train_status_;
scene::Scene RenderTest::scene_;
std::string RenderTest::model_path_;

TEST_F(RenderTest, SameModeTwiceIsIdentical) {
  render::Renderer renderer(vk_);
  image::Image a, b;
  render::RenderStats sa, sb;
  ASSERT_TRUE(renderer.render(scene_, small(true), a, sa));
  ASSERT_TRUE(renderer.render(scene_, small(true), b, sb));
  ASSERT_EQ(a.rgb.size(), size_t(64 * 48 * 3));
  EXPECT_EQ(a.rgb, b.rgb);
  EXPECT_GT(mean(a), 0.05);  // not black
  EXPECT_EQ(sa.lsnif_instances, 0u);
  EXPECT_EQ(sa.triangle_instances, 2u);
  std::printf("reference: %.1f ms per sample, triangle BLAS %llu B, TLAS %llu B\n", sa.ms_per_sample,
              (unsigned long long)sa.triangle_blas_bytes, (unsigned long long)sa.tlas_bytes);
}

TEST_F(RenderTest, WithoutLsnifObjectsBothModesAgreeExactly) {
  scene::Scene plain = scene_;
  plain.instances[0].lsnif = -1;
  render::Renderer renderer(vk_);
  image::Image a, b;
  render::RenderStats s;
  ASSERT_TRUE(renderer.render(plain, small(true), a, s));
  ASSERT_TRUE(renderer.render(plain, small(false), b, s));
  EXPECT_EQ(a.rgb, b.rgb);  // same random sequence per pixel in both modes
}

TEST_F(RenderTest, LsnifRenderIsCloseToTheReference) {
  render::Renderer renderer(vk_);
  image::Image ref, lsnif, empty;
  render::RenderStats sr, sl, se;
  ASSERT_TRUE(renderer.render(scene_, small(true), ref, sr));
  ASSERT_TRUE(renderer.render(scene_, small(false), lsnif, sl));
  EXPECT_EQ(sl.lsnif_instances, 1u);
  EXPECT_EQ(sl.lsnif_models, 1u);
  EXPECT_GT(sl.lsnif_bytes, 0u);
  scene::Scene no_object = scene_;
  no_object.instances.erase(no_object.instances.begin());
  ASSERT_TRUE(renderer.render(no_object, small(true), empty, se));
  // The noise floor: a reference with independent random sequences (samples 1000..1007).
  render::RenderSettings other = small(true);
  other.first_sample = 1000;
  image::Image ref2;
  ASSERT_TRUE(renderer.render(scene_, other, ref2, se));
  dump(ref, "reference");
  dump(lsnif, "lsnif");
  dump(empty, "no_object");
  // LDR-FLIP (the renders are in [0, ~1.2]; LDR-FLIP clamps to [0, 1] as a display would).
  flip::FlipSettings fs;
  fs.heatmap = false;
  flip::FlipResult f_lsnif, f_empty, f_noise;
  ASSERT_TRUE(flip::ldr_flip(ref, lsnif, fs, f_lsnif));
  ASSERT_TRUE(flip::ldr_flip(ref, empty, fs, f_empty));
  ASSERT_TRUE(flip::ldr_flip(ref, ref2, fs, f_noise));
  std::printf("mean FLIP vs reference: LSNIF %.4f, object removed %.4f, independent 8-spp reference %.4f\n",
              f_lsnif.stats.mean, f_empty.stats.mean, f_noise.stats.mean);
  // The bound: with the same random sequences, replacing the mesh by the LSNIF model must change the
  // image less than the Monte Carlo noise of this sample count does (an independent reference), and
  // far less than removing the object.
  EXPECT_LT(f_lsnif.stats.mean, f_noise.stats.mean);
  EXPECT_LT(f_lsnif.stats.mean, 0.5 * f_empty.stats.mean);
  const double d_lsnif = mean_abs_diff(ref, lsnif), d_empty = mean_abs_diff(ref, empty);
  std::printf("mean |ref - lsnif| %.4f, mean |ref - no object| %.4f, mean ref %.4f; LSNIF %.1f ms/sample, "
              "reference %.1f ms/sample\n",
              d_lsnif, d_empty, mean(ref), sl.ms_per_sample, sr.ms_per_sample);
  EXPECT_GT(d_empty, 0.02);           // the object matters in this view
  EXPECT_LT(d_lsnif, 0.35 * d_empty);  // and the LSNIF object stands in for it
}

TEST_F(RenderTest, BadScenesGiveClearErrors) {
  render::Renderer renderer(vk_);
  image::Image out;
  render::RenderStats s;
  scene::Scene bad = scene_;
  bad.instances[1].object_to_world[3][0] = std::nanf("");
  Status st = renderer.render(bad, small(true), out, s);
  EXPECT_FALSE(st);
  EXPECT_NE(st.message().find("non-finite"), std::string::npos) << st.message();
  bad = scene_;
  bad.instances[0].mesh = -1;  // LSNIF only: no reference geometry
  st = renderer.render(bad, small(true), out, s);
  EXPECT_FALSE(st);
  EXPECT_NE(st.message().find("reference"), std::string::npos) << st.message();
  bad = scene_;
  bad.lsnif_objects[0].model_path = "/nonexistent/x.lsnif";
  st = renderer.render(bad, small(false), out, s);
  EXPECT_FALSE(st);
  EXPECT_NE(st.message().find("x.lsnif"), std::string::npos) << st.message();
  bad = scene_;
  bad.instances.clear();
  EXPECT_FALSE(renderer.render(bad, small(true), out, s));
}

}  // namespace
}  // namespace lsnif
