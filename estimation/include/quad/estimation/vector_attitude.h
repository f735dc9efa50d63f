// Attitude from one accelerometer and one magnetometer sample (TRIAD), and the accelerometer tilt.
//
// Usage:
//   quad::Quat q;
//   if (quad::est::attitude_from_vectors(accel_frd, mag_frd, mag_ref_ned, q)) { ... q = q_IB ... }
//
// The accelerometer at rest reads the specific force -g R^T e_z, so "down" in the body is -a/|a|. Down and
// the magnetic field span the same plane in both frames; the triads built from them give R_IB. Used to
// initialise the observers and as the measured attitude R_m of the Mahony baseline. Costs two square
// roots and a few divisions: an initialisation path, not a per-sample one for the conditioned observer.
#pragma once

#include "quad/math/math.h"

namespace quad {
namespace est {

// Sets q_ib and returns true when both vectors are finite, non-zero and not parallel.
bool attitude_from_vectors(const Vec3& accel_frd, const Vec3& mag_frd, const Vec3& mag_ref_ned, Quat& q_ib);

// The magnetic reference a vehicle sees at boot, expressed with magnetic north as the x axis of NED:
// (|m_horizontal|, 0, m_down), in the magnetometer's own units. Returns false for degenerate input.
bool magnetic_reference_from_sample(const Vec3& accel_frd, const Vec3& mag_frd, Vec3& mag_ref_ned);

// q_IB measured from the star's attitude in the body, q_BS (LANDING_TARGET q): q_SB = q_BS*, with the
// star's axes along NED up to its quarter-turn symmetry about down (its tips along north and east),
// resolved by taking the quarter turn nearest `estimate`.
Quat attitude_from_star(const Quat& q_bs, const Quat& estimate);

}  // namespace est
}  // namespace quad
