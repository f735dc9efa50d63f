#include "quad/estimation/ekf.h"

#include "quad/estimation/vector_attitude.h"

namespace quad {
namespace est {

namespace {

constexpr int kN = kEkfErrorStates;

// exp(dtheta / 2) to second order (cos x ~ 1 - x^2/2, sinc x ~ 1 - x^2/6 at x = |dtheta|/2, as the
// thesis' propagator), then normalised: no trigonometry in the hot path.
Quat small_rotation(const Vec3& dtheta) {
  const float x2 = 0.25f * norm_sq(dtheta);
  const float s = 0.5f * (1.0f - x2 * (1.0f / 6.0f));
  return normalized(Quat{1.0f - 0.5f * x2, dtheta.x * s, dtheta.y * s, dtheta.z * s});
}

// A symmetric 3x3 from its upper triangle xx xy xz yy yz zz.
void unpack_upper(const float u[6], float m[3][3]) {
  m[0][0] = u[0];
  m[0][1] = m[1][0] = u[1];
  m[0][2] = m[2][0] = u[2];
  m[1][1] = u[3];
  m[1][2] = m[2][1] = u[4];
  m[2][2] = u[5];
}

// The measurement noise of a fix group: the station's covariance plus a floor, or sigma^2 I.
void fix_noise(const float* cov, bool have, float sigma, float floor_sigma, float out[6]) {
  const float floor_var = floor_sigma * floor_sigma;
  for (int i = 0; i < 6; ++i) out[i] = have ? cov[i] : 0.0f;
  const float diag = have ? floor_var : sigma * sigma;
  out[0] += diag;
  out[3] += diag;
  out[5] += diag;
}

// q_IB measured by a fix: an external pose's own, or the star's.
Quat measured_attitude(const StarFix& fix, const Quat& estimate) {
  return fix.ned ? normalized(fix.q_bs) : attitude_from_star(fix.q_bs, estimate);
}

}  // namespace

bool cholesky3(const float u[6], float l[6]) {
  // l00 l10 l11 l20 l21 l22
  if (!(u[0] > 0.0f)) return false;
  l[0] = sqrtf(u[0]);
  l[1] = u[1] / l[0];
  const float d1 = u[3] - l[1] * l[1];
  if (!(d1 > 0.0f)) return false;
  l[2] = sqrtf(d1);
  l[3] = u[2] / l[0];
  l[4] = (u[4] - l[3] * l[1]) / l[2];
  const float d2 = u[5] - l[3] * l[3] - l[4] * l[4];
  if (!(d2 > 0.0f)) return false;
  l[5] = sqrtf(d2);
  return true;
}

namespace {

// Solves L y = b for the packed lower Cholesky factor.
Vec3 forward3(const float l[6], const Vec3& b) {
  const float y0 = b.x / l[0];
  const float y1 = (b.y - l[1] * y0) / l[2];
  const float y2 = (b.z - l[3] * y0 - l[4] * y1) / l[5];
  return {y0, y1, y2};
}

}  // namespace

void ErrorStateEkf::reset(const Quat& q, const Vec3& p, const Vec3& v, const Vec3& gyro_bias, const Vec3& accel_bias) {
  x_.q = normalized(q);
  x_.p = p;
  x_.v = v;
  x_.gyro_bias = gyro_bias;
  x_.accel_bias = accel_bias;
  x_.star_bias = Vec3{};
  for (int i = 0; i < kN; ++i)
    for (int j = 0; j < kN; ++j) P_[i][j] = 0.0f;
  const EkfParams& k = params_;
  const float diag[5] = {k.tilt_sigma0, k.pos_sigma0, k.vel_sigma0, k.gyro_bias_sigma0, k.accel_bias_sigma0};
  for (int b = 0; b < 5; ++b)
    for (int i = 0; i < 3; ++i) P_[3 * b + i][3 * b + i] = diag[b] * diag[b];
  // The heading's uncertainty is about NED down: at a level start, the body z axis.
  P_[2][2] = k.yaw_sigma0 * k.yaw_sigma0;
  P_[kEkfStarBias][kEkfStarBias] = P_[kEkfStarBias + 1][kEkfStarBias + 1] = k.star_bias_sigma0 * k.star_bias_sigma0;
  ratios_ = EkfTestRatios{};
}

void ErrorStateEkf::set_covariance(int i, int j, float value) {
  P_[i][j] = value;
  P_[j][i] = value;
}

// ---------------------------------------------------------------------------------------------------
// Prediction

void ErrorStateEkf::propagate_nominal(EkfState& x, const Vec3& delta_angle, const Vec3& delta_velocity, float dt) {
  const Vec3 dtheta = delta_angle - x.gyro_bias * dt;        // seed 004 eq. 3.6: (omega - omega_b) dt
  const Vec3 dv_body = delta_velocity - x.accel_bias * dt;   // (a - a_b) dt
  const Mat3 r = to_dcm(x.q);                                // eq. 3.5
  // eq. 3.8 with the errata (gravity outside R): v <- v + R (a - a_b) dt + g e3 dt.
  const Vec3 dv = r * dv_body + Vec3{0.0f, 0.0f, kGravity * dt};
  x.p += x.v * dt + dv * (0.5f * dt);  // eq. 3.9, with the velocity's mean over the step
  x.v += dv;
  x.q = normalized(x.q * small_rotation(dtheta));  // eq. 3.7 with the errata: Hamilton product, renormalised
  // eq. 3.10, 3.11: the biases are constant (random walks in Q).
}

void ErrorStateEkf::transition(const EkfState& x, const Vec3& delta_angle, const Vec3& delta_velocity, float dt,
                               float F[kN][kN]) {
  // eq. 3.14, F = df/dx, for the error state: the attitude error turns back by the step's rotation and
  // integrates the gyro bias error; the velocity error takes the rotated specific force's cross product
  // with the attitude error and the accelerometer bias error.
  for (int i = 0; i < kN; ++i)
    for (int j = 0; j < kN; ++j) F[i][j] = i == j ? 1.0f : 0.0f;
  const Vec3 dtheta = delta_angle - x.gyro_bias * dt;
  const Mat3 a = transpose(to_dcm(small_rotation(dtheta)));
  const Mat3 r = to_dcm(x.q);
  const Mat3 m = r * skew(delta_velocity - x.accel_bias * dt) * -1.0f;
  const Mat3 n = r * -dt;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      F[kEkfTheta + i][kEkfTheta + j] = a.m[i][j];
      F[kEkfVel + i][kEkfTheta + j] = m.m[i][j];
      F[kEkfVel + i][kEkfAccelBias + j] = n.m[i][j];
      F[kEkfPos + i][kEkfTheta + j] = 0.5f * dt * m.m[i][j];
      F[kEkfPos + i][kEkfAccelBias + j] = 0.5f * dt * n.m[i][j];
    }
    F[kEkfTheta + i][kEkfGyroBias + i] = -dt;
    F[kEkfPos + i][kEkfVel + i] = dt;
  }
}

