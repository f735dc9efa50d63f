// Estimator replay for the agreement test (tests/pil/test_estimator_agreement.cpp): the same source
// runs the attitude observer and the position filter over the recorded sensor log on the host, on the
// ATmega2560 (simavr) and on the Cortex-M4F (QEMU), and prints the estimates as the exact bits of each
// float, so the host can compare the three builds.
//
// Per log row: observer update (the magnetometer when the row holds a new sample), the kinematic
// acceleration into the position filter's predict, and every fourth row (25 Hz) a position fix: the
// true position of four rows earlier, fused at its capture time (40 ms late, like the vision fix).
// Every fifth row prints one record: "R k q0 q1 q2 q3 pn pe pd vn ve vd" with the floats as 8 hex digits.
#pragma once

#include <stdint.h>
#include <string.h>

#include "quad/estimation/conditioned_observer.h"
#include "quad/estimation/position_filter.h"

namespace quad {
namespace replay {

struct Row {
  uint32_t t_us;
  float imu[9];  // accel (m/s^2), gyro (rad/s), mag (gauss), body FRD
  uint8_t mag_new;
  float truth[3];  // true NED position, m
};

constexpr uint16_t kFixEvery = 4;
constexpr uint16_t kRecordEvery = 5;

// Put: void(char). Load: void(uint16_t index, Row&) (the AVR reads its table from flash).
template <typename Put, typename Load>
void run(uint16_t rows, Load load, Put put) {
  est::ConditionedObserver observer;  // fresh each run (about 700 bytes of stack on the AVR)
  est::PositionFilter<est::history_length(100)> filter;
  auto hex = [&](float v) {
    uint32_t bits;
    memcpy(&bits, &v, sizeof bits);
    put(' ');
    for (int shift = 28; shift >= 0; shift -= 4) put("0123456789abcdef"[(bits >> shift) & 0xFu]);
  };
  Row row;
  Row fix_row;
  uint32_t last_t = 0;
  for (uint16_t k = 0; k < rows; ++k) {
    load(k, row);
    const Vec3 accel{row.imu[0], row.imu[1], row.imu[2]};
    const Vec3 gyro{row.imu[3], row.imu[4], row.imu[5]};
    const Vec3 mag{row.imu[6], row.imu[7], row.imu[8]};
    if (k == 0) {
      observer.initialize(accel, mag);
    } else {
      const float dt = static_cast<float>(row.t_us - last_t) * 1e-6f;
      observer.update(gyro, accel, mag, row.mag_new != 0, dt);
    }
    last_t = row.t_us;
    filter.predict(est::kinematic_acceleration(observer.dcm(), accel), row.t_us);
    if (k >= kFixEvery && k % kFixEvery == 0) {
      load(static_cast<uint16_t>(k - kFixEvery), fix_row);
      filter.fuse_position(Vec3{fix_row.truth[0], fix_row.truth[1], fix_row.truth[2]}, fix_row.t_us);
    }
    if (k % kRecordEvery == kRecordEvery - 1) {
      put('R');
      put(' ');
      for (uint16_t d = 10000; d > 0; d /= 10) put(static_cast<char>('0' + (k / d) % 10));
      const Quat& q = observer.attitude();
      hex(q.w);
      hex(q.x);
      hex(q.y);
      hex(q.z);
      const Vec3 p = filter.position(), v = filter.velocity();
      hex(p.x);
      hex(p.y);
      hex(p.z);
      hex(v.x);
      hex(v.y);
      hex(v.z);
      put('\n');
    }
  }
  put('E');
  put('\n');
}

}  // namespace replay
}  // namespace quad
