#include "quad/vision/pair_list.h"

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>

namespace quad::vision {
namespace {

std::vector<std::string> split_csv_line(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream stream(line);
  std::string cell;
  while (std::getline(stream, cell, ',')) {
    const size_t a = cell.find_first_not_of(" \t\r\"");
    const size_t b = cell.find_last_not_of(" \t\r\"");
    cells.push_back(a == std::string::npos ? "" : cell.substr(a, b - a + 1));
  }
  return cells;
}

}  // namespace

std::vector<ImagePair> read_pair_list(const std::string& csv_path) {
  std::ifstream in(csv_path);
  if (!in) throw std::runtime_error(csv_path + ": cannot open pair list");
  const std::filesystem::path base = std::filesystem::path(csv_path).parent_path();
  std::string line;
  int line_number = 0;
  int left_column = -1, right_column = -1;
  std::vector<ImagePair> pairs;
  while (std::getline(in, line)) {
    ++line_number;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    const std::vector<std::string> cells = split_csv_line(line);
    if (left_column < 0) {
      for (size_t i = 0; i < cells.size(); ++i) {
        if (cells[i] == "left") left_column = static_cast<int>(i);
        if (cells[i] == "right") right_column = static_cast<int>(i);
      }
      if (left_column < 0 || right_column < 0) {
        throw std::runtime_error(csv_path + ":" + std::to_string(line_number) +
                                 ": header must name the columns 'left' and 'right'");
      }
      continue;
    }
    const size_t needed = static_cast<size_t>(std::max(left_column, right_column)) + 1;
    if (cells.size() < needed || cells[left_column].empty() || cells[right_column].empty()) {
      throw std::runtime_error(csv_path + ":" + std::to_string(line_number) + ": missing left or right path");
    }
    auto resolve = [&](const std::string& p) {
      const std::filesystem::path path(p);
      return (path.is_relative() ? base / path : path).string();
    };
    pairs.push_back(ImagePair{resolve(cells[left_column]), resolve(cells[right_column]), line_number});
  }
  if (left_column < 0) throw std::runtime_error(csv_path + ": empty pair list (need a header 'left,right')");
  return pairs;
}

cv::Mat read_grey_image(const std::string& path) {
  cv::Mat image = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (image.empty()) throw std::runtime_error(path + ": cannot read image (missing or not an image)");
  return image;
}

}  // namespace quad::vision