void ErrorStateEkf::predict(const Vec3& delta_angle, const Vec3& delta_velocity, float dt) {
  if (!(dt > 0.0f) || !is_finite(delta_angle) || !is_finite(delta_velocity)) return;
  const Vec3 dtheta = delta_angle - x_.gyro_bias * dt;
  const Mat3 a = transpose(to_dcm(small_rotation(dtheta)));
  const Mat3 r = to_dcm(x_.q);
  const Mat3 m = r * skew(delta_velocity - x_.accel_bias * dt) * -1.0f;
  const Mat3 n = r * -dt;
  propagate_nominal(x_, delta_angle, delta_velocity, dt);
  predict_covariance(a, m, n, dt);
  add_process_noise(dt);
}

void ErrorStateEkf::predict_covariance(const Mat3& a, const Mat3& m, const Mat3& n, float dt) {
  // P <- F P F^T (seed 004 eq. 3.19) by blocks: F is the identity but for A (attitude), -dt I (gyro bias
  // into attitude), dt I (velocity into position), M and N (attitude and accelerometer bias into
  // velocity, half of them times dt into position). B = F P first (rows 0-8; the bias rows are P's),
  // then the upper triangle of B F^T, then the mirror.
  float b[9][kN];
  const float half_dt = 0.5f * dt;
  for (int c = 0; c < kN; ++c) {
    for (int r = 0; r < 3; ++r) {
      const float w = m.m[r][0] * P_[0][c] + m.m[r][1] * P_[1][c] + m.m[r][2] * P_[2][c] + n.m[r][0] * P_[12][c] +
                      n.m[r][1] * P_[13][c] + n.m[r][2] * P_[14][c];
      b[r][c] = a.m[r][0] * P_[0][c] + a.m[r][1] * P_[1][c] + a.m[r][2] * P_[2][c] - dt * P_[9 + r][c];
      b[3 + r][c] = P_[3 + r][c] + dt * P_[6 + r][c] + half_dt * w;
      b[6 + r][c] = P_[6 + r][c] + w;
    }
  }
  for (int i = 0; i < 9; ++i) {
    const float* bi = b[i];
    float z[3];  // (B_i,theta M^T + B_i,ba N^T)
    for (int j = 0; j < 3; ++j) {
      z[j] = bi[0] * m.m[j][0] + bi[1] * m.m[j][1] + bi[2] * m.m[j][2] + bi[12] * n.m[j][0] + bi[13] * n.m[j][1] +
             bi[14] * n.m[j][2];
    }
    for (int j = i; j < kN; ++j) {
      float v;
      if (j < 3) {
        v = bi[0] * a.m[j][0] + bi[1] * a.m[j][1] + bi[2] * a.m[j][2] - dt * bi[9 + j];
      } else if (j < 6) {
        v = bi[j] + dt * bi[j + 3] + half_dt * z[j - 3];
      } else if (j < 9) {
        v = bi[j] + z[j - 6];
      } else {
        v = bi[j];
      }
      P_[i][j] = v;
    }
  }
  // Rows 9-16 (the biases) are unchanged above the diagonal; mirror everything.
  for (int i = 0; i < kN; ++i)
    for (int j = i + 1; j < kN; ++j) P_[j][i] = P_[i][j];
}

