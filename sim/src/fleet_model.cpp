#include "quad/sim/fleet_model.h"

#include <cstdio>
#include <fstream>
#include <regex>
#include <sstream>
#include <stdexcept>

namespace quad::sim {
namespace {

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open the model");
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// [begin, end) of the first `<tag ...>...</tag>` element whose opening text starts with `open`.
std::pair<size_t, size_t> element(const std::string& xml, const std::string& open, const std::string& tag,
                                  const std::string& path) {
  const size_t begin = xml.find(open);
  if (begin == std::string::npos) throw std::runtime_error(path + ": no " + open + "...> element for the fleet model");
  const std::string close = "</" + tag + ">";
  const size_t end = xml.find(close, begin);
  if (end == std::string::npos) throw std::runtime_error(path + ": " + open + " is not closed");
  return {begin, end + close.size()};
}

// Every name="X", site="X" and joint="X" in `text` becomes "PREFIX/X".
std::string prefix_names(const std::string& text, const std::string& prefix) {
  static const std::regex kName(R"re(\b(name|site|joint)="([^"]+)")re");
  return std::regex_replace(text, kName, "$1=\"" + prefix + "/$2\"");
}

std::string num(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.6g", v);
  return b;
}

// MuJoCo's world is x north, y west, z up; FRD body axes map to FLU by (x, -y, -z) (frames.h).
std::string flu(const Eigen::Vector3d& frd) { return num(frd.x()) + " " + num(-frd.y()) + " " + num(-frd.z()); }

const char* rgba(const std::string& colour) {
  if (colour == "red") return "0.9 0.1 0.1 1";
  if (colour == "green") return "0.1 0.8 0.2 1";
  if (colour == "blue") return "0.1 0.2 0.9 1";
  return "0.95 0.85 0.1 1";  // yellow
}

std::string vehicle_body(const std::string& body, const FleetVehicle& v, double rest_z) {
  std::string out = prefix_names(body, v.name);
  // The start position as the body's reference pose (qpos0), so the copies never overlap at load.
  static const std::regex kPos(R"re(<body ([^>]*)pos="[^"]*")re");
  out = std::regex_replace(out, kPos, "<body $1pos=\"" + num(v.initial_north_east_m.x()) + " " +
                                          num(-v.initial_north_east_m.y()) + " " + num(rest_z) + "\"",
                           std::regex_constants::format_first_only);
  std::string extra = "      <geom name=\"" + v.name + "/hull\" type=\"cylinder\" pos=\"0 0 0.02\" size=\"" +
                      num(kHullRadiusM) + " " + num(kHullHalfHeightM) +
                      "\" contype=\"2\" conaffinity=\"2\" mass=\"0\" rgba=\"0 0 0 0\" group=\"3\"/>\n";
  for (const Marker& m : v.markers)
    extra += "      <geom name=\"" + v.name + "/marker_" + m.colour + "\" type=\"sphere\" pos=\"" + flu(m.position_frd_m) +
             "\" size=\"" + num(m.radius_m) + "\" rgba=\"" + rgba(m.colour) + "\" contype=\"0\" conaffinity=\"0\" mass=\"0\"/>\n";
  const size_t close = out.rfind("</body>");
  return out.substr(0, close) + extra + "    " + out.substr(close);
}

}  // namespace

std::string fleet_model_xml(const std::string& model_path, const std::vector<FleetVehicle>& vehicles) {
  const std::string xml = slurp(model_path);
  const auto body = element(xml, "<body name=\"quad\"", "body", model_path);
  const std::string body_text = xml.substr(body.first, body.second - body.first);
  if (body_text.find("<body", 1) != std::string::npos)
    throw std::runtime_error(model_path + ": the quad body has child bodies; the fleet model repeats a single body");
  std::smatch pos;
  if (!std::regex_search(body_text, pos, std::regex(R"re(pos="\S+ \S+ (\S+)")re")))
    throw std::runtime_error(model_path + ": the quad body has no pos");
  const double rest_z = std::stod(pos[1]);
  const auto actuator = element(xml, "<actuator>", "actuator", model_path);
  const auto sensor = element(xml, "<sensor>", "sensor", model_path);
  if (!(body.second < actuator.first && actuator.second < sensor.first))
    throw std::runtime_error(model_path + ": expected the quad body, then <actuator>, then <sensor>");
  auto inner = [&](std::pair<size_t, size_t> e, size_t open_len, size_t close_len) {
    return xml.substr(e.first + open_len, e.second - e.first - open_len - close_len);
  };
  const std::string actuators = inner(actuator, std::string("<actuator>").size(), std::string("</actuator>").size());
  const std::string sensors = inner(sensor, std::string("<sensor>").size(), std::string("</sensor>").size());

  std::string bodies, acts, sens;
  for (const FleetVehicle& v : vehicles) {
    bodies += vehicle_body(body_text, v, rest_z) + "\n    ";
    acts += prefix_names(actuators, v.name);
    sens += prefix_names(sensors, v.name);
  }
  std::string out = xml.substr(0, body.first) + bodies + xml.substr(body.second, actuator.first - body.second);
  out += "<actuator>" + acts + "</actuator>" + xml.substr(actuator.second, sensor.first - actuator.second);
  out += "<sensor>" + sens + "</sensor>" + xml.substr(sensor.second);
  return out;
}

}  // namespace quad::sim
