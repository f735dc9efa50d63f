#include "quad/vision/ground/room_camera.h"

#include <stdexcept>

#include <opencv2/calib3d.hpp>

namespace quad::vision::ground {

cv::Matx34d RoomCamera::projection() const {
  cv::Matx34d Rt;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) Rt(r, c) = R_CI(r, c);
    Rt(r, 3) = t_CI[r];
  }
  return K * Rt;  // seed 003 eq. 3.2
}

cv::Vec3d RoomCamera::centre_ned() const { return -(R_CI.t() * t_CI); }

std::vector<cv::Point2d> RoomCamera::undistort(const std::vector<cv::Point2d>& pixels) const {
  if (pixels.empty()) return {};
  std::vector<cv::Point2d> out;
  cv::undistortPoints(pixels, out, K, D, cv::noArray(), K,
                      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 1e-9));
  return out;
}

cv::Matx33d fundamental(const RoomCamera& a, const RoomCamera& b) {
  // Relative pose x_b = R x_a + t; E = [t]x R; F = K_b^-T E K_a^-1 (Hartley & Zisserman 9.6, seed 003 ref. [6]).
  const cv::Matx33d R = b.R_CI * a.R_CI.t();
  const cv::Vec3d t = b.t_CI - R * a.t_CI;
  const cv::Matx33d tx(0, -t[2], t[1], t[2], 0, -t[0], -t[1], t[0], 0);
  return b.K.inv().t() * (tx * R) * a.K.inv();
}

void save_room_rig(const RoomRig& rig, const std::string& path) {
  cv::FileStorage fs(path, cv::FileStorage::WRITE);
  if (!fs.isOpened()) throw std::runtime_error(path + ": cannot write");
  fs << "cameras" << static_cast<int>(rig.cameras.size());
  for (size_t i = 0; i < rig.cameras.size(); ++i) {
    const RoomCamera& c = rig.cameras[i];
    const std::string p = "camera_" + std::to_string(i) + "_";
    fs << p + "image_size" << c.image_size;
    fs << p + "K" << cv::Mat(c.K);
    fs << p + "D" << cv::Mat(c.D);
    fs << p + "R_CI" << cv::Mat(c.R_CI);
    fs << p + "t_CI" << cv::Mat(c.t_CI);
    fs << p + "P" << cv::Mat(c.projection());  // for readers that want the matrix of eq. 3.2 only
    fs << p + "centre_ned" << cv::Mat(c.centre_ned());
  }
}

namespace {

cv::Mat read_matrix(const cv::FileStorage& fs, const std::string& path, const std::string& key, int rows, int cols) {
  const cv::FileNode node = fs[key];
  if (node.empty()) throw std::runtime_error(path + ": missing key '" + key + "'");
  cv::Mat m;
  try {
    node >> m;
  } catch (const cv::Exception&) {
    throw std::runtime_error(path + ": key '" + key + "' is not a matrix");
  }
  if (m.total() != static_cast<size_t>(rows * cols)) {
    throw std::runtime_error(path + ": key '" + key + "' must have " + std::to_string(rows * cols) + " elements");
  }
  m.convertTo(m, CV_64F);
  return m.reshape(1, rows);
}

}  // namespace

RoomRig load_room_rig(const std::string& path) {
  cv::FileStorage fs;
  try {
    fs.open(path, cv::FileStorage::READ);
  } catch (const cv::Exception&) {
    throw std::runtime_error(path + ": not a readable OpenCV YAML/XML file");
  }
  if (!fs.isOpened()) throw std::runtime_error(path + ": cannot open");
  if (!fs["cameras"].isInt()) throw std::runtime_error(path + ": missing or malformed key 'cameras' (an integer)");
  const int n = static_cast<int>(fs["cameras"]);
  if (n < 2) throw std::runtime_error(path + ": key 'cameras' must be at least 2 (triangulation needs two views)");
  RoomRig rig;
  for (int i = 0; i < n; ++i) {
    const std::string p = "camera_" + std::to_string(i) + "_";
    RoomCamera c;
    const cv::FileNode size = fs[p + "image_size"];
    if (!size.isSeq() || size.size() != 2 || !size[0].isInt() || !size[1].isInt()) {
      throw std::runtime_error(path + ": missing or malformed key '" + p + "image_size' ([width, height])");
    }
    c.image_size = cv::Size(static_cast<int>(size[0]), static_cast<int>(size[1]));
    if (c.image_size.width <= 0 || c.image_size.height <= 0) {
      throw std::runtime_error(path + ": key '" + p + "image_size' must be positive");
    }
    c.K = cv::Matx33d(read_matrix(fs, path, p + "K", 3, 3));
    c.D = cv::Vec<double, 5>(read_matrix(fs, path, p + "D", 5, 1));
    c.R_CI = cv::Matx33d(read_matrix(fs, path, p + "R_CI", 3, 3));
    c.t_CI = cv::Vec3d(read_matrix(fs, path, p + "t_CI", 3, 1));
    if (std::abs(cv::determinant(c.R_CI) - 1.0) > 1e-6) {
      throw std::runtime_error(path + ": key '" + p + "R_CI' is not a rotation");
    }
    rig.cameras.push_back(c);
  }
  return rig;
}

}  // namespace quad::vision::ground
