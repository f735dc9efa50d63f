#include "quad/sim/vehicle.h"

#include <stdexcept>

#include "quad/sim/frames.h"

namespace quad::sim {
namespace {

int require_id(const mjModel* m, mjtObj type, const std::string& name, const std::string& path) {
  const int id = mj_name2id(m, type, name.c_str());
  if (id < 0) throw std::runtime_error(path + ": the model has no " + mju_type2Str(type) + " named '" + name + "'");
  return id;
}

}  // namespace

Vehicle::Vehicle(const VehicleParams& params)
    : p_(params), motors_{Motor(params.motor), Motor(params.motor), Motor(params.motor), Motor(params.motor)} {
  char error[1000] = "";
  model_ = mj_loadXML(p_.model_path.c_str(), nullptr, error, sizeof error);
  if (!model_) throw std::runtime_error(p_.model_path + ": " + error);
  data_ = mj_makeData(model_);
  body_ = require_id(model_, mjOBJ_BODY, "quad", p_.model_path);
  for (size_t i = 0; i < 4; ++i) actuator_[i] = require_id(model_, mjOBJ_ACTUATOR, p_.rotor_order[i], p_.model_path);
  accel_adr_ = model_->sensor_adr[require_id(model_, mjOBJ_SENSOR, "accel", p_.model_path)];
  rest_height_m_ = model_->qpos0[2];
  // The actuators' ctrl is thrust in newtons: their limit must not clip the motor model.
  for (int a : actuator_) model_->actuator_ctrlrange[2 * a + 1] = 1.5 * p_.motor.max_thrust_n;
  reset(Eigen::Vector2d::Zero(), 0.0, 0.0);
}

Vehicle::~Vehicle() {
  if (data_) mj_deleteData(data_);
  if (model_) mj_deleteModel(model_);
}

void Vehicle::reset(const Eigen::Vector2d& north_east, double height_above_rest_m, double yaw_rad) {
  mj_resetData(model_, data_);
  const Eigen::Vector3d p_world = ned_to_world({north_east.x(), north_east.y(), -(rest_height_m_ + height_above_rest_m)});
  const Eigen::Quaterniond q_wb = q_ib_to_world_body(q_ib_from_yaw(yaw_rad));
  for (int i = 0; i < 3; ++i) data_->qpos[i] = p_world[i];
  data_->qpos[3] = q_wb.w();
  data_->qpos[4] = q_wb.x();
  data_->qpos[5] = q_wb.y();
  data_->qpos[6] = q_wb.z();
  for (auto& m : motors_) m = Motor(p_.motor);
  commands_.fill(0.0);
  mj_forward(model_, data_);
}

void Vehicle::set_motor_efficiency(int motor, double efficiency) {
  motors_.at(static_cast<size_t>(motor)).set_efficiency(efficiency);
}

void Vehicle::settle_on_ground(double seconds) {
  const std::array<double, 4> commands = commands_;
  commands_.fill(0.0);
  const int n = static_cast<int>(seconds / model_->opt.timestep + 0.5);
  for (int i = 0; i < n; ++i) step();
  commands_ = commands;
  data_->time = 0.0;
}

void Vehicle::settle_motors() {
  for (size_t i = 0; i < 4; ++i) motors_[i].settle(commands_[i]);
}

double Vehicle::mass_kg() const { return mj_getTotalmass(model_); }

double Vehicle::mean_speed_fraction() const {
  double sum = 0.0;
  for (const auto& m : motors_) sum += m.speed_rad_s() / m.params().max_speed_rad_s;
  return sum / 4.0;
}

void Vehicle::step() {
  const double dt = model_->opt.timestep;
  for (size_t i = 0; i < 4; ++i) {
    motors_[i].step(commands_[i], dt);
    data_->ctrl[actuator_[i]] = motors_[i].thrust_n();
  }
  // Drag relative to the air, applied at the centre of mass (world frame).
  const Eigen::Vector3d v_world(data_->qvel[0], data_->qvel[1], data_->qvel[2]);
  const Eigen::Vector3d v_rel = v_world - ned_to_world(wind_ned_);
  const Eigen::Vector3d drag = -(p_.drag_linear_n_per_m_s + p_.drag_quadratic_n_per_m2_s2 * v_rel.norm()) * v_rel;
  double* f = data_->xfrc_applied + 6 * body_;
  f[0] = drag.x();
  f[1] = drag.y();
  f[2] = drag.z();
  mj_step(model_, data_);
}

VehicleTruth Vehicle::truth() const {
  VehicleTruth t;
  t.t = data_->time;
  t.position_ned = world_to_ned({data_->qpos[0], data_->qpos[1], data_->qpos[2]});
  t.velocity_ned = world_to_ned({data_->qvel[0], data_->qvel[1], data_->qvel[2]});
  t.q_ib = world_body_to_q_ib(Eigen::Quaterniond(data_->qpos[3], data_->qpos[4], data_->qpos[5], data_->qpos[6]));
  t.rate_frd = flu_to_frd({data_->qvel[3], data_->qvel[4], data_->qvel[5]});
  const mjtNum* s = data_->sensordata;
  t.specific_force_frd = flu_to_frd({s[accel_adr_], s[accel_adr_ + 1], s[accel_adr_ + 2]});
  return t;
}

}  // namespace quad::sim
