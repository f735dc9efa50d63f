// quad_sim: the MuJoCo hardware-in-the-loop simulator (docs/simulator.md).
//
//   quad_sim --scenario FILE [--out DIR] [--seed N] [--set KEY=VALUE]... [--realtime] [--firmware CMD] [--viewer]
//            [--viewer-screenshot FILE.png] [--record FILE.mp4] [--ground-port LINK] [--station CMD]
//            [--station-calib FILE] [--room-calib FILE] [--gcs [udp:HOST:PORT]] [--no-tlog] [--no-plots] [--quiet]
//
// Exit status: 0 the run completed and wrote every output; 1 the run was cut short (interrupted, the
// firmware stopped answering, ...) or could not start; 2 bad arguments; 3 the run completed and its log
// and summary are written, but the plots or the --record video could not be made.
#include <unistd.h>

#include <atomic>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "quad/sim/fleet_session.h"
#include "quad/sim/hil_session.h"
#include "quad/sim/recorder.h"
#include "quad/sim/scenario.h"
#include "quad/sim/vehicle.h"
#include "quad/sim/viewer.h"

namespace {

std::atomic<bool> g_stop{false};

void on_signal(int) { g_stop = true; }

int usage(const char* error) {
  if (error) std::fprintf(stderr, "quad_sim: %s\n", error);
  std::fprintf(stderr,
               "usage: quad_sim --scenario FILE [--out DIR] [--seed N] [--set KEY=VALUE]... [--realtime] [--firmware CMD]\n"
               "                [--viewer] [--viewer-screenshot FILE.png] [--record FILE.mp4] [--ground-port LINK]\n"
               "                [--station CMD] [--station-calib FILE] [--room-calib FILE] [--gcs [udp:HOST:PORT]]\n"
               "                [--no-tlog] [--no-plots] [--quiet]\n"
               "  --scenario FILE   YAML scenario (sim/scenarios/*.yaml)\n"
               "  --out DIR         run folder (default runs/<scenario>-<UTC time>)\n"
               "  --seed N          override the scenario's random seed\n"
               "  --set KEY=VALUE   override one scenario key (repeatable): a dotted path, list items by index,\n"
               "                    a YAML value: radio.latency_s=0.01, firmware_params.POS_KP_XY=4,\n"
               "                    commands.3.at_s=45, wind.mean_ned_m_s=[1,0,0]\n"
               "  --realtime        pace by the wall clock (emulated MCUs) instead of lockstep\n"
               "  --firmware CMD    firmware command (default: quad_firmware next to quad_sim, its flight\n"
               "                    logs in the run folder: --log-dir DIR); the port\n"
               "                    arguments (--uart0 ... --params FILE) are appended\n"
               "  --viewer          MuJoCo window following the vehicle (needs a display); closing it ends\n"
               "                    the run like Ctrl-C. Left drag rotates, right drag or the wheel zooms\n"
               "  --viewer-screenshot FILE.png  with --viewer: the window's last picture, at the end\n"
               "  --record FILE     render an MP4 offscreen (OSMesa + ffmpeg), chase camera\n"
               "  --ground-port LINK  the base-station side of the radio as a serial port (a symlink to a\n"
               "                    pty) for the vision station or a ground station; set vision.enabled:\n"
               "                    false in the scenario when the station sends the fixes\n"
               "  --station CMD     vision station command for scenarios with camera.enabled (default:\n"
               "                    'vision_station run' next to quad_sim); --calib --settings --source\n"
               "                    sim:SOCKET --out PTY --baud B --status-s 10 --timeout-ms 60000 are appended.\n"
               "                    The station is calibrated by CMD with 'run' replaced by 'calibrate' on\n"
               "                    chessboards rendered through the scenario's cameras, cached in\n"
               "                    station_calibration/ beside the station executable\n"
               "  --station-calib FILE  give the station this calibration instead\n"
               "                    With ground_cameras.enabled the same command with 'run' replaced by 'track'\n"
               "                    is the ground-camera station (--room --vehicles --source sim:SOCKET --radio\n"
               "                    ID=PTY --baud B --message M --out RUN/ground_track.jsonl appended), calibrated\n"
               "                    by 'calibrate-room' on boards rendered through the room cameras (cached)\n"
               "  --room-calib FILE give the ground-camera station this room calibration instead\n"
               "  --gcs [udp:HOST:PORT]  a ground station over UDP (default udp:127.0.0.1:14550, where\n"
               "                    QGroundControl and MAVProxy listen): what comes out of the ground side of\n"
               "                    the radio is sent there, datagrams from whoever sends to the simulator's\n"
               "                    socket enter the radio (use --realtime to fly by hand)\n"
               "  --no-tlog         do not write RUN/link.tlog (the ground side of the radio, both ways)\n"
               "  --no-plots        skip the PNG plots\n"
               "  --quiet           no progress line\n"
               "exit status: 0 complete; 1 cut short or not started; 2 bad arguments; 3 complete, log and\n"
               "summary written, but the plots (python3-matplotlib) or the --record video failed\n");
  return 2;
}

std::string executable_dir() {
  char buf[4096];
  const ssize_t n = readlink("/proc/self/exe", buf, sizeof buf - 1);
  if (n <= 0) return ".";
  std::string p(buf, static_cast<size_t>(n));
  return p.substr(0, p.find_last_of('/'));
}

std::vector<std::string> split_words(const std::string& s) {
  std::istringstream in(s);
  std::vector<std::string> out;
  for (std::string w; in >> w;) out.push_back(w);
  return out;
}

std::string utc_stamp() {
  const std::time_t now = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y%m%dT%H%M%SZ", std::gmtime(&now));
  return buf;
}

}  // namespace

