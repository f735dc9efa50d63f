#include "quad/vision/star_pose.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace quad::vision {
namespace {

struct Line {
  cv::Point2d point, direction;
};

// Least-squares line through the inner part of the contour run a..b (indices, cyclic): the ends are
// rounded by blur and by the polygon fit, so only the middle 70 % is used.
Line fit_edge(const std::vector<cv::Point2f>& contour, int a, int b, std::vector<cv::Point2f>& run) {
  const int n = static_cast<int>(contour.size());
  const int length = (b - a + n) % n;
  run.clear();
  for (int k = length * 15 / 100; k <= length * 85 / 100; ++k) run.push_back(contour[(a + k) % n]);
  if (run.size() < 3) {
    const cv::Point2d p = contour[a], q = contour[b];
    return Line{p, (q - p) / std::max(cv::norm(q - p), 1e-9)};
  }
  cv::Vec4f l;
  cv::fitLine(run, l, cv::DIST_L2, 0, 0.01, 0.01);
  return Line{cv::Point2d(l[2], l[3]), cv::Point2d(l[0], l[1])};
}

bool intersect(const Line& a, const Line& b, cv::Point2d& out) {
  const double cross = a.direction.x * b.direction.y - a.direction.y * b.direction.x;
  if (std::fabs(cross) < 0.05) return false;  // nearly parallel edges: no sharp vertex
  const cv::Point2d d = b.point - a.point;
  const double s = (d.x * b.direction.y - d.y * b.direction.x) / cross;
  out = a.point + s * a.direction;
  return true;
}

// The polygon's vertices as indices into the contour (approxPolyDP keeps contour points), or empty.
std::vector<int> octagon_indices(const std::vector<cv::Point2f>& contour) {
  const double perimeter = cv::arcLength(contour, true);
  for (double fraction : {0.025, 0.02, 0.03, 0.015, 0.035, 0.04, 0.05}) {
    std::vector<cv::Point2f> polygon;
    cv::approxPolyDP(contour, polygon, fraction * perimeter, true);
    if (polygon.size() != 8) continue;
    std::vector<int> indices;
    for (const cv::Point2f& p : polygon) {
      const auto it = std::find(contour.begin(), contour.end(), p);
      if (it == contour.end()) return {};
      indices.push_back(static_cast<int>(it - contour.begin()));
    }
    std::sort(indices.begin(), indices.end());
    return indices;
  }
  return {};
}

std::array<cv::Point3d, 8> star_model(const StarPoseSettings& s) {
  std::array<cv::Point3d, 8> m;
  for (int k = 0; k < 8; ++k) {
    const double r = (k % 2 == 0 ? 1.0 : s.inner_ratio) * s.tip_radius_m;
    m[k] = cv::Point3d(r * std::cos(k * CV_PI / 4.0), r * std::sin(k * CV_PI / 4.0), 0.0);
  }
  return m;
}

// Rotation and scale taking the (centred) model onto the (centred) points: Kabsch/Umeyama.
cv::Matx33d kabsch(const std::array<cv::Point3d, 8>& model, const std::array<cv::Point3d, 8>& points,
                   const cv::Point3d& centre) {
  cv::Matx33d H = cv::Matx33d::zeros();
  for (int k = 0; k < 8; ++k) {
    const cv::Vec3d p(points[k] - centre), m(model[k]);
    H += cv::Matx33d(p[0] * m[0], p[0] * m[1], p[0] * m[2], p[1] * m[0], p[1] * m[1], p[1] * m[2], p[2] * m[0],
                     p[2] * m[1], p[2] * m[2]);
  }
  cv::SVD svd(cv::Mat(H), cv::SVD::FULL_UV);
  cv::Mat D = cv::Mat::eye(3, 3, CV_64F);
  if (cv::determinant(svd.u * svd.vt) < 0) D.at<double>(2, 2) = -1.0;
  return cv::Matx33d(cv::Mat(svd.u * D * svd.vt));
}

cv::Matx33d rotation_from_vector(const cv::Vec3d& w) {
  cv::Matx33d R;
  cv::Rodrigues(w, R);
  return R;
}

}  // namespace

namespace {

// The eight vertices (a tip first) and, for edge k from vertex k to k+1, the contour points on it.
struct StarOutline {
  std::array<cv::Point2d, 8> vertices;
  std::array<std::vector<cv::Point2f>, 8> edges;

