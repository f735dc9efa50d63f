#include "quad/sim/fleet_world.h"

#include <stdexcept>

#include "quad/sim/frames.h"

namespace quad::sim {
namespace {

int require_id(const mjModel* m, mjtObj type, const std::string& name, const std::string& path) {
  const int id = mj_name2id(m, type, name.c_str());
  if (id < 0) throw std::runtime_error(path + ": the fleet model has no " + mju_type2Str(type) + " named '" + name + "'");
  return id;
}

}  // namespace

FleetWorld::FleetWorld(const VehicleParams& params, const std::vector<FleetVehicle>& vehicles) : p_(params) {
  char error[1000] = "";
  model_ = mj_loadXML(p_.model_path.c_str(), nullptr, error, sizeof error);
  if (!model_) throw std::runtime_error(p_.model_path + ": " + error);
  data_ = mj_makeData(model_);
  const std::string& path = p_.model_path;
  for (const FleetVehicle& v : vehicles) {
    const std::string pre = v.name + "/";
    Airframe a{-1, -1, -1, -1, -1, {}, {Motor(p_.motor), Motor(p_.motor), Motor(p_.motor), Motor(p_.motor)}, {}};
    a.body = require_id(model_, mjOBJ_BODY, pre + "quad", path);
    const int joint = model_->body_jntadr[a.body];
    if (joint < 0 || model_->jnt_type[joint] != mjJNT_FREE) throw std::runtime_error(path + ": " + pre + "quad has no free joint");
    a.qpos = model_->jnt_qposadr[joint];
    a.qvel = model_->jnt_dofadr[joint];
    a.hull = require_id(model_, mjOBJ_GEOM, pre + "hull", path);
    for (size_t i = 0; i < 4; ++i) a.actuator[i] = require_id(model_, mjOBJ_ACTUATOR, pre + p_.rotor_order[i], path);
    a.accel = model_->sensor_adr[require_id(model_, mjOBJ_SENSOR, pre + "accel", path)];
    for (int act : a.actuator) model_->actuator_ctrlrange[2 * act + 1] = 1.5 * p_.motor.max_thrust_n;
    airframes_.push_back(a);
  }
  rest_height_m_ = model_->qpos0[airframes_.at(0).qpos + 2];
  touching_.assign(airframes_.size() * airframes_.size(), 0);
}

FleetWorld::~FleetWorld() {
  if (data_) mj_deleteData(data_);
  if (model_) mj_deleteModel(model_);
}

void FleetWorld::start(const std::vector<FleetVehicle>& vehicles, double settle_s) {
  mj_resetData(model_, data_);
  for (size_t i = 0; i < airframes_.size(); ++i) {
    const FleetVehicle& v = vehicles[i];
    const Eigen::Vector3d p = ned_to_world({v.initial_north_east_m.x(), v.initial_north_east_m.y(),
                                            -(rest_height_m_ + v.initial_height_m)});
    const Eigen::Quaterniond q = q_ib_to_world_body(q_ib_from_yaw(v.initial_yaw_rad));
    mjtNum* qpos = data_->qpos + airframes_[i].qpos;
    for (int k = 0; k < 3; ++k) qpos[k] = p[k];
    qpos[3] = q.w(), qpos[4] = q.x(), qpos[5] = q.y(), qpos[6] = q.z();
    airframes_[i].commands.fill(0.0);
  }
  mj_forward(model_, data_);
  // Settling: those in the air are held there (velocity zeroed each step), so only the gear settles.
  const int n = static_cast<int>(settle_s / model_->opt.timestep + 0.5);
  std::vector<std::array<mjtNum, 7>> held(airframes_.size());
  for (size_t i = 0; i < airframes_.size(); ++i)
    for (int k = 0; k < 7; ++k) held[i][static_cast<size_t>(k)] = data_->qpos[airframes_[i].qpos + k];
  for (int s = 0; s < n; ++s) {
    step();
    for (size_t i = 0; i < airframes_.size(); ++i) {
      if (vehicles[i].initial_height_m == 0.0) continue;
      for (int k = 0; k < 7; ++k) data_->qpos[airframes_[i].qpos + k] = held[i][static_cast<size_t>(k)];
      for (int k = 0; k < 6; ++k) data_->qvel[airframes_[i].qvel + k] = 0.0;
    }
  }
  if (n > 0) mj_forward(model_, data_);
  collisions_.clear();
  data_->time = 0.0;
}

double FleetWorld::mean_speed_fraction(size_t i) const {
  double sum = 0.0;
  for (const Motor& m : airframes_[i].motors) sum += m.speed_rad_s() / m.params().max_speed_rad_s;
  return sum / 4.0;
}

void FleetWorld::step() {
  const double dt = model_->opt.timestep;
  const Eigen::Vector3d wind_world = ned_to_world(wind_ned_);
  for (Airframe& a : airframes_) {
    for (size_t i = 0; i < 4; ++i) {
      a.motors[i].step(a.commands[i], dt);
      data_->ctrl[a.actuator[i]] = a.motors[i].thrust_n();
    }
    const Eigen::Vector3d v(data_->qvel[a.qvel], data_->qvel[a.qvel + 1], data_->qvel[a.qvel + 2]);
    const Eigen::Vector3d v_rel = v - wind_world;
    const Eigen::Vector3d drag = -(p_.drag_linear_n_per_m_s + p_.drag_quadratic_n_per_m2_s2 * v_rel.norm()) * v_rel;
    double* f = data_->xfrc_applied + 6 * a.body;
    f[0] = drag.x(), f[1] = drag.y(), f[2] = drag.z();
  }
  mj_step(model_, data_);
  count_collisions();
}

void FleetWorld::count_collisions() {
  const size_t n = airframes_.size();
  std::vector<uint8_t> now(n * n, 0);
  for (int c = 0; c < data_->ncon; ++c) {
    const mjContact& con = data_->contact[c];
    size_t a = n, b = n;
    for (size_t i = 0; i < n; ++i) {
      if (con.geom1 == airframes_[i].hull) a = i;
      if (con.geom2 == airframes_[i].hull) b = i;
    }
    if (a == n || b == n || a == b) continue;
    if (a > b) std::swap(a, b);
    now[a * n + b] = 1;
    if (!touching_[a * n + b]) collisions_.push_back({data_->time, a, b});
  }
  touching_.swap(now);
}

VehicleTruth FleetWorld::truth(size_t i) const {
  const Airframe& a = airframes_[i];
  const mjtNum* q = data_->qpos + a.qpos;
  const mjtNum* v = data_->qvel + a.qvel;
  VehicleTruth t;
  t.t = data_->time;
  t.position_ned = world_to_ned({q[0], q[1], q[2]});
  t.velocity_ned = world_to_ned({v[0], v[1], v[2]});
  t.q_ib = world_body_to_q_ib(Eigen::Quaterniond(q[3], q[4], q[5], q[6]));
  t.rate_frd = flu_to_frd({v[3], v[4], v[5]});
  const mjtNum* s = data_->sensordata + a.accel;
  t.specific_force_frd = flu_to_frd({s[0], s[1], s[2]});
  return t;
}

}  // namespace quad::sim
