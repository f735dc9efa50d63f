#include "quad/estimation/xqy_calibration.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>
#include <Eigen/SVD>

namespace quad {
namespace est {

Eigen::Vector3d rotation_log(const Eigen::Matrix3d& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}

double rotation_angle(const Eigen::Matrix3d& R) {
  const double c = std::clamp((R.trace() - 1.0) / 2.0, -1.0, 1.0);
  // Near zero acos loses digits: the skew part's norm is 2 sin(angle).
  const Eigen::Matrix3d skew = R - R.transpose();
  const double s = 0.5 * Eigen::Vector3d(skew(2, 1), skew(0, 2), skew(1, 0)).norm();
  return std::atan2(s, c);
}

namespace {

struct WahbaSums {
  Eigen::Matrix3d Z = Eigen::Matrix3d::Zero();
  long pairs = 0;
};

// Z = sum w_ij r_ij q_ijᵀ (seed 002 eq. 15, w_ij = 1) with r_ij, q_ij the logarithms of the relative
// rotations a(i, j), b(i, j) (eq. 13 for X, eq. 17 for Y).
template <class RelativeA, class RelativeB>
WahbaSums wahba_sums(size_t n, RelativeA a, RelativeB b, const XqyOptions& o) {
  WahbaSums s;
  for (size_t i = 0; i < n; ++i) {
    for (size_t j = i + 1; j < n; ++j) {
      const Eigen::Matrix3d A = a(i, j), B = b(i, j);
      const double angle_b = rotation_angle(B);
      if (angle_b < o.min_relative_angle_rad || angle_b > o.max_relative_angle_rad) continue;
      if (rotation_angle(A) > o.max_relative_angle_rad) continue;
      s.Z += rotation_log(A) * rotation_log(B).transpose();  // eq. 15
      ++s.pairs;
    }
  }
  return s;
}

// The proper rotation nearest Z's direction: U diag(1, 1, det U det V) Vᵀ (seed 002 eq. 16).
Eigen::Matrix3d wahba_rotation(const Eigen::JacobiSVD<Eigen::Matrix3d>& svd) {
  const Eigen::Matrix3d& U = svd.matrixU();
  const Eigen::Matrix3d& V = svd.matrixV();
  const Eigen::Vector3d d(1.0, 1.0, U.determinant() * V.determinant());
  return U * d.asDiagonal() * V.transpose();
}

// The proper rotation nearest M in the Frobenius norm: U diag(1, 1, det U det V) Vᵀ.
Eigen::Matrix3d nearest_rotation(const Eigen::Matrix3d& M) {
  return wahba_rotation(Eigen::JacobiSVD<Eigen::Matrix3d>(M, Eigen::ComputeFullU | Eigen::ComputeFullV));
}

double zyx_yaw(const Eigen::Matrix3d& R) { return std::atan2(R(1, 0), R(0, 0)); }

// X with its ZYX yaw set to the star layout's heading, the quarter turn nearest the data's: X_i = R_i Q_iᵀ
// is X up to the few degrees of Y, enough to tell the station's four star frames apart. Turning X about
// NED's z changes its yaw only (X = Rz(yaw) Ry Rx), so the tilt from eq. 16 stays.
Eigen::Matrix3d with_layout_heading(const Eigen::Matrix3d& X, const std::vector<const RotationPair*>& s,
                                    double heading) {
  Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
  for (const RotationPair* p : s) sum += p->R * p->Q.transpose();
  const double coarse = zyx_yaw(nearest_rotation(sum));
  const double quarter = M_PI / 2.0;
  const double yaw = heading + quarter * std::round((coarse - heading) / quarter);
  return Eigen::AngleAxisd(yaw - zyx_yaw(X), Eigen::Vector3d::UnitZ()).toRotationMatrix() * X;
}

}  // namespace

Eigen::Matrix3d solve_y_given_x(const std::vector<RotationPair>& pairs, const Eigen::Matrix3d& X) {
  Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
  for (const RotationPair& p : pairs) sum += (X * p.Q).transpose() * p.R;
  return nearest_rotation(sum);
}

XqyResult solve_xqy(const std::vector<RotationPair>& pairs, const XqyOptions& o) {
  XqyResult r;
  if (pairs.size() < 3) {
    r.message = "need at least 3 rotation pairs, got " + std::to_string(pairs.size());
    return r;
  }
  // Evenly spaced samples: the sums are over all pairs (i, j).
  std::vector<const RotationPair*> s;
  const size_t n = std::min(pairs.size(), static_cast<size_t>(std::max(3, o.max_samples)));
  for (size_t k = 0; k < n; ++k) s.push_back(&pairs[k * pairs.size() / n]);
  r.samples = static_cast<int>(n);

  // X: R_i R_jᵀ = X Q_i Q_jᵀ Xᵀ (eq. 12), so r_ij = X q_ij (eq. 14).
  const WahbaSums sx = wahba_sums(
      n, [&](size_t i, size_t j) -> Eigen::Matrix3d { return s[i]->R * s[j]->R.transpose(); },
      [&](size_t i, size_t j) -> Eigen::Matrix3d { return s[i]->Q * s[j]->Q.transpose(); }, o);
  // Y: R_jᵀ R_i = Yᵀ Q_jᵀ Q_i Y (eq. 17), so r_ij = Yᵀ q_ij.
  const WahbaSums sy = wahba_sums(
      n, [&](size_t i, size_t j) -> Eigen::Matrix3d { return s[j]->R.transpose() * s[i]->R; },
      [&](size_t i, size_t j) -> Eigen::Matrix3d { return s[j]->Q.transpose() * s[i]->Q; }, o);
  r.relative_pairs_x = sx.pairs;
  r.relative_pairs_y = sy.pairs;
  if (sx.pairs < 2 || sy.pairs < 2) {
    r.message = "too few pairs of samples rotated against each other by more than " +
                std::to_string(o.min_relative_angle_rad) + " rad (" + std::to_string(std::min(sx.pairs, sy.pairs)) + ")";
    return r;
  }
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd_x(sx.Z, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd_y(sy.Z, Eigen::ComputeFullU | Eigen::ComputeFullV);
  r.singular_values_x = svd_x.singularValues();
  r.singular_values_y = svd_y.singularValues();
  const double spread = std::min(r.singular_values_x(1) / r.singular_values_x(0),
                                 r.singular_values_y(1) / r.singular_values_y(0));
  // With the star's heading known, rotations about one axis (yaw turns) suffice: X's freedom about it is
  // its heading.
  if (!o.star_heading_known && !(spread >= o.min_axis_spread)) {
    r.message = "the rotations are about one axis only (second / first singular value of Z " +
                std::to_string(spread) + " < " + std::to_string(o.min_axis_spread) +
                "): rotate about a second axis (tilt as well as yaw)";
    return r;
  }
  if (o.star_heading_known) {
    r.X = with_layout_heading(wahba_rotation(svd_x), s, o.star_heading_rad);  // eq. 16, heading from the layout
    r.Y = solve_y_given_x(pairs, r.X);
  } else {
    r.X = wahba_rotation(svd_x);               // eq. 16
    r.Y = wahba_rotation(svd_y).transpose();   // Y = V diag(1, 1, det U det V) Uᵀ (after eq. 17)
  }
  double sum_sq = 0.0;
  for (const RotationPair& p : pairs) {
    const double e = rotation_angle(p.R * (r.X * p.Q * r.Y).transpose());
    sum_sq += e * e;
  }
  r.residual_rms_rad = std::sqrt(sum_sq / static_cast<double>(pairs.size()));
  r.ok = true;
  return r;
}

}  // namespace est
}  // namespace quad
