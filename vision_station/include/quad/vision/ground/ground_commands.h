// The ground-camera subcommands of vision_station (docs/vision_station.md, "Ground-camera mode"):
//   calibrate-room --images DIR [--board 8x6] [--square 0.10] --out room.yaml
//   track --room room.yaml --vehicles vehicles.yaml --frames frames.csv [--out FILE.jsonl]
//         [--no-epipolar] [--no-roi]
//   track --room room.yaml --vehicles vehicles.yaml --source sim:SOCKET [--radio ID=PATH[,...]] [--baud B]
//         [--message vision_position_estimate] [--out FILE.jsonl] [--status-s S] [--timeout-ms MS]
#pragma once

#include <map>
#include <stdexcept>
#include <string>

namespace quad::vision::ground {

// A command-line mistake (exit code 2 with the usage text).
struct CommandUsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

int calibrate_room_command(const std::map<std::string, std::string>& options);
int track_command(const std::map<std::string, std::string>& options);

}  // namespace quad::vision::ground
