// Named parameters: every gain, filter setting, limit and airframe constant of the flight application.
//
// One table (QUAD_PARAM_TABLE) gives each parameter its MAVLink name (at most 16 characters), its
// default (thesis table 8.1 where the thesis gives one; OBS_DELTA differs, docs/firmware.md) and its
// valid range. Values are floats (MAVLink
// MAV_PARAM_TYPE_REAL32) held in RAM; names, defaults and ranges stay in flash.
#pragma once

#include <stdint.h>

#include "quad/firmware/flash.h"
#include "quad/firmware/redundant_record.h"

namespace quad {
namespace fw {

// X(id, "NAME", default, min, max)
#define QUAD_PARAM_TABLE(X)                                                                      \
  /* scheduler: the control loop rate (HIL: the rate the simulator sends HIL_SENSOR at) */       \
  X(kLoopHz, "SYS_LOOP_HZ", 100.0f, 50.0f, 1000.0f)                                              \
  /* HIL: 1 when the simulator steps in lockstep with the answers (HIL_ACTUATOR_CONTROLS flags bit 0); */ \
  /* quad_sim sets it from its mode (0 with --realtime) */                                     \
  X(kHilLockstep, "HIL_LOCKSTEP", 1.0f, 0.0f, 1.0f)                                              \
  /* boot calibration (thesis eq. 7.2, 7.4): windows of CAL_TIME s, still and level */          \
  X(kCalTime, "CAL_TIME", 2.0f, 0.2f, 30.0f)                                                     \
  X(kCalGyroStd, "CAL_GYRO_STD", 0.01f, 0.0001f, 1.0f)                                           \
  X(kCalAccStd, "CAL_ACC_STD", 0.1f, 0.001f, 5.0f)                                               \
  X(kCalGyroMax, "CAL_GYRO_MAX", 0.35f, 0.001f, 2.0f)                                            \
  X(kCalAccMax, "CAL_ACC_MAX", 1.0f, 0.01f, 5.0f)                                                \
  /* IMU full-scale ranges (MPU-6000 as the APM 2.5 runs it: +-2000 deg/s, +-8 g) and how long a */ \
  /* clipped gyro axis may be held at its last good value before the IMU counts as unhealthy (s) */ \
  X(kImuGyroRange, "IMU_GYRO_RANGE", 34.906585f, 1.0f, 100.0f)                                   \
  X(kImuAccRange, "IMU_ACC_RANGE", 78.4532f, 10.0f, 400.0f)                                      \
  X(kImuClipHold, "IMU_CLIP_HOLD", 0.05f, 0.0f, 0.5f)                                            \
  /* conditioned attitude observer: thesis table 8.1 gains; delta raised from the table's 0.03 to */ \
  /* cover the MPU-6000's in-flight bias drift after the boot calibration (docs/firmware.md) */  \
  X(kObsK1, "OBS_K1", 1.0f, 0.0f, 100.0f)                                                        \
  X(kObsK2, "OBS_K2", 0.2f, 0.0f, 100.0f)                                                        \
  X(kObsK3, "OBS_K3", 0.03125f, 0.0f, 10.0f)                                                     \
  X(kObsK4, "OBS_K4", 0.00625f, 0.0f, 10.0f)                                                     \
  X(kObsKb, "OBS_KB", 16.0f, 0.0f, 1000.0f)                                                      \
  X(kObsDelta, "OBS_DELTA", 0.05f, 0.0f, 1.0f)                                                   \
  X(kObsAccTol, "OBS_ACC_TOL", 0.2f, 0.01f, 1.0f)                                                \
  /* position Kalman filter, thesis eq. 8.12; table 8.1: Q = I T. KF_Q_MODEL 1: white accel. */  \
  X(kKfQModel, "KF_Q_MODEL", 0.0f, 0.0f, 1.0f)                                                   \
  X(kKfQPos, "KF_Q_POS", 1.0f, 0.0f, 100.0f)                                                     \
  X(kKfQVel, "KF_Q_VEL", 1.0f, 0.0f, 100.0f)                                                     \
  X(kKfQAcc, "KF_Q_ACC", 1.0f, 0.0f, 100.0f)                                                     \
  X(kKfFixSigXY, "KF_FIX_SIG_XY", 0.05f, 0.001f, 10.0f)                                          \
  X(kKfFixSigZ, "KF_FIX_SIG_Z", 0.05f, 0.001f, 10.0f)                                            \
  X(kKfGateSig, "KF_GATE_SIG", 5.0f, 1.0f, 100.0f)                                               \
  /* 1: the accelerometer's vertical bias as a state on z, learned as fast as x and y's (its drift */ \
  /* since the boot calibration is otherwise a vertical velocity error: docs/estimation.md) */     \
  X(kKfZBias, "KF_Z_BIAS", 1.0f, 0.0f, 1.0f)                                                     \
  /* 1: the horizontal acceleration error (the observer's tilt error while it learns a gyro bias) as */ \
  /* a state on x and y, so it does not become a velocity error (docs/firmware.md) */            \
  X(kKfXYBias, "KF_XY_BIAS", 1.0f, 0.0f, 1.0f)                                                   \
  /* in-flight accelerometer x/y bias, learned hovering in AUTO (quad/estimation/hover_accel_bias.h): */ \
  /* time constant (s; 0 = off) and the largest bias it may learn (m/s^2) */                     \
  X(kEstABiasTau, "EST_ABIAS_TAU", 10.0f, 0.0f, 600.0f)                                          \
  X(kEstABiasMax, "EST_ABIAS_MAX", 0.15f, 0.0f, 1.0f)                                            \
  /* the estimator: 0 the thesis pair (conditioned observer + per-axis Kalman filter), 1 the EKF */ \
  /* (seed 004; not in the AVR image); changed on the ground only. EST_MAG_USE 0: no magnetometer */ \
  /* in the EKF (heading from the star's attitude alone) */                                     \
  X(kEstType, "EST_TYPE", 0.0f, 0.0f, 1.0f)                                                      \
  X(kEstMagUse, "EST_MAG_USE", 1.0f, 0.0f, 1.0f)                                                 \
  /* what the estimator takes from the star's attitude: 0 nothing, 1 its heading, 2 heading and */ \
  /* tilt (the EKF: with the station's tilt bias estimated, docs/estimation.md, "The star's */      \
  /* attitude"; the thesis pair: "The star's attitude in the thesis pair") */                      \
  X(kEstStarAtt, "EST_STAR_ATT", 1.0f, 0.0f, 2.0f)                                                \
  /* the EKF's floors on the station's fix covariance (m, rad), as PX4's EKF2_EVP_NOISE and */      \
  /* EKF2_EVA_NOISE: the station reports its scatter, not the mount's or the star's */             \
  X(kEstEvpNoise, "EST_EVP_NOISE", 0.001f, 0.0005f, 0.1f)                                         \
  X(kEstEvaNoise, "EST_EVA_NOISE", 0.0017f, 0.0001f, 0.1f)                                        \
  /* the prior sigma of the station's tilt bias (rad; the EKF's b_s, EST_STAR_ATT 2) */               \
  X(kEstSattBias, "EST_SATT_BIAS", 0.0087f, 0.0f, 0.05f)                                          \
  /* ground hold (quad/estimation/ground_hold.h): still on the ground below these rates (rad/s) and */ \
  /* specific-force deviations from g (m/s^2); the reference point's height above the floor standing */ \
  /* on the gear (m; the Quad-C of the simulator: 0.13) */                                      \
  X(kEstGndGyro, "EST_GND_GYRO", 0.1f, 0.001f, 2.0f)                                             \
  X(kEstGndAcc, "EST_GND_ACC", 0.5f, 0.01f, 5.0f)                                                \
  X(kEstGndHgt, "EST_GND_HGT", 0.13f, 0.0f, 5.0f)                                                \
  /* vision: the star's NED position (m) */                                                      \
  X(kVisStarN, "VIS_STAR_N", 0.0f, -1000.0f, 1000.0f)                                            \
  X(kVisStarE, "VIS_STAR_E", 0.0f, -1000.0f, 1000.0f)                                            \
  X(kVisStarD, "VIS_STAR_D", 0.0f, -1000.0f, 1000.0f)                                            \
  /* external poses (ATT_POS_MOCAP, VISION_POSITION_ESTIMATE, EXTERNAL_POSE_TARGETED): below 0 their */ \
  /* time_usec is the vehicle's clock (a sender that follows it with TIMESYNC); else the capture time */ \
  /* is the arrival minus this (s), as PX4's EKF2_EV_DELAY, for a sender on its own clock */      \
  X(kExtPoseDelay, "EXT_POSE_DELAY", -1.0f, -1.0f, 0.25f)                                        \
  /* the camera rig's mount error: the body frame the station reports fixes in, relative to the IMU's */ \
  /* (ZYX Euler angles, rad; tools/mount_calibration, docs/estimation.md "The camera mount"), */  \
  /* applied to every fix's position and attitude before either estimator takes it */           \
  X(kEstCamRoll, "EST_CAM_ROLL", 0.0f, -0.2f, 0.2f)                                              \
  X(kEstCamPitch, "EST_CAM_PITCH", 0.0f, -0.2f, 0.2f)                                            \
  X(kEstCamYaw, "EST_CAM_YAW", 0.0f, -0.2f, 0.2f)                                                \
  /* magnetometer calibration, thesis eq. 7.5: m = W (m_raw - b) before the observer; gauss */   \
  X(kMagOfsX, "MAG_OFS_X", 0.0f, -2.0f, 2.0f)                                                    \
  X(kMagOfsY, "MAG_OFS_Y", 0.0f, -2.0f, 2.0f)                                                    \
  X(kMagOfsZ, "MAG_OFS_Z", 0.0f, -2.0f, 2.0f)                                                    \
  X(kMagSiXX, "MAG_SI_XX", 1.0f, -3.0f, 3.0f)                                                    \
  X(kMagSiXY, "MAG_SI_XY", 0.0f, -3.0f, 3.0f)                                                    \
  X(kMagSiXZ, "MAG_SI_XZ", 0.0f, -3.0f, 3.0f)                                                    \
  X(kMagSiYX, "MAG_SI_YX", 0.0f, -3.0f, 3.0f)                                                    \
  X(kMagSiYY, "MAG_SI_YY", 1.0f, -3.0f, 3.0f)                                                    \
  X(kMagSiYZ, "MAG_SI_YZ", 0.0f, -3.0f, 3.0f)                                                    \
  X(kMagSiZX, "MAG_SI_ZX", 0.0f, -3.0f, 3.0f)                                                    \
  X(kMagSiZY, "MAG_SI_ZY", 0.0f, -3.0f, 3.0f)                                                    \
  X(kMagSiZZ, "MAG_SI_ZZ", 1.0f, -3.0f, 3.0f)                                                    \
  /* magnetic declination (rad, east of true north positive): the heading is relative to true north */ \
  X(kMagDecl, "MAG_DECL", 0.0f, -3.1416f, 3.1416f)                                               \
  /* attitude PD, thesis eq. 8.39 and table 8.1 */                                               \
  X(kAttAlpha, "ATT_ALPHA", 3.0f, 0.001f, 100.0f)                                                \
  X(kAttGammaXY, "ATT_GAMMA_XY", 0.625f, 0.001f, 100.0f)                                         \
  X(kAttGammaZ, "ATT_GAMMA_Z", 0.5f, 0.001f, 100.0f)                                             \
  /* position control, thesis eq. 8.20 and table 8.1 */                                          \
  X(kPosKpXY, "POS_KP_XY", 3.625f, 0.001f, 100.0f)                                               \
  X(kPosKpZ, "POS_KP_Z", 3.625f, 0.001f, 100.0f)                                                 \
  X(kPosKvXY, "POS_KV_XY", 11.875f, 0.001f, 100.0f)                                              \
  X(kPosKvZ, "POS_KV_Z", 3.5f, 0.001f, 100.0f)                                                   \
  X(kPosTiltMax, "POS_TILT_MAX", 0.6109f, 0.05f, 1.3f)                                           \
  /* position trim: integral of the position error as an acceleration feed-forward, in AUTO while */ \
  /* airborne (removes the offsets of a thrust-model mismatch, an accelerometer bias, a weak motor; */ \
  /* 0 turns an axis pair off; firmware/include/quad/firmware/position_trim.h) */               \
  X(kPosKiXY, "POS_KI_XY", 1.0f, 0.0f, 20.0f)                                                    \
  X(kPosIMaxXY, "POS_I_MAX_XY", 2.0f, 0.0f, 5.0f)                                                \
  X(kPosKiZ, "POS_KI_Z", 1.0f, 0.0f, 10.0f)                                                      \
  X(kPosIMaxZ, "POS_I_MAX_Z", 2.0f, 0.0f, 5.0f)                                                  \
  /* setpoint shaping in AUTO */                                                                 \
  X(kShpSpeed, "SHP_SPEED", 1.0f, 0.05f, 10.0f)                                                  \
  X(kShpAccel, "SHP_ACCEL", 1.0f, 0.05f, 10.0f)                                                  \
  X(kShpGain, "SHP_GAIN", 2.0f, 0.1f, 20.0f)                                                     \
  /* airframe: 3DR Quad-C, plus configuration (control/vehicle.h, docs/control.md) */            \
  X(kVehFrame, "VEH_FRAME", 0.0f, 0.0f, 1.0f)                                                    \
  X(kVehMass, "VEH_MASS", 1.4f, 0.1f, 20.0f)                                                     \
  X(kVehIxx, "VEH_IXX", 0.015f, 1e-4f, 10.0f)                                                    \
  X(kVehIyy, "VEH_IYY", 0.015f, 1e-4f, 10.0f)                                                    \
  X(kVehIzz, "VEH_IZZ", 0.027f, 1e-4f, 10.0f)                                                    \
  X(kVehArm, "VEH_ARM", 0.26f, 0.05f, 2.0f)                                                      \
  X(kVehMotThrMax, "VEH_MOT_THR_MAX", 8.63f, 0.5f, 100.0f)                                       \
  X(kVehThrCoef, "VEH_THR_COEF", 1.863e-5f, 1e-8f, 1e-2f)                                        \
  X(kVehYawK, "VEH_YAW_K", 0.016f, 0.0f, 1.0f)                                                   \
  /* manual flight from the RC sticks, thesis sec. 6.1.4 */                                      \
  X(kManTiltMax, "MAN_TILT_MAX", 0.5236f, 0.05f, 0.785f)                                         \
  X(kManYawRate, "MAN_YAW_RATE", 1.5708f, 0.1f, 6.0f)                                            \
  X(kManThrMax, "MAN_THR_MAX", 1.0f, 0.1f, 1.0f)                                                 \
  X(kManDeadband, "MAN_DEADBAND", 20.0f, 0.0f, 200.0f)                                           \
  /* RC switches (sec. 6.1.4): motor enable and manual/auto toggles; 0 = not used (simulator) */  \
  X(kRcSwitches, "RC_SWITCHES", 0.0f, 0.0f, 1.0f)                                                \
  /* arming, landing and failsafes */                                                            \
  X(kArmThrMax, "ARM_THR_MAX", 0.1f, 0.0f, 0.5f)                                                 \
  X(kLandSpeed, "LAND_SPEED", 0.5f, 0.1f, 3.0f)                                                  \
  X(kLandVzMax, "LAND_VZ_MAX", 0.25f, 0.05f, 1.0f)                                               \
  X(kLandThrFrac, "LAND_THR_FRAC", 0.9f, 0.1f, 1.0f)                                             \
  X(kLandTime, "LAND_TIME", 1.0f, 0.1f, 10.0f)                                                   \
  /* height above the star (m) below which a commanded landing expects to lose it: no failsafe */ \
  X(kLandVisHgt, "LAND_VIS_HGT", 0.55f, 0.0f, 10.0f)                                             \
  X(kFsVisTimeout, "FS_VIS_TIMEOUT", 0.5f, 0.05f, 10.0f)                                         \
  X(kFsRcTimeout, "FS_RC_TIMEOUT", 1.0f, 0.1f, 10.0f)                                            \
  X(kFsRcEnable, "FS_RC_ENABLE", 1.0f, 0.0f, 1.0f)                                               \
  /* radio link (UART2) MAVLink signing: 1 = sign and require signatures (key set over USB only) */ \
  X(kSignEnable, "SIGN_ENABLE", 0.0f, 0.0f, 1.0f)                                                \
  /* telemetry rates (Hz; 0 turns a stream off) */                                               \
  X(kTelHbHz, "TEL_HB_HZ", 1.0f, 0.0f, 50.0f)                                                    \
  X(kTelAttHz, "TEL_ATT_HZ", 10.0f, 0.0f, 500.0f)                                                \
  X(kTelPosHz, "TEL_POS_HZ", 10.0f, 0.0f, 500.0f)                                                \
  X(kTelSysHz, "TEL_SYS_HZ", 1.0f, 0.0f, 50.0f)                                                  \
  X(kTelEstHz, "TEL_EST_HZ", 2.0f, 0.0f, 50.0f)                                                  \
  /* flight log (docs/logging.md): 0 off, 1 from arming to disarming, 2 from boot; the IMU topics */ \
  /* every LOG_IMU_DIV-th iteration */                                                           \
  X(kLogMode, "LOG_MODE", 1.0f, 0.0f, 2.0f)                                                      \
  X(kLogImuDiv, "LOG_IMU_DIV", 1.0f, 1.0f, 100.0f)

enum ParamId : uint8_t {
#define QUAD_PARAM_ENUM(id, name, def, lo, hi) id,
  QUAD_PARAM_TABLE(QUAD_PARAM_ENUM)
#undef QUAD_PARAM_ENUM
  kParamCount
};

constexpr uint8_t kParamNameLength = 16;  // MAVLink param_id: 16 chars, NUL-terminated only if shorter

struct ParamInfo {
  char name[kParamNameLength + 1];
  float default_value;
  float min;
  float max;
};

// Copies the table entry out of flash.
ParamInfo param_info(uint8_t index);

// Index of the parameter whose name equals the first 16 characters of `name` (which need not be
// NUL-terminated at 16), or -1.
int16_t param_find(const char* name);

// Why a value was refused.
enum class ParamError : uint8_t { kNone, kUnknownName, kNotFinite, kOutOfRange };

class Params {
 public:
  Params() { reset_to_defaults(); }

