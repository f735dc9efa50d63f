// Image pairs for offline evaluation: a CSV with a header naming the columns left and right.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace quad::vision {

struct ImagePair {
  std::string left, right;
  int line = 0;  // line in the CSV (1-based), 0 when not from a file
};

// Relative paths are taken relative to the CSV's folder. Throws std::runtime_error naming file and line.
std::vector<ImagePair> read_pair_list(const std::string& csv_path);

// Reads an image as CV_8UC1; throws std::runtime_error naming the file when it cannot be read.
cv::Mat read_grey_image(const std::string& path);

}  // namespace quad::vision