void ErrorStateEkf::add_process_noise(float dt) {
  // eq. 3.18, Q = G N G^T, for white noise densities: the gyro noise enters the attitude error, the
  // accelerometer's the velocity error (R N R^T = N for an isotropic N), the random walks the biases.
  const EkfParams& k = params_;
  const float q[4] = {k.gyro_noise * k.gyro_noise * dt, k.accel_noise * k.accel_noise * dt,
                      k.gyro_bias_walk * k.gyro_bias_walk * dt, k.accel_bias_walk * k.accel_bias_walk * dt};
  const int offset[4] = {kEkfTheta, kEkfVel, kEkfGyroBias, kEkfAccelBias};
  for (int b = 0; b < 4; ++b)
    for (int i = 0; i < 3; ++i) P_[offset[b] + i][offset[b] + i] += q[b];
  const float qs = k.star_bias_walk * k.star_bias_walk * dt;
  P_[kEkfStarBias][kEkfStarBias] += qs;
  P_[kEkfStarBias + 1][kEkfStarBias + 1] += qs;
}

// ---------------------------------------------------------------------------------------------------
// Updates (seed 004 eq. 3.22-3.27 and 3.29-3.34, with the errata K = P H^T S^-1, as one group per fix)

namespace {

// What a group update needs: rows of H over columns [c0, c0 + width), the innovation, the noise.
struct Group {
  int rows;
  int c0;
  int width;
  float h[3][kN];
  float nu[3];
  float noise[6];  // upper triangle (rows 3) or noise[0] (rows 1)
};

}  // namespace

