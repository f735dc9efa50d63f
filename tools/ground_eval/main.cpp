// ground_scene_gen: independent frame sets and calibration boards for the vision station's ground-camera
// mode (docs/vision_station.md, "Ground-camera mode").
//   ground_scene_gen boards DIR [--seed N]
//   ground_scene_gen scene DIR --scenario single|pair|crossing|retreat|four [--frames N] [--seed N]
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "ground_scenes.h"

int main(int argc, char** argv) {
  using namespace ground_eval;
  if (argc < 3) {
    std::fprintf(stderr, "usage: ground_scene_gen boards DIR [--seed N]\n"
                         "       ground_scene_gen scene DIR --scenario single|pair|crossing|retreat|four [--frames N] [--seed N]\n");
    return 2;
  }
  const std::string command = argv[1], dir = argv[2];
  SceneOptions options;
  for (int i = 3; i + 1 < argc; i += 2) {
    const std::string key = argv[i], value = argv[i + 1];
    if (key == "--seed") {
      options.seed = std::strtoull(value.c_str(), nullptr, 10);
    } else if (key == "--frames") {
      options.frames = std::atoi(value.c_str());
    } else if (key == "--scenario") {
      bool known = false;
      for (Scenario s : {Scenario::kSingle, Scenario::kPair, Scenario::kCrossing, Scenario::kRetreat, Scenario::kFour}) {
        if (value == scenario_name(s)) {
          options.scenario = s;
          known = true;
        }
      }
      if (!known) {
        std::fprintf(stderr, "ground_scene_gen: unknown scenario '%s'\n", value.c_str());
        return 2;
      }
    } else {
      std::fprintf(stderr, "ground_scene_gen: unknown option '%s'\n", key.c_str());
      return 2;
    }
  }
  try {
    const auto cameras = make_room_cameras(RoomSpec());
    if (command == "boards") {
      const auto written = write_calibration_set(dir, cameras, BoardSpec(), 12, options.seed);
      for (size_t c = 0; c < written.size(); ++c) std::printf("camera %zu: %d views\n", c, written[c]);
    } else if (command == "scene") {
      write_scene_set(dir, cameras, VehicleModel(), options);
    } else {
      std::fprintf(stderr, "ground_scene_gen: unknown command '%s'\n", command.c_str());
      return 2;
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ground_scene_gen: %s\n", e.what());
    return 1;
  }
  return 0;
}
