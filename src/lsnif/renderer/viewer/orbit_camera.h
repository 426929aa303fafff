// orbit_camera.h -- the viewer's camera: orbit about a target (drag), dolly (scroll) and fly
// (keys move eye and target together). No window code: the viewer feeds it input deltas.
#pragma once
#include <glm/glm.hpp>

namespace lsnif::viewer {

class OrbitCamera {
 public:
  // Starts at `camera_to_world` (looks down -z, y up) with the target `distance` ahead of the eye.
  // The camera's roll is dropped (the orbit keeps +y up).
  void set(const glm::mat4& camera_to_world, float distance, float yfov);

  // Turns about the target by `yaw` (about +y) and `pitch` (about the camera's right axis) radians;
  // the pitch stays within +-89 degrees.
  void orbit(float yaw, float pitch);
  // Moves the eye towards (factor < 1) or away from (factor > 1) the target: distance *= factor.
  void dolly(float factor);
  // Moves eye and target by `right`, `up`, `forward` in units of the target distance.
  void fly(float right, float up, float forward);

  glm::mat4 camera_to_world() const;
  glm::vec3 eye() const;
  glm::vec3 target() const { return target_; }
  float distance() const { return distance_; }
  float yfov() const { return yfov_; }

 private:
  glm::vec3 forward() const;
  glm::vec3 target_{0.0f};
  float distance_ = 1.0f, yaw_ = 0.0f, pitch_ = 0.0f, yfov_ = 0.8f;
};

}  // namespace lsnif::viewer
