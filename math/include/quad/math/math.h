// Umbrella header of the freestanding math core.
#pragma once

#include "quad/math/mat3.h"
#include "quad/math/matrix.h"
#include "quad/math/quat.h"
#include "quad/math/scalar.h"
#include "quad/math/vec3.h"
