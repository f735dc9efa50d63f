#include "quad/vision/stereo_calibration.h"

#include <yaml-cpp/yaml.h>

#include <fstream>
#include <optional>
#include <tuple>
#include <utility>
#include <vector>
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

// The open files of one calibration (one file, or OpenCV's sample pair intrinsics + extrinsics).
struct CalibrationFiles {
  std::vector<std::pair<std::string, cv::FileStorage>> files;  // (path, storage)

  // The first file holding one of `keys` (aliases, e.g. K1 and OpenCV's sample name M1), with the key found.
  std::optional<std::tuple<std::string, cv::FileNode, std::string>> find(std::initializer_list<const char*> keys) const {
    for (const auto& [path, fs] : files) {
      for (const char* key : keys) {
        const cv::FileNode node = fs[key];
        if (!node.empty()) return std::make_tuple(path, node, std::string(key));
      }
    }
    return std::nullopt;
  }
  std::string names() const {
    std::string out;
    for (const auto& file : files) out += (out.empty() ? "" : " + ") + file.first;
    return out;
  }
};

std::string shape(int rows, int cols) { return std::to_string(rows) + "x" + std::to_string(cols); }

// Reads a matrix node with `count` double entries, or throws naming the file and key.
cv::Mat read_matrix_node(const cv::FileNode& node, const std::string& path, const std::string& key, const std::string& expected,
                         size_t count) {
  // OpenCV allocates rows x cols x channels before it reads `data`: check the declared shape first, so
  // a damaged file gets this error instead of a multi-gigabyte allocation.
  const std::string message = path + ": key '" + key + "' must be a " + expected + " OpenCV matrix (rows, cols, dt, data)";
  if (!node.isMap()) throw CalibrationFileError(message);
  const cv::FileNode r = node["rows"], c = node["cols"], data = node["data"];
  if (!r.isInt() || !c.isInt() || static_cast<int>(r) <= 0 || static_cast<int>(c) <= 0 ||
      static_cast<long long>(static_cast<int>(r)) * static_cast<int>(c) != static_cast<long long>(count) ||
      !data.isSeq() || data.size() != count) {
    throw CalibrationFileError(message);
  }
  cv::Mat m;
  try {
    node >> m;
  } catch (const cv::Exception&) {
    throw CalibrationFileError(path + ": key '" + key + "' is not an OpenCV matrix");
  }
  if (m.empty() || m.total() != count || m.channels() != 1) throw CalibrationFileError(message);
  m.convertTo(m, CV_64F);
  if (!cv::checkRange(m)) throw CalibrationFileError(path + ": key '" + key + "' has a non-finite entry");
  return m.reshape(1, static_cast<int>(count));
}

cv::Mat read_matrix(const CalibrationFiles& files, std::initializer_list<const char*> keys, int rows, int cols) {
  const auto found = files.find(keys);
  if (!found) throw CalibrationFileError(files.names() + ": missing key '" + *keys.begin() + "'");
  const auto& [path, node, key] = *found;
  return read_matrix_node(node, path, key, shape(rows, cols), static_cast<size_t>(rows) * cols).reshape(1, rows);
}

// Distortion: OpenCV writes 4, 5, 8, 12 or 14 coefficients. The station's lens model is k1 k2 p1 p2 k3;
// longer vectors are accepted when the terms beyond k3 are zero.
cv::Vec<double, 5> read_distortion(const CalibrationFiles& files, std::initializer_list<const char*> keys) {
  const auto found = files.find(keys);
  if (!found) throw CalibrationFileError(files.names() + ": missing key '" + *keys.begin() + "'");
  const auto& [path, node, key] = *found;
  const cv::FileNode r = node.isMap() ? node["rows"] : cv::FileNode(), c = node.isMap() ? node["cols"] : cv::FileNode();
  const long long count = r.isInt() && c.isInt() ? static_cast<long long>(static_cast<int>(r)) * static_cast<int>(c) : 0;
  if (count != 4 && count != 5 && count != 8 && count != 12 && count != 14) {
    throw CalibrationFileError(path + ": key '" + key + "' must hold 4, 5, 8, 12 or 14 distortion coefficients");
  }
  const cv::Mat m = read_matrix_node(node, path, key, "1x" + std::to_string(count), static_cast<size_t>(count));
  cv::Vec<double, 5> d(0, 0, 0, 0, 0);
  for (int i = 0; i < m.rows; ++i) {
    if (i < 5) {
      d[i] = m.at<double>(i);
    } else if (m.at<double>(i) != 0.0) {
      throw CalibrationFileError(path + ": key '" + key + "' has a non-zero coefficient " + std::to_string(i + 1) +
                                 " (rational/thin-prism/tilt model); the station's lens model is k1 k2 p1 p2 k3");
    }
  }
  return d;
}

