// vision_eval_gen: stereo sets for measuring the vision station, drawn by a model that shares no code with
// it (eval_camera.h).
//   vision_eval_gen sets --out DIR --split tune|heldout --stars N [--conditions a,b,..] [--photos DIR]
//   vision_eval_gen chessboards --out DIR [--views 96]
// sets: per condition DIR/<condition>/ with NNNNN_left/right images (PNG, JPEG for JPEG conditions),
// pairs.csv (left,right: the station's pair list) and truth.csv; N pairs with the star in full view plus
// N/3 without (none, or cut by an image edge). chessboards: DIR/pairs.csv of 9 × 6 boards, 30 mm squares.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "eval_scene.h"

namespace {

using namespace vision_eval;
namespace fs = std::filesystem;

// Floor photographs (Debian opencv-doc). The held-out split never sees the tuning split's photographs.
const std::vector<std::string> kTunePhotos{"baboon.jpg", "fruits.jpg", "building.jpg"};
const std::vector<std::string> kHeldOutPhotos{"starry_night.jpg", "graf1.png", "leuvenA.jpg", "stuff.jpg"};

std::map<std::string, std::string> options(int argc, char** argv) {
  std::map<std::string, std::string> o;
  for (int i = 2; i + 1 < argc; i += 2) o[argv[i]] = argv[i + 1];
  if (argc % 2 != 0) throw std::runtime_error(std::string("option ") + argv[argc - 1] + " needs a value");
  return o;
}

std::string get(const std::map<std::string, std::string>& o, const std::string& key, const std::string& fallback) {
  const auto it = o.find(key);
  if (it != o.end()) return it->second;
  if (fallback.empty()) throw std::runtime_error("missing " + key);
  return fallback;
}

void write_image(const fs::path& path, const cv::Mat& image, int jpeg_quality) {
  const std::vector<int> params = jpeg_quality > 0 ? std::vector<int>{cv::IMWRITE_JPEG_QUALITY, jpeg_quality}
                                                   : std::vector<int>{cv::IMWRITE_PNG_COMPRESSION, 1};
  if (!cv::imwrite(path.string(), image, params)) throw std::runtime_error(path.string() + ": cannot write");
}

void write_truth_line(std::ofstream& out, const std::string& left, const PairTruth& t) {
  char line[512];
  std::snprintf(line, sizeof line,
                "%s,%d,%d,%.6f,%.6f,%.6f,%.5f,%.4f,%.3f,%s,%.2f,%d,%.2f,%.2f,%.4f,%d,%d,%d,%d,%.6f,%.6f,%.6f\n", left.c_str(),
                t.star_in_view ? 1 : 0, t.star_cut ? 1 : 0, t.star_left[0], t.star_left[1], t.star_left[2], t.range_m,
                t.height_m, t.tilt_deg, t.floor.c_str(), t.blur_px, t.interlaced ? 1 : 0, t.field_shift_px, t.skew_px,
                t.snow, t.sync_bands, t.jpeg_quality, t.frozen ? 1 : 0, t.decoys, t.star_normal[0], t.star_normal[1],
                t.star_normal[2]);
  out << line;
}

int make_sets(const std::map<std::string, std::string>& o) {
  const fs::path out = get(o, "--out", "");
  const std::string split = get(o, "--split", "");
  if (split != "tune" && split != "heldout") throw std::runtime_error("--split must be tune or heldout");
  const int stars = std::stoi(get(o, "--stars", ""));
  const fs::path photo_dir = get(o, "--photos", "/usr/share/doc/opencv-doc/examples/data");
  std::vector<std::string> photos;
  for (const std::string& name : split == "tune" ? kTunePhotos : kHeldOutPhotos) photos.push_back((photo_dir / name).string());
  const std::string only = o.count("--conditions") ? "," + o.at("--conditions") + "," : "";
  const std::vector<Condition> conditions = all_conditions();
  PairGenerator generator(fpv_rig(), photos);
  for (size_t ci = 0; ci < conditions.size(); ++ci) {
    const Condition& condition = conditions[ci];
    if (!only.empty() && only.find("," + condition.name + ",") == std::string::npos) continue;
    // Seeds differ per split and per condition: no pair of one split appears in another.
    const uint64_t seed = (split == "tune" ? 1000 : 90000) + 17 * ci;
    generator.reseed(seed);
    const fs::path dir = out / condition.name;
    fs::create_directories(dir);
    std::ofstream pairs(dir / "pairs.csv"), truth(dir / "truth.csv");
    pairs << "left,right\n";
    truth << "left,star_in_view,star_cut,x,y,z,range_m,height_m,tilt_deg,floor,blur_px,interlaced,field_shift_px,"
             "skew_px,snow,sync_bands,jpeg_quality,frozen,decoys,normal_x,normal_y,normal_z\n";
    const int without = (stars + 2) / 3, total = stars + without;  // 25 % of the pairs have no star in view
    for (int i = 0; i < total; ++i) {
      const bool no_star = (i + 1) * without / total > i * without / total;  // spread evenly
      const StereoImages p = generator.make(condition, !no_star);
      char name[32];
      const char* ext = p.truth.jpeg_quality > 0 ? "jpg" : "png";
      std::snprintf(name, sizeof name, "%05d_left.%s", i, ext);
      const std::string left = name;
      std::snprintf(name, sizeof name, "%05d_right.%s", i, ext);
      const std::string right = name;
      write_image(dir / left, p.left, p.truth.jpeg_quality);
      write_image(dir / right, p.right, p.truth.jpeg_quality);
      pairs << left << "," << right << "\n";
      write_truth_line(truth, left, p.truth);
      if ((i + 1) % 50 == 0 || i + 1 == total) std::cerr << "\r" << condition.name << ": " << i + 1 << "/" << total << std::flush;
    }
    std::cerr << "\n";
  }
  return 0;
}

int make_chessboards(const std::map<std::string, std::string>& o) {
  const fs::path out = get(o, "--out", "");
  const int views = std::stoi(get(o, "--views", "96"));
  fs::create_directories(out);
  std::ofstream pairs(out / "pairs.csv");
  pairs << "left,right\n";
  const std::vector<StereoImages> boards = chessboard_views(fpv_rig(), views, 9, 6, 0.03, 7);
  for (size_t i = 0; i < boards.size(); ++i) {
    const std::string stem = "board" + std::to_string(i);
    write_image(out / (stem + "_left.png"), boards[i].left, 0);
    write_image(out / (stem + "_right.png"), boards[i].right, 0);
    pairs << stem << "_left.png," << stem << "_right.png\n";
  }
  std::cerr << boards.size() << " chessboard pairs in " << out.string() << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const std::string command = argc > 1 ? argv[1] : "";
    if (command == "sets") return make_sets(options(argc, argv));
    if (command == "chessboards") return make_chessboards(options(argc, argv));
    std::cerr << "usage: vision_eval_gen sets --out DIR --split tune|heldout --stars N [--conditions a,b]"
                 " [--photos DIR]\n       vision_eval_gen chessboards --out DIR [--views 96]\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "vision_eval_gen: " << e.what() << "\n";
    return 1;
  }
}