  // Vertex k becomes vertex −k (the tip stays first): the contour read the other way round.
  void reverse() {
    std::reverse(vertices.begin() + 1, vertices.end());
    std::reverse(edges.begin(), edges.end());  // edge k joined k, k+1; it now joins 8−k−1, 8−k
  }
  // Vertex k becomes vertex k − s.
  void rotate(int s) {
    std::rotate(vertices.begin(), vertices.begin() + s, vertices.end());
    std::rotate(edges.begin(), edges.begin() + s, edges.end());
  }
  double signed_area() const {
    double area = 0.0;
    for (int k = 0; k < 8; ++k) area += vertices[k].x * vertices[(k + 1) % 8].y - vertices[(k + 1) % 8].x * vertices[k].y;
    return area;
  }
};

bool find_outline(const std::vector<cv::Point2f>& contour, StarOutline& outline) {
  if (contour.size() < 24) return false;
  const std::vector<int> corner = octagon_indices(contour);
  if (corner.size() != 8) return false;
  std::array<Line, 8> edges;  // edge k runs from corner k to corner k+1
  for (int k = 0; k < 8; ++k) edges[k] = fit_edge(contour, corner[k], corner[(k + 1) % 8], outline.edges[k]);
  for (int k = 0; k < 8; ++k) {
    const cv::Point2d polygon_vertex = contour[corner[k]];
    cv::Point2d p;
    const double edge = cv::norm(contour[corner[(k + 1) % 8]] - contour[corner[k]]);
    // A blunted tip moves the polygon vertex inwards; the edges' intersection restores it, unless the
    // edges are nearly parallel or the intersection runs off (a poorly fitted edge).
    outline.vertices[k] =
        intersect(edges[(k + 7) % 8], edges[k], p) && cv::norm(p - polygon_vertex) < 0.3 * edge ? p : polygon_vertex;
  }
  cv::Point2d centre(0, 0);
  for (const cv::Point2d& p : outline.vertices) centre += p / 8.0;
  double even = 0.0, odd = 0.0;
  for (int k = 0; k < 8; ++k) (k % 2 == 0 ? even : odd) += cv::norm(outline.vertices[k] - centre);
  if (odd > even) outline.rotate(1);
  return true;
}

}  // namespace

bool find_star_vertices(const std::vector<cv::Point2f>& contour, std::array<cv::Point2d, 8>& vertices) {
  StarOutline outline;
  if (!find_outline(contour, outline)) return false;
  vertices = outline.vertices;
  return true;
}

