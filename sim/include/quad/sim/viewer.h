// Interactive window onto a run (--viewer): a GLFW window with MuJoCo's renderer, a free camera that
// tracks the vehicle (left drag rotates, right drag or the wheel zooms). Kept apart from the OSMesa
// recorder (recorder.h): this one needs a display and an on-screen GLX context, that one neither.
//
// The session calls frame() at its frame rate of simulated time; the viewer draws only when enough wall
// time has passed, so in lockstep (tens of times real time) it costs a bounded share of the run rather
// than one render per call.
#pragma once

#include <chrono>
#include <stdexcept>
#include <string>

#include <mujoco/mujoco.h>

struct GLFWwindow;

namespace quad::sim {

class Vehicle;

// No display, or GLFW cannot open a window there: the reason, for the user.
class ViewerUnavailable : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class Viewer {
 public:
  // Opens the window now (before the flight starts, so a missing display is reported before anything
  // runs); the MuJoCo context is made on the first frame, when the model is known.
  // Throws ViewerUnavailable with the reason.
  explicit Viewer(const std::string& title, int width = 960, int height = 540);
  ~Viewer();
  Viewer(const Viewer&) = delete;
  Viewer& operator=(const Viewer&) = delete;

  // Handles window events and, when a redraw is due, draws the vehicle's current state.
  void frame(Vehicle& vehicle);
  // The user closed the window: the caller ends the run (like Ctrl-C).
  bool closed() const;
  long frames_drawn() const { return frames_drawn_; }
  // Draws the state of the last frame() call and writes it as a PNG. Throws if frame() was never called
  // or the file cannot be written.
  void screenshot(const std::string& png_path);

 private:
  static void on_cursor(GLFWwindow* w, double x, double y);
  static void on_button(GLFWwindow* w, int button, int action, int mods);
  static void on_scroll(GLFWwindow* w, double dx, double dy);
  void make_context(const mjModel* model);
  void draw();

  GLFWwindow* window_ = nullptr;
  const mjModel* model_ = nullptr;
  mjvScene scene_{};
  mjvCamera camera_{};
  mjvOption option_{};
  mjrContext context_{};
  bool have_context_ = false;
  // Mouse drag state for the camera.
  bool left_down_ = false, right_down_ = false;
  double last_x_ = 0.0, last_y_ = 0.0;
  // Pacing: the next draw is due at next_draw_.
  std::chrono::steady_clock::time_point next_draw_{};
  long frames_drawn_ = 0;
};

}  // namespace quad::sim
