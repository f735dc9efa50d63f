// A raw pseudo-terminal that serves a child process (quad_firmware, quad_gs) as a serial port: the child
// opens `path`, the test polls the nonblocking `master`.
#pragma once

#include <fcntl.h>

#include "raw_pty.h"

namespace quad_test {

struct ChildPortPty : RawPty {
  ChildPortPty() : RawPty(/*nonblocking_master=*/true) {
    if (path.empty()) return;
    // The child must not inherit our ends, or closing them would not hang up its port.
    fcntl(master, F_SETFD, FD_CLOEXEC);
    fcntl(slave, F_SETFD, FD_CLOEXEC);
  }
};

}  // namespace quad_test