namespace {

// Both outlines, read in the model's direction and with the same tip first.
bool matched_outlines(const std::vector<cv::Point2f>& left, const std::vector<cv::Point2f>& right, StarOutline& l,
                      StarOutline& r) {
  if (!find_outline(left, l) || !find_outline(right, r)) return false;
  // The model runs from x towards y about a z pointing away from the cameras, which in the image is
  // from u towards v (positive shoelace area): a contour running the other way is read backwards.
  if (l.signed_area() < 0.0) l.reverse();
  if (r.signed_area() < 0.0) r.reverse();
  // The right outline's first tip: the one whose rows agree and whose disparities spread least.
  int shift = 0;
  double best = std::numeric_limits<double>::infinity();
  for (int s = 0; s < 8; s += 2) {
    double rows = 0.0, mean = 0.0, square = 0.0;
    for (int k = 0; k < 8; ++k) {
      const cv::Point2d& a = l.vertices[k];
      const cv::Point2d& b = r.vertices[(k + s) % 8];
      rows += (a.y - b.y) * (a.y - b.y);
      mean += (a.x - b.x) / 8.0;
      square += (a.x - b.x) * (a.x - b.x) / 8.0;
    }
    const double cost = rows / 8.0 + (square - mean * mean);
    if (cost < best) {
      best = cost;
      shift = s;
    }
  }
  r.rotate(shift);
  return true;
}

// The model placed in the rectified left frame: X = scale·R·m + t.
struct Placement {
  cv::Matx33d R = cv::Matx33d::eye();
  cv::Vec3d t;
  double scale = 1.0;
  cv::Vec3d place(const cv::Point3d& m) const { return scale * (R * cv::Vec3d(m)) + t; }
  // δ = (rotation vector applied on the left, translation, log scale).
  Placement moved(const cv::Vec<double, 7>& d) const {
    return Placement{rotation_from_vector(cv::Vec3d(d[0], d[1], d[2])) * R, t + cv::Vec3d(d[3], d[4], d[5]),
                     scale * std::exp(d[6])};
  }
};

cv::Point2d project(const cv::Matx34d& P, const cv::Vec3d& X) {
  const cv::Vec3d x = P * cv::Vec4d(X[0], X[1], X[2], 1.0);
  return cv::Point2d(x[0] / x[2], x[1] / x[2]);
}

// Triangulated vertices (thesis eq. 8.3–8.4 each) and the rigid fit of the model to them.
bool initial_placement(const StarOutline& l, const StarOutline& r, const StereoCalibration& c,
                       const std::array<cv::Point3d, 8>& model, Placement& out) {
  const double f = c.P1(0, 0), fy = c.P1(1, 1), cx1 = c.P1(0, 2), cy = c.P1(1, 2), cx2 = c.P2(0, 2), b = c.baseline();
  std::array<cv::Point3d, 8> points;
  cv::Point3d centre(0, 0, 0);
  for (int k = 0; k < 8; ++k) {
    const double d = (l.vertices[k].x - cx1) - (r.vertices[k].x - cx2);
    if (!(d > 0.0)) return false;
    const double z = f * b / d;
    const double v = 0.5 * (l.vertices[k].y + r.vertices[k].y);
    points[k] = cv::Point3d((l.vertices[k].x - cx1) * z / f, (v - cy) * z / fy, z);
    centre += points[k] / 8.0;
  }
  double spread_points = 0.0, spread_model = 0.0;
  for (int k = 0; k < 8; ++k) {
    spread_points += (points[k] - centre).dot(points[k] - centre);
    spread_model += model[k].dot(model[k]);
  }
  out = Placement{kabsch(model, points, centre), cv::Vec3d(centre), std::sqrt(spread_points / spread_model)};
  return true;
}

// Residuals of a placement: the vertices' rectified (u, v) in both views (32), or, with `edges`, the
// distance of every edge point to the projected model edge it lies on (one per point).
void residuals(const Placement& p, const StarOutline& l, const StarOutline& r, const StereoCalibration& c,
               const std::array<cv::Point3d, 8>& model, bool edges, std::vector<double>& out) {
  out.clear();
  for (int view = 0; view < 2; ++view) {
    const cv::Matx34d& P = view == 0 ? c.P1 : c.P2;
    const StarOutline& o = view == 0 ? l : r;
    std::array<cv::Point2d, 8> v;
    for (int k = 0; k < 8; ++k) v[k] = project(P, p.place(model[k]));
    for (int k = 0; k < 8; ++k) {
      if (!edges) {
        out.push_back(o.vertices[k].x - v[k].x);
        out.push_back(o.vertices[k].y - v[k].y);
        continue;
      }
      const cv::Point2d a = v[k], d = v[(k + 1) % 8] - v[k];
      const cv::Point2d n = cv::Point2d(-d.y, d.x) / std::max(cv::norm(d), 1e-9);
      for (const cv::Point2f& q : o.edges[k]) out.push_back(n.dot(cv::Point2d(q) - a));
    }
  }
}

// Gauss-Newton with a forward-difference Jacobian; returns the Jacobian and residual sum of squares at
// the solution.
bool gauss_newton(Placement& p, const std::function<void(const Placement&, std::vector<double>&)>& f, cv::Mat& J,
                  double& rss) {
  std::vector<double> r0, r1;
  for (int iteration = 0; iteration < 12; ++iteration) {
    f(p, r0);
    const int n = static_cast<int>(r0.size());
    J.create(n, 7, CV_64F);
    for (int j = 0; j < 7; ++j) {
      cv::Vec<double, 7> d = cv::Vec<double, 7>::all(0.0);
      d[j] = j >= 3 && j < 6 ? 1e-7 * p.t[2] : 1e-7;
      f(p.moved(d), r1);
      for (int i = 0; i < n; ++i) J.at<double>(i, j) = (r1[i] - r0[i]) / d[j];
    }
    cv::Mat step;
    if (!cv::solve(J.t() * J, -J.t() * cv::Mat(r0), step, cv::DECOMP_CHOLESKY)) return false;
    p = p.moved(cv::Vec<double, 7>(step));
    if (cv::norm(step) < 1e-10) break;
  }
  f(p, r0);
  rss = 0.0;
  for (double v : r0) rss += v * v;
  return true;
}

}  // namespace

