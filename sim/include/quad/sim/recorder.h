// MP4 of a run, rendered offscreen and headless: an OSMesa context (no display), MuJoCo's renderer,
// raw RGB frames piped into ffmpeg (libx264). The issue-8 stereo cameras will render through the same
// context.
#pragma once

#include <cstdio>
#include <string>
#include <vector>

#include <mujoco/mujoco.h>

namespace quad::sim {

class Vehicle;

class OffscreenRecorder {
 public:
  // Creates the GL context for `model` and starts ffmpeg writing `path`. Throws with the reason.
  OffscreenRecorder(const mjModel* model, const std::string& path, int width = 640, int height = 360,
                    double fps = 30.0, const std::string& camera = "chase");
  ~OffscreenRecorder();  // finishes the file
  OffscreenRecorder(const OffscreenRecorder&) = delete;
  OffscreenRecorder& operator=(const OffscreenRecorder&) = delete;

  void frame(Vehicle& vehicle);
  long frames() const { return frames_; }
  // Closes ffmpeg's input and waits for it to finish the file. Returns what went wrong (a frame that
  // could not be written, ffmpeg's exit status), empty when the file is complete. Called by the
  // destructor if not before.
  std::string finish();

 private:
  struct Gl;
  Gl* gl_ = nullptr;
  mjvScene scene_{};
  mjvCamera camera_{};
  mjvOption option_{};
  mjrContext context_{};
  int width_, height_;
  std::vector<unsigned char> rgb_;
  std::FILE* ffmpeg_ = nullptr;
  long frames_ = 0;
  bool write_failed_ = false;
};

}  // namespace quad::sim
