// The parameters that reach a float field of a configuration struct unchanged, as tables of (parameter,
// field offset) pairs: the parts of the flight application copy them in one loop (load_fields) instead of a load
// and a store per field, about 20 bytes of AVR flash each with the 16-bit offset arithmetic. The fields
// computed from parameters (VEH_FRAME, the yaw coefficient, MAN_THR_MAX, ...) stay written out there.
// In a header so the tests can check every entry (tests/firmware/test_params.cpp, "ParamFields").
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "quad/control/cascade.h"
#include "quad/control/manual.h"
#include "quad/control/setpoint_shaper.h"
#include "quad/estimation/calibration.h"
#include "quad/estimation/conditioned_observer.h"
#include "quad/estimation/ekf.h"
#include "quad/estimation/position_filter.h"
#include "quad/firmware/calibration.h"
#include "quad/firmware/flash.h"
#include "quad/firmware/params.h"

namespace quad {
namespace fw {

// A parameter and the byte offset of the float field it is copied into.
struct ParamField {
  uint8_t id;
  uint8_t offset;
};

// Overload resolution in QUAD_PARAM_FIELD's sizeof (never evaluated) refuses a field that is not a float.
constexpr char float_field(const float*) { return 1; }

// The offset narrows to uint8_t in a constant expression: a field beyond 255 bytes does not compile.
#define QUAD_PARAM_FIELD(T, id, member) \
  { id, sizeof(float_field(&static_cast<T*>(nullptr)->member)) * offsetof(T, member) }

// Copies p.get(table[i].id) into the float at dst + table[i].offset for each of the n entries (table
// in flash). Out of line in param_fields.cpp.
void load_fields(const Params& p, void* dst, const ParamField* table, uint8_t n);

template <class T, uint8_t N>
void load_fields(const Params& p, T& dst, const ParamField (&table)[N]) {
  load_fields(p, &dst, table, N);
}

constexpr ParamField kCascadeFields[] QUAD_FLASH = {
    QUAD_PARAM_FIELD(ctrl::CascadeParams, kVehMass, vehicle.mass),
    QUAD_PARAM_FIELD(ctrl::CascadeParams, kVehIxx, vehicle.inertia.x),
    QUAD_PARAM_FIELD(ctrl::CascadeParams, kVehIyy, vehicle.inertia.y),
    QUAD_PARAM_FIELD(ctrl::CascadeParams, kVehIzz, vehicle.inertia.z),
    QUAD_PARAM_FIELD(ctrl::CascadeParams, kVehArm, vehicle.arm_length),
    QUAD_PARAM_FIELD(ctrl::CascadeParams, kVehMotThrMax, vehicle.max_motor_thrust),
    QUAD_PARAM_FIELD(ctrl::CascadeParams, kVehThrCoef, vehicle.thrust_coeff),
    QUAD_PARAM_FIELD(ctrl::CascadeParams, kPosKpXY, position.kp.x),
    QUAD_PARAM_FIELD(ctrl::CascadeParams, kPosKpXY, position.kp.y),
    QUAD_PARAM_FIELD(ctrl::CascadeParams, kPosKpZ, position.kp.z),
    QUAD_PARAM_FIELD(ctrl::CascadeParams, kPosKvXY, position.kv.x),
    QUAD_PARAM_FIELD(ctrl::CascadeParams, kPosKvXY, position.kv.y),
    QUAD_PARAM_FIELD(ctrl::CascadeParams, kPosKvZ, position.kv.z),
    QUAD_PARAM_FIELD(ctrl::CascadeParams, kAttAlpha, attitude.alpha),
    QUAD_PARAM_FIELD(ctrl::CascadeParams, kAttGammaXY, attitude.gamma.x),
    QUAD_PARAM_FIELD(ctrl::CascadeParams, kAttGammaXY, attitude.gamma.y),
    QUAD_PARAM_FIELD(ctrl::CascadeParams, kAttGammaZ, attitude.gamma.z),
    QUAD_PARAM_FIELD(ctrl::CascadeParams, kPosTiltMax, max_tilt),
};

constexpr ParamField kManualFields[] QUAD_FLASH = {
    QUAD_PARAM_FIELD(ctrl::ManualParams, kManTiltMax, max_angle),
    QUAD_PARAM_FIELD(ctrl::ManualParams, kManYawRate, max_yaw_rate),
};

constexpr ParamField kShaperFields[] QUAD_FLASH = {
    QUAD_PARAM_FIELD(ctrl::ShaperParams, kShpSpeed, max_speed),
    QUAD_PARAM_FIELD(ctrl::ShaperParams, kShpAccel, max_accel),
    QUAD_PARAM_FIELD(ctrl::ShaperParams, kShpGain, final_gain),
};

// W's rows are MAG_SI_X*, MAG_SI_Y*, MAG_SI_Z* (thesis eq. 7.5).
constexpr ParamField kMagFields[] QUAD_FLASH = {
    QUAD_PARAM_FIELD(est::MagCalibration, kMagOfsX, offset.x),
    QUAD_PARAM_FIELD(est::MagCalibration, kMagOfsY, offset.y),
    QUAD_PARAM_FIELD(est::MagCalibration, kMagOfsZ, offset.z),
    QUAD_PARAM_FIELD(est::MagCalibration, kMagSiXX, soft_iron.m[0][0]),
    QUAD_PARAM_FIELD(est::MagCalibration, kMagSiXY, soft_iron.m[0][1]),
    QUAD_PARAM_FIELD(est::MagCalibration, kMagSiXZ, soft_iron.m[0][2]),
    QUAD_PARAM_FIELD(est::MagCalibration, kMagSiYX, soft_iron.m[1][0]),
    QUAD_PARAM_FIELD(est::MagCalibration, kMagSiYY, soft_iron.m[1][1]),
    QUAD_PARAM_FIELD(est::MagCalibration, kMagSiYZ, soft_iron.m[1][2]),
    QUAD_PARAM_FIELD(est::MagCalibration, kMagSiZX, soft_iron.m[2][0]),
    QUAD_PARAM_FIELD(est::MagCalibration, kMagSiZY, soft_iron.m[2][1]),
    QUAD_PARAM_FIELD(est::MagCalibration, kMagSiZZ, soft_iron.m[2][2]),
};

constexpr ParamField kObserverFields[] QUAD_FLASH = {
    QUAD_PARAM_FIELD(est::ObserverParams, kObsK1, k1),
    QUAD_PARAM_FIELD(est::ObserverParams, kObsK2, k2),
    QUAD_PARAM_FIELD(est::ObserverParams, kObsK3, k3),
    QUAD_PARAM_FIELD(est::ObserverParams, kObsK4, k4),
    QUAD_PARAM_FIELD(est::ObserverParams, kObsKb, kb),
    QUAD_PARAM_FIELD(est::ObserverParams, kObsDelta, delta),
    QUAD_PARAM_FIELD(est::ObserverParams, kObsAccTol, accel_norm_tolerance),
};

constexpr ParamField kFilterFields[] QUAD_FLASH = {
    QUAD_PARAM_FIELD(est::PositionFilterParams, kKfQPos, q_pos),
    QUAD_PARAM_FIELD(est::PositionFilterParams, kKfQVel, q_vel),
    QUAD_PARAM_FIELD(est::PositionFilterParams, kKfQAcc, q_accel),
    QUAD_PARAM_FIELD(est::PositionFilterParams, kKfFixSigXY, fix_sigma_xy),
    QUAD_PARAM_FIELD(est::PositionFilterParams, kKfFixSigZ, fix_sigma_z),
    QUAD_PARAM_FIELD(est::PositionFilterParams, kKfGateSig, gate_sigma),
};

constexpr ParamField kStarFields[] QUAD_FLASH = {
    QUAD_PARAM_FIELD(Vec3, kVisStarN, x),
    QUAD_PARAM_FIELD(Vec3, kVisStarE, y),
    QUAD_PARAM_FIELD(Vec3, kVisStarD, z),
};

constexpr ParamField kCameraMountFields[] QUAD_FLASH = {
    QUAD_PARAM_FIELD(Euler, kEstCamRoll, roll),
    QUAD_PARAM_FIELD(Euler, kEstCamPitch, pitch),
    QUAD_PARAM_FIELD(Euler, kEstCamYaw, yaw),
};

// The EKF's floors on the station's covariance and the prior of its tilt bias (the EKF is not in the
// ATmega2560 image: there this table is never referenced).
constexpr ParamField kEkfFields[] QUAD_FLASH = {
    QUAD_PARAM_FIELD(est::EkfParams, kEstEvpNoise, fix_sigma_floor),
    QUAD_PARAM_FIELD(est::EkfParams, kEstEvaNoise, attitude_sigma_floor),
    QUAD_PARAM_FIELD(est::EkfParams, kEstSattBias, star_bias_sigma0),
};

constexpr ParamField kCalibrationFields[] QUAD_FLASH = {
    QUAD_PARAM_FIELD(CalibrationConfig, kCalTime, duration_s),
    QUAD_PARAM_FIELD(CalibrationConfig, kCalGyroStd, limits.max_gyro_std),
    QUAD_PARAM_FIELD(CalibrationConfig, kCalAccStd, limits.max_accel_std),
    QUAD_PARAM_FIELD(CalibrationConfig, kCalGyroMax, limits.max_gyro_mean),
    QUAD_PARAM_FIELD(CalibrationConfig, kCalAccMax, limits.max_accel_bias),
};

}  // namespace fw
}  // namespace quad
