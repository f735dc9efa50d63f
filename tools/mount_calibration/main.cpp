// mount_calibration LOG.ulg [--expect-deg ROLL,PITCH,YAW] [--star-yaw-deg A | --free-star-yaw] [...]
//
// The camera rig's mount from a calibration flight's log (seed 002's R = XQY; tools/mount_calibration/
// README.md): prints the mount as roll / pitch / yaw and as the EST_CAM_* parameter lines to set. With
// --expect-deg, also the angle between the recovered mount and the one given (a known, simulated error).
// By default X's heading is the star layout's (tips along north and east, as VIS_STAR_* and the EKF
// assume: XqyOptions::star_heading_known); --free-star-yaw solves seed 002 as written, X free, and needs
// a flight that tilts well about two horizontal axes.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <string>

#include "mount_log.h"

namespace {

constexpr double kDeg = M_PI / 180.0;

int usage(const std::string& why) {
  std::cerr << "mount_calibration: " << why << "\n"
            << "usage: mount_calibration LOG.ulg [--expect-deg ROLL,PITCH,YAW] [--min-angle-deg A]\n"
            << "  LOG.ulg            a firmware flight log with vision_fix (the star's attitude) and\n"
            << "                     vehicle_attitude: a calibration flight (sim/scenarios/mount_calibration.yaml)\n"
            << "  --expect-deg R,P,Y a known mount (ZYX Euler, degrees): print the recovered mount's error\n"
            << "  --min-angle-deg A  leave out sample pairs rotated less than A against each other (default 1.15)\n"
            << "  --min-axis-spread S  refuse when Z's second singular value is below S x its first (default 0.0002)\n"
            << "  --star-yaw-deg A   the star's heading in NED, modulo 90 deg (default 0: tips along north and east)\n"
            << "  --free-star-yaw    leave the star's heading free (seed 002 as written; needs tilts about two axes)\n";
  return 2;
}

bool parse_triple(const std::string& text, Eigen::Vector3d* v) {
  std::istringstream in(text);
  char c1 = 0, c2 = 0;
  double a, b, c;
  if (!(in >> a >> c1 >> b >> c2 >> c) || c1 != ',' || c2 != ',') return false;
  std::string rest;
  if (in >> rest) return false;
  *v = Eigen::Vector3d(a, b, c);
  return true;
}

void print_angles(const char* label, const Eigen::Matrix3d& R) {
  const Eigen::Vector3d e = quad::mount::euler_zyx(R) / kDeg;
  std::printf("%s roll %+.3f pitch %+.3f yaw %+.3f deg (%.3f deg in all)\n", label, e.x(), e.y(), e.z(),
              quad::est::rotation_angle(R) / kDeg);
}

}  // namespace

