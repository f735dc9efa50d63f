// Several vehicles in one MuJoCo world (the model from fleet_model.h): per vehicle the motor models,
// the rotor actuators, the drag relative to the wind and the accelerometer, as quad/sim/vehicle.h does for
// one; one mj_step moves them all, so they push each other through their hulls' contacts. Contacts
// between two vehicles' hulls are counted as collisions (a collision: the first step of a contact between
// a pair, so a lasting touch counts once).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

#include "quad/sim/motor.h"
#include "quad/sim/scenario.h"
#include "quad/sim/vehicle.h"

namespace quad::sim {

struct Collision {
  double t = 0.0;
  size_t a = 0, b = 0;  // vehicle indices, a < b
};

class FleetWorld {
 public:
  // `params.model_path` is the generated fleet model; `vehicles` in its order.
  FleetWorld(const VehicleParams& params, const std::vector<FleetVehicle>& vehicles);
  ~FleetWorld();
  FleetWorld(const FleetWorld&) = delete;
  FleetWorld& operator=(const FleetWorld&) = delete;

  size_t size() const { return airframes_.size(); }
  // Every vehicle at its scenario start, then `seconds` of settling on the gear (motors off) for those on
  // the ground; the clock restarts at zero.
  void start(const std::vector<FleetVehicle>& vehicles, double settle_s);
  void set_commands(size_t i, const std::array<double, 4>& c) { airframes_[i].commands = c; }
  void set_wind_ned(const Eigen::Vector3d& wind) { wind_ned_ = wind; }
  void step();

  double time() const { return data_->time; }
  double timestep() const { return model_->opt.timestep; }
  VehicleTruth truth(size_t i) const;
  double rest_down_m() const { return -rest_height_m_; }
  double mean_speed_fraction(size_t i) const;
  const std::array<double, 4>& commands(size_t i) const { return airframes_[i].commands; }
  const Motor& motor(size_t i, int m) const { return airframes_[i].motors[static_cast<size_t>(m)]; }
  const std::vector<Collision>& collisions() const { return collisions_; }
  const mjModel* model() const { return model_; }
  mjData* data() { return data_; }

 private:
  struct Airframe {
    int body = -1, qpos = -1, qvel = -1, accel = -1, hull = -1;
    std::array<int, 4> actuator{};
    std::array<Motor, 4> motors;
    std::array<double, 4> commands{};
  };
  void count_collisions();

  VehicleParams p_;
  mjModel* model_ = nullptr;
  mjData* data_ = nullptr;
  std::vector<Airframe> airframes_;
  std::vector<uint8_t> touching_;  // per pair (a * n + b): in contact after the last step
  std::vector<Collision> collisions_;
  double rest_height_m_ = 0.0;
  Eigen::Vector3d wind_ned_ = Eigen::Vector3d::Zero();
};

}  // namespace quad::sim
