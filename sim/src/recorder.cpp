#include "quad/sim/recorder.h"

#include <GL/osmesa.h>

#include <sys/wait.h>

#include <stdexcept>

#include "quad/sim/vehicle.h"

namespace quad::sim {
namespace {
// Another GL context may share the process (the --viewer window, GLX): Mesa's GLX and OSMesa crash when
// one binds while the other's context is still current, so each binds its own and releases it after use.
void release_osmesa() { OSMesaMakeCurrent(nullptr, nullptr, 0, 0, 0); }
}  // namespace

struct OffscreenRecorder::Gl {
  OSMesaContext context = nullptr;
  std::vector<unsigned char> buffer;  // OSMesa's default framebuffer (MuJoCo renders into its own FBO)
};

OffscreenRecorder::OffscreenRecorder(const mjModel* model, const std::string& path, int width, int height,
                                     double fps, const std::string& camera)
    : width_(width), height_(height), rgb_(static_cast<size_t>(3 * width * height)) {
  if (width > model->vis.global.offwidth || height > model->vis.global.offheight)
    throw std::runtime_error("recording size exceeds the model's offscreen buffer (visual/global offwidth, offheight)");
  gl_ = new Gl;
  gl_->context = OSMesaCreateContextExt(OSMESA_RGBA, 24, 8, 0, nullptr);
  gl_->buffer.resize(static_cast<size_t>(4 * width * height));
  if (!gl_->context || !OSMesaMakeCurrent(gl_->context, gl_->buffer.data(), GL_UNSIGNED_BYTE, width, height)) {
    delete gl_;
    gl_ = nullptr;
    throw std::runtime_error("cannot create an OSMesa rendering context");
  }
  mjv_defaultScene(&scene_);
  mjv_defaultCamera(&camera_);
  mjv_defaultOption(&option_);
  mjr_defaultContext(&context_);
  mjv_makeScene(model, &scene_, 2000);
  mjr_makeContext(model, &context_, mjFONTSCALE_100);
  mjr_setBuffer(mjFB_OFFSCREEN, &context_);
  release_osmesa();
  const int cam = mj_name2id(model, mjOBJ_CAMERA, camera.c_str());
  if (cam >= 0) {
    camera_.type = mjCAMERA_FIXED;
    camera_.fixedcamid = cam;
  }
  // mjr_readPixels returns rows bottom-up: ffmpeg flips them.
  const std::string cmd = "ffmpeg -loglevel error -y -f rawvideo -pix_fmt rgb24 -s " + std::to_string(width) + "x" +
                          std::to_string(height) + " -r " + std::to_string(fps) +
                          " -i - -vf vflip -c:v libx264 -preset veryfast -pix_fmt yuv420p '" + path + "'";
  ffmpeg_ = popen(cmd.c_str(), "w");
  if (!ffmpeg_) throw std::runtime_error("cannot start ffmpeg for " + path);
}

std::string OffscreenRecorder::finish() {
  if (!ffmpeg_) return "";
  const int status = pclose(ffmpeg_);
  ffmpeg_ = nullptr;
  if (write_failed_) return "ffmpeg stopped taking frames (is ffmpeg installed?)";
  if (status == -1) return "cannot wait for ffmpeg";
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    return WIFEXITED(status) && WEXITSTATUS(status) == 127 ? std::string("ffmpeg is not installed")
                                                           : "ffmpeg failed (status " + std::to_string(status) + ")";
  return "";
}

OffscreenRecorder::~OffscreenRecorder() {
  finish();
  if (gl_) OSMesaMakeCurrent(gl_->context, gl_->buffer.data(), GL_UNSIGNED_BYTE, width_, height_);
  mjr_freeContext(&context_);
  mjv_freeScene(&scene_);
  if (gl_) {
    release_osmesa();
    OSMesaDestroyContext(gl_->context);
    delete gl_;
  }
}

void OffscreenRecorder::frame(Vehicle& vehicle) {
  OSMesaMakeCurrent(gl_->context, gl_->buffer.data(), GL_UNSIGNED_BYTE, width_, height_);
  const mjrRect viewport{0, 0, width_, height_};
  mjv_updateScene(vehicle.model(), vehicle.data(), &option_, nullptr, &camera_, mjCAT_ALL, &scene_);
  mjr_render(viewport, &scene_, &context_);
  mjr_readPixels(rgb_.data(), nullptr, viewport, &context_);
  release_osmesa();
  if (!write_failed_ && std::fwrite(rgb_.data(), 1, rgb_.size(), ffmpeg_) != rgb_.size()) write_failed_ = true;
  ++frames_;
}

}  // namespace quad::sim
