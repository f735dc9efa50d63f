#include "eval_render.h"

#include <cmath>

#include <opencv2/imgproc.hpp>

namespace vision_eval {
namespace {

double light_at(const Lighting& L, double x, double y) {
  double f = 1.0 + L.gradient[0] * x + L.gradient[1] * y;
  if (L.spot_gain != 0.0) {
    const double dx = x - L.spot_centre.x, dy = y - L.spot_centre.y;
    f += L.spot_gain * std::exp(-(dx * dx + dy * dy) / (2.0 * L.spot_sigma * L.spot_sigma));
  }
  if (L.shadow) {
    const double d = (L.shadow_normal[0] * x + L.shadow_normal[1] * y - L.shadow_offset) / L.shadow_softness;
    const double t = d <= -1.0 ? 0.0 : d >= 1.0 ? 1.0 : 0.5 + 0.75 * d - 0.25 * d * d * d;  // smooth step
    f *= 1.0 - L.shadow_depth * t;
  }
  return std::max(f, 0.05);
}

// Adds one canvas's coverage where the plane hits (px, py) fall on it.
void add_coverage(const CoverageCanvas& canvas, const cv::Mat& px, const cv::Mat& py, cv::Mat& coverage) {
  const double x0 = canvas.origin.x, y0 = canvas.origin.y;
  const double x1 = x0 + canvas.coverage.cols * canvas.metres_per_px, y1 = y0 + canvas.coverage.rows * canvas.metres_per_px;
  cv::Mat inside = (px >= x0) & (px <= x1) & (py >= y0) & (py <= y1);
  const cv::Rect box = cv::boundingRect(inside);
  if (box.empty()) return;
  cv::Mat cx = (px(box) - x0) / canvas.metres_per_px;
  cv::Mat cy = (py(box) - y0) / canvas.metres_per_px;
  cv::Mat local;
  cv::remap(canvas.coverage, local, cx, cy, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::Mat target = coverage(box);
  target = cv::min(target + local, 1.0);
}

}  // namespace

cv::Mat render_view(const RayGrid& grid, int factor, const CameraPose& pose, const FloorLook& floor,
                    const std::vector<CoverageCanvas>& canvases, const Lighting& light) {
  cv::Mat px, py;
  grid.plane_hits(pose, px, py);
  // Coverage of the outlines and the floor texture, both looked up at the plane point of each sub-pixel.
  cv::Mat coverage(px.size(), CV_32F, cv::Scalar(0));
  for (const CoverageCanvas& canvas : canvases) add_coverage(canvas, px, py, coverage);
  cv::Mat texture;
  if (!floor.texture.empty()) {
    const cv::Matx23d& A = floor.plane_to_texture;
    cv::Mat tx = A(0, 0) * px + A(0, 1) * py + A(0, 2);
    cv::Mat ty = A(1, 0) * px + A(1, 1) * py + A(1, 2);
    cv::remap(floor.texture, texture, tx, ty, cv::INTER_LINEAR, cv::BORDER_REFLECT_101);
  }
  cv::Mat fine(px.size(), CV_32F);
  for (int r = 0; r < fine.rows; ++r) {
    const float* x = px.ptr<float>(r);
    const float* y = py.ptr<float>(r);
    const float* cov = coverage.ptr<float>(r);
    const float* tex = texture.empty() ? nullptr : texture.ptr<float>(r);
    float* out = fine.ptr<float>(r);
    for (int c = 0; c < fine.cols; ++c) {
      if (std::isnan(x[c])) {
        out[c] = static_cast<float>(light.level * floor.background_albedo);
        continue;
      }
      const double ground = tex ? 1.0 - floor.contrast * (1.0 - tex[c]) : 1.0;
      const double albedo = ground * (1.0 - cov[c]) + floor.shape_albedo * cov[c];
      out[c] = static_cast<float>(light.level * albedo * light_at(light, x[c], y[c]));
    }
  }
  cv::Mat view;
  cv::resize(fine, view, cv::Size(fine.cols / factor, fine.rows / factor), 0, 0, cv::INTER_AREA);
  if (light.vignetting > 0.0) {
    const double hx = 0.5 * (view.cols - 1), hy = 0.5 * (view.rows - 1), r2max = hx * hx + hy * hy;
    for (int r = 0; r < view.rows; ++r) {
      float* v = view.ptr<float>(r);
      for (int c = 0; c < view.cols; ++c) {
        const double r2 = ((c - hx) * (c - hx) + (r - hy) * (r - hy)) / r2max;
        v[c] = static_cast<float>(v[c] * (1.0 - light.vignetting * r2));
      }
    }
  }
  return view;
}

}  // namespace vision_eval