int read_positive_int(const CalibrationFiles& files, const char* key) {
  const auto found = files.find({key});
  if (!found) {
    throw CalibrationFileError(files.names() + ": missing key '" + key +
                               "' (OpenCV's stereo_calib sample does not write the image size: add image_width "
                               "and image_height)");
  }
  const auto& [path, node, name] = *found;
  if (!node.isInt() || static_cast<int>(node) <= 0) {
    throw CalibrationFileError(path + ": key '" + name + "' must be a positive integer");
  }
  return static_cast<int>(node);
}

}  // namespace
namespace {

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
  for (const char* key : {"K1", "M1", "D1", "K2", "M2", "D2", "R", "T", "R1", "R2", "P1", "P2", "Q"}) {
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

StereoCalibration read_calibration(const CalibrationFiles& files) {
  StereoCalibration c;
  c.rig.image_size.width = read_positive_int(files, "image_width");
  c.rig.image_size.height = read_positive_int(files, "image_height");
  c.rig.left.K = cv::Matx33d(read_matrix(files, {"K1", "M1"}, 3, 3));
  c.rig.left.D = read_distortion(files, {"D1"});
  c.rig.right.K = cv::Matx33d(read_matrix(files, {"K2", "M2"}, 3, 3));
  c.rig.right.D = read_distortion(files, {"D2"});
  c.rig.R = cv::Matx33d(read_matrix(files, {"R"}, 3, 3));
  c.rig.T = cv::Vec3d(read_matrix(files, {"T"}, 3, 1));
  // Rectification: all five keys, or none (then computed here, as `calibrate` would have).
  const char* rectification_keys[] = {"R1", "R2", "P1", "P2", "Q"};
  int present = 0;
  for (const char* key : rectification_keys) present += files.find({key}) ? 1 : 0;
  if (present == 0) {
    if (!(c.rig.T[0] < 0.0)) {
      throw CalibrationFileError(files.names() + ": key 'T' does not put the right camera to the right of the left "
                                 "one (need T[0] < 0)");
    }
    StereoCalibration computed = rectify(c.rig);
    computed.rectification_computed = true;
    return computed;
  }
  for (const char* key : rectification_keys) {
    if (!files.find({key})) {
      throw CalibrationFileError(files.names() + ": missing key '" + key +
                                 "' (give all of R1 R2 P1 P2 Q, or none to have them computed)");
    }
  }
  c.R1 = cv::Matx33d(read_matrix(files, {"R1"}, 3, 3));
  c.R2 = cv::Matx33d(read_matrix(files, {"R2"}, 3, 3));
  c.P1 = cv::Matx34d(read_matrix(files, {"P1"}, 3, 4));
  c.P2 = cv::Matx34d(read_matrix(files, {"P2"}, 3, 4));
  c.Q = cv::Matx44d(read_matrix(files, {"Q"}, 4, 4));
  if (!(c.P1(0, 0) > 0.0) || !(c.baseline() > 0.0)) {
    throw CalibrationFileError(files.names() + ": P1/P2 do not describe a horizontal rig with the right camera on "
                               "the right (need P1(0,0) > 0 and P2(0,3) < 0)");
  }
  return c;
}

}  // namespace

StereoCalibration load_calibration(const std::string& spec) {
  std::vector<std::string> paths;
  const size_t comma = spec.find(',');
  if (comma == std::string::npos) {
    paths.push_back(spec);
  } else {
    paths.push_back(spec.substr(0, comma));
    paths.push_back(spec.substr(comma + 1));
    if (paths[0].empty() || paths[1].empty() || paths[1].find(',') != std::string::npos) {
      throw CalibrationFileError(spec + ": expected CALIB.yaml or INTRINSICS.yml,EXTRINSICS.yml");
    }
  }
  CalibrationFiles files;
  for (const std::string& path : paths) {
    check_structure(path);
    cv::FileStorage fs;
    try {
      fs.open(path, cv::FileStorage::READ);
    } catch (const std::exception&) {  // cv::Exception, and std::length_error from OpenCV's parser
      throw CalibrationFileError(path + ": not a readable OpenCV YAML/XML file");
    }
    if (!fs.isOpened()) throw CalibrationFileError(path + ": cannot open calibration file");
    files.files.emplace_back(path, fs);
  }
  // The checks name the key at fault; an OpenCV assertion on a structure they did not foresee still
  // leaves here as a CalibrationFileError naming the file, never as a raw cv::Exception.
  try {
    return read_calibration(files);
  } catch (const CalibrationFileError&) {
    throw;
  } catch (const cv::Exception& e) {
    throw CalibrationFileError(files.names() + ": malformed calibration file (" + e.err + ")");
  } catch (const std::exception& e) {
    throw CalibrationFileError(files.names() + ": malformed calibration file (" + e.what() + ")");
  }
}

}  // namespace quad::vision