int main(int argc, char** argv) {
  std::string path;
  bool have_expect = false;
  Eigen::Vector3d expect_deg = Eigen::Vector3d::Zero();
  quad::est::XqyOptions options;
  options.star_heading_known = true;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") return usage("the camera mount from a calibration flight's log"), 0;
    if (a == "--free-star-yaw") {
      options.star_heading_known = false;
    } else if (a == "--expect-deg" || a == "--min-angle-deg" || a == "--min-axis-spread" || a == "--star-yaw-deg") {
      if (i + 1 >= argc) return usage(a + ": needs a value");
      const std::string v = argv[++i];
      if (a == "--expect-deg") {
        if (!parse_triple(v, &expect_deg)) return usage("--expect-deg '" + v + "': expected ROLL,PITCH,YAW in degrees");
        have_expect = true;
      } else if (a == "--min-axis-spread") {
        char* end = nullptr;
        const double d = std::strtod(v.c_str(), &end);
        if (end == v.c_str() || *end != '\0' || !(d >= 0.0 && d <= 1.0)) return usage("--min-axis-spread '" + v + "': expected 0 to 1");
        options.min_axis_spread = d;
      } else if (a == "--star-yaw-deg") {
        char* end = nullptr;
        const double d = std::strtod(v.c_str(), &end);
        if (end == v.c_str() || *end != '\0' || !(d >= -360.0 && d <= 360.0)) return usage("--star-yaw-deg '" + v + "': expected -360 to 360");
        options.star_heading_rad = d * kDeg;
      } else {
        char* end = nullptr;
        const double d = std::strtod(v.c_str(), &end);
        if (end == v.c_str() || *end != '\0' || !(d >= 0.0 && d < 90.0)) return usage("--min-angle-deg '" + v + "': expected 0 to 90");
        options.min_relative_angle_rad = d * kDeg;
      }
    } else if (!a.empty() && a[0] == '-') {
      return usage("unknown option " + a);
    } else if (path.empty()) {
      path = a;
    } else {
      return usage("one log only (" + path + ", " + a + ")");
    }
  }
  if (path.empty()) return usage("no log given");
  try {
    const quad::mount::LogPairs log = quad::mount::read_log_pairs(path);
    std::printf("%s: %d fixes with the star's attitude, %zu paired with the estimator's attitude\n", path.c_str(),
                log.fixes_with_attitude, log.pairs.size());
    if (log.logged_star_attitude > 0.0f) {
      std::fprintf(stderr,
                   "mount_calibration: %s: warning: the flight ran with EST_STAR_ATT %g: the estimator took the "
                   "star's heading%s, so that much of the mount turns the estimate with the fixes and is not seen; "
                   "fly the calibration with EST_STAR_ATT 0\n",
                   path.c_str(), log.logged_star_attitude, log.logged_star_attitude > 1.5f ? " and tilt" : "");
    }
    const quad::mount::MountResult m = quad::mount::calibrate_mount(log, options);
    if (!m.xqy.ok) {
      std::fprintf(stderr, "mount_calibration: %s: %s\n", path.c_str(), m.xqy.message.c_str());
      return 1;
    }
    std::printf("samples %d (%d outliers left out), relative pairs %ld / %ld, residual RMS %.3f deg\n", m.samples,
                m.outliers, m.xqy.relative_pairs_x, m.xqy.relative_pairs_y, m.xqy.residual_rms_rad / kDeg);
    const Eigen::Vector3d& sx = m.xqy.singular_values_x;
    const Eigen::Vector3d& sy = m.xqy.singular_values_y;
    std::printf("Z singular values (X, eq. 15): %.4g %.4g %.4g (ratios %.2e %.2e)\n", sx(0), sx(1), sx(2), sx(1) / sx(0),
                sx(2) / sx(0));
    std::printf("Z singular values (Y, eq. 17): %.4g %.4g %.4g (ratios %.2e %.2e)\n", sy(0), sy(1), sy(2), sy(1) / sy(0),
                sy(2) / sy(0));
    std::printf("star heading: %s\n", options.star_heading_known ? "the layout's (--star-yaw-deg)" : "free (seed 002 as written)");
    print_angles("star frame in NED (X = R_NS):", m.xqy.X);
    print_angles("mount left in the log's fixes (R_BV = Y^T):", m.R_BV_residual);
    const Eigen::Vector3d logged = log.logged_mount_rad / kDeg;
    std::printf("EST_CAM_* the log ran with: roll %+.3f pitch %+.3f yaw %+.3f deg\n", logged.x(), logged.y(), logged.z());
    print_angles("mount:", m.R_BV);
    if (have_expect) {
      const Eigen::Matrix3d expected = quad::mount::from_euler_zyx(expect_deg * kDeg);
      std::printf("error against the expected mount: %.3f deg\n",
                  quad::est::rotation_angle(m.R_BV * expected.transpose()) / kDeg);
    }
    if (options.star_heading_known) {
      // For comparison: seed 002 as written, the star's heading free (refused when the flight's rotations
      // are about one axis only).
      quad::est::XqyOptions free = options;
      free.star_heading_known = false;
      const quad::mount::MountResult f = quad::mount::calibrate_mount(log, free);
      if (!f.xqy.ok) {
        std::printf("with the star's heading free: %s\n", f.xqy.message.c_str());
      } else {
        print_angles("with the star's heading free, star frame:", f.xqy.X);
        print_angles("with the star's heading free, mount:", f.R_BV);
        if (have_expect) {
          const Eigen::Matrix3d expected = quad::mount::from_euler_zyx(expect_deg * kDeg);
          std::printf("with the star's heading free, error against the expected mount: %.3f deg\n",
                      quad::est::rotation_angle(f.R_BV * expected.transpose()) / kDeg);
        }
      }
    }
    const Eigen::Vector3d e = quad::mount::euler_zyx(m.R_BV);
    std::printf("EST_CAM_ROLL %.6f\nEST_CAM_PITCH %.6f\nEST_CAM_YAW %.6f\n", e.x(), e.y(), e.z());
  } catch (const std::exception& ex) {
    std::fprintf(stderr, "mount_calibration: %s\n", ex.what());
    return 1;
  }
  return 0;
}
