// Umbrella header of the estimation layer (quad_estimation).
#pragma once

#include "quad/estimation/calibration.h"
#include "quad/estimation/conditioned_observer.h"
#include "quad/estimation/delayed_ekf.h"
#include "quad/estimation/ekf.h"
#include "quad/estimation/ground_hold.h"
#include "quad/estimation/hover_accel_bias.h"
#include "quad/estimation/linear_complementary_filter.h"
#include "quad/estimation/mahony_filter.h"
#include "quad/estimation/position_filter.h"
#include "quad/estimation/vector_attitude.h"