namespace {

// y_i = L^-1 (P H^T)_i for every row i, w = L^-1 nu, with L L^T = S = H P H^T + R; returns NIS = |w|^2
// or a negative value when S is not positive definite. s_diag receives S's diagonal.
float whiten(const float P[kN][kN], const Group& g, float y[kN][3], float w[3], float s_diag[3]) {
  float pht[kN][3];
  for (int i = 0; i < kN; ++i) {
    for (int r = 0; r < g.rows; ++r) {
      float acc = 0.0f;
      for (int k = 0; k < g.width; ++k) acc += P[i][g.c0 + k] * g.h[r][k];
      pht[i][r] = acc;
    }
  }
  float s[6] = {0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f};
  const int idx[3][3] = {{0, 1, 2}, {1, 3, 4}, {2, 4, 5}};
  for (int r = 0; r < g.rows; ++r) {
    for (int c = r; c < g.rows; ++c) {
      float acc = 0.0f;
      for (int k = 0; k < g.width; ++k) acc += g.h[r][k] * pht[g.c0 + k][c];
      s[idx[r][c]] = acc + (g.rows == 1 ? g.noise[0] : g.noise[idx[r][c]]);
    }
  }
  if (g.rows == 1) {
    if (!(s[0] > 0.0f)) return -1.0f;
    const float inv = 1.0f / sqrtf(s[0]);
    for (int i = 0; i < kN; ++i) y[i][0] = pht[i][0] * inv;
    w[0] = g.nu[0] * inv;
    s_diag[0] = s[0];
    return w[0] * w[0];
  }
  float l[6];
  if (!cholesky3(s, l)) return -1.0f;
  for (int i = 0; i < kN; ++i) {
    const Vec3 yi = forward3(l, Vec3{pht[i][0], pht[i][1], pht[i][2]});
    y[i][0] = yi.x;
    y[i][1] = yi.y;
    y[i][2] = yi.z;
  }
  const Vec3 wv = forward3(l, Vec3{g.nu[0], g.nu[1], g.nu[2]});
  w[0] = wv.x;
  w[1] = wv.y;
  w[2] = wv.z;
  s_diag[0] = s[0];
  s_diag[1] = s[3];
  s_diag[2] = s[5];
  return dot(wv, wv);
}

// The update itself: dx = Y w (= K nu), P -= Y Y^T (= K S K^T), injected into the nominal state.
void apply_group(float P[kN][kN], EkfState& x, const float y[kN][3], const float w[3], int rows) {
  float dx[kN];
  for (int i = 0; i < kN; ++i) {
    float acc = 0.0f;
    for (int r = 0; r < rows; ++r) acc += y[i][r] * w[r];
    dx[i] = acc;
  }
  for (int i = 0; i < kN; ++i) {
    for (int j = i; j < kN; ++j) {
      float acc = 0.0f;
      for (int r = 0; r < rows; ++r) acc += y[i][r] * y[j][r];
      P[i][j] -= acc;
      P[j][i] = P[i][j];
    }
    if (P[i][i] < 1e-12f) P[i][i] = 1e-12f;
  }
  ErrorStateEkf::inject(x, dx);
}

// The whole of a group's update: whitened, its normalised innovation squared over the gate as the test
// ratio, refused above the gate, else applied.
EkfFuse gated_update(float P[kN][kN], EkfState& x, const Group& g, float gate_chi2, float* ratio) {
  float y[kN][3], w[3], s[3];
  const float nis = whiten(P, g, y, w, s);
  if (nis < 0.0f) return EkfFuse::kRejectedInvalid;
  *ratio = nis / gate_chi2;
  if (nis > gate_chi2) return EkfFuse::kRejectedGate;
  apply_group(P, x, y, w, g.rows);
  return EkfFuse::kFused;
}

}  // namespace

void ErrorStateEkf::inject(EkfState& x, const float dx[kN]) {
  x.q = normalized(x.q * small_rotation(Vec3{dx[0], dx[1], dx[2]}));
  x.p += Vec3{dx[3], dx[4], dx[5]};
  x.v += Vec3{dx[6], dx[7], dx[8]};
  x.gyro_bias += Vec3{dx[9], dx[10], dx[11]};
  x.accel_bias += Vec3{dx[12], dx[13], dx[14]};
  x.star_bias += Vec3{dx[15], dx[16], 0.0f};
}

