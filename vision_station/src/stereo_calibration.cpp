#include "quad/vision/stereo_calibration.h"

#include <yaml-cpp/yaml.h>

#include <fstream>
#include <sstream>

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
  if (!node.isMap()) {
    throw CalibrationFileError(path + ": key '" + key + "' must be a " + std::to_string(rows) + "x" +
                               std::to_string(cols) + " OpenCV matrix (rows, cols, dt, data)");
  }
  const cv::FileNode r = node["rows"], c = node["cols"], data = node["data"];
  if (!r.isInt() || !c.isInt() || static_cast<int>(r) <= 0 || static_cast<int>(c) <= 0 ||
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

namespace {
StereoCalibration read_calibration(const cv::FileStorage& fs, const std::string& path);

constexpr size_t kMaxCalibrationFileBytes = 1 << 20;  // a real file is ~2.5 KB

// OpenCV 4.6's YAML reader loops forever on some malformed files (fuzzing found a 54-byte one), so a
// file is first parsed with yaml-cpp, and only a document of the expected shape (a mapping whose
// matrix keys are mappings with rows, cols and a data list) is handed to cv::FileStorage.
void check_structure(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw CalibrationFileError(path + ": cannot open calibration file");
  std::ostringstream buffer;
  buffer << in.rdbuf();
  std::string text = buffer.str();
  if (text.size() > kMaxCalibrationFileBytes) throw CalibrationFileError(path + ": too large for a calibration file");
  if (text.rfind("%YAML:", 0) == 0) text[5] = ' ';  // OpenCV writes "%YAML:1.0" for YAML's "%YAML 1.0"
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw CalibrationFileError(path + ":" + std::to_string(e.mark.line + 1) + ": not a YAML calibration file: " + e.msg);
  }
  if (!root.IsMap()) throw CalibrationFileError(path + ": must be a YAML mapping of calibration keys");
  for (const char* key : {"image_width", "image_height"}) {
    if (root[key] && !root[key].IsScalar()) throw CalibrationFileError(path + ": key '" + key + "' must be a number");
  }
  for (const char* key : {"K1", "D1", "K2", "D2", "R", "T", "R1", "R2", "P1", "P2", "Q"}) {
    const YAML::Node m = root[key];
    if (!m) continue;  // reported as missing, by name, when it is read
    if (!m.IsMap() || !m["rows"] || !m["rows"].IsScalar() || !m["cols"] || !m["cols"].IsScalar() || !m["data"] ||
        !m["data"].IsSequence()) {
      throw CalibrationFileError(path + ": key '" + key + "' must be an OpenCV matrix (rows, cols, dt, data)");
    }
    for (const auto& v : m["data"])
      if (!v.IsScalar()) throw CalibrationFileError(path + ": key '" + key + "' has a data entry that is not a number");
  }
}
}  // namespace

StereoCalibration load_calibration(const std::string& path) {
  check_structure(path);
  cv::FileStorage fs;
  try {
    fs.open(path, cv::FileStorage::READ);
  } catch (const std::exception&) {  // cv::Exception, and std::length_error from OpenCV's parser
    throw CalibrationFileError(path + ": not a readable OpenCV YAML/XML file");
  }
  if (!fs.isOpened()) throw CalibrationFileError(path + ": cannot open calibration file");
  // The checks below name the key at fault; an OpenCV assertion on a structure they did not foresee
  // still leaves here as a CalibrationFileError naming the file, never as a raw cv::Exception.
  try {
    return read_calibration(fs, path);
  } catch (const CalibrationFileError&) {
    throw;
  } catch (const cv::Exception& e) {
    throw CalibrationFileError(path + ": malformed calibration file (" + e.err + ")");
  } catch (const std::exception& e) {
    throw CalibrationFileError(path + ": malformed calibration file (" + e.what() + ")");
  }
}

namespace {

StereoCalibration read_calibration(const cv::FileStorage& fs, const std::string& path) {
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

}  // namespace

}  // namespace quad::vision