int main(int argc, char** argv) {
  std::string scenario_path, out_dir, firmware, record, ground_port, station, station_calib, room_calib, screenshot;
  std::optional<long> seed;
  std::vector<quad::sim::ScenarioOverride> overrides;
  std::optional<quad::sim::UdpEndpoint> gcs;
  bool realtime = false, viewer = false, plots = true, quiet = false, tlog = true;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&](const char* name) -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(std::string(name) + " needs a value");
      return argv[++i];
    };
    try {
      if (a == "--scenario") scenario_path = value("--scenario");
      else if (a == "--out") out_dir = value("--out");
      else if (a == "--seed") seed = std::stol(value("--seed"));
      else if (a == "--set") overrides.push_back(quad::sim::parse_override(value("--set")));
      else if (a == "--firmware") firmware = value("--firmware");
      else if (a == "--record") record = value("--record");
      else if (a == "--viewer-screenshot") screenshot = value("--viewer-screenshot");
      else if (a == "--ground-port") ground_port = value("--ground-port");
      else if (a == "--station") station = value("--station");
      else if (a == "--station-calib") station_calib = value("--station-calib");
      else if (a == "--room-calib") room_calib = value("--room-calib");
      else if (a == "--gcs") {
        // The value is optional: the next argument is it unless it is another option.
        const bool given = i + 1 < argc && std::string(argv[i + 1]).rfind("--", 0) != 0;
        try {
          gcs = quad::sim::parse_udp_endpoint(given ? argv[++i] : "udp:127.0.0.1:14550");
        } catch (const std::invalid_argument& e) {
          throw std::invalid_argument(std::string("--gcs ") + e.what());
        }
      }
      else if (a == "--no-tlog") tlog = false;
      else if (a == "--realtime") realtime = true;
      else if (a == "--viewer") viewer = true;
      else if (a == "--no-plots") plots = false;
      else if (a == "--quiet") quiet = true;
      else if (a == "--help" || a == "-h") return usage(nullptr);
      else return usage(("unknown argument " + a).c_str());
    } catch (const std::exception& e) {
      return usage(e.what());
    }
  }
  if (scenario_path.empty()) return usage("--scenario is required");
  if (!screenshot.empty() && !viewer) return usage("--viewer-screenshot needs --viewer");

  try {
    quad::sim::Scenario scenario = quad::sim::load_scenario(scenario_path, overrides);
    if (seed) scenario.seed = static_cast<uint64_t>(*seed);
    if (out_dir.empty()) out_dir = "runs/" + scenario.name + "-" + utc_stamp();

    quad::sim::SessionOptions options;
    options.out_dir = out_dir;
    options.realtime = realtime;
    options.progress = !quiet;
    options.stop = &g_stop;
    options.ground_port_link = ground_port;
    options.gcs_udp = gcs;
    options.link_record = tlog;
    const std::string default_fw = executable_dir() + "/quad_firmware";
    // The host firmware keeps its flight logs in the run folder (runs/<run>/log_001.ulg).
    options.firmware_argv = firmware.empty() ? std::vector<std::string>{default_fw, "--log-dir", out_dir}
                                             : split_words(firmware);
    if (firmware.empty() && access(default_fw.c_str(), X_OK) != 0) {
      std::fprintf(stderr, "quad_sim: %s is not built (cmake --build build/host --target quad_firmware), "
                           "or pass --firmware CMD\n", default_fw.c_str());
      return 1;
    }

    const std::string default_station = executable_dir() + "/vision_station";
    options.station_calibration = station_calib;
    options.room_calibration = room_calib;
    options.station_argv = station.empty() ? std::vector<std::string>{default_station, "run"} : split_words(station);
    if ((scenario.camera.enabled || scenario.ground_cameras.enabled) && station.empty() && access(default_station.c_str(), X_OK) != 0) {
      std::fprintf(stderr, "quad_sim: the scenario renders the cameras but %s is not built "
                           "(cmake --build build/host --target vision_station), or pass --station CMD\n",
                   default_station.c_str());
      return 1;
    }

    // The window opens before the flight, so a missing display stops the run before anything starts.
    std::unique_ptr<quad::sim::Viewer> window;
    if (viewer) {
      try {
        window = std::make_unique<quad::sim::Viewer>("quad_sim: " + scenario.name);
      } catch (const quad::sim::ViewerUnavailable& e) {
        std::fprintf(stderr, "quad_sim: %s\n", e.what());
        return 1;
      }
    }
    std::unique_ptr<quad::sim::OffscreenRecorder> recorder;
    if (!record.empty() || window) {
      options.on_frame = [&](quad::sim::Vehicle& v) {
        if (!record.empty()) {
          if (!recorder) recorder = std::make_unique<quad::sim::OffscreenRecorder>(v.model(), record);
          recorder->frame(v);
        }
        if (window) {
          window->frame(v);
          if (window->closed()) g_stop = true;  // ends the run like Ctrl-C: summary cut short, logs kept
        }
      };
    }
    std::signal(SIGINT, on_signal);
    std::signal(SIGTERM, on_signal);
    std::signal(SIGPIPE, SIG_IGN);
    std::fprintf(stderr, "quad_sim: %s (seed %llu), %s, run folder %s\n", scenario.name.c_str(),
                 static_cast<unsigned long long>(scenario.seed), realtime ? "real time" : "lockstep", out_dir.c_str());
    const bool fleet = !scenario.vehicles.empty();
    if (fleet && (viewer || !record.empty() || !ground_port.empty()))
      return usage("--viewer, --record and --ground-port are single-vehicle options (the scenario has vehicles:)");
    const quad::sim::SessionResult r =
        fleet ? quad::sim::run_fleet_session(scenario, options) : quad::sim::run_session(scenario, options);
    bool outputs_ok = true;
    if (recorder) {
      const std::string error = recorder->finish();
      if (!error.empty()) {
        std::fprintf(stderr, "quad_sim: recording %s failed: %s\n", record.c_str(), error.c_str());
        outputs_ok = false;
      }
      recorder.reset();
    } else if (!record.empty()) {
      std::fprintf(stderr, "quad_sim: recording %s failed: no frame was rendered\n", record.c_str());
      outputs_ok = false;
    }
    if (window && !screenshot.empty()) {
      try {
        window->screenshot(screenshot);
      } catch (const std::exception& e) {
        std::fprintf(stderr, "quad_sim: %s\n", e.what());
      }
    }
    window.reset();
    if (plots && !fleet) {  // plot_run.py draws one vehicle's log
      const std::string python = access("/usr/bin/python3", X_OK) == 0 ? "/usr/bin/python3" : "python3";
      const std::string cmd = python + " '" QUAD_SIM_SOURCE_DIR "/plots/plot_run.py' '" + out_dir + "'";
      if (std::system(cmd.c_str()) != 0) {
        std::fprintf(stderr, "quad_sim: plotting failed (%s; it needs python3-matplotlib); the log and summary "
                             "are in %s\n", cmd.c_str(), out_dir.c_str());
        outputs_ok = false;
      }
    }
    std::fprintf(stderr, "quad_sim: %s after %.1f s simulated in %.1f s (%.1fx real time)%s; summary: %s/summary.json\n",
                 r.complete ? "complete" : ("cut short (" + r.reason + ")").c_str(), r.sim_time_s, r.wall_time_s,
                 r.wall_time_s > 0 ? r.sim_time_s / r.wall_time_s : 0.0, r.crashed ? ", CRASHED" : "", out_dir.c_str());
    if (!r.complete) return 1;
    return outputs_ok ? 0 : 3;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "quad_sim: %s\n", e.what());
    return 1;
  }
}
