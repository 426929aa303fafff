// Render-time scene edits: transforms parsed from the command line against hand-computed points,
// node transforms replaced on every instance of the node, pre-trained objects added with their own
// material, and clear errors for bad text, unknown nodes, singular matrices and missing models.
#include "lsnif/scene/scene_edit.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

namespace lsnif::scene {
namespace {

glm::vec3 apply(const glm::mat4& m, glm::vec3 p) { return glm::vec3(m * glm::vec4(p, 1.0f)); }

void expect_near(glm::vec3 a, glm::vec3 b) {
  EXPECT_NEAR(a.x, b.x, 1e-5f);
  EXPECT_NEAR(a.y, b.y, 1e-5f);
  EXPECT_NEAR(a.z, b.z, 1e-5f);
}

TEST(SceneEdit, ParsesTranslationScaleAndRotation) {
  glm::mat4 m;
  ASSERT_TRUE(parse_transform("1,2,3", m));
  expect_near(apply(m, {0, 0, 0}), {1, 2, 3});
  expect_near(apply(m, {1, 1, 1}), {2, 3, 4});
  ASSERT_TRUE(parse_transform("1,2,3,2", m));
  expect_near(apply(m, {1, 0, 0}), {3, 2, 3});
  // 90 degrees about +y turns +x into -z (right-handed), then scale 2, then translate.
  ASSERT_TRUE(parse_transform("0.5,0,-1,2,90", m));
  expect_near(apply(m, {1, 0, 0}), {0.5f, 0, -3});
  expect_near(apply(m, {0, 1, 0}), {0.5f, 2, -1});
  expect_near(apply(m, {0, 0, 1}), {2.5f, 0, -1});
  // Twelve numbers: row-major 3x4.
  ASSERT_TRUE(parse_transform("0,-1,0,5, 1,0,0,6, 0,0,1,7", m));
  expect_near(apply(m, {1, 0, 0}), {5, 7, 7});
  expect_near(apply(m, {0, 1, 0}), {4, 6, 7});
}

TEST(SceneEdit, ParsesPoints) {
  glm::vec3 p(0.0f);
  ASSERT_TRUE(parse_point("1,-2,3.5", "--look-at", p));
  EXPECT_EQ(p, glm::vec3(1, -2, 3.5f));
  for (const char* bad : {"1,2", "1,2,3,4", "1,x,3", "1,2,inf", "1e39,0,0", ""}) {
    const Status s = parse_point(bad, "--look-at", p);
    EXPECT_FALSE(s) << bad;
    EXPECT_NE(s.message().find("--look-at"), std::string::npos) << s.message();
  }
}

TEST(SceneEdit, RejectsBadTransformsNamingThem) {
  glm::mat4 m(1.0f);
  for (const char* bad : {"", "1,2", "1,2,3,4,5,6", "1,a,3", "1,2,inf", "1,2,nan", "1,2,3,0", "1,2,3,-1", "1,2,3,",
                          "0,0,0,1, 0,0,0,2, 0,0,1,3", "1e999,0,0"}) {
    const Status s = parse_transform(bad, m);
    EXPECT_FALSE(s) << "'" << bad << "' accepted";
    EXPECT_NE(s.message().find("transform"), std::string::npos) << s.message();
  }
  EXPECT_EQ(m, glm::mat4(1.0f));  // untouched on failure
}

TEST(SceneEdit, ParsesTheSunOption) {
  Sun sun;
  ASSERT_TRUE(parse_sun("0,2,0,3", sun));
  EXPECT_TRUE(sun.enabled);
  EXPECT_EQ(sun.direction, glm::vec3(0, 1, 0));
  EXPECT_EQ(sun.irradiance, glm::vec3(3));
  EXPECT_NEAR(sun.angular_diameter, 0.53 * M_PI / 180.0, 1e-7);
  ASSERT_TRUE(parse_sun("1,0,0,1,2", sun));
  EXPECT_NEAR(sun.angular_diameter, 2.0 * M_PI / 180.0, 1e-7);
  for (const char* bad : {"0,1,0", "0,0,0,1", "0,1,0,-1", "0,1,0,1,0", "0,1,0,1,95", "0,1,x,1", "0,1,0,1,1,1"}) {
    const Status s = parse_sun(bad, sun);
    EXPECT_FALSE(s) << bad;
    EXPECT_NE(s.message().find("--sun"), std::string::npos) << s.message();
  }
}

TEST(SceneEdit, LookAtCameraLooksAtItsTarget) {
  Camera cam;
  ASSERT_TRUE(make_look_at_camera({1, 2, 3}, {0, 0, 0}, 60.0f, "c", cam));
  const glm::vec3 fwd = -glm::vec3(cam.camera_to_world[2]);
  expect_near(fwd, glm::normalize(glm::vec3(-1, -2, -3)));
  expect_near(glm::vec3(cam.camera_to_world[3]), {1, 2, 3});
  EXPECT_NEAR(cam.camera_to_world[0].y, 0.0f, 1e-6f);  // no roll
  EXPECT_GT(cam.camera_to_world[1].y, 0.0f);
  EXPECT_NEAR(cam.yfov, float(M_PI / 3), 1e-6f);
  ASSERT_TRUE(make_look_at_camera({0, 5, 0}, {0, 0, 0}, 30.0f, "down", cam));  // straight down: still a basis
  expect_near(-glm::vec3(cam.camera_to_world[2]), {0, -1, 0});
  EXPECT_NEAR(glm::dot(glm::vec3(cam.camera_to_world[0]), glm::vec3(cam.camera_to_world[1])), 0.0f, 1e-6f);
  EXPECT_FALSE(make_look_at_camera({1, 1, 1}, {1, 1, 1}, 30.0f, "same", cam));
  EXPECT_FALSE(make_look_at_camera({1, 1, 1}, {0, 0, 0}, 180.0f, "wide", cam));
  EXPECT_FALSE(make_look_at_camera({NAN, 1, 1}, {0, 0, 0}, 30.0f, "nan", cam));
}

Scene two_nodes() {
  Scene s;
  s.path = "test.gltf";
  Mesh mesh;
  mesh.name = "tri";
  Primitive p;
  p.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  p.indices = {0, 1, 2};
  mesh.primitives = {p};
  s.meshes = {mesh};
  s.materials = {Material()};
  Instance a, b, c;
  a.node_name = "a";
  a.mesh = 0;
  b.node_name = "b";
  b.mesh = 0;
  c = a;  // a second instance of node name "a"
  s.instances = {a, b, c};
  return s;
}

TEST(SceneEdit, NodeTransformReplacesEveryInstanceOfTheNode) {
  Scene s = two_nodes();
  glm::mat4 m;
  ASSERT_TRUE(parse_transform("0,3,0", m));
  ASSERT_TRUE(set_node_transform(s, "a", m));
  EXPECT_EQ(s.instances[0].object_to_world, m);
  EXPECT_EQ(s.instances[2].object_to_world, m);
  EXPECT_EQ(s.instances[1].object_to_world, glm::mat4(1.0f));
  const Status unknown = set_node_transform(s, "nobody", m);
  EXPECT_FALSE(unknown);
  EXPECT_NE(unknown.message().find("nobody"), std::string::npos);
  glm::mat4 singular(1.0f);
  singular[1] = glm::vec4(0.0f);
  EXPECT_FALSE(set_node_transform(s, "a", singular));
  glm::mat4 nan_matrix(1.0f);
  nan_matrix[3][0] = std::nanf("");
  EXPECT_FALSE(set_node_transform(s, "b", nan_matrix));
}

TEST(SceneEdit, AddsAPretrainedObjectWithItsOwnMaterial) {
  const std::filesystem::path model = std::filesystem::temp_directory_path() / "lsnif_scene_edit_test.lsnif";
  {
    std::ofstream f(model, std::ios::binary);
    f.write("LSNIF\0\r\n", 8);  // check_lsnif_file reads the magic only
  }
  Scene s = two_nodes();
  glm::mat4 m;
  ASSERT_TRUE(parse_transform("2,0,0", m));
  ASSERT_TRUE(add_lsnif_instance(s, model.string(), m, "added"));
  ASSERT_EQ(s.instances.size(), 4u);
  const Instance& in = s.instances.back();
  EXPECT_EQ(in.node_name, "added");
  EXPECT_EQ(in.mesh, -1);
  ASSERT_EQ(in.lsnif, 0);
  EXPECT_EQ(s.lsnif_objects[0].resolved_path, model.string());
  ASSERT_EQ(s.lsnif_objects[0].material_map.size(), 1u);
  EXPECT_EQ(s.lsnif_objects[0].material_map[0], 1u);  // the new material, after the scene's one
  EXPECT_EQ(s.materials.size(), 2u);
  EXPECT_EQ(in.object_to_world, m);
  const Status missing = add_lsnif_instance(s, "/nonexistent/x.lsnif", m, "x");
  EXPECT_FALSE(missing);
  EXPECT_NE(missing.message().find("x.lsnif"), std::string::npos);
  EXPECT_FALSE(add_lsnif_instance(s, model.string(), m, ""));
  EXPECT_EQ(s.instances.size(), 4u);  // nothing added on failure
  std::filesystem::remove(model);
}

}  // namespace
}  // namespace lsnif::scene
