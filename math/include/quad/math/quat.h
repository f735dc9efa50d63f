// Hamilton quaternion, scalar first. Project convention: q = q_IB rotates body (FRD) vectors into the
// inertial (NED) frame, v_I = q (x) v_B (x) q^-1   (thesis eq. 3.14).
//
// Non-unit input (|q| != 1, e.g. an integrator's drift). Below, q = s u with u a unit quaternion, s = |q|:
//  - normalising, scale-invariant (any non-zero q gives the result for u): normalized, to_euler,
//    to_rotation_vector, angle_between, integrate_second_order (unit result);
//  - homogeneous, the norm passes through: operator*, conjugate, canonical (sign only), integrate_exact;
//  - unit-only hot-path forms, no normalisation (they run in the AVR control loop): to_dcm and rotate
//    apply s^2 R(u) + (1 - s^2) I, rotate_inverse its transpose, see there. Normalise first if |q| may be off.
#pragma once

#include "quad/math/mat3.h"

namespace quad {

struct Quat {
  float w = 1.0f;
  float x = 0.0f;
  float y = 0.0f;
  float z = 0.0f;

  constexpr Quat() = default;
  constexpr Quat(float w_, float x_, float y_, float z_) : w(w_), x(x_), y(y_), z(z_) {}
  static constexpr Quat identity() { return Quat{}; }
  Vec3 vec() const { return {x, y, z}; }
};

QUAD_MATH_FN Quat operator*(const Quat& q, float s) { return {q.w * s, q.x * s, q.y * s, q.z * s}; }
QUAD_MATH_FN Quat operator+(const Quat& a, const Quat& b) { return {a.w + b.w, a.x + b.x, a.y + b.y, a.z + b.z}; }
QUAD_MATH_FN Quat operator-(const Quat& q) { return {-q.w, -q.x, -q.y, -q.z}; }

// P (x) Q = [p0 q0 - p.q ; p0 q + q0 p + p x q]   (thesis eq. 3.11). No normalisation: |P Q| = |P| |Q|.
QUAD_MATH_FN Quat operator*(const Quat& p, const Quat& q) {
  return {p.w * q.w - p.x * q.x - p.y * q.y - p.z * q.z,
          p.w * q.x + p.x * q.w + p.y * q.z - p.z * q.y,
          p.w * q.y - p.x * q.z + p.y * q.w + p.z * q.x,
          p.w * q.z + p.x * q.y - p.y * q.x + p.z * q.w};
}

QUAD_MATH_FN float dot(const Quat& a, const Quat& b) { return a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z; }
QUAD_MATH_FN float norm_sq(const Quat& q) { return dot(q, q); }
QUAD_MATH_FN float norm(const Quat& q) { return sqrtf(dot(q, q)); }

// Q* = [q0; -q], which is Q^-1 (thesis eq. 3.12) for a unit Q. For any Q, Q (x) Q* = |Q|^2 [1; 0], so the
// inverse of a non-unit Q is Q* / |Q|^2; this function does not divide.
QUAD_MATH_FN Quat conjugate(const Quat& q) { return {q.w, -q.x, -q.y, -q.z}; }

// Unit quaternion along q; a zero (|q| <= 1e-10), overflowing (|q|^2 not finite in float, |q| >~ 1.8e19)
// or non-finite input yields the identity instead of NaN.
QUAD_MATH_FN Quat normalized(const Quat& q) {
  const float n2 = q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z;  // norm_sq, inline (hot path)
  if (!(n2 > 1e-20f) || !is_finite(n2)) return Quat::identity();
  const float s = 1.0f / sqrtf(n2);
  return {q.w * s, q.x * s, q.y * s, q.z * s};
}

// The representative with a non-negative scalar part: q and -q are the same attitude, and controllers
// that act on the vector part must use this one to turn the short way.
QUAD_MATH_FN Quat canonical(const Quat& q) { return q.w < 0.0f ? -q : q; }

QUAD_MATH_FN bool is_finite(const Quat& q) { return is_finite(q.w) && is_finite(q.x) && is_finite(q.y) && is_finite(q.z); }
// A received attitude worth normalising: finite and not far from unit norm.
QUAD_MATH_FN bool usable_attitude(const Quat& q) { return is_finite(q) && norm_sq(q) > 0.5f; }

// v_I = q (x) [0 v_B] (x) q^-1 for a unit q, in the cheap form v + 2 w (u x v) + 2 u x (u x v).
// No normalisation (hot path). For a non-unit q = s u (u unit, s = |q|) the result is exactly
// to_dcm(q) v = s^2 R(u) v + (1 - s^2) v = R(u) v + (s^2 - 1)(R(u) - I) v: neither R(u) v (what the
// sandwich of eq. 3.14 gives for any |q|) nor s^2 R(u) v. Its error against R(u) v is at most
// 2 |s^2 - 1| |v|, about 4 |s - 1| |v| for a small drift of the norm.
// Written out in components (same operations in the same order as t = 2 u x v, v + w t + u x t): on the
// AVR the vector helpers are calls, and this is a hot path.
QUAD_MATH_FN Vec3 rotate(const Quat& q, const Vec3& v) {
  const float tx = (q.y * v.z - q.z * v.y) * 2.0f;
  const float ty = (q.z * v.x - q.x * v.z) * 2.0f;
  const float tz = (q.x * v.y - q.y * v.x) * 2.0f;
  return {v.x + tx * q.w + (q.y * tz - q.z * ty), v.y + ty * q.w + (q.z * tx - q.x * tz),
          v.z + tz * q.w + (q.x * ty - q.y * tx)};
}

// v_B = q^-1 (x) [0 v_I] (x) q: inertial to body, for a unit q. rotate() of conjugate(q): for q = s u it
// gives s^2 R(u)^T v + (1 - s^2) v (error at most 2 |s^2 - 1| |v|, as above).
QUAD_MATH_FN Vec3 rotate_inverse(const Quat& q, const Vec3& v) { return rotate(conjugate(q), v); }

// R(Q), the Rodrigues map   (thesis eq. 3.16/3.18); R = R_IB for q = q_IB, for a unit q.
// No normalisation (hot path). It evaluates eq. 3.18 as printed (1 - 2 (q2^2 + q3^2) on the diagonal), which
// uses |q| = 1: for a non-unit q = s u (u unit, s = |q|) it gives s^2 R(u) + (1 - s^2) I (the matrix of
// rotate(q, .)), not orthogonal, and not the s^2 R(u) of the homogeneous eq. 3.16. Normalise first if |q|
// may be off; the error against R(u) is (s^2 - 1)(R(u) - I), at most 2 |s^2 - 1| in the 2-norm.
Mat3 to_dcm(const Quat& q);

// Inverse of eq. 3.18 (Shepperd's method: picks the largest pivot, so it is accurate for every
// rotation, including angles near pi). Returns the representative with w >= 0.
Quat from_dcm(const Mat3& r);

// ZYX (yaw-pitch-roll) Euler angles, radians.
struct Euler {
  float roll = 0.0f;
  float pitch = 0.0f;
  float yaw = 0.0f;
};

// R = Rz(psi) Ry(theta) Rx(phi)   (thesis eq. 3.8)
Mat3 dcm_from_euler(const Euler& e);

// Euler angles to quaternion   (thesis eq. 3.19)
Quat from_euler(const Euler& e);

// Quaternion to Euler angles   (thesis eq. 3.20, corrected per the errata: factors of 2, pitch with
// sin(pitch) = 2 (q0 q2 - q1 q3) in [-1, 1]). Computed in a robust equivalent form (pitch by atan2 of
// sin against cos, roll and yaw from the half-angle pairs (roll + yaw)/2 and (yaw - roll)/2, see quat.cpp):
// the angles describe the attitude to float round-off (~1e-6) for every pitch, including near +-90 deg.
// Any non-zero q (normalised internally; zero or non-finite gives all zeros). Pitch is in [-90, 90] deg.
// Within ~4.5e-7 rad of pitch = +-90 deg (gimbal lock) roll and yaw are not separable; the result then
// puts the whole heading into yaw and sets roll to 0 so it stays finite and consistent.
Euler to_euler(const Quat& q);

// Rotation vector (axis * angle) to quaternion (unit) and back. to_rotation_vector takes any non-zero q
// (normalised internally) and returns the angle in [0, pi] (the w >= 0 representative).
Quat from_rotation_vector(const Vec3& rv);
Vec3 to_rotation_vector(const Quat& q);

// The attitude propagator of thesis eq. 4.11/4.14:
//   exp(T/2 A(Omega)) = cos(T|Omega|/2) I4 + T/2 sinc(T|Omega|/2) A(Omega)
// applied to q. A(Omega) q = q (x) [0 Omega], so this is q (x) dq with dq the exact rotation of the body
// turning at the constant body rate Omega for T seconds. No normalisation: |result| = |q| (dq is unit).
Quat integrate_exact(const Quat& q, const Vec3& omega, float dt);

// Thesis sec. 4.3: the same propagator with cos and sinc replaced by their second-order Taylor terms,
// cos(x) ~ 1 - x^2/2 and sinc(x) ~ 1 - x^2/6 (no trigonometric calls: the APM 2.5 form). The result is
// renormalised so the small norm error of the approximation does not accumulate; a non-unit q therefore
// gives the same unit result as q / |q|.
Quat integrate_second_order(const Quat& q, const Vec3& omega, float dt);

// Smallest angle between two attitudes, in [0, pi]. Any non-zero a, b (normalised internally), either sign.
float angle_between(const Quat& a, const Quat& b);

}  // namespace quad