  float get(ParamId id) const { return values_[id]; }
  float get(uint8_t index) const { return values_[index]; }
  // All values in table order (the store's payload).
  const float* values() const { return values_; }

  // Sets a value after checking it is finite and within the table's range.
  ParamError set(uint8_t index, float value);

  void reset_to_defaults();

  // Counts changes, so users can tell cheaply whether to re-read their configuration.
  uint16_t generation() const { return generation_; }

 private:
  float values_[kParamCount];
  uint16_t generation_ = 0;
};

// Persistent store: the values as one redundant record (redundant_record.h: two copies with sequence
// numbers and a CRC, so power lost during a save leaves either the old or the new complete set), tagged
// with the layout version and a hash of the table's names, so another firmware's values are never read
// into the wrong slots.
enum class StoreStatus : uint8_t {
  kLoaded,         // every value came from the store
  kEmpty,          // erased storage (first boot): defaults
  kSchemaChanged,  // written by firmware with another parameter table: defaults
  kCorrupt,        // no valid copy, or a value out of range: defaults
  kIoError,        // the storage could not be read: defaults
};

FlashText store_status_text(StoreStatus status);

uint16_t params_schema_hash();
// Bytes of storage the two copies take, from params_store_offset().
uint16_t params_store_size();

// Loads every value from the newest valid copy, or resets `params` to the defaults and says why.
StoreStatus params_load(const StorageIo& io, Params& params);

// Saves every value into the copy that is not the newest (only the bytes that changed are written).
bool params_save_all(const StorageIo& io, const Params& params);

}  // namespace fw
}  // namespace quad
