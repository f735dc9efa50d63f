#include "quad/estimation/vector_attitude.h"

namespace quad {
namespace est {

namespace {

// Orthonormal triad (north, east, down) of a frame from its "down" direction and a magnetic field
// vector, both expressed in that frame: east = down x m, north = east x down (NED: e3 x e1 = e2).
bool triad(const Vec3& down, const Vec3& mag, Vec3& north, Vec3& east) {
  east = normalized(cross(down, mag), 1e-6f);
  if (norm_sq(east) < 0.5f) return false;  // normalized() returns zero for (near) parallel vectors
  north = cross(east, down);
  return true;
}

bool body_down(const Vec3& accel_frd, Vec3& down) {
  if (!is_finite(accel_frd)) return false;
  // At rest the accelerometer reads -g R^T e_z: "down" is along -a.
  down = normalized(-accel_frd, 1e-3f);
  return norm_sq(down) > 0.5f;
}

}  // namespace

bool attitude_from_vectors(const Vec3& accel_frd, const Vec3& mag_frd, const Vec3& mag_ref_ned, Quat& q_ib) {
  Vec3 d_b;
  if (!body_down(accel_frd, d_b) || !is_finite(mag_frd) || !is_finite(mag_ref_ned)) return false;
  const Vec3 d_i{0.0f, 0.0f, 1.0f};
  Vec3 n_b, e_b, n_i, e_i;
  if (!triad(d_b, mag_frd, n_b, e_b) || !triad(d_i, mag_ref_ned, n_i, e_i)) return false;
  // R_IB maps each body triad vector onto its inertial counterpart: R = sum_k t_I,k t_B,k^T, summed row
  // by row (the same operations as three outer products added): the boot calibration's last iteration
  // is the image's deepest stack, and five 36-byte matrix temporaries would sit on it.
  Mat3 r;
  for (int i = 0; i < 3; ++i) {
    const Vec3 row = n_b * n_i[i] + e_b * e_i[i] + d_b * d_i[i];
    r.m[i][0] = row.x;
    r.m[i][1] = row.y;
    r.m[i][2] = row.z;
  }
  q_ib = from_dcm(r);
  return is_finite(q_ib);
}

bool magnetic_reference_from_sample(const Vec3& accel_frd, const Vec3& mag_frd, Vec3& mag_ref_ned) {
  Vec3 d_b;
  if (!body_down(accel_frd, d_b) || !is_finite(mag_frd)) return false;
  const float down = dot(d_b, mag_frd);
  const float horizontal = norm(mag_frd - d_b * down);
  if (!(horizontal > 1e-6f * norm(mag_frd)) || !is_finite(horizontal)) return false;
  mag_ref_ned = {horizontal, 0.0f, down};
  return true;
}

Quat attitude_from_star(const Quat& q_bs, const Quat& estimate) {
  const Quat q_bs_unit = normalized(q_bs);
  const Quat q_sb = conjugate(q_bs_unit);
  // The candidates are t_k (x) q_sb with t_k the quarter turns about down, (cos, 0, 0, sin) of 0, 90,
  // 180, -90 deg; <t_k (x) q_sb, q> = <t_k, q (x) q_sb*> (unit q_sb), so one product m = q (x) q_bs and
  // four dot products with the sparse t_k pick the nearest: m.w, c (m.w + m.z), m.z, c (m.w - m.z).
  const Quat m = estimate * q_bs_unit;
  const float c = 0.70710678f;
  // (No tables of the t_k: on the AVR a constant array is copied into RAM.)
  float w = 1.0f, z = 0.0f, best = absf(m.w);
  if (absf(c * (m.w + m.z)) > best) {
    best = absf(c * (m.w + m.z));
    w = c;
    z = c;
  }
  if (absf(m.z) > best) {
    best = absf(m.z);
    w = 0.0f;
    z = 1.0f;
  }
  if (absf(c * (m.w - m.z)) > best) {
    w = c;
    z = -c;
  }
  // (w, 0, 0, z) (x) q_sb
  return Quat{w * q_sb.w - z * q_sb.z, w * q_sb.x - z * q_sb.y, w * q_sb.y + z * q_sb.x, w * q_sb.z + z * q_sb.w};
}

}  // namespace est
}  // namespace quad
