#include "mount_log.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/Geometry>

#include "ulog_reader.h"

namespace quad::mount {

namespace {

struct TimedAttitude {
  uint64_t t_us;
  Eigen::Quaterniond q;
};

const ulog::FieldRef& field(const ulog::File& log, const ulog::Layout& l, const char* name) {
  try {
    return l.field(name);
  } catch (const ulog::Error& e) {
    throw std::runtime_error(log.path() + ": " + e.what());
  }
}

const ulog::Layout& topic(const ulog::File& log, const char* name) {
  try {
    return log.layout(name);
  } catch (const ulog::Error& e) {
    throw std::runtime_error(e.what());
  }
}

bool is_one_of(const std::vector<uint16_t>& ids, uint16_t id) { return std::find(ids.begin(), ids.end(), id) != ids.end(); }

Eigen::Quaterniond quaternion(const ulog::Record& r, const ulog::FieldRef& f) {
  return Eigen::Quaterniond(ulog::number(r, f, 0), ulog::number(r, f, 1), ulog::number(r, f, 2), ulog::number(r, f, 3));
}

}  // namespace

LogPairs read_log_pairs(const std::string& path) {
  const ulog::File log(path);
  const ulog::Layout& att = topic(log, "vehicle_attitude");
  const ulog::Layout& fix = topic(log, "vision_fix");
  const ulog::FieldRef& att_q = field(log, att, "q");
  const ulog::FieldRef& fix_q = field(log, fix, "q");
  const ulog::FieldRef& fix_t = field(log, fix, "timestamp_sample");
  const std::vector<uint16_t> att_ids = log.ids_of("vehicle_attitude"), fix_ids = log.ids_of("vision_fix");

  std::vector<TimedAttitude> attitudes;
  std::vector<std::pair<uint64_t, Eigen::Quaterniond>> fixes;
  for (const ulog::Record& r : log.records()) {
    if (r.kind != ulog::Record::Kind::kData) continue;
    if (is_one_of(att_ids, r.msg_id)) {
      attitudes.push_back({ulog::timestamp(r, att), quaternion(r, att_q).normalized()});
    } else if (is_one_of(fix_ids, r.msg_id)) {
      const Eigen::Quaterniond q = quaternion(r, fix_q);
      if (!q.coeffs().allFinite() || std::fabs(q.norm() - 1.0) > 1e-3) continue;  // no pose (NaN) or damaged
      if (q.w() == 1.0 && q.vec().isZero()) continue;  // LANDING_TARGET's "no attitude"
      fixes.emplace_back(static_cast<uint64_t>(ulog::number(r, fix_t)), q.normalized());
    }
  }
  std::sort(attitudes.begin(), attitudes.end(), [](const TimedAttitude& a, const TimedAttitude& b) { return a.t_us < b.t_us; });

  LogPairs out;
  const char* names[3] = {"EST_CAM_ROLL", "EST_CAM_PITCH", "EST_CAM_YAW"};
  for (int i = 0; i < 3; ++i) {
    const auto it = log.initial_params().find(names[i]);
    if (it != log.initial_params().end()) out.logged_mount_rad(i) = it->second;
  }
  if (const auto it = log.initial_params().find("EST_STAR_ATT"); it != log.initial_params().end())
    out.logged_star_attitude = static_cast<float>(it->second);
  for (const auto& [t, q_vs] : fixes) {
    ++out.fixes_with_attitude;
    const auto after = std::lower_bound(attitudes.begin(), attitudes.end(), t,
                                        [](const TimedAttitude& a, uint64_t time) { return a.t_us < time; });
    if (after == attitudes.begin() || after == attitudes.end()) {
      ++out.outside_attitude_span;
      continue;
    }
    const TimedAttitude& before = *(after - 1);
    const double span = static_cast<double>(after->t_us - before.t_us);
    const double f = span > 0.0 ? static_cast<double>(t - before.t_us) / span : 0.0;
    const Eigen::Quaterniond q_nb = before.q.slerp(f, after->q);
    out.pairs.push_back({q_nb.toRotationMatrix(), q_vs.toRotationMatrix().transpose()});
  }
  return out;
}

void unify_star_frame(std::vector<est::RotationPair>* pairs) {
  if (pairs->empty()) return;
  // X_i = R_i Q_iᵀ (Y ~ I: a few degrees) is the star frame in NED up to the station's choice of tip.
  const Eigen::Matrix3d X0 = pairs->front().R * pairs->front().Q.transpose();
  for (est::RotationPair& p : *pairs) {
    const Eigen::Matrix3d X = p.R * p.Q.transpose();
    Eigen::Matrix3d best_turn = Eigen::Matrix3d::Identity();
    double best = 1e9;
    for (int k = 0; k < 4; ++k) {
      // Q = R_SV: the star frame turned by Rz about its z is S' with R_S'V = Rzᵀ R_SV.
      const Eigen::Matrix3d Rz = Eigen::AngleAxisd(k * M_PI / 2.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
      const double e = est::rotation_angle(X0.transpose() * X * Rz);
      if (e < best) {
        best = e;
        best_turn = Rz;
      }
    }
    p.Q = best_turn.transpose() * p.Q;
  }
}

MountResult calibrate_mount(const LogPairs& log, const est::XqyOptions& options) {
  std::vector<est::RotationPair> pairs = log.pairs;
  unify_star_frame(&pairs);
  MountResult m;
  m.xqy = est::solve_xqy(pairs, options);
  if (m.xqy.ok) {
    const double limit = std::max(4.0 * m.xqy.residual_rms_rad, M_PI / 180.0);
    std::vector<est::RotationPair> kept;
    for (const est::RotationPair& p : pairs) {
      if (est::rotation_angle(p.R * (m.xqy.X * p.Q * m.xqy.Y).transpose()) <= limit) kept.push_back(p);
    }
    m.outliers = static_cast<int>(pairs.size() - kept.size());
    if (m.outliers > 0) m.xqy = est::solve_xqy(kept, options);
    pairs.swap(kept);
  }
  m.samples = static_cast<int>(pairs.size());
  m.R_BV_residual = m.xqy.Y.transpose();
  // The log's fixes were turned by the logged mount M0 (p_V' = M0 p_V); the rest Yᵀ follows it.
  m.R_BV = m.R_BV_residual * from_euler_zyx(log.logged_mount_rad);
  return m;
}

Eigen::Vector3d euler_zyx(const Eigen::Matrix3d& R) {
  const double pitch = std::asin(std::clamp(-R(2, 0), -1.0, 1.0));
  return Eigen::Vector3d(std::atan2(R(2, 1), R(2, 2)), pitch, std::atan2(R(1, 0), R(0, 0)));
}

Eigen::Matrix3d from_euler_zyx(const Eigen::Vector3d& e) {
  return (Eigen::AngleAxisd(e.z(), Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(e.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(e.x(), Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

}  // namespace quad::mount
