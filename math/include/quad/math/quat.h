// Hamilton quaternion, scalar first. Project convention: q = q_IB rotates body (FRD) vectors into the
// inertial (NED) frame, v_I = q (x) v_B (x) q^-1   (thesis eq. 3.14).
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

inline Quat operator*(const Quat& q, float s) { return {q.w * s, q.x * s, q.y * s, q.z * s}; }
inline Quat operator+(const Quat& a, const Quat& b) { return {a.w + b.w, a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Quat operator-(const Quat& q) { return {-q.w, -q.x, -q.y, -q.z}; }

// P (x) Q = [p0 q0 - p.q ; p0 q + q0 p + p x q]   (thesis eq. 3.11)
inline Quat operator*(const Quat& p, const Quat& q) {
  return {p.w * q.w - p.x * q.x - p.y * q.y - p.z * q.z,
          p.w * q.x + p.x * q.w + p.y * q.z - p.z * q.y,
          p.w * q.y - p.x * q.z + p.y * q.w + p.z * q.x,
          p.w * q.z + p.x * q.y - p.y * q.x + p.z * q.w};
}

inline float dot(const Quat& a, const Quat& b) { return a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z; }
inline float norm_sq(const Quat& q) { return dot(q, q); }
inline float norm(const Quat& q) { return sqrtf(dot(q, q)); }

// Q^-1 = [q0; -q]   (thesis eq. 3.12, for unit quaternions)
inline Quat conjugate(const Quat& q) { return {q.w, -q.x, -q.y, -q.z}; }

// Unit quaternion along q; a zero or non-finite input yields the identity instead of NaN.
inline Quat normalized(const Quat& q) {
  const float n2 = norm_sq(q);
  if (!(n2 > 1e-20f) || !is_finite(n2)) return Quat::identity();
  return q * (1.0f / sqrtf(n2));
}

// The representative with a non-negative scalar part: q and -q are the same attitude, and controllers
// that act on the vector part must use this one to turn the short way.
inline Quat canonical(const Quat& q) { return q.w < 0.0f ? -q : q; }

inline bool is_finite(const Quat& q) { return is_finite(q.w) && is_finite(q.x) && is_finite(q.y) && is_finite(q.z); }

// v_I = q (x) [0 v_B] (x) q^-1 for a unit q, in the cheap form v + 2 w (u x v) + 2 u x (u x v).
inline Vec3 rotate(const Quat& q, const Vec3& v) {
  const Vec3 u = q.vec();
  const Vec3 t = cross(u, v) * 2.0f;
  return v + t * q.w + cross(u, t);
}

// v_B = q^-1 (x) [0 v_I] (x) q: inertial to body.
inline Vec3 rotate_inverse(const Quat& q, const Vec3& v) { return rotate(conjugate(q), v); }

// R(Q), the Rodrigues map   (thesis eq. 3.16/3.18); R = R_IB for q = q_IB.
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

// Quaternion to Euler angles   (thesis eq. 3.20, corrected per the errata: factors of 2, asin with a
// clamped argument). At pitch = +-90 deg roll and yaw are not separable; the result then puts the whole
// heading into yaw and sets roll to 0 so it stays finite and consistent.
Euler to_euler(const Quat& q);

// Rotation vector (axis * angle) to quaternion and back.
Quat from_rotation_vector(const Vec3& rv);
Vec3 to_rotation_vector(const Quat& q);

// The attitude propagator of thesis eq. 4.11/4.14:
//   exp(T/2 A(Omega)) = cos(T|Omega|/2) I4 + T/2 sinc(T|Omega|/2) A(Omega)
// applied to q. A(Omega) q = q (x) [0 Omega], so this is q (x) dq with dq the exact rotation of the body
// turning at the constant body rate Omega for T seconds.
Quat integrate_exact(const Quat& q, const Vec3& omega, float dt);

// Thesis sec. 4.3: the same propagator with cos and sinc replaced by their second-order Taylor terms,
// cos(x) ~ 1 - x^2/2 and sinc(x) ~ 1 - x^2/6 (no trigonometric calls: the APM 2.5 form). The result is
// renormalised so the small norm error of the approximation does not accumulate.
Quat integrate_second_order(const Quat& q, const Vec3& omega, float dt);

// Smallest angle between two attitudes, in [0, pi].
float angle_between(const Quat& a, const Quat& b);

}  // namespace quad
