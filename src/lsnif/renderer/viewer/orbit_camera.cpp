// orbit_camera.cpp -- yaw/pitch/distance about a target; see orbit_camera.h.
#include "lsnif/renderer/viewer/orbit_camera.h"

#include <algorithm>
#include <cmath>

namespace lsnif::viewer {

namespace {
constexpr float kMaxPitch = 89.0f * 3.14159265f / 180.0f;
}

// forward = (cos p sin y, sin p, -cos p cos y): yaw 0, pitch 0 looks down -z like a glTF camera.
glm::vec3 OrbitCamera::forward() const {
  return {std::cos(pitch_) * std::sin(yaw_), std::sin(pitch_), -std::cos(pitch_) * std::cos(yaw_)};
}

void OrbitCamera::set(const glm::mat4& camera_to_world, float distance, float yfov) {
  const glm::vec3 eye(camera_to_world[3]);
  glm::vec3 f = -glm::vec3(camera_to_world[2]);
  const float len = glm::length(f);
  f = len > 0.0f ? f / len : glm::vec3(0, 0, -1);
  pitch_ = std::clamp(std::asin(std::clamp(f.y, -1.0f, 1.0f)), -kMaxPitch, kMaxPitch);
  yaw_ = std::atan2(f.x, -f.z);
  distance_ = distance > 0.0f && std::isfinite(distance) ? distance : 1.0f;
  yfov_ = yfov;
  target_ = eye + forward() * distance_;
}

void OrbitCamera::orbit(float yaw, float pitch) {
  yaw_ += yaw;
  pitch_ = std::clamp(pitch_ + pitch, -kMaxPitch, kMaxPitch);
}

void OrbitCamera::dolly(float factor) {
  if (factor > 0.0f && std::isfinite(factor)) distance_ = std::max(distance_ * factor, 1e-4f);
}

void OrbitCamera::fly(float right, float up, float forward_amount) {
  const glm::mat4 m = camera_to_world();
  target_ += distance_ * (right * glm::vec3(m[0]) + up * glm::vec3(m[1]) - forward_amount * glm::vec3(m[2]));
}

glm::vec3 OrbitCamera::eye() const { return target_ - forward() * distance_; }

glm::mat4 OrbitCamera::camera_to_world() const {
  const glm::vec3 f = forward();
  const glm::vec3 right = glm::normalize(glm::vec3(std::cos(yaw_), 0.0f, std::sin(yaw_)));
  const glm::vec3 up = glm::cross(right, f);
  return glm::mat4(glm::vec4(right, 0), glm::vec4(up, 0), glm::vec4(-f, 0), glm::vec4(eye(), 1));
}

}  // namespace lsnif::viewer
