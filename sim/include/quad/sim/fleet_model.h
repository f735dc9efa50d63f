// The MJCF of several vehicles in one world, made from the single-vehicle model (sim/models/quad_c.xml):
// its `quad` body is repeated once per vehicle with every name inside it (geoms, sites, cameras, the
// joint) prefixed `NAME/`, its actuators and accelerometer repeated on the prefixed sites. Each copy gets
//   - a collision hull: a cylinder around the rotor discs (radius `hull_radius_m`), massless, colliding
//     only with the other vehicles' hulls (contype = conaffinity = 2; the floor and the feet are 1), so
//     vehicles touch each other in the physics while the single-vehicle contacts are unchanged;
//   - its colour markers as massless, contact-free spheres (`NAME/marker_COLOUR`).
#pragma once

#include <string>
#include <vector>

#include "quad/sim/scenario.h"

namespace quad::sim {

constexpr double kHullRadiusM = 0.39;       // the rotor discs' outer edge: 0.26 m arm + 0.127 m prop
constexpr double kHullHalfHeightM = 0.05;   // hub to prop plane

// The model text for `vehicles`; throws std::runtime_error naming `model_path` when it does not have the
// single-vehicle model's layout (one `quad` body, an <actuator> and a <sensor> section).
std::string fleet_model_xml(const std::string& model_path, const std::vector<FleetVehicle>& vehicles);

}  // namespace quad::sim