void ErrorStateEkf::fuse_star(const StarFix& fix, EkfFuse* position_result, EkfFuse* attitude_result) {
  EkfFuse pr = EkfFuse::kRejectedInvalid, ar = EkfFuse::kRejectedInvalid;
  const Mat3 r = to_dcm(x_.q);
  if (is_finite(fix.star_body)) {
    // h = R^T (s - p): H_theta = [h]x, H_p = -R^T (body-frame attitude error); an external pose's h = p.
    Group g;
    g.rows = 3;
    g.c0 = kEkfTheta;
    g.width = 6;
    const Vec3 h = fix.ned ? x_.p : mul_transpose(r, params_.star_ned - x_.p);
    const Mat3 sk = skew(h);
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) {
        g.h[i][j] = fix.ned ? 0.0f : sk.m[i][j];
        g.h[i][3 + j] = fix.ned ? (i == j ? 1.0f : 0.0f) : -r.m[j][i];
      }
    }
    const Vec3 nu = fix.star_body - h;  // seed 004 eq. 3.22: measurement minus prediction
    g.nu[0] = nu.x;
    g.nu[1] = nu.y;
    g.nu[2] = nu.z;
    fix_noise(fix.pos_cov, fix.has_covariance, params_.fix_sigma, params_.fix_sigma_floor, g.noise);
    float y[kN][3], w[3], s[3];
    const float nis = whiten(P_, g, y, w, s);
    if (nis >= 0.0f) {
      const float gate1 = params_.gate_chi2_1;
      ratios_.pos_horiz = maxf(nu.x * nu.x / s[0], nu.y * nu.y / s[1]) / gate1;
      ratios_.pos_vert = nu.z * nu.z / s[2] / gate1;
      pr = nis > params_.gate_chi2_3 ? EkfFuse::kRejectedGate : EkfFuse::kFused;
      if (pr == EkfFuse::kFused) apply_group(P_, x_, y, w, 3);
    }
  }
  if (fix.has_attitude && usable_attitude(fix.q_bs)) {
    if (params_.star_attitude == StarAttitudeUse::kFull) ar = fuse_star_attitude(fix);
    if (params_.star_attitude == StarAttitudeUse::kHeading) ar = fuse_star_heading(fix);
  }
  if (position_result != nullptr) *position_result = pr;
  if (attitude_result != nullptr) *attitude_result = ar;
}

EkfFuse ErrorStateEkf::fuse_star_attitude(const StarFix& fix) {
  // q_meas = q (x) exp(b_s / 2): the residual is the attitude error plus the station's tilt bias,
  // H = (I, 0, 0, 0, 0, E) with E the body x, y columns.
  Group g;
  g.rows = 3;
  g.c0 = kEkfTheta;
  g.width = kN;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < kN; ++j) g.h[i][j] = i == j ? 1.0f : 0.0f;
  // The tilt bias belongs to the station's star; an external pose (fix.ned) carries its own attitude.
  const bool star = !fix.ned;
  if (star) {
    g.h[0][kEkfStarBias] = 1.0f;
    g.h[1][kEkfStarBias + 1] = 1.0f;
  }
  const Quat measured = measured_attitude(fix, x_.q);
  Vec3 nu = to_rotation_vector(conjugate(x_.q) * measured);  // body-frame rotation to the measurement
  if (star) nu = nu - x_.star_bias;
  g.nu[0] = nu.x;
  g.nu[1] = nu.y;
  g.nu[2] = nu.z;
  fix_noise(fix.att_cov, fix.has_covariance, params_.attitude_sigma, params_.attitude_sigma_floor, g.noise);
  return gated_update(P_, x_, g, params_.gate_chi2_3, &ratios_.attitude);
}

EkfFuse ErrorStateEkf::fuse_star_heading(const StarFix& fix) {
  // The heading of q_IB measured from the star against the estimate's, H = e3^T R as for the
  // magnetometer; its variance the attitude covariance's share about NED down.
  const Mat3 r = to_dcm(x_.q);
  const Mat3 rm = to_dcm(measured_attitude(fix, x_.q));
  if (!(rm.m[0][0] * rm.m[0][0] + rm.m[1][0] * rm.m[1][0] > 0.25f)) return EkfFuse::kRejectedInvalid;
  Group g;
  g.rows = 1;
  g.c0 = kEkfTheta;
  g.width = 3;
  g.nu[0] = wrap_pi(atan2f(rm.m[1][0], rm.m[0][0]) - atan2f(r.m[1][0], r.m[0][0]));
  for (int j = 0; j < 3; ++j) g.h[0][j] = r.m[2][j];
  float var = params_.attitude_sigma * params_.attitude_sigma;
  if (fix.has_covariance) {
    float c[3][3];
    unpack_upper(fix.att_cov, c);
    var = params_.attitude_sigma_floor * params_.attitude_sigma_floor;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) var += r.m[2][i] * c[i][j] * r.m[2][j];
  }
  g.noise[0] = var;
  return gated_update(P_, x_, g, params_.gate_chi2_1, &ratios_.heading);
}

