// test_support.h -- pieces shared by the end-to-end and GPU tests: the tiny training settings they
// train with, and one skewed instance transform.
#pragma once
#include <glm/glm.hpp>

#include "intersector.h"
#include "trainer.h"

namespace lsnif::test {

// A small, fast model: V=16, H=12, grid 32..64 with 2^14 entries, 2x64 MLP, batches of 2048, no
// progress bar. Callers set the steps, seed and hit parametrization they need.
inline TrainSettings tiny_train_settings() {
  TrainSettings s;
  s.config.voxel_resolution = 16;
  s.config.max_points = 12;
  set_grid_resolutions(s.config, 32, 64);
  s.config.log2_table_size = 14;
  s.config.hidden_width = 64;
  s.batch_size = 2048;
  s.progress = false;
  return s;
}

// Object-to-world rotation * non-uniform scale (2, 0.5, 1.3), then a translation (3, -1, 7).
inline glm::mat3 skewed_linear() {
  const glm::mat3 R = glm::mat3(glm::vec3(0.36f, 0.48f, -0.8f), glm::vec3(-0.8f, 0.6f, 0.0f),
                                glm::vec3(0.48f, 0.64f, 0.6f));
  return R * glm::mat3(glm::vec3(2, 0, 0), glm::vec3(0, 0.5f, 0), glm::vec3(0, 0, 1.3f));
}
inline glm::vec3 skewed_translation() { return glm::vec3(3, -1, 7); }
inline Transform3x4 skewed_instance() {
  const glm::mat3 A = skewed_linear();
  const glm::vec3 T = skewed_translation();
  Transform3x4 xf;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) xf.m[r][c] = A[c][r];
    xf.m[r][3] = T[r];
  }
  return xf;
}

}  // namespace lsnif::test
