#include "quad/sim/viewer.h"

#include <GLFW/glfw3.h>

#include <algorithm>
#include <cstdlib>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "quad/sim/vehicle.h"

namespace quad::sim {
namespace {

using Clock = std::chrono::steady_clock;

// At most 30 redraws per second of wall time, and after each redraw a pause at least as long as it took:
// a software renderer (llvmpipe, ~0.1 s a frame) then slows a lockstep run by at most half, a GPU not at all.
constexpr std::chrono::duration<double> kMinFramePeriod{1.0 / 30.0};

std::string g_glfw_error;  // GLFW reports errors through a callback; kept for the exception text
void on_glfw_error(int, const char* description) { g_glfw_error = description; }

Viewer* self(GLFWwindow* w) { return static_cast<Viewer*>(glfwGetWindowUserPointer(w)); }

}  // namespace

Viewer::Viewer(const std::string& title, int width, int height) {
  const char* display = std::getenv("DISPLAY");
  const char* wayland = std::getenv("WAYLAND_DISPLAY");
  if ((!display || !*display) && (!wayland || !*wayland))
    throw ViewerUnavailable("--viewer needs a display (DISPLAY is not set); use --record FILE.mp4 to render "
                            "offscreen, or run under xvfb-run");
  glfwSetErrorCallback(on_glfw_error);
  if (!glfwInit()) throw ViewerUnavailable("--viewer: cannot initialise GLFW: " + g_glfw_error);
  // MuJoCo 2.2 renders with the compatibility profile (fixed-function parts): no core profile hints.
  glfwWindowHint(GLFW_SAMPLES, 4);
  window_ = glfwCreateWindow(width, height, title.c_str(), nullptr, nullptr);
  if (!window_) {
    glfwTerminate();
    throw ViewerUnavailable("--viewer: cannot open a window on " + std::string(display ? display : wayland) +
                            ": " + g_glfw_error);
  }
  glfwSetWindowUserPointer(window_, this);
  glfwSetCursorPosCallback(window_, on_cursor);
  glfwSetMouseButtonCallback(window_, on_button);
  glfwSetScrollCallback(window_, on_scroll);
  glfwMakeContextCurrent(window_);
  glfwSwapInterval(0);  // never wait for vertical sync: the simulation must not stall on the display
  glfwMakeContextCurrent(nullptr);
  mjv_defaultScene(&scene_);
  mjv_defaultCamera(&camera_);
  mjv_defaultOption(&option_);
  mjr_defaultContext(&context_);
}

Viewer::~Viewer() {
  if (have_context_) {
    glfwMakeContextCurrent(window_);
    mjr_freeContext(&context_);
    mjv_freeScene(&scene_);
    glfwMakeContextCurrent(nullptr);
  }
  glfwDestroyWindow(window_);
  glfwTerminate();
}

bool Viewer::closed() const { return glfwWindowShouldClose(window_); }

void Viewer::make_context(const mjModel* model) {
  model_ = model;
  glfwMakeContextCurrent(window_);
  mjv_makeScene(model, &scene_, 2000);
  mjr_makeContext(model, &context_, mjFONTSCALE_100);
  glfwMakeContextCurrent(nullptr);
  have_context_ = true;
  // A free camera following the vehicle's body, seen from behind-left and above like the model's chase camera.
  const int body = mj_name2id(model, mjOBJ_BODY, "quad");
  if (body >= 0) {
    camera_.type = mjCAMERA_TRACKING;
    camera_.trackbodyid = body;
  }
  camera_.distance = 3.5;
  camera_.azimuth = 45.0;
  camera_.elevation = -25.0;
}

void Viewer::frame(Vehicle& vehicle) {
  if (!have_context_) make_context(vehicle.model());
  // The scene follows every call (a few microseconds), so the last picture and a screenshot at the end
  // show the final state even when the last draw was skipped.
  mjv_updateScene(vehicle.model(), vehicle.data(), &option_, nullptr, &camera_, mjCAT_ALL, &scene_);
  const Clock::time_point start = Clock::now();
  if (start < next_draw_) return;
  glfwPollEvents();
  draw();
  glfwSwapBuffers(window_);
  glfwMakeContextCurrent(nullptr);
  ++frames_drawn_;
  const Clock::time_point end = Clock::now();
  next_draw_ = std::max(start + std::chrono::duration_cast<Clock::duration>(kMinFramePeriod), end + (end - start));
}

void Viewer::draw() {
  glfwMakeContextCurrent(window_);
  mjrRect viewport{0, 0, 0, 0};
  glfwGetFramebufferSize(window_, &viewport.width, &viewport.height);
  mjr_setBuffer(mjFB_WINDOW, &context_);
  mjr_render(viewport, &scene_, &context_);
}

void Viewer::screenshot(const std::string& png_path) {
  if (!have_context_) throw std::runtime_error("--viewer-screenshot: the run ended before its first frame");
  draw();  // into the back buffer, read before any swap
  int width = 0, height = 0;
  glfwGetFramebufferSize(window_, &width, &height);
  cv::Mat rgb(height, width, CV_8UC3);
  mjr_readPixels(rgb.data, nullptr, mjrRect{0, 0, width, height}, &context_);
  glfwMakeContextCurrent(nullptr);
  cv::Mat bgr;
  cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
  cv::flip(bgr, bgr, 0);  // OpenGL rows run bottom-up
  if (!cv::imwrite(png_path, bgr)) throw std::runtime_error("--viewer-screenshot: cannot write " + png_path);
}

void Viewer::on_cursor(GLFWwindow* w, double x, double y) {
  Viewer* v = self(w);
  const double dx = x - v->last_x_, dy = y - v->last_y_;
  v->last_x_ = x;
  v->last_y_ = y;
  if (!v->have_context_ || (!v->left_down_ && !v->right_down_)) return;
  int width = 1, height = 1;
  glfwGetWindowSize(w, &width, &height);
  const mjtMouse action = v->left_down_ ? mjMOUSE_ROTATE_V : mjMOUSE_ZOOM;
  mjv_moveCamera(v->model_, action, dx / height, dy / height, &v->scene_, &v->camera_);
}

void Viewer::on_button(GLFWwindow* w, int, int, int) {
  Viewer* v = self(w);
  v->left_down_ = glfwGetMouseButton(w, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS;
  v->right_down_ = glfwGetMouseButton(w, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS;
  glfwGetCursorPos(w, &v->last_x_, &v->last_y_);
}

void Viewer::on_scroll(GLFWwindow* w, double, double dy) {
  Viewer* v = self(w);
  if (v->have_context_) mjv_moveCamera(v->model_, mjMOUSE_ZOOM, 0.0, -0.05 * dy, &v->scene_, &v->camera_);
}

}  // namespace quad::sim