void ErrorStateEkf::initialize_position(const StarFix& fix) {
  // (An external pose: R = I and no attitude share, p = the fix.)
  const Mat3 r = fix.ned ? Mat3::identity() : to_dcm(x_.q);
  x_.p = fix.ned ? fix.star_body : params_.star_ned - r * fix.star_body;
  // Cov(p) = R C R^T + [R b]x P_theta [R b]x^T (the attitude's share), no cross-covariances.
  float c[3][3];
  float noise[6];
  fix_noise(fix.pos_cov, fix.has_covariance, params_.fix_sigma, params_.fix_sigma_floor, noise);
  unpack_upper(noise, c);
  Mat3 cm;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) cm.m[i][j] = c[i][j];
  Mat3 pt;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) pt.m[i][j] = P_[i][j];
  const Mat3 jt = fix.ned ? Mat3{} : r * skew(fix.star_body);  // d(R b)/d theta = -R [b]x; the sign cancels
  const Mat3 cov = r * cm * transpose(r) + jt * pt * transpose(jt);
  for (int i = 0; i < kN; ++i) {
    for (int k = 0; k < 3; ++k) {
      P_[kEkfPos + k][i] = 0.0f;
      P_[i][kEkfPos + k] = 0.0f;
    }
  }
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) P_[kEkfPos + i][kEkfPos + j] = cov.m[i][j];
}

EkfFuse ErrorStateEkf::fuse_heading(const Vec3& mag_frd) {
  if (!is_finite(mag_frd)) return EkfFuse::kRejectedInvalid;
  const Mat3 r = to_dcm(x_.q);
  const Vec3 m = r * mag_frd;  // the field in NED as the estimated attitude sees it
  const Vec3& ref = params_.mag_ref_ned;
  const float horizontal = m.x * m.x + m.y * m.y;
  if (!(horizontal > 0.01f * norm_sq(m)) || !(ref.x * ref.x + ref.y * ref.y > 0.0f)) return EkfFuse::kRejectedInvalid;
  Group g;
  g.rows = 1;
  g.c0 = kEkfTheta;
  g.width = 3;
  // nu = psi_ref - psi_measured; H = e3^T R (a body-frame error turns the heading about NED down).
  g.nu[0] = wrap_pi(atan2f(ref.y, ref.x) - atan2f(m.y, m.x));
  for (int j = 0; j < 3; ++j) g.h[0][j] = r.m[2][j];
  g.noise[0] = params_.heading_sigma * params_.heading_sigma;
  return gated_update(P_, x_, g, params_.gate_chi2_1, &ratios_.heading);
}

EkfFuse ErrorStateEkf::fuse_zero_velocity() {
  Group g;
  g.rows = 3;
  g.c0 = kEkfVel;
  g.width = 3;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) g.h[i][j] = i == j ? 1.0f : 0.0f;
  g.nu[0] = -x_.v.x;
  g.nu[1] = -x_.v.y;
  g.nu[2] = -x_.v.z;
  const float var = params_.zero_velocity_sigma * params_.zero_velocity_sigma;
  const float noise[6] = {var, 0.0f, 0.0f, var, 0.0f, var};
  for (int i = 0; i < 6; ++i) g.noise[i] = noise[i];
  float y[kN][3], w[3], s[3];
  const float nis = whiten(P_, g, y, w, s);
  if (nis < 0.0f) return EkfFuse::kRejectedInvalid;
  ratios_.velocity = nis / params_.gate_chi2_3;
  // Not gated: standing still is known, and a gate would refuse it after a drift it exists to stop.
  apply_group(P_, x_, y, w, 3);
  return EkfFuse::kFused;
}

