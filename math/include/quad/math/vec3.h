// Three-vector for the flight core (NED / FRD components, SI units).
#pragma once

#include "quad/math/scalar.h"

namespace quad {

struct Vec3 {
  float x = 0.0f;
  float y = 0.0f;
  float z = 0.0f;

  constexpr Vec3() = default;
  constexpr Vec3(float x_, float y_, float z_) : x(x_), y(y_), z(z_) {}

  float& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
  float operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }

  Vec3& operator+=(const Vec3& o) { x += o.x; y += o.y; z += o.z; return *this; }
  Vec3& operator-=(const Vec3& o) { x -= o.x; y -= o.y; z -= o.z; return *this; }
  Vec3& operator*=(float s) { x *= s; y *= s; z *= s; return *this; }
};

QUAD_MATH_FN Vec3 operator+(const Vec3& a, const Vec3& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
QUAD_MATH_FN Vec3 operator-(const Vec3& a, const Vec3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
QUAD_MATH_FN Vec3 operator-(const Vec3& a) { return {-a.x, -a.y, -a.z}; }
QUAD_MATH_FN Vec3 operator*(const Vec3& a, float s) { return {a.x * s, a.y * s, a.z * s}; }
QUAD_MATH_FN Vec3 operator*(float s, const Vec3& a) { return {a.x * s, a.y * s, a.z * s}; }

QUAD_MATH_FN float dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

QUAD_MATH_FN Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}

// Element-wise product (diagonal gain matrices times a vector).
QUAD_MATH_FN Vec3 hadamard(const Vec3& a, const Vec3& b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }

QUAD_MATH_FN float norm_sq(const Vec3& a) { return dot(a, a); }
QUAD_MATH_FN float norm(const Vec3& a) { return sqrtf(dot(a, a)); }

// Unit vector along a; the zero vector (or anything shorter than `eps`) maps to zero rather than NaN,
// so callers can test the result instead of guarding every division.
QUAD_MATH_FN Vec3 normalized(const Vec3& a, float eps = 1e-12f) {
  const float n2 = norm_sq(a);
  if (!(n2 > eps * eps)) return Vec3{};
  return a * (1.0f / sqrtf(n2));
}

QUAD_MATH_FN bool is_finite(const Vec3& a) { return is_finite(a.x) && is_finite(a.y) && is_finite(a.z); }

// sat_Delta(x) = x min(1, Delta/||x||)   (thesis eq. 4.9)
QUAD_MATH_FN Vec3 sat_delta(const Vec3& x, float delta) {
  const float n2 = norm_sq(x);
  if (n2 <= delta * delta) return x;
  return x * (delta / sqrtf(n2));
}

}  // namespace quad
