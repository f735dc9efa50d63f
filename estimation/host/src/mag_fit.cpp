#include "quad/estimation/mag_fit.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <Eigen/Dense>

namespace quad {
namespace est {

namespace {

MagFitResult refuse(MagFitResult r, const std::string& why) {
  r.ok = false;
  r.message = why;
  return r;
}

// Why the samples cannot be fitted at all (too few, not finite, no field norm), or an empty string.
std::string unusable_samples(const std::vector<Eigen::Vector3d>& samples, const MagFitOptions& options) {
  const int n = static_cast<int>(samples.size());
  if (n < std::max(options.min_samples, 9)) {
    return "magnetometer fit: " + std::to_string(n) + " samples, at least " +
           std::to_string(std::max(options.min_samples, 9)) + " needed";
  }
  for (int i = 0; i < n; ++i) {
    if (!samples[i].allFinite()) return "magnetometer fit: sample " + std::to_string(i) + " is not finite";
  }
  if (!(options.field_norm > 0.0)) return "magnetometer fit: field_norm must be positive";
  return "";
}

// Fit quality (RMS of |W (m - b)| / |m_I| - 1) and coverage (the least eigenvalue of the scatter of the
// corrected directions) on the corrected samples, into r.
void measure_fit(const std::vector<Eigen::Vector3d>& samples, const MagFitOptions& options, const Eigen::Vector3d& b,
                 const Eigen::Matrix3d& w, MagFitResult& r) {
  const int n = static_cast<int>(samples.size());
  double sq = 0.0;
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const auto& m : samples) {
    const Eigen::Vector3d v = w * (m - b);
    const double len = v.norm();
    sq += std::pow(len / options.field_norm - 1.0, 2);
    if (len > 0.0) scatter += (v / len) * (v / len).transpose();
  }
  r.residual_rms = std::sqrt(sq / n);
  r.coverage = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scatter / n).eigenvalues().minCoeff();
}

}  // namespace

MagFitResult fit_magnetometer(const std::vector<Eigen::Vector3d>& samples, const MagFitOptions& options) {
  MagFitResult r;
  const int n = static_cast<int>(samples.size());
  const std::string unusable = unusable_samples(samples, options);
  if (!unusable.empty()) return refuse(r, unusable);

  // Centre and scale the data first so that the nine columns of eq. 7.17 are of similar size and the
  // right-hand side of eq. 7.16 (C10 normalised to 1) is safe: the origin is then inside the ellipsoid.
  Eigen::Vector3d c0 = Eigen::Vector3d::Zero();
  for (const auto& m : samples) c0 += m;
  c0 /= n;
  double s0 = 0.0;
  for (const auto& m : samples) s0 += (m - c0).squaredNorm();
  s0 = std::sqrt(s0 / n);
  if (!(s0 > 0.0)) return refuse(r, "magnetometer fit: all samples are equal");

  // thesis eq. 7.15-7.17: one row per sample, M C = 1.
  Eigen::MatrixXd design(n, 9);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d x = (samples[i] - c0) / s0;
    design.row(i) << x.x() * x.x(), x.x() * x.y(), x.x() * x.z(), x.y() * x.y(), x.y() * x.z(), x.z() * x.z(), x.x(),
        x.y(), x.z();
  }
  // eq. 7.18's least-squares solution, computed by SVD rather than the normal equations (same minimiser,
  // square root of the condition number), which also yields the conditioning of the problem.
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(design, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const auto& sv = svd.singularValues();
  r.condition = sv(8) > 0.0 ? sv(0) / sv(8) : std::numeric_limits<double>::infinity();
  const Eigen::VectorXd c = svd.solve(Eigen::VectorXd::Ones(n));

  // Quadric x^T A x + l^T x = 1 in the scaled coordinates.
  Eigen::Matrix3d a;
  a << c(0), c(1) / 2, c(2) / 2, c(1) / 2, c(3), c(4) / 2, c(2) / 2, c(4) / 2, c(5);
  const Eigen::Vector3d l(c(6), c(7), c(8));
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig_a(a);
  if (eig_a.eigenvalues().minCoeff() <= 0.0) return refuse(r, "magnetometer fit: the samples do not describe an ellipsoid");
  // Centre x_c = -A^-1 l / 2; then (x - x_c)^T A (x - x_c) = 1 + x_c^T A x_c.
  const Eigen::Vector3d xc = -0.5 * a.ldlt().solve(l);
  const double k = 1.0 + xc.dot(a * xc);
  if (!(k > 0.0)) return refuse(r, "magnetometer fit: degenerate quadric");
  // Back to raw units: (m - b)^T E (m - b) = 1 with b = c0 + s0 x_c, E = A / (k s0^2).
  const Eigen::Vector3d b = c0 + s0 * xc;
  const Eigen::Matrix3d e = a / (k * s0 * s0);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig_e(e);
  // Symmetric soft-iron correction W = |m_I| E^(1/2): |W (m - b)| = |m_I| on the fitted ellipsoid.
  const Eigen::Matrix3d w = options.field_norm * eig_e.eigenvectors() *
                            eig_e.eigenvalues().cwiseSqrt().asDiagonal() * eig_e.eigenvectors().transpose();

  measure_fit(samples, options, b, w, r);
  r.offset = b;
  r.soft_iron = w;
  for (int i = 0; i < 3; ++i) {
    r.calibration.offset[i] = static_cast<float>(b(i));
    for (int j = 0; j < 3; ++j) r.calibration.soft_iron.m[i][j] = static_cast<float>(w(i, j));
  }
  std::ostringstream summary;
  summary << "magnetometer fit: " << n << " samples, residual " << r.residual_rms << ", coverage " << r.coverage
          << ", condition " << r.condition;
  if (r.coverage < options.min_coverage) {
    return refuse(r, summary.str() + ": the samples do not cover enough directions (coverage below " +
                         std::to_string(options.min_coverage) + "); turn the vehicle about every axis");
  }
  if (r.condition > options.max_condition) {
    return refuse(r, summary.str() + ": the fit is ill-conditioned (condition above " +
                         std::to_string(options.max_condition) + "); turn the vehicle about every axis");
  }
  if (r.residual_rms > options.max_residual) {
    return refuse(r, summary.str() + ": residual above " + std::to_string(options.max_residual));
  }
  r.ok = true;
  r.message = summary.str();
  return r;
}

}  // namespace est
}  // namespace quad
