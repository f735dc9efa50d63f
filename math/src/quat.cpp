#include "quad/math/quat.h"

namespace quad {

Mat3 to_dcm(const Quat& q) {
  // thesis eq. 3.18. The factor 2 goes into one operand of each product (x2 = x + x): multiplying by two
  // is exact in binary floating point, so the entries are bit-identical to 2 (x y - w z) etc., for nine
  // multiplications instead of eighteen (each one ~150 cycles on the AVR).
  const float w = q.w, x = q.x, y = q.y, z = q.z;
  const float x2 = x + x, y2 = y + y, z2 = z + z;
  const float xx = x * x2, yy = y * y2, zz = z * z2;
  const float xy = x * y2, xz = x * z2, yz = y * z2;
  const float wx = w * x2, wy = w * y2, wz = w * z2;
  Mat3 r;
  r.m[0][0] = 1.0f - (yy + zz);
  r.m[0][1] = xy - wz;
  r.m[0][2] = xz + wy;
  r.m[1][0] = xy + wz;
  r.m[1][1] = 1.0f - (xx + zz);
  r.m[1][2] = yz - wx;
  r.m[2][0] = xz - wy;
  r.m[2][1] = yz + wx;
  r.m[2][2] = 1.0f - (xx + yy);
  return r;
}

Quat from_dcm(const Mat3& r) {
  const float tr = r.m[0][0] + r.m[1][1] + r.m[2][2];
  Quat q;
  if (tr >= r.m[0][0] && tr >= r.m[1][1] && tr >= r.m[2][2]) {
    const float s = 2.0f * safe_sqrtf(1.0f + tr);  // s = 4 w
    q = {0.25f * s, (r.m[2][1] - r.m[1][2]) / s, (r.m[0][2] - r.m[2][0]) / s, (r.m[1][0] - r.m[0][1]) / s};
  } else if (r.m[0][0] >= r.m[1][1] && r.m[0][0] >= r.m[2][2]) {
    const float s = 2.0f * safe_sqrtf(1.0f + r.m[0][0] - r.m[1][1] - r.m[2][2]);  // s = 4 x
    q = {(r.m[2][1] - r.m[1][2]) / s, 0.25f * s, (r.m[0][1] + r.m[1][0]) / s, (r.m[0][2] + r.m[2][0]) / s};
  } else if (r.m[1][1] >= r.m[2][2]) {
    const float s = 2.0f * safe_sqrtf(1.0f - r.m[0][0] + r.m[1][1] - r.m[2][2]);  // s = 4 y
    q = {(r.m[0][2] - r.m[2][0]) / s, (r.m[0][1] + r.m[1][0]) / s, 0.25f * s, (r.m[1][2] + r.m[2][1]) / s};
  } else {
    const float s = 2.0f * safe_sqrtf(1.0f - r.m[0][0] - r.m[1][1] + r.m[2][2]);  // s = 4 z
    q = {(r.m[1][0] - r.m[0][1]) / s, (r.m[0][2] + r.m[2][0]) / s, (r.m[1][2] + r.m[2][1]) / s, 0.25f * s};
  }
  return canonical(normalized(q));
}

Mat3 dcm_from_euler(const Euler& e) {
  // thesis eq. 3.8
  const float cf = cosf(e.roll), sf = sinf(e.roll);
  const float ct = cosf(e.pitch), st = sinf(e.pitch);
  const float cp = cosf(e.yaw), sp = sinf(e.yaw);
  Mat3 r;
  r.m[0][0] = ct * cp;
  r.m[0][1] = sf * st * cp - cf * sp;
  r.m[0][2] = sf * sp + cf * st * cp;
  r.m[1][0] = ct * sp;
  r.m[1][1] = cf * cp + sf * st * sp;
  r.m[1][2] = cf * st * sp - sf * cp;
  r.m[2][0] = -st;
  r.m[2][1] = sf * ct;
  r.m[2][2] = cf * ct;
  return r;
}

Quat from_euler(const Euler& e) {
  // thesis eq. 3.19
  const float cf = cosf(0.5f * e.roll), sf = sinf(0.5f * e.roll);
  const float ct = cosf(0.5f * e.pitch), st = sinf(0.5f * e.pitch);
  const float cp = cosf(0.5f * e.yaw), sp = sinf(0.5f * e.yaw);
  return {cf * ct * cp + sf * st * sp, sf * ct * cp - cf * st * sp, cf * st * cp + sf * ct * sp,
          cf * ct * sp - sf * st * cp};
}

Euler to_euler(const Quat& qin) {
  // thesis eq. 3.20 with the errata applied, in a form that stays accurate up to the pole. The angles are
  // those of eq. 3.20 (sin(pitch) = 2 (w y - x z) as in the erratum's asin); only how they are computed
  // differs, because near pitch = +-90 deg both the erratum's asin and the roll/yaw atan2 of eq. 3.20 lose
  // accuracy (the derivative of asin at 1 is infinite; the atan2 arguments shrink to O(cos(pitch))):
  //  - pitch = atan2(sin, cos) with cos(pitch) = sqrt((1 - sin)(1 + sin)), both factors sums of squares
  //    (no cancellation), so pitch is accurate to float round-off everywhere;
  //  - from eq. 3.19, with ch = cos(pitch/2) and sh = sin(pitch/2):
  //      (w - y, x + z) = (ch - sh) (cos, sin)((roll + yaw)/2),
  //      (w + y, z - x) = (ch + sh) (cos, sin)((yaw - roll)/2),
  //    and |(w - y, x + z)|^2 = 1 - sin(pitch), |(w + y, z - x)|^2 = 1 + sin(pitch). Each half-angle atan2
  //    degrades only where its own pair vanishes, and there its angle is multiplied by cos(pitch) in the
  //    DCM, so the attitude the angles describe stays accurate to float round-off.
  const Quat q = normalized(qin);
  const float a = q.w - q.y, b = q.x + q.z;  // (ch - sh) (cos, sin)((roll + yaw)/2)
  const float c = q.w + q.y, d = q.z - q.x;  // (ch + sh) (cos, sin)((yaw - roll)/2)
  const float one_minus_sp = a * a + b * b, one_plus_sp = c * c + d * d;
  const float sp = 2.0f * (q.w * q.y - q.x * q.z);
  Euler e;
  e.pitch = atan2f(sp, sqrtf(one_minus_sp * one_plus_sp));
  // Gimbal lock only where 1 -+ sin(pitch) < 1e-13, i.e. pitch within ~4.5e-7 rad (a few float steps)
  // of +-90 deg: there the pair is round-off and roll and yaw are not separable. Only
  // yaw - sign(pitch) roll is defined; put it all in yaw, roll = 0 (moves the DCM by <= 2 cos(pitch)).
  if (one_minus_sp < 1e-13f) {  // pitch = +90 deg: yaw - roll
    e.roll = 0.0f;
    e.yaw = wrap_pi(2.0f * atan2f(d, c));
  } else if (one_plus_sp < 1e-13f) {  // pitch = -90 deg: yaw + roll
    e.roll = 0.0f;
    e.yaw = wrap_pi(2.0f * atan2f(b, a));
  } else {
    const float sum = atan2f(b, a), diff = atan2f(d, c);  // (roll + yaw)/2, (yaw - roll)/2
    e.roll = wrap_pi(sum - diff);
    e.yaw = wrap_pi(sum + diff);
  }
  return e;
}

Quat from_rotation_vector(const Vec3& rv) {
  const float angle = norm(rv);
  const float half = 0.5f * angle;
  const float k = 0.5f * sincf(half);  // sin(angle/2)/angle, finite at 0
  return {cosf(half), rv.x * k, rv.y * k, rv.z * k};
}

Vec3 to_rotation_vector(const Quat& qin) {
  const Quat q = canonical(normalized(qin));
  const float s = norm(q.vec());
  if (s < 1e-7f) return q.vec() * 2.0f;  // angle ~ 2 s for tiny rotations
  const float angle = 2.0f * atan2f(s, q.w);
  return q.vec() * (angle / s);
}

namespace {
// c I4 + k A(Omega) applied to q, with k = T/2 * sinc(.) already folded in: c q + q (x) [0, k Omega].
Quat apply_propagator(const Quat& q, const Vec3& omega, float c, float k) {
  const Quat d{c, omega.x * k, omega.y * k, omega.z * k};
  return q * d;
}
}  // namespace

Quat integrate_exact(const Quat& q, const Vec3& omega, float dt) {
  // thesis eq. 4.14 / 4.15
  const float half = 0.5f * dt * norm(omega);
  return apply_propagator(q, omega, cosf(half), 0.5f * dt * sincf(half));
}

Quat integrate_second_order(const Quat& q, const Vec3& omega, float dt) {
  // thesis sec. 4.3: second-order approximation of the trigonometric terms of eq. 4.18
  const float half2 = 0.25f * dt * dt * norm_sq(omega);
  const float c = 1.0f - 0.5f * half2;
  const float k = 0.5f * dt * (1.0f - half2 * (1.0f / 6.0f));
  return normalized(apply_propagator(q, omega, c, k));
}

float angle_between(const Quat& a, const Quat& b) {
  const float d = absf(dot(normalized(a), normalized(b)));
  const float v = norm((conjugate(normalized(a)) * normalized(b)).vec());
  return 2.0f * atan2f(v, d);
}

}  // namespace quad
