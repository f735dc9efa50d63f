#include "quad/sim/camera_model.h"

#include <cmath>
#include <stdexcept>

#include "quad/sim/frames.h"

namespace quad::sim {
namespace {

constexpr double kValidFraction = 0.97;

// Normalised undistorted (x, y) to normalised distorted, the Brown–Conrady polynomial in OpenCV's
// ordering (k1, k2, p1, p2, k3).
Eigen::Vector2d distort(const LensParams& l, double x, double y) {
  const double r2 = x * x + y * y;
  const double radial = 1.0 + l.k1 * r2 + l.k2 * r2 * r2 + l.k3 * r2 * r2 * r2;
  return {x * radial + 2.0 * l.p1 * x * y + l.p2 * (r2 + 2.0 * x * x),
          y * radial + l.p1 * (r2 + 2.0 * y * y) + 2.0 * l.p2 * x * y};
}

Eigen::Vector2d to_pixel(const LensParams& l, const Eigen::Vector2d& d) {
  return {l.fx * d.x() + l.cx, l.fy * d.y() + l.cy};
}

}  // namespace

double lens_fold_radius(const LensParams& l) {
  for (double r = 0.0; r < 3.0; r += 1e-4) {
    const double r2 = r * r;
    if (1.0 + 3.0 * l.k1 * r2 + 5.0 * l.k2 * r2 * r2 + 7.0 * l.k3 * r2 * r2 * r2 <= 0.0) return r;
  }
  return 3.0;
}

std::optional<Eigen::Vector2d> project_lens(const LensParams& lens, double valid_radius, const Eigen::Vector3d& p) {
  if (p.z() <= 1e-4) return std::nullopt;
  const double x = p.x() / p.z(), y = p.y() / p.z();
  const double r = std::hypot(x, y), limit = kValidFraction * valid_radius;
  if (r <= limit) return to_pixel(lens, distort(lens, x, y));
  // Beyond the limit the polynomial is no lens (it folds back): continue it linearly through the
  // origin, so that the image periphery still shows the floor further out, in order.
  return to_pixel(lens, distort(lens, x * limit / r, y * limit / r) * (r / limit));
}

std::optional<Eigen::Vector2d> unproject_lens(const LensParams& lens, double valid_radius, const Eigen::Vector2d& uv) {
  const Eigen::Vector2d target((uv.x() - lens.cx) / lens.fx, (uv.y() - lens.cy) / lens.fy);
  const double limit = kValidFraction * valid_radius;
  // On the linear continuation (project_lens) when the target lies beyond the limit's image.
  const double angle = std::atan2(target.y(), target.x());
  const Eigen::Vector2d at_limit = distort(lens, limit * std::cos(angle), limit * std::sin(angle));
  if (target.norm() > at_limit.norm()) return Eigen::Vector2d(std::cos(angle), std::sin(angle)) * limit * target.norm() / at_limit.norm();
  Eigen::Vector2d x = target;
  for (int i = 0; i < 50; ++i) {
    const Eigen::Vector2d f = distort(lens, x.x(), x.y()) - target;
    if (f.norm() < 1e-12) break;
    constexpr double h = 1e-7;
    Eigen::Matrix2d J;
    J.col(0) = (distort(lens, x.x() + h, x.y()) - distort(lens, x.x() - h, x.y())) / (2.0 * h);
    J.col(1) = (distort(lens, x.x(), x.y() + h) - distort(lens, x.x(), x.y() - h)) / (2.0 * h);
    x -= J.inverse() * f;
    if (x.norm() > limit) x *= limit / x.norm();  // stay on the monotonic branch of the polynomial
  }
  if ((distort(lens, x.x(), x.y()) - target).norm() > 1e-9) return std::nullopt;
  return x;
}

SimStereoRig stereo_rig_from_model(const mjModel* m, const CameraParams& params, const std::string& model_path) {
  SimStereoRig rig;
  rig.width = params.image_width;
  rig.height = params.image_height;
  rig.left = params.left;
  rig.right = params.right;
  // MuJoCo camera frame (x right, y up, looking along −z) to OpenCV's (x right, y down, z forward).
  const Eigen::Matrix3d mujoco_to_opencv = Eigen::Vector3d(1.0, -1.0, -1.0).asDiagonal();
  // Body FLU to FRD (quad/sim/frames.h).
  const Eigen::Matrix3d flu_to_frd_matrix = Eigen::Vector3d(1.0, -1.0, -1.0).asDiagonal();
  for (const char* name : {"cam_left", "cam_right"}) {
    const int id = mj_name2id(m, mjOBJ_CAMERA, name);
    if (id < 0) throw std::runtime_error(model_path + ": no camera '" + name + "' (the rendered stereo cameras need cam_left and cam_right)");
    const mjtNum* q = m->cam_quat + 4 * id;
    const Eigen::Matrix3d R_flu_mujoco = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized().toRotationMatrix();
    CameraMountModel mount;
    mount.R_BC = flu_to_frd_matrix * R_flu_mujoco * mujoco_to_opencv;
    mount.t_BC = flu_to_frd(Eigen::Vector3d(m->cam_pos[3 * id], m->cam_pos[3 * id + 1], m->cam_pos[3 * id + 2]));
    (std::string(name) == "cam_left" ? rig.left_mount : rig.right_mount) = mount;
  }
  return rig;
}

SimStereoRig misaligned(const SimStereoRig& rig, const Eigen::Vector3d& e) {
  const Eigen::Matrix3d E = (Eigen::AngleAxisd(e.z(), Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(e.y(), Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(e.x(), Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  SimStereoRig out = rig;
  for (CameraMountModel* m : {&out.left_mount, &out.right_mount}) {
    m->R_BC = E * m->R_BC;
    m->t_BC = E * m->t_BC;
  }
  return out;
}

CameraPose camera_pose_over_floor(const CameraMountModel& mount, const Eigen::Vector3d& p_ned, const Eigen::Quaterniond& q_ib) {
  // p_B = R_IBᵀ (p_I − p), p_C = R_BCᵀ (p_B − t_BC).
  const Eigen::Matrix3d R_CB = mount.R_BC.transpose();
  const Eigen::Matrix3d R_BI = q_ib.toRotationMatrix().transpose();
  return CameraPose{R_CB * R_BI, -R_CB * (R_BI * p_ned + mount.t_BC)};
}

}  // namespace quad::sim
