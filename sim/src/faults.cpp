#include "quad/sim/faults.h"

#include <algorithm>
#include <limits>

namespace quad::sim {

FaultEffects fault_effects(const std::vector<Fault>& faults, const RadioConditions& base_radio, double t) {
  FaultEffects e;
  e.radio = base_radio;
  for (const Fault& f : faults) {
    if (!f.active(t)) continue;
    switch (f.type) {
      case FaultType::kRadioLoss: e.radio.loss = std::max(e.radio.loss, f.value); break;
      case FaultType::kBitErrorRate: e.radio.bit_error_rate = std::max(e.radio.bit_error_rate, f.value); break;
      case FaultType::kRadioLatency: e.radio.latency_s = f.value; break;
      case FaultType::kMagDisturbance: e.mag_offset_ned_gauss += f.vector; break;
      case FaultType::kGyroBiasStep: e.gyro_bias_step_rad_s += f.vector; break;
      case FaultType::kMotorEfficiency: e.motor_efficiency[static_cast<size_t>(f.motor)] *= f.value; break;
      case FaultType::kVisionDropout: e.vision_dropout = true; break;
      case FaultType::kRcLoss: e.rc_loss = true; break;
      case FaultType::kVisionLatency: e.vision_errors.extra_latency_s += f.value; break;
      case FaultType::kVisionScale: e.vision_errors.scale_frd = e.vision_errors.scale_frd.cwiseProduct(f.vector); break;
      case FaultType::kVisionDecoy: e.vision_errors.decoy_ned = f.vector; break;
      case FaultType::kImuSaturation:
        if (e.imu == ImuSampleFault::kNone) e.imu = ImuSampleFault::kSaturated;
        break;
      case FaultType::kImuNonFinite: e.imu = ImuSampleFault::kNonFinite; break;
    }
  }
  return e;
}

ImuReading apply_imu_fault(const ImuReading& reading, ImuSampleFault fault, const ImuParams& params) {
  switch (fault) {
    case ImuSampleFault::kNone: return reading;
    case ImuSampleFault::kSaturated: {
      auto pin = [](const Eigen::Vector3d& v, double range) {
        return Eigen::Vector3d(v.unaryExpr([range](double x) { return x < 0.0 ? -range : range; }));
      };
      return {pin(reading.specific_force_frd, params.accel.range), pin(reading.rate_frd, params.gyro.range)};
    }
    case ImuSampleFault::kNonFinite: {
      const double nan = std::numeric_limits<double>::quiet_NaN();
      const double inf = std::numeric_limits<double>::infinity();
      return {Eigen::Vector3d(nan, inf, -inf), Eigen::Vector3d(-inf, nan, inf)};
    }
  }
  return reading;
}

const char* fault_name(FaultType type) {
  switch (type) {
    case FaultType::kVisionDropout: return "vision dropout";
    case FaultType::kRadioLoss: return "radio loss";
    case FaultType::kBitErrorRate: return "bit error rate";
    case FaultType::kRadioLatency: return "radio latency";
    case FaultType::kMagDisturbance: return "magnetic disturbance";
    case FaultType::kGyroBiasStep: return "gyro bias step";
    case FaultType::kMotorEfficiency: return "motor efficiency";
    case FaultType::kRcLoss: return "RC loss";
    case FaultType::kVisionLatency: return "vision latency";
    case FaultType::kVisionScale: return "vision scale error";
    case FaultType::kVisionDecoy: return "vision decoy";
    case FaultType::kImuSaturation: return "IMU saturation";
    case FaultType::kImuNonFinite: return "IMU non-finite samples";
  }
  return "?";
}

}  // namespace quad::sim
