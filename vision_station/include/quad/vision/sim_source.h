// sim:ENDPOINT — the simulator's rendered stereo cameras, in lockstep (wire: sim_protocol.h). The source
// connects to the simulator's Unix socket, reads each pair with its capture time (the simulated clock,
// which is the vehicle's), and answers every pair once the station's output for it has been written, so
// that the simulator can collect the fix at a determined simulated time.
#pragma once

#include <chrono>
#include <memory>
#include <string>

#include "quad/vision/frame_source.h"

namespace quad::vision {

// Connects to the socket at `path`, waiting up to `connect_timeout` for the simulator to create it;
// throws FrameSourceError naming the path otherwise.
std::unique_ptr<FrameSource> make_sim_source(const std::string& path,
                                             std::chrono::milliseconds connect_timeout = std::chrono::seconds(5));

}  // namespace quad::vision
