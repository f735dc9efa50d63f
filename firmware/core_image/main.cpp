// Core image for the cross targets: runs the math core on inputs the compiler cannot see (volatile),
// so every routine is linked and measured. Replaced by the flight application's image.
#include "quad/math/math.h"

namespace {
volatile float g_in[4] = {0.1f, -0.2f, 0.3f, 0.01f};
volatile float g_out[4];
}  // namespace

int main() {
  quad::Quat q = quad::Quat::identity();
  for (;;) {
    const quad::Vec3 w{g_in[0], g_in[1], g_in[2]};
    q = quad::integrate_exact(q, w, g_in[3]);
    q = quad::integrate_second_order(q, w, g_in[3]);
    const quad::Euler e = quad::to_euler(q);
    const quad::Quat back = quad::from_dcm(quad::dcm_from_euler(e));
    const quad::Vec3 s = quad::sat_delta(quad::project(w, quad::rotate(back, w)), 0.03f);
    g_out[0] = e.roll + s.x;
    g_out[1] = e.pitch + s.y;
    g_out[2] = e.yaw + s.z;
    g_out[3] = quad::norm(quad::to_rotation_vector(quad::from_euler(e)));
  }
}
