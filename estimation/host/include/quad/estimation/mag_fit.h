// Magnetometer hard- and soft-iron calibration by least-squares ellipsoid fit (thesis eq. 7.15-7.18;
// the closed-form 7.9-7.14 are not used, see the errata). Host only (Eigen, C++17): library
// quad_estimation_host. The result is applied on the vehicle with quad::est::MagCalibration.
//
// Usage:
//   std::vector<Eigen::Vector3d> raw = ...;          // samples while turning the vehicle in all directions
//   quad::est::MagFitResult r = quad::est::fit_magnetometer(raw, {/*field_norm=*/0.5});
//   if (r.ok) { use r.calibration; report r.residual_rms } else { std::cerr << r.message; }
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "quad/estimation/calibration.h"

namespace quad {
namespace est {

struct MagFitOptions {
  double field_norm = 1.0;       // ||m_I|| in the output units (thesis: from a field model); 1: unit field
  int min_samples = 50;
  // Coverage: the smallest eigenvalue of the mean outer product of the corrected unit directions. A
  // uniform sphere gives 1/3 on every axis; a single planar turn gives 0 on its axis.
  double min_coverage = 0.15;
  // Conditioning of the centred, scaled design matrix of eq. 7.16: ~3 for samples over the whole sphere;
  // a narrow band of attitudes fits its own samples well (small residual) with a wrong offset.
  double max_condition = 30.0;
  double max_residual = 0.05;    // RMS of |W (m - b)| / field_norm - 1 above which the fit is refused
};

struct MagFitResult {
  bool ok = false;
  std::string message;            // why the fit was refused, or a summary
  MagCalibration calibration;     // W (m - b), |W (m - b)| ~ field_norm
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
  Eigen::Matrix3d soft_iron = Eigen::Matrix3d::Identity();
  double residual_rms = 0.0;      // RMS of |corrected| / field_norm - 1: the fit-quality figure
  double coverage = 0.0;          // smallest eigenvalue described in MagFitOptions::min_coverage
  double condition = 0.0;         // condition number of the (scaled) design matrix of eq. 7.16
};

MagFitResult fit_magnetometer(const std::vector<Eigen::Vector3d>& samples, const MagFitOptions& options = {});

}  // namespace est
}  // namespace quad
