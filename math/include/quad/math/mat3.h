// 3x3 matrix (row-major) for rotations, inertia, projections and skew operators.
#pragma once

#include "quad/math/vec3.h"

namespace quad {

struct Mat3 {
  float m[3][3] = {{0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 0.0f}};

  float& operator()(int r, int c) { return m[r][c]; }
  float operator()(int r, int c) const { return m[r][c]; }

  static Mat3 identity() { return diag(1.0f, 1.0f, 1.0f); }
  static Mat3 diag(float a, float b, float c) {
    Mat3 r;
    r.m[0][0] = a;
    r.m[1][1] = b;
    r.m[2][2] = c;
    return r;
  }
  static Mat3 from_rows(const Vec3& r0, const Vec3& r1, const Vec3& r2) {
    Mat3 r;
    for (int i = 0; i < 3; ++i) {
      r.m[0][i] = r0[i];
      r.m[1][i] = r1[i];
      r.m[2][i] = r2[i];
    }
    return r;
  }
  Vec3 row(int r) const { return {m[r][0], m[r][1], m[r][2]}; }
  Vec3 col(int c) const { return {m[0][c], m[1][c], m[2][c]}; }
};

QUAD_MATH_FN Vec3 operator*(const Mat3& a, const Vec3& v) {
  return {a.m[0][0] * v.x + a.m[0][1] * v.y + a.m[0][2] * v.z,
          a.m[1][0] * v.x + a.m[1][1] * v.y + a.m[1][2] * v.z,
          a.m[2][0] * v.x + a.m[2][1] * v.y + a.m[2][2] * v.z};
}

QUAD_MATH_FN Mat3 operator*(const Mat3& a, const Mat3& b) {
  Mat3 r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = a.m[i][0] * b.m[0][j] + a.m[i][1] * b.m[1][j] + a.m[i][2] * b.m[2][j];
  return r;
}

QUAD_MATH_FN Mat3 operator+(const Mat3& a, const Mat3& b) {
  Mat3 r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = a.m[i][j] + b.m[i][j];
  return r;
}

QUAD_MATH_FN Mat3 operator-(const Mat3& a, const Mat3& b) {
  Mat3 r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = a.m[i][j] - b.m[i][j];
  return r;
}

QUAD_MATH_FN Mat3 operator*(const Mat3& a, float s) {
  Mat3 r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = a.m[i][j] * s;
  return r;
}

QUAD_MATH_FN Mat3 transpose(const Mat3& a) {
  Mat3 r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = a.m[j][i];
  return r;
}

// Mat3^T v without forming the transpose (inertial -> body with a DCM R_IB).
QUAD_MATH_FN Vec3 mul_transpose(const Mat3& a, const Vec3& v) {
  return {a.m[0][0] * v.x + a.m[1][0] * v.y + a.m[2][0] * v.z,
          a.m[0][1] * v.x + a.m[1][1] * v.y + a.m[2][1] * v.z,
          a.m[0][2] * v.x + a.m[1][2] * v.y + a.m[2][2] * v.z};
}

QUAD_MATH_FN Mat3 outer(const Vec3& a, const Vec3& b) {
  return Mat3::from_rows(b * a.x, b * a.y, b * a.z);
}

QUAD_MATH_FN float determinant(const Mat3& a) {
  return a.m[0][0] * (a.m[1][1] * a.m[2][2] - a.m[1][2] * a.m[2][1]) -
         a.m[0][1] * (a.m[1][0] * a.m[2][2] - a.m[1][2] * a.m[2][0]) +
         a.m[0][2] * (a.m[1][0] * a.m[2][1] - a.m[1][1] * a.m[2][0]);
}

// sk(x): x cross y = sk(x) y   (thesis eq. 3.17; the OCR'd third row has a sign typo, this is the
// standard form whose (2,1) entry is +x1).
QUAD_MATH_FN Mat3 skew(const Vec3& x) {
  Mat3 r;
  r.m[0][1] = -x.z;
  r.m[0][2] = x.y;
  r.m[1][0] = x.z;
  r.m[1][2] = -x.x;
  r.m[2][0] = -x.y;
  r.m[2][1] = x.x;
  return r;
}

// pi_x := ||x|| I - x x^T   (thesis eq. 4.7/4.8, exactly as printed: for a unit x it is the orthogonal
// projector onto the plane normal to x; for other x it also scales, which eq. 4.8 relies on).
QUAD_MATH_FN Mat3 projection(const Vec3& x) { return Mat3::identity() * norm(x) - outer(x, x); }

// pi_x y without forming the matrix: ||x|| y - x (x . y).
QUAD_MATH_FN Vec3 project(const Vec3& x, const Vec3& y) { return y * norm(x) - x * dot(x, y); }

QUAD_MATH_FN bool is_finite(const Mat3& a) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (!is_finite(a.m[i][j])) return false;
  return true;
}

}  // namespace quad