EkfFuse ErrorStateEkf::fuse_position_hold(const Vec3& p_hold) {
  // h = p, H = I on the position; a pseudo-measurement like the zero velocity (PX4 EKF2's fusion of the
  // last known position without aiding), so not gated either.
  if (!is_finite(p_hold)) return EkfFuse::kRejectedInvalid;
  Group g;
  g.rows = 3;
  g.c0 = kEkfPos;
  g.width = 3;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) g.h[i][j] = i == j ? 1.0f : 0.0f;
  g.nu[0] = p_hold.x - x_.p.x;
  g.nu[1] = p_hold.y - x_.p.y;
  g.nu[2] = p_hold.z - x_.p.z;
  const float var = params_.hold_position_sigma * params_.hold_position_sigma;
  const float noise[6] = {var, 0.0f, 0.0f, var, 0.0f, var};
  for (int i = 0; i < 6; ++i) g.noise[i] = noise[i];
  float y[kN][3], w[3], s[3];
  if (whiten(P_, g, y, w, s) < 0.0f) return EkfFuse::kRejectedInvalid;
  apply_group(P_, x_, y, w, 3);
  return EkfFuse::kFused;
}

void ErrorStateEkf::keep_above(float down) {
  if (x_.p.z > down) x_.p.z = down;
}

EkfFuse ErrorStateEkf::fuse_hover_force(const Vec3& specific_force) {
  // h = b_a (x, y), H = I on the accelerometer bias: one scalar group per axis, each gated.
  if (!is_finite(specific_force)) return EkfFuse::kRejectedInvalid;
  const float f[2] = {specific_force.x, specific_force.y};
  const float b[2] = {x_.accel_bias.x, x_.accel_bias.y};
  EkfFuse result = EkfFuse::kFused;
  float worst = 0.0f;
  for (int axis = 0; axis < 2; ++axis) {
    Group g;
    g.rows = 1;
    g.c0 = kEkfAccelBias;
    g.width = 3;
    for (int j = 0; j < 3; ++j) g.h[0][j] = j == axis ? 1.0f : 0.0f;
    g.nu[0] = f[axis] - b[axis];
    g.noise[0] = params_.hover_force_sigma * params_.hover_force_sigma;
    float y[kN][3], w[3], s[3];
    const float nis = whiten(P_, g, y, w, s);
    if (nis < 0.0f) return EkfFuse::kRejectedInvalid;
    worst = maxf(worst, nis / params_.gate_chi2_1);
    if (nis > params_.gate_chi2_1) {
      result = EkfFuse::kRejectedGate;
      continue;
    }
    apply_group(P_, x_, y, w, 1);
  }
  ratios_.hover_force = worst;
  return result;
}

// ---------------------------------------------------------------------------------------------------

float ErrorStateEkf::tilt_sigma() const {
  // The attitude error's share about the NED horizontal axes: R P_theta R^T's upper-left 2x2 trace.
  const Mat3 r = to_dcm(x_.q);
  Mat3 pt;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) pt.m[i][j] = P_[i][j];
  const Mat3 c = r * pt * transpose(r);
  return safe_sqrtf(c.m[0][0] + c.m[1][1]);
}

float ErrorStateEkf::yaw_sigma() const {
  const Vec3 r2 = to_dcm(x_.q).row(2);
  Vec3 pr;
  for (int i = 0; i < 3; ++i) pr[i] = P_[i][0] * r2.x + P_[i][1] * r2.y + P_[i][2] * r2.z;
  return safe_sqrtf(dot(r2, pr));
}

float ErrorStateEkf::horizontal_pos_sigma() const { return safe_sqrtf(P_[3][3] + P_[4][4]); }
float ErrorStateEkf::vertical_pos_sigma() const { return safe_sqrtf(P_[5][5]); }
float ErrorStateEkf::velocity_sigma() const { return safe_sqrtf(P_[6][6] + P_[7][7] + P_[8][8]); }

bool ErrorStateEkf::finite() const {
  if (!is_finite(x_.q) || !is_finite(x_.p) || !is_finite(x_.v) || !is_finite(x_.gyro_bias) ||
      !is_finite(x_.accel_bias))
    return false;
  for (int i = 0; i < kN; ++i)
    if (!is_finite(P_[i][i]) || !(P_[i][i] >= 0.0f)) return false;
  return true;
}

}  // namespace est
}  // namespace quad
