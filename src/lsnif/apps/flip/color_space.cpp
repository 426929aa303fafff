// color_space.cpp -- the color transforms of FLIP: sRGB transfer, linear RGB <-> XYZ (derived from
// the sRGB primaries and D65), YCxCz, CIELAB, the Hunt adjustment, HyAB and the redistribution of
// the color error (LDR-FLIP paper, section 4.1).
#include <cmath>

#include "lsnif/apps/flip/flip_detail.h"
#include "lsnif/image/image_io.h"

namespace lsnif::flip::detail {
namespace {

using Mat3 = std::array<std::array<double, 3>, 3>;

Mat3 inverse(const Mat3& m) {
  const double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                     m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                     m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
  Mat3 r;
  r[0][0] = (m[1][1] * m[2][2] - m[1][2] * m[2][1]) / det;
  r[0][1] = (m[0][2] * m[2][1] - m[0][1] * m[2][2]) / det;
  r[0][2] = (m[0][1] * m[1][2] - m[0][2] * m[1][1]) / det;
  r[1][0] = (m[1][2] * m[2][0] - m[1][0] * m[2][2]) / det;
  r[1][1] = (m[0][0] * m[2][2] - m[0][2] * m[2][0]) / det;
  r[1][2] = (m[0][2] * m[1][0] - m[0][0] * m[1][2]) / det;
  r[2][0] = (m[1][0] * m[2][1] - m[1][1] * m[2][0]) / det;
  r[2][1] = (m[0][1] * m[2][0] - m[0][0] * m[2][1]) / det;
  r[2][2] = (m[0][0] * m[1][1] - m[0][1] * m[1][0]) / det;
  return r;
}

// RGB -> XYZ: the columns are the primaries' XYZ (x/y, 1, (1-x-y)/y) scaled so that RGB (1, 1, 1)
// lands on the white point's XYZ.
Mat3 make_rgb_to_xyz() {
  const double prim[3][2] = {{0.64, 0.33}, {0.30, 0.60}, {0.15, 0.06}};
  const double wx = 0.3127, wy = 0.3290;
  Mat3 p;
  for (int c = 0; c < 3; ++c) {
    p[0][c] = prim[c][0] / prim[c][1];
    p[1][c] = 1.0;
    p[2][c] = (1.0 - prim[c][0] - prim[c][1]) / prim[c][1];
  }
  const double w[3] = {wx / wy, 1.0, (1.0 - wx - wy) / wy};
  const Mat3 pi = inverse(p);
  double s[3];
  for (int r = 0; r < 3; ++r) s[r] = pi[r][0] * w[0] + pi[r][1] * w[1] + pi[r][2] * w[2];
  Mat3 m;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m[r][c] = p[r][c] * s[c];
  return m;
}

struct Matrices {
  float to_xyz[3][3], to_rgb[3][3];
  float white[3], inv_white[3];
  Matrices() {
    const Mat3 m = make_rgb_to_xyz();
    const Mat3 mi = inverse(m);
    for (int r = 0; r < 3; ++r) {
      double row = 0;
      for (int c = 0; c < 3; ++c) {
        to_xyz[r][c] = float(m[r][c]);
        to_rgb[r][c] = float(mi[r][c]);
        row += m[r][c];
      }
      white[r] = float(row);
      inv_white[r] = float(1.0 / row);
    }
  }
};

const Matrices& matrices() {
  static const Matrices m;
  return m;
}

Vec3 mul(const float m[3][3], const Vec3& v) {
  return {m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2], m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
          m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2]};
}

// CIELAB's f: cube root above (6/29)^3, the linear segment below.
float lab_f(float t) {
  constexpr float delta = 6.0f / 29.0f;
  constexpr float delta3 = delta * delta * delta;
  return t > delta3 ? std::cbrt(t) : t / (3.0f * delta * delta) + 4.0f / 29.0f;
}

}  // namespace

// FLIP's sRGB transfer is the one image_io uses to read and write 8-bit files.
float srgb_to_linear(float c) { return image::srgb_to_linear(c); }
float linear_to_srgb(float c) { return image::linear_to_srgb(c); }

Vec3 linear_rgb_to_xyz(const Vec3& rgb) { return mul(matrices().to_xyz, rgb); }
Vec3 xyz_to_linear_rgb(const Vec3& xyz) { return mul(matrices().to_rgb, xyz); }
Vec3 white_xyz() { return {matrices().white[0], matrices().white[1], matrices().white[2]}; }

Vec3 xyz_to_ycxcz(const Vec3& xyz) {
  const float* iw = matrices().inv_white;
  const float x = xyz[0] * iw[0], y = xyz[1] * iw[1], z = xyz[2] * iw[2];
  return {116.0f * y - 16.0f, 500.0f * (x - y), 200.0f * (y - z)};
}

Vec3 ycxcz_to_xyz(const Vec3& ycxcz) {
  const float* w = matrices().white;
  const float y = (ycxcz[0] + 16.0f) / 116.0f;
  const float x = ycxcz[1] / 500.0f + y;
  const float z = y - ycxcz[2] / 200.0f;
  return {x * w[0], y * w[1], z * w[2]};
}

Vec3 xyz_to_lab(const Vec3& xyz) {
  const float* iw = matrices().inv_white;
  const float fx = lab_f(xyz[0] * iw[0]), fy = lab_f(xyz[1] * iw[1]), fz = lab_f(xyz[2] * iw[2]);
  return {116.0f * fy - 16.0f, 500.0f * (fx - fy), 200.0f * (fy - fz)};
}

Vec3 hunt_adjust(const Vec3& lab) { return {lab[0], 0.01f * lab[0] * lab[1], 0.01f * lab[0] * lab[2]}; }

float hyab(const Vec3& p, const Vec3& q) {
  const float da = p[1] - q[1], db = p[2] - q[2];
  return std::abs(p[0] - q[0]) + std::sqrt(da * da + db * db);
}

Vec3 linear_rgb_to_hunt_lab(const Vec3& rgb) { return hunt_adjust(xyz_to_lab(linear_rgb_to_xyz(rgb))); }

double max_color_error() {
  static const double cmax = [] {
    const Vec3 green = linear_rgb_to_hunt_lab({0.0f, 1.0f, 0.0f});
    const Vec3 blue = linear_rgb_to_hunt_lab({0.0f, 0.0f, 1.0f});
    return std::pow(double(hyab(green, blue)), kQc);
  }();
  return cmax;
}

// The HyAB distance raised to qc is compressed so that the lowest pc of its range [0, cmax^qc]
// takes the error range [0, pt] and the rest the range [pt, 1].
float redistribute_color_error(float hyab_distance) {
  const double cmax = max_color_error();
  const double knee = kPc * cmax;
  const double e = std::pow(double(hyab_distance), kQc);
  const double out = e < knee ? e * (kPt / knee) : kPt + (e - knee) / (cmax - knee) * (1.0 - kPt);
  return float(out);
}

}  // namespace lsnif::flip::detail
