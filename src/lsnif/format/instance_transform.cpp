// instance_transform.cpp -- check_instance_transform (instance_transform.h).
#include "lsnif/format/instance_transform.h"

#include <cmath>

namespace lsnif {

Status check_instance_transform(const float m[3][4]) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c)
      if (!std::isfinite(m[r][c]))
        return Status::error("instance transform entry [%d][%d] = %g is not finite", r, c, double(m[r][c]));
  double a[3][3], norm = 1.0;
  for (int r = 0; r < 3; ++r) {
    double n2 = 0;
    for (int c = 0; c < 3; ++c) {
      a[r][c] = double(m[r][c]);
      n2 += a[r][c] * a[r][c];
    }
    norm *= std::sqrt(n2);
  }
  const double det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
                     a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
                     a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
  if (!(std::fabs(det) > 1e-12 * norm))
    return Status::error("instance transform is singular (det %g, product of row norms %g)", det, norm);
  return Status::ok();
}

}  // namespace lsnif
