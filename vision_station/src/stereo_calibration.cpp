#include "quad/vision/stereo_calibration.h"

#include <opencv2/calib3d.hpp>

namespace quad::vision {

StereoCalibration rectify(const StereoRig& rig) {
  StereoCalibration c;
  c.rig = rig;
  cv::Mat R1, R2, P1, P2, Q;
  // OpenCV's default scaling (alpha −1): for the thesis rig it gives the rectified focal length of
  // table 7.2 (458.9 px), which is how the thesis rectified.
  cv::stereoRectify(cv::Mat(rig.left.K), cv::Mat(rig.left.D), cv::Mat(rig.right.K), cv::Mat(rig.right.D),
                    rig.image_size, cv::Mat(rig.R), cv::Mat(rig.T), R1, R2, P1, P2, Q,
                    cv::CALIB_ZERO_DISPARITY, -1.0, rig.image_size);
  c.R1 = cv::Matx33d(R1);
  c.R2 = cv::Matx33d(R2);
  c.P1 = cv::Matx34d(P1);
  c.P2 = cv::Matx34d(P2);
  c.Q = cv::Matx44d(Q);
  return c;
}

void save_calibration(const StereoCalibration& c, const std::string& path) {
  cv::FileStorage fs(path, cv::FileStorage::WRITE);
  if (!fs.isOpened()) throw CalibrationFileError(path + ": cannot open for writing");
  fs << "image_width" << c.rig.image_size.width << "image_height" << c.rig.image_size.height;
  fs << "K1" << cv::Mat(c.rig.left.K) << "D1" << cv::Mat(c.rig.left.D).t();
  fs << "K2" << cv::Mat(c.rig.right.K) << "D2" << cv::Mat(c.rig.right.D).t();
  fs << "R" << cv::Mat(c.rig.R) << "T" << cv::Mat(c.rig.T);
  fs << "R1" << cv::Mat(c.R1) << "R2" << cv::Mat(c.R2) << "P1" << cv::Mat(c.P1) << "P2" << cv::Mat(c.P2)
     << "Q" << cv::Mat(c.Q);
}

namespace {

// Reads a matrix key with exactly rows × cols double entries (any shape with that many elements for
// vectors), or throws naming the file and key.
cv::Mat read_matrix(const cv::FileStorage& fs, const std::string& path, const char* key, int rows, int cols) {
  const cv::FileNode node = fs[key];
  if (node.empty()) throw CalibrationFileError(path + ": missing key '" + key + "'");
  // OpenCV allocates rows x cols x channels before it reads `data`: check the declared shape first, so
  // a damaged file gets this error instead of a multi-gigabyte allocation.
  const cv::FileNode r = node["rows"], c = node["cols"], data = node["data"];
  if (!node.isMap() || !r.isInt() || !c.isInt() || static_cast<int>(r) <= 0 || static_cast<int>(c) <= 0 ||
      static_cast<long long>(static_cast<int>(r)) * static_cast<int>(c) != static_cast<long long>(rows) * cols ||
      !data.isSeq() || data.size() != static_cast<size_t>(rows) * static_cast<size_t>(cols)) {
    throw CalibrationFileError(path + ": key '" + key + "' must be a " + std::to_string(rows) + "x" +
                               std::to_string(cols) + " OpenCV matrix (rows, cols, dt, data)");
  }
  cv::Mat m;
  try {
    node >> m;
  } catch (const cv::Exception&) {
    throw CalibrationFileError(path + ": key '" + key + "' is not an OpenCV matrix");
  }
  if (m.empty() || m.total() != static_cast<size_t>(rows) * static_cast<size_t>(cols) || m.channels() != 1) {
    throw CalibrationFileError(path + ": key '" + key + "' must be a " + std::to_string(rows) + "x" +
                               std::to_string(cols) + " matrix");
  }
  m.convertTo(m, CV_64F);
  m = m.reshape(1, rows);
  if (!cv::checkRange(m)) throw CalibrationFileError(path + ": key '" + key + "' has a non-finite entry");
  return m;
}

int read_positive_int(const cv::FileStorage& fs, const std::string& path, const char* key) {
  const cv::FileNode node = fs[key];
  if (node.empty()) throw CalibrationFileError(path + ": missing key '" + key + "'");
  if (!node.isInt() || static_cast<int>(node) <= 0) {
    throw CalibrationFileError(path + ": key '" + key + "' must be a positive integer");
  }
  return static_cast<int>(node);
}

}  // namespace

StereoCalibration load_calibration(const std::string& path) {
  cv::FileStorage fs;
  try {
    fs.open(path, cv::FileStorage::READ);
  } catch (const cv::Exception& e) {
    throw CalibrationFileError(path + ": not a readable OpenCV YAML/XML file");
  }
  if (!fs.isOpened()) throw CalibrationFileError(path + ": cannot open calibration file");
  StereoCalibration c;
  c.rig.image_size.width = read_positive_int(fs, path, "image_width");
  c.rig.image_size.height = read_positive_int(fs, path, "image_height");
  c.rig.left.K = cv::Matx33d(read_matrix(fs, path, "K1", 3, 3));
  c.rig.left.D = cv::Vec<double, 5>(read_matrix(fs, path, "D1", 5, 1));
  c.rig.right.K = cv::Matx33d(read_matrix(fs, path, "K2", 3, 3));
  c.rig.right.D = cv::Vec<double, 5>(read_matrix(fs, path, "D2", 5, 1));
  c.rig.R = cv::Matx33d(read_matrix(fs, path, "R", 3, 3));
  c.rig.T = cv::Vec3d(read_matrix(fs, path, "T", 3, 1));
  c.R1 = cv::Matx33d(read_matrix(fs, path, "R1", 3, 3));
  c.R2 = cv::Matx33d(read_matrix(fs, path, "R2", 3, 3));
  c.P1 = cv::Matx34d(read_matrix(fs, path, "P1", 3, 4));
  c.P2 = cv::Matx34d(read_matrix(fs, path, "P2", 3, 4));
  c.Q = cv::Matx44d(read_matrix(fs, path, "Q", 4, 4));
  if (!(c.P1(0, 0) > 0.0) || !(c.baseline() > 0.0)) {
    throw CalibrationFileError(path + ": P1/P2 do not describe a horizontal rig with the right camera on the "
                               "right (need P1(0,0) > 0 and P2(0,3) < 0)");
  }
  return c;
}

}  // namespace quad::vision
