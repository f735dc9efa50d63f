// The vision path: the base station's star fix, measured at a past capture time, becomes a vehicle
// position in NED.
//
// LANDING_TARGET carries the star's position relative to the vehicle in body FRD, p_B. With the star
// at the known NED point s (parameters VIS_STAR_N/E/D) and the attitude R_IB the vehicle had when the
// image was captured,
//   p_I = s - R_IB(t_capture) p_B                       (thesis eq. 8.5, sign per the errata:
//                                                        p_I = -R_IB (R_BC p_C + t_BC) with the camera
//                                                        terms already applied by the station)
// The attitude at the capture time comes from AttitudeHistory, a short record of past attitudes.
#pragma once

#include <stdint.h>

#include "quad/math/math.h"

namespace quad {
namespace fw {

// LANDING_TARGET's q (q_BS) is 1 0 0 0 when the station fitted no attitude.
inline bool star_attitude_fitted(const float q[4]) {
  return !(q[0] == 1.0f && q[1] == 0.0f && q[2] == 0.0f && q[3] == 0.0f);
}

// Past attitudes at a decimated rate, quantised to 16 bits per component (error < 1e-4 rad): 12 records
// of 12 bytes cover a few hundred milliseconds (every 3rd iteration at 100 Hz spans 0.36 s). 12, not
// more: the ATmega2560's 6 KiB budget (data + bss + peak stack) has no room for more.
class AttitudeHistory {
 public:
  static constexpr uint8_t kCapacity = 12;

  // The smallest decimation at which the records span at least span_s at loop_hz (two records spare
  // for the interpolation at both ends).
  static uint8_t decimation_for(float loop_hz, float span_s);

  // Record one sample every `decimation` calls to push().
  void set_decimation(uint8_t decimation) { decimation_ = decimation == 0 ? 1 : decimation; }
  uint8_t decimation() const { return decimation_; }
  void clear() { count_ = 0; head_ = 0; skip_ = 0; }

  void push(uint32_t t_us, const Quat& q);

  // The attitude at t_us, interpolated between the two records around it. False when t_us lies
  // outside the recorded span (older than the oldest record, or newer than the newest by more than
  // one record spacing).
  bool lookup(uint32_t t_us, Quat& q) const;

  uint8_t size() const { return count_; }

 private:
  struct Record {
    uint32_t t_us;
    int16_t q[4];
  };
  const Record& at(uint8_t age) const;  // 0 = newest
  static Quat unpack(const Record& r);

  Record records_[kCapacity];
  uint8_t head_ = 0;   // next slot to write
  uint8_t count_ = 0;
  uint8_t decimation_ = 1;
  uint8_t skip_ = 0;
  uint32_t newest_push_us_ = 0;
};

// The camera rig's mount error, R_BV: V is the body frame the station reports a fix in (its nominal
// camera-to-body rotation applied), B the IMU's. A fix's star position p_V and attitude q_VS become
// p_B = R_BV p_V and q_BS = q_BV q_VS (seed 002: R_BV = Yᵀ of R = XQY, tools/mount_calibration).
class CameraMount {
 public:
  // ZYX Euler angles of R_BV (EST_CAM_ROLL, EST_CAM_PITCH, EST_CAM_YAW), radians.
  void configure(const Euler& e);
  // In place: the star's position in body FRD, and its attitude q (w, x, y, z) unless it is the
  // identity, which LANDING_TARGET sends when the station fitted none.
  void apply(Vec3* star_body, float q[4]) const;
  bool identity() const { return identity_; }

 private:
  Quat q_bv_;
  bool identity_ = true;
};

// thesis eq. 8.5 (errata sign): the vehicle's NED position from the star seen in body FRD.
inline Vec3 vehicle_position_from_star(const Vec3& star_ned, const Quat& q_ib_at_capture, const Vec3& star_body) {
  return star_ned - rotate(q_ib_at_capture, star_body);
}

}  // namespace fw
}  // namespace quad