StarPose estimate_star_pose(const std::vector<cv::Point2f>& left, const std::vector<cv::Point2f>& right,
                            const StereoCalibration& calibration, const StarPoseSettings& settings) {
  StarPose pose;
  StarOutline l, r;
  const std::array<cv::Point3d, 8> model = star_model(settings);
  Placement p;
  if (!matched_outlines(left, right, l, r) || !initial_placement(l, r, calibration, model, p)) return pose;
  cv::Mat J;
  double rss = 0.0;
  // Vertices first (a good start from the triangulation), then every edge point.
  auto vertices = [&](const Placement& q, std::vector<double>& out) { residuals(q, l, r, calibration, model, false, out); };
  if (!gauss_newton(p, vertices, J, rss)) return pose;
  pose.rms_px = std::sqrt(rss / 32.0);
  if (!(pose.rms_px <= settings.max_rms_px) || !(p.t[2] > 0.0)) return pose;
  auto edges = [&](const Placement& q, std::vector<double>& out) { residuals(q, l, r, calibration, model, true, out); };
  if (!gauss_newton(p, edges, J, rss) || J.rows <= 7 || !(p.t[2] > 0.0)) return pose;
  // Covariance: the edge points' noise from the residuals, floored.
  pose.vertex_sigma_px = std::max(std::sqrt(rss / (J.rows - 7.0)), settings.min_vertex_sigma_px);
  cv::Mat normal_inverse;
  if (cv::invert(J.t() * J, normal_inverse, cv::DECOMP_CHOLESKY) == 0.0) return pose;
  const cv::Mat cov = pose.vertex_sigma_px * pose.vertex_sigma_px * normal_inverse;
  // The rectified left frame is the left camera frame rotated by R1.
  const cv::Matx33d R1t = calibration.R1.t();
  pose.R_CS = R1t * p.R;
  pose.t_C = R1t * p.t;
  pose.attitude_cov_C = R1t * cv::Matx33d(cv::Mat(cov(cv::Rect(0, 0, 3, 3)))) * R1t.t();
  pose.position_cov_C = R1t * cv::Matx33d(cv::Mat(cov(cv::Rect(3, 3, 3, 3)))) * R1t.t();
  pose.size_ratio = p.scale;
  pose.valid = true;
  return pose;
}

cv::Matx33d star_attitude_in_body(const cv::Matx33d& R_BC, const cv::Matx33d& R_CS) {
  const cv::Matx33d R_BS = R_BC * R_CS;
  // Rotating the star frame by k·90° about its z gives the same star; pick the x nearest body forward.
  cv::Matx33d best = R_BS;
  double best_forward = -2.0;
  for (int k = 0; k < 4; ++k) {
    const double c = std::cos(k * CV_PI / 2.0), s = std::sin(k * CV_PI / 2.0);
    const cv::Matx33d candidate = R_BS * cv::Matx33d(c, -s, 0, s, c, 0, 0, 0, 1);
    if (candidate(0, 0) > best_forward) {
      best_forward = candidate(0, 0);
      best = candidate;
    }
  }
  return best;
}

cv::Vec4d quaternion_from_rotation(const cv::Matx33d& R) {
  // Shepperd's method: the largest of w, x, y, z is computed from the diagonal, the rest from it.
  const double trace = R(0, 0) + R(1, 1) + R(2, 2);
  cv::Vec4d q;
  if (trace > 0.0) {
    const double s = 2.0 * std::sqrt(1.0 + trace);
    q = cv::Vec4d(0.25 * s, (R(2, 1) - R(1, 2)) / s, (R(0, 2) - R(2, 0)) / s, (R(1, 0) - R(0, 1)) / s);
  } else if (R(0, 0) > R(1, 1) && R(0, 0) > R(2, 2)) {
    const double s = 2.0 * std::sqrt(1.0 + R(0, 0) - R(1, 1) - R(2, 2));
    q = cv::Vec4d((R(2, 1) - R(1, 2)) / s, 0.25 * s, (R(0, 1) + R(1, 0)) / s, (R(0, 2) + R(2, 0)) / s);
  } else if (R(1, 1) > R(2, 2)) {
    const double s = 2.0 * std::sqrt(1.0 + R(1, 1) - R(0, 0) - R(2, 2));
    q = cv::Vec4d((R(0, 2) - R(2, 0)) / s, (R(0, 1) + R(1, 0)) / s, 0.25 * s, (R(1, 2) + R(2, 1)) / s);
  } else {
    const double s = 2.0 * std::sqrt(1.0 + R(2, 2) - R(0, 0) - R(1, 1));
    q = cv::Vec4d((R(1, 0) - R(0, 1)) / s, (R(0, 2) + R(2, 0)) / s, (R(1, 2) + R(2, 1)) / s, 0.25 * s);
  }
  if (q[0] < 0.0) q = -q;
  return q / cv::norm(q);
}

}  // namespace quad::vision
