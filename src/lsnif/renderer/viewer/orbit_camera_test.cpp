// The viewer's orbit camera against direct geometry: it starts exactly where it is put, orbiting
// keeps the eye on the sphere about the target and the target fixed, dolly scales the distance,
// fly translates eye and target alike, and the basis stays orthonormal with +y up.
#include "lsnif/renderer/viewer/orbit_camera.h"

#include <gtest/gtest.h>

#include <cmath>

#include <glm/gtc/matrix_transform.hpp>

namespace lsnif::viewer {
namespace {

glm::mat4 look_at_camera(glm::vec3 eye, glm::vec3 target) {
  return glm::inverse(glm::lookAt(eye, target, glm::vec3(0, 1, 0)));  // view -> camera-to-world
}

void expect_near(glm::vec3 a, glm::vec3 b, float tol = 1e-4f) {
  EXPECT_NEAR(a.x, b.x, tol);
  EXPECT_NEAR(a.y, b.y, tol);
  EXPECT_NEAR(a.z, b.z, tol);
}

void expect_orthonormal(const glm::mat4& m) {
  const glm::vec3 r(m[0]), u(m[1]), b(m[2]);
  EXPECT_NEAR(glm::length(r), 1.0f, 1e-5f);
  EXPECT_NEAR(glm::length(u), 1.0f, 1e-5f);
  EXPECT_NEAR(glm::length(b), 1.0f, 1e-5f);
  EXPECT_NEAR(glm::dot(r, u), 0.0f, 1e-5f);
  EXPECT_NEAR(glm::dot(r, b), 0.0f, 1e-5f);
  EXPECT_NEAR(r.y, 0.0f, 1e-5f);  // no roll
  EXPECT_GT(u.y, 0.0f);
  expect_near(glm::cross(r, u), b, 1e-5f);  // right-handed
}

TEST(OrbitCamera, StartsWhereItIsPut) {
  const glm::vec3 eye(1.0f, 2.0f, 3.0f), target(-0.5f, 0.3f, 0.2f);
  const glm::mat4 m = look_at_camera(eye, target);
  OrbitCamera cam;
  cam.set(m, glm::length(target - eye), 0.7f);
  const glm::mat4 back = cam.camera_to_world();
  for (int c = 0; c < 4; ++c) expect_near(glm::vec3(back[c]), glm::vec3(m[c]));
  expect_near(cam.target(), target);
  EXPECT_FLOAT_EQ(cam.yfov(), 0.7f);
}

TEST(OrbitCamera, OrbitKeepsTargetAndDistance) {
  const glm::vec3 eye(0.0f, 1.0f, 4.0f), target(0.0f, 0.5f, 0.0f);
  OrbitCamera cam;
  cam.set(look_at_camera(eye, target), glm::length(target - eye), 0.8f);
  for (int i = 0; i < 20; ++i) {
    cam.orbit(0.37f, i % 2 ? 0.2f : -0.15f);
    expect_near(cam.target(), target);
    EXPECT_NEAR(glm::length(cam.eye() - target), glm::length(target - eye), 1e-4f);
    const glm::mat4 m = cam.camera_to_world();
    expect_orthonormal(m);
    expect_near(-glm::vec3(m[2]), glm::normalize(target - cam.eye()), 1e-4f);  // still looks at the target
  }
  // Quarter turn about +y from looking down -z: now looking down +x (yaw is about +y, clockwise from above).
  OrbitCamera q;
  q.set(look_at_camera(glm::vec3(0, 0, 2), glm::vec3(0)), 2.0f, 0.8f);
  q.orbit(float(M_PI / 2), 0.0f);
  expect_near(-glm::vec3(q.camera_to_world()[2]), glm::vec3(1, 0, 0));
  expect_near(q.eye(), glm::vec3(-2, 0, 0));
}

TEST(OrbitCamera, PitchIsClampedShortOfThePoles) {
  OrbitCamera cam;
  cam.set(look_at_camera(glm::vec3(0, 0, 2), glm::vec3(0)), 2.0f, 0.8f);
  cam.orbit(0.0f, 10.0f);
  const glm::mat4 m = cam.camera_to_world();
  expect_orthonormal(m);
  EXPECT_NEAR(std::asin(-m[2].y), 89.0f * float(M_PI) / 180.0f, 1e-4f);
}

TEST(OrbitCamera, DollyScalesAndFlyTranslates) {
  const glm::vec3 eye(2.0f, 1.0f, 2.0f), target(0.0f);
  OrbitCamera cam;
  cam.set(look_at_camera(eye, target), glm::length(eye), 0.8f);
  cam.dolly(0.5f);
  EXPECT_NEAR(cam.distance(), 0.5f * glm::length(eye), 1e-5f);
  expect_near(cam.target(), target);
  cam.dolly(-1.0f);  // ignored
  cam.dolly(NAN);    // ignored
  EXPECT_NEAR(cam.distance(), 0.5f * glm::length(eye), 1e-5f);
  const glm::mat4 before = cam.camera_to_world();
  const glm::vec3 eye0 = cam.eye(), target0 = cam.target();
  cam.fly(0.1f, 0.2f, 0.3f);
  const glm::vec3 expected = cam.distance() * (0.1f * glm::vec3(before[0]) + 0.2f * glm::vec3(before[1]) -
                                               0.3f * glm::vec3(before[2]));
  expect_near(cam.eye() - eye0, expected);
  expect_near(cam.target() - target0, expected);
}

}  // namespace
}  // namespace lsnif::viewer
