// Sensor models: statistics of long still logs against the configured values, filter delay, clipping,
// quantisation, the magnetometer's rate and distortion (thesis eq. 7.5).
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <vector>

#include "quad/sim/imu.h"
#include "quad/sim/magnetometer.h"
#include "quad/sim/vehicle.h"

namespace quad::sim {
namespace {

constexpr double kG = 9.80665;
const Eigen::Vector3d kLevelAtRest(0.0, 0.0, -kG);

// Allan deviation at averaging time tau_samples (non-overlapping clusters).
double allan_deviation(const std::vector<double>& x, size_t tau_samples) {
  const size_t clusters = x.size() / tau_samples;
  std::vector<double> means(clusters);
  for (size_t c = 0; c < clusters; ++c) {
    double s = 0.0;
    for (size_t i = 0; i < tau_samples; ++i) s += x[c * tau_samples + i];
    means[c] = s / static_cast<double>(tau_samples);
  }
  double sum = 0.0;
  for (size_t c = 1; c < clusters; ++c) sum += (means[c] - means[c - 1]) * (means[c] - means[c - 1]);
  return std::sqrt(sum / (2.0 * static_cast<double>(clusters - 1)));
}

double stddev(const std::vector<double>& x) {
  double m = 0.0, s = 0.0;
  for (double v : x) m += v;
  m /= static_cast<double>(x.size());
  for (double v : x) s += (v - m) * (v - m);
  return std::sqrt(s / static_cast<double>(x.size() - 1));
}

// White noise density N from the Allan variance AVAR(tau) = N^2 / tau + K^2 tau / 3 at two averaging
// times, solved for N (the random walk K dominates the accelerometer's long clusters, so one tau is not
// enough). tau1 = 0.5 s is long against the DLPF (8 ms), tau2 = 20 s pins the random-walk term.
double white_density(const std::vector<double>& x, double rate_hz) {
  const double t1 = 0.5, t2 = 20.0;
  const double a1 = std::pow(allan_deviation(x, static_cast<size_t>(t1 * rate_hz)), 2);
  const double a2 = std::pow(allan_deviation(x, static_cast<size_t>(t2 * rate_hz)), 2);
  // a1 = N^2/t1 + k t1, a2 = N^2/t2 + k t2 (k = K^2/3): eliminate k.
  const double n2 = (a1 * t2 - a2 * t1) / (t2 / t1 - t1 / t2);
  return std::sqrt(n2);
}

TEST(Mpu6000, WhiteNoiseDensityOfAStillLogMatchesTheConfiguration) {
  const ImuParams p;  // 1000 s at 1 kHz, level and still
  Mpu6000 imu(p, Rng(7, "imu"));
  std::vector<std::vector<double>> axes(6);
  for (int i = 0; i < 1000000; ++i) {
    const ImuReading r = imu.sample(kLevelAtRest, Eigen::Vector3d::Zero());
    for (int a = 0; a < 3; ++a) {
      axes[static_cast<size_t>(a)].push_back(r.rate_frd[a]);
      axes[static_cast<size_t>(3 + a)].push_back(r.specific_force_frd[a]);
    }
  }
  for (int a = 0; a < 3; ++a) {
    std::printf("axis %d: gyro white noise %.4g rad/s/sqrt(Hz) (configured %.4g), accel %.4g m/s^2/sqrt(Hz) (%.4g)\n", a,
                white_density(axes[static_cast<size_t>(a)], 1000.0), p.gyro.noise_density,
                white_density(axes[static_cast<size_t>(3 + a)], 1000.0), p.accel.noise_density);
    EXPECT_NEAR(white_density(axes[static_cast<size_t>(a)], 1000.0) / p.gyro.noise_density, 1.0, 0.10) << "gyro " << a;
    EXPECT_NEAR(white_density(axes[static_cast<size_t>(3 + a)], 1000.0) / p.accel.noise_density, 1.0, 0.10)
        << "accel " << a;
  }
}

TEST(Mpu6000, TurnOnBiasAcrossPowerUpsMatchesTheConfiguration) {
  const ImuParams p;
  std::vector<double> gyro, accel;
  for (uint64_t seed = 1; seed <= 300; ++seed) {
    Mpu6000 imu(p, Rng(seed, "imu"));
    Eigen::Vector3d g = Eigen::Vector3d::Zero(), f = Eigen::Vector3d::Zero();
    for (int i = 0; i < 1000; ++i) {  // the first second's mean is the bias
      const ImuReading r = imu.sample(kLevelAtRest, Eigen::Vector3d::Zero());
      g += r.rate_frd / 1000.0;
      f += (r.specific_force_frd - kLevelAtRest) / 1000.0;
    }
    for (int a = 0; a < 3; ++a) {
      gyro.push_back(g[a]);
      accel.push_back(f[a]);
    }
  }
  std::printf("turn-on bias over 300 power-ups: gyro %.4g rad/s (configured %.4g), accel %.4g m/s^2 (%.4g)\n",
              stddev(gyro), p.gyro.turn_on_bias, stddev(accel), p.accel.turn_on_bias);
  EXPECT_NEAR(stddev(gyro) / p.gyro.turn_on_bias, 1.0, 0.10);
  EXPECT_NEAR(stddev(accel) / p.accel.turn_on_bias, 1.0, 0.10);
}

TEST(Mpu6000, BiasRandomWalkOfLongLogsMatchesTheConfiguration) {
  // The difference of two adjacent 100 s means of a random walk K has variance 2 K^2 tau / 3 (Allan);
  // white noise adds 2 N^2 / tau, removed with the configured density (2 % of the total here).
  ImuParams p;
  p.sample_rate_hz = 100.0;  // the densities are rate-independent; 10x fewer samples
  const double tau = 100.0;
  const size_t n = static_cast<size_t>(tau * p.sample_rate_hz);
  double sum_gyro = 0.0, sum_accel = 0.0;
  int count = 0;
  for (uint64_t seed = 1; seed <= 200; ++seed) {
    Mpu6000 imu(p, Rng(seed, "walk"));
    Eigen::Vector3d g[2] = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()}, f[2] = {g[0], g[0]};
    for (int w = 0; w < 2; ++w)
      for (size_t i = 0; i < n; ++i) {
        const ImuReading r = imu.sample(kLevelAtRest, Eigen::Vector3d::Zero());
        g[w] += r.rate_frd / static_cast<double>(n);
        f[w] += r.specific_force_frd / static_cast<double>(n);
      }
    sum_gyro += (g[1] - g[0]).squaredNorm();
    sum_accel += (f[1] - f[0]).squaredNorm();
    count += 3;
  }
  auto walk = [&](double mean_sq, const ImuAxisParams& a) {
    return std::sqrt((mean_sq - 2.0 * a.noise_density * a.noise_density / tau) * 3.0 / (2.0 * tau));
  };
  std::printf("bias random walk over 200 x 200 s: gyro %.4g (configured %.4g), accel %.4g (%.4g)\n",
              walk(sum_gyro / count, p.gyro), p.gyro.bias_random_walk, walk(sum_accel / count, p.accel),
              p.accel.bias_random_walk);
  EXPECT_NEAR(walk(sum_gyro / count, p.gyro) / p.gyro.bias_random_walk, 1.0, 0.10);
  EXPECT_NEAR(walk(sum_accel / count, p.accel) / p.accel.bias_random_walk, 1.0, 0.10);
}

ImuParams noiseless() {
  ImuParams p;
  p.gyro = {0, 0, 0, p.gyro.range, p.gyro.lsb, 0};
  p.accel = {0, 0, 0, p.accel.range, p.accel.lsb, 0};
  return p;
}

TEST(Mpu6000, LevelAtRestReadsMinusGOnZ) {
  Mpu6000 imu(noiseless(), Rng(1, "imu"));
  ImuReading r{};
  for (int i = 0; i < 100; ++i) r = imu.sample(kLevelAtRest, Eigen::Vector3d::Zero());
  EXPECT_NEAR(r.specific_force_frd.x(), 0.0, 1e-12);
  EXPECT_NEAR(r.specific_force_frd.z(), -kG, imu.params().accel.lsb);
  EXPECT_TRUE(r.rate_frd.isZero());
}

TEST(Mpu6000, DlpfDelaysAStepByAboutEightMilliseconds) {
  Mpu6000 imu(noiseless(), Rng(1, "imu"));
  imu.sample(kLevelAtRest, Eigen::Vector3d::Zero());
  const double step = 1.0;  // rad/s
  int samples_to_63 = 0;
  while (imu.sample(kLevelAtRest, {step, 0, 0}).rate_frd.x() < (1.0 - std::exp(-1.0)) * step) ++samples_to_63;
  EXPECT_GE(samples_to_63, 7);  // data sheet: 8.3 ms at 20 Hz; a first-order 20 Hz filter: 8.0 ms
  EXPECT_LE(samples_to_63, 9);
}

TEST(Mpu6000, ClipsAtFullScaleAndQuantises) {
  Mpu6000 imu(noiseless(), Rng(1, "imu"));
  ImuReading r{};
  for (int i = 0; i < 500; ++i) r = imu.sample({0, 0, -100.0}, {50.0, -0.1234567, 0});
  EXPECT_NEAR(r.rate_frd.x(), imu.params().gyro.range, imu.params().gyro.lsb);
  EXPECT_NEAR(r.specific_force_frd.z(), -imu.params().accel.range, imu.params().accel.lsb);
  const double counts = r.rate_frd.y() / imu.params().gyro.lsb;
  EXPECT_NEAR(counts, std::round(counts), 1e-9) << "outputs are whole counts";
  EXPECT_NE(r.rate_frd.y(), -0.1234567);
}

TEST(Mpu6000, GyroBiasStepFaultShiftsTheReading) {
  Mpu6000 imu(noiseless(), Rng(1, "imu"));
  imu.set_gyro_bias_step({0.0, 0.0, 0.05});
  ImuReading r{};
  for (int i = 0; i < 500; ++i) r = imu.sample(kLevelAtRest, Eigen::Vector3d::Zero());
  EXPECT_NEAR(r.rate_frd.z(), 0.05, imu.params().gyro.lsb);
}

// Vibration noise (imu.h): extra white noise whose standard deviation is vibration_at_full_speed times the
// mean rotor speed over the maximum, as the session takes it from the vehicle's motors. Everything else
// is switched off and the DLPF bypassed, so the raw ADC samples show the added noise alone; then the
// same through the default 20 Hz DLPF, which passes sqrt(a / (2 - a)) of a white input's deviation
// (first order, a = 1 - exp(-2 pi fc dt)).
TEST(Mpu6000, VibrationNoiseScalesWithTheMeanRotorSpeed) {
  VehicleParams vp;
  vp.model_path = QUAD_SIM_SOURCE_DIR "/models/quad_c.xml";
  Vehicle vehicle(vp);
  ImuParams raw = noiseless();
  raw.dlpf_cutoff_hz = 0.0;
  raw.gyro.lsb = raw.accel.lsb = 0.0;
  raw.gyro.vibration_at_full_speed = 0.05;  // rad/s
  raw.accel.vibration_at_full_speed = 0.8;  // m/s^2
  ImuParams filtered = raw;
  filtered.dlpf_cutoff_hz = ImuParams().dlpf_cutoff_hz;
  filtered.gyro.lsb = ImuParams().gyro.lsb;
  filtered.accel.lsb = ImuParams().accel.lsb;
  const double a = 1.0 - std::exp(-2.0 * M_PI * filtered.dlpf_cutoff_hz / filtered.sample_rate_hz);
  const double dlpf_gain = std::sqrt(a / (2.0 - a));

  // (motor commands, mean speed fraction): at rest, a quarter, half (two rotors at full speed), full.
  const std::array<std::array<double, 4>, 4> commands{{{0, 0, 0, 0}, {0.25, 0.25, 0.25, 0.25}, {1, 0, 1, 0}, {1, 1, 1, 1}}};
  const double fractions[] = {0.0, 0.25, 0.5, 1.0};
  for (size_t c = 0; c < commands.size(); ++c) {
    vehicle.set_commands(commands[c]);
    vehicle.settle_motors();
    const double speed = vehicle.mean_speed_fraction();
    ASSERT_NEAR(speed, fractions[c], 1e-12) << "the ESC map makes the command the speed fraction";
    for (const ImuParams* p : {&raw, &filtered}) {
      Mpu6000 imu(*p, Rng(11 + c, "vibration"));
      std::vector<std::vector<double>> axes(6);
      for (int i = 0; i < 40000; ++i) {
        const ImuReading r = imu.sample(kLevelAtRest, Eigen::Vector3d::Zero(), speed);
        if (i < 200) continue;  // the filter's start
        for (int k = 0; k < 3; ++k) {
          axes[static_cast<size_t>(k)].push_back(r.rate_frd[k]);
          axes[static_cast<size_t>(3 + k)].push_back(r.specific_force_frd[k]);
        }
      }
      const double gain = p == &raw ? 1.0 : dlpf_gain;
      for (int k = 0; k < 6; ++k) {
        const double measured = stddev(axes[static_cast<size_t>(k)]);
        const double expected = gain * speed * (k < 3 ? p->gyro.vibration_at_full_speed : p->accel.vibration_at_full_speed);
        if (k == 0 || k == 3)
          std::printf("vibration at %.2f of full speed, %s, %s: std %.4g (expected %.4g)\n", speed,
                      p == &raw ? "raw" : "through the DLPF", k < 3 ? "gyro x" : "accel x", measured, expected);
        if (speed == 0.0) {
          EXPECT_LT(measured, 1e-9) << "no vibration at rest, axis " << k;
        } else {
          EXPECT_NEAR(measured / expected, 1.0, 0.10) << "speed " << speed << ", axis " << k << (p == &raw ? " raw" : " DLPF");
        }
      }
    }
  }
}

TEST(Hmc5883l, SeventyFiveHertzNoiseAndTheConfiguredField) {
  MagParams p;
  p.scale = {1, 1, 1};
  p.misalignment_rad = {0, 0, 0};
  p.hard_iron_gauss = {0, 0, 0};
  Hmc5883l mag(p, Rng(3, "mag"));
  const Eigen::Vector3d field(0.21, -0.03, 0.45);  // level, heading North: body field = NED field
  std::vector<double> x;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  int outputs = 0;
  for (int i = 0; i < 100000; ++i) {  // 100 s at 1 kHz
    if (mag.update(i * 1e-3, field)) {
      ++outputs;
      mean += mag.reading();
      x.push_back(mag.reading().x());
    }
  }
  EXPECT_NEAR(outputs, 7500, 2);
  EXPECT_TRUE((mean / outputs).isApprox(field, 1e-3)) << (mean / outputs).transpose();
  std::printf("magnetometer: %d outputs in 100 s, noise %.4g G (configured %.4g)\n", outputs, stddev(x), p.noise_gauss);
  EXPECT_NEAR(stddev(x) / p.noise_gauss, 1.0, 0.10);
}

TEST(Hmc5883l, HardAndSoftIronFollowThesisEq75) {
  MagParams p;  // the default distortion
  p.noise_gauss = 0.0;
  Hmc5883l mag(p, Rng(3, "mag"));
  const Eigen::Vector3d body_field(-0.1, 0.3, 0.4);
  for (int i = 0; i < 20; ++i) mag.update(i * 1e-3, body_field);
  const Eigen::Matrix3d D = soft_iron_matrix(p.scale, p.misalignment_rad);
  const Eigen::Vector3d expected = D * body_field + p.hard_iron_gauss;
  EXPECT_TRUE(mag.reading().isApprox(expected, 2e-3)) << mag.reading().transpose();
  // D is lower-triangular with the scale errors on the diagonal when the angles vanish.
  EXPECT_DOUBLE_EQ(D(0, 1), 0.0);
  EXPECT_DOUBLE_EQ(soft_iron_matrix({2, 3, 4}, {0, 0, 0}).diagonal().sum(), 9.0);
}

}  // namespace
}  // namespace quad::sim
