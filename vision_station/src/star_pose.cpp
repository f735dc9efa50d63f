#include "quad/vision/star_pose.h"

#include <algorithm>
#include <cfloat>
#include <complex>
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

// A small or blurred star's outline often simplifies to 7 or 9 vertices at every tolerance. Then: the four
// tips are the farthest points (whitened by the outline's second moments, which undoes a tilted view)
// in the four quarter-turns about the 4th harmonic's phase of the radius, and each inner corner is the
// nearest point between two neighbouring tips. Indices into the contour in contour order, or empty.
std::vector<int> octagon_by_radius(const std::vector<cv::Point2f>& contour) {
  const cv::Moments m = cv::moments(contour);
  if (!(std::fabs(m.m00) > 1e-9)) return {};
  const double cx = m.m10 / m.m00, cy = m.m01 / m.m00;
  const cv::Matx22d C(m.mu20 / m.m00, m.mu11 / m.m00, m.mu11 / m.m00, m.mu02 / m.m00);
  cv::Matx21d eigenvalues;
  cv::Matx22d eigenvectors;
  cv::eigen(C, eigenvalues, eigenvectors);
  if (!(eigenvalues(1) > 1e-9)) return {};
  const int n = static_cast<int>(contour.size());
  std::vector<double> radius(n), angle(n);
  std::complex<double> fourth = 0.0;
  for (int i = 0; i < n; ++i) {
    const cv::Matx21d d(contour[i].x - cx, contour[i].y - cy);
    const double u = (eigenvectors.row(0) * d)(0) / std::sqrt(eigenvalues(0));
    const double v = (eigenvectors.row(1) * d)(0) / std::sqrt(eigenvalues(1));
    radius[i] = std::hypot(u, v);
    angle[i] = std::atan2(v, u);
    fourth += radius[i] * std::polar(1.0, -4.0 * angle[i]);
  }
  const double phase = std::arg(fourth) / 4.0;  // a tip's angle
  std::vector<int> tips(4, -1);
  for (int i = 0; i < n; ++i) {
    const double turns = (angle[i] - phase) / (0.5 * CV_PI);
    const int k = ((static_cast<int>(std::lround(turns)) % 4) + 4) % 4;
    if (tips[k] < 0 || radius[i] > radius[tips[k]]) tips[k] = i;
  }
  if (std::find(tips.begin(), tips.end(), -1) != tips.end()) return {};
  std::sort(tips.begin(), tips.end());
  std::vector<int> indices;
  for (int k = 0; k < 4; ++k) {
    const int a = tips[k], b = k == 3 ? tips[0] + n : tips[k + 1];
    if (b - a < 2) return {};
    int inner = a + 1;
    for (int j = a + 1; j < b; ++j) inner = radius[j % n] < radius[inner % n] ? j : inner;
    indices.push_back(a);
    indices.push_back(inner % n);
  }
  std::sort(indices.begin(), indices.end());
  return indices;
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
  return octagon_by_radius(contour);
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

// cv::Rodrigues's formula, term by term in its order (the same rotation to the last bit), without its
// array wrapping: the pose fit calls this some hundred times per fix.
cv::Matx33d rotation_from_vector(const cv::Vec3d& w) {
  const double theta = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
  if (theta < DBL_EPSILON) return cv::Matx33d::eye();
  const double c = std::cos(theta), s = std::sin(theta), c1 = 1.0 - c;
  const cv::Vec3d r = w * (1.0 / theta);
  const cv::Matx33d rrt(r[0] * r[0], r[0] * r[1], r[0] * r[2], r[0] * r[1], r[1] * r[1], r[1] * r[2], r[0] * r[2],
                        r[1] * r[2], r[2] * r[2]);
  const cv::Matx33d r_x(0, -r[2], r[1], r[2], 0, -r[0], -r[1], r[0], 0);
  return c * cv::Matx33d::eye() + c1 * rrt + s * r_x;
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
    std::reverse(edges.begin(), edges.end());  // edge k joined vertices k, k+1; after reversal it joins 8−k−1, 8−k
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

bool find_outline(const std::vector<cv::Point2f>& contour, StarOutline& outline, bool by_radius = false) {
  if (contour.size() < 24) return false;
  const std::vector<int> corner = by_radius ? octagon_by_radius(contour) : octagon_indices(contour);
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

// The edge point refined by the profile's area: across a step from level A to level B the integral of
// (I − A)/(B − A) over [c − W, c + W] is W minus the edge's offset from c, for any symmetric blur and for
// pixels that average their area (the mid-level crossing of interpolated samples is off by up to 0.08 px
// depending on the edge's sub-pixel phase and direction, differently in the two views: a tilt of the star
// of 0.2 deg at 1.5 m). The levels are the means of the window's two outermost samples on each side.
namespace {

// v[k + half] = grey_at(gray, c + k · step · normal) for k = −half … half; false when a sample leaves the
// image. With both ends inside (by a margin far above rounding) the line is, so the samples are taken
// without grey_at's checks: the same values, for a third of the cost.
bool sample_line(const cv::Mat& gray, const cv::Point2d& c, const cv::Point2d& normal, double step, int half, double* v) {
  constexpr double kMargin = 1e-6;
  const cv::Point2d a = c - half * step * normal, b = c + half * step * normal;
  const double x_limit = gray.cols - 1 - kMargin, y_limit = gray.rows - 1 - kMargin;
  const bool inside = std::min(a.x, b.x) >= kMargin && std::min(a.y, b.y) >= kMargin &&
                      std::max(a.x, b.x) < x_limit && std::max(a.y, b.y) < y_limit;
  if (!inside) {
    for (int k = -half; k <= half; ++k) {
      v[k + half] = grey_at(gray, c + k * step * normal);
      if (v[k + half] < 0.0) return false;
    }
    return true;
  }
  for (int k = -half; k <= half; ++k) {
    const cv::Point2d p = c + k * step * normal;
    v[k + half] = bilinear_inside(gray.data, gray.step[0], p.x, p.y);
  }
  return true;
}

cv::Point2d balanced_edge(const cv::Mat& gray, const cv::Point2d& c, const cv::Point2d& normal) {
  constexpr int kHalf = 8;       // samples each side, ...
  constexpr double kStep = 0.25;  // ... this far apart: W = 2 px
  double v[2 * kHalf + 1];
  if (!sample_line(gray, c, normal, kStep, kHalf, v)) return c;
  const double a = 0.5 * (v[0] + v[1]), b = 0.5 * (v[2 * kHalf] + v[2 * kHalf - 1]);
  if (!(std::fabs(b - a) > 10.0)) return c;
  double area = 0.0;  // trapezoids, in pixels
  for (int k = 0; k < 2 * kHalf; ++k) area += 0.5 * (v[k] + v[k + 1] - 2.0 * a) * kStep;
  const double offset = kHalf * kStep - area / (b - a);
  return std::fabs(offset) < 1.0 ? c + offset * normal : c;
}

}  // namespace

bool edge_near(const cv::Mat& gray, const cv::Point2d& p, const cv::Point2d& normal, cv::Point2d& edge,
               double max_offset_px) {
  constexpr int kHalf = 6;         // samples each side, ...
  constexpr double kStep = 0.5;    // ... this far apart (±3 px)
  double profile[2 * kHalf + 1];
  if (!sample_line(gray, p, normal, kStep, kHalf, profile)) return false;
  double lo = 255.0, hi = 0.0;
  for (const double value : profile) {
    lo = std::min(lo, value);
    hi = std::max(hi, value);
  }
  if (!(hi - lo > 10.0)) return false;
  // The edge is where the profile crosses the middle between star and floor; the crossing nearest p.
  const double mid = 0.5 * (lo + hi);
  double nearest = 1e9;
  for (int k = 0; k < 2 * kHalf; ++k) {
    const double a = profile[k] - mid, b = profile[k + 1] - mid;
    if (a * b > 0.0 || a == b) continue;
    const double s = (k - kHalf + a / (a - b)) * kStep;
    if (std::fabs(s) < std::fabs(nearest)) nearest = s;
  }
  if (!(std::fabs(nearest) <= max_offset_px)) return false;
  // The crossing refined by the profile's area around it.
  edge = balanced_edge(gray, p + nearest * normal, normal);
  return true;
}

std::vector<cv::Point2f> subpixel_edges(const cv::Mat& gray, const std::vector<cv::Point>& contour) {
  const int n = static_cast<int>(contour.size());
  std::vector<cv::Point2f> out;
  out.reserve(contour.size());
  for (int i = 0; i < n; ++i) {
    const cv::Point2d p = contour[i];
    const cv::Point2d t = cv::Point2d(contour[(i + 2) % n] - contour[(i + n - 2) % n]);
    const double length = cv::norm(t);
    cv::Point2d best = p;
    // The contour pixel lies just inside the star: its edge is within 2 px.
    if (length > 0.0 && !edge_near(gray, p, cv::Point2d(t.y / length, -t.x / length), best, 2.0)) best = p;
    out.emplace_back(static_cast<float>(best.x), static_cast<float>(best.y));
  }
  return out;
}

NearRectifier::NearRectifier(const StereoCalibration& c, int camera)
    : K_(camera == 0 ? c.rig.left.K : c.rig.right.K), D_(camera == 0 ? c.rig.left.D : c.rig.right.D) {
  const cv::Matx34d& P = camera == 0 ? c.P1 : c.P2;
  const cv::Matx33d P33(P(0, 0), P(0, 1), P(0, 2), P(1, 0), P(1, 1), P(1, 2), P(2, 0), P(2, 1), P(2, 2));
  back_ = (camera == 0 ? c.R1 : c.R2).t() * P33.inv();
}

cv::Point2d NearRectifier::pixel(double x, double y, cv::Matx22d* jacobian) const {
  // OpenCV's lens model (k1, k2, p1, p2, k3), then the camera matrix.
  const double k1 = D_[0], k2 = D_[1], p1 = D_[2], p2 = D_[3], k3 = D_[4];
  const double r2 = x * x + y * y;
  const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
  const double xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
  const double yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
  if (jacobian != nullptr) {  // ∂(xd, yd)/∂(x, y), then through the camera matrix
    const double radial_slope = k1 + r2 * (2.0 * k2 + 3.0 * r2 * k3);  // ∂radial/∂r²
    const double cross = 2.0 * x * y * radial_slope + 2.0 * p1 * x + 2.0 * p2 * y;
    const cv::Matx22d lens(radial + 2.0 * x * x * radial_slope + 2.0 * p1 * y + 6.0 * p2 * x, cross,
                           cross, radial + 2.0 * y * y * radial_slope + 6.0 * p1 * y + 2.0 * p2 * x);
    *jacobian = cv::Matx22d(K_(0, 0), K_(0, 1), 0.0, K_(1, 1)) * lens;
  }
  return cv::Point2d(K_(0, 0) * xd + K_(0, 1) * yd + K_(0, 2), K_(1, 1) * yd + K_(1, 2));
}

cv::Point2d NearRectifier::raw(const cv::Point2d& q) const {
  const cv::Vec3d ray = back_ * cv::Vec3d(q.x, q.y, 1.0);
  return pixel(ray[0] / ray[2], ray[1] / ray[2], nullptr);
}

cv::Point2d NearRectifier::raw(const cv::Point2d& q, cv::Matx22d& jacobian) const {
  const cv::Vec3d ray = back_ * cv::Vec3d(q.x, q.y, 1.0);
  // The perspective division's ∂(x, y)/∂q.
  const double w2 = ray[2] * ray[2];
  const cv::Matx22d projection((back_(0, 0) * ray[2] - ray[0] * back_(2, 0)) / w2,
                               (back_(0, 1) * ray[2] - ray[0] * back_(2, 1)) / w2,
                               (back_(1, 0) * ray[2] - ray[1] * back_(2, 0)) / w2,
                               (back_(1, 1) * ray[2] - ray[1] * back_(2, 1)) / w2);
  cv::Matx22d lens;
  const cv::Point2d p = pixel(ray[0] / ray[2], ray[1] / ray[2], &lens);
  jacobian = lens * projection;
  return p;
}

cv::Point2d NearRectifier::rectified(const cv::Point2d& target, cv::Point2d q) const {
  for (int iteration = 0; iteration < 4; ++iteration) {
    cv::Matx22d J;
    const cv::Point2d e = target - raw(q, J);
    if (e.dot(e) < 1e-12) break;
    const double det = J(0, 0) * J(1, 1) - J(0, 1) * J(1, 0);
    if (std::fabs(det) < 1e-12) break;
    q += cv::Point2d((J(1, 1) * e.x - J(0, 1) * e.y) / det, (-J(1, 0) * e.x + J(0, 0) * e.y) / det);
  }
  return q;
}

bool find_star_vertices(const std::vector<cv::Point2f>& contour, std::array<cv::Point2d, 8>& vertices) {
  StarOutline outline;
  if (!find_outline(contour, outline)) return false;
  vertices = outline.vertices;
  return true;
}

namespace {

// Both outlines, read in the model's direction and with the same tip first.
bool matched_outlines(const std::vector<cv::Point2f>& left, const std::vector<cv::Point2f>& right, StarOutline& l,
                      StarOutline& r, bool left_by_radius, bool right_by_radius) {
  if (!find_outline(left, l, left_by_radius) || !find_outline(right, r, right_by_radius)) return false;
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

// The 16 projected star corners (view-major) of a placement.
std::array<cv::Point2d, 16> corners(const Placement& p, const StereoCalibration& c, const std::array<cv::Point3d, 8>& model) {
  std::array<cv::Point2d, 16> v;
  for (int k = 0; k < 8; ++k) {
    const cv::Vec3d X = p.place(model[k]);
    v[k] = project(c.P1, X);
    v[8 + k] = project(c.P2, X);
  }
  return v;
}

// The 16 projected star edges as lines (nx, ny, d): distance of q = nx·qx + ny·qy − d.
std::array<cv::Vec3d, 16> edge_lines(const std::array<cv::Point2d, 16>& v) {
  std::array<cv::Vec3d, 16> lines;
  for (int i = 0; i < 16; ++i) {
    const cv::Point2d a = v[i], b = v[(i / 8) * 8 + (i % 8 + 1) % 8];
    const cv::Point2d d = b - a;
    const cv::Point2d n = cv::Point2d(-d.y, d.x) / std::max(cv::norm(d), 1e-9);
    lines[i] = cv::Vec3d(n.x, n.y, n.dot(a));
  }
  return lines;
}

// The step a fit's parameter j is perturbed by for its numerical derivative.
double derivative_step(const Placement& p, int j) { return j >= 3 && j < 6 ? 1e-7 * p.t[2] : 1e-7; }

cv::Vec<double, 7> unit(int j, double h) {
  cv::Vec<double, 7> d = cv::Vec<double, 7>::all(0.0);
  d[j] = h;
  return d;
}

// A fit's normal equations: JᵀJ, Jᵀr and the residual sum of squares (r = observed − predicted).
struct Normal {
  cv::Matx<double, 7, 7> JtJ = cv::Matx<double, 7, 7>::zeros();
  cv::Vec<double, 7> Jtr = cv::Vec<double, 7>::all(0.0);
  double rss = 0.0;
  int rows = 0;
  void add(double r, const double* j) {
    for (int a = 0; a < 7; ++a) {
      Jtr[a] += j[a] * r;
      for (int b = a; b < 7; ++b) JtJ(a, b) += j[a] * j[b];
    }
    rss += r * r;
    ++rows;
  }
  void symmetrise() {
    for (int a = 0; a < 7; ++a)
      for (int b = 0; b < a; ++b) JtJ(a, b) = JtJ(b, a);
  }
};

// The vertex fit: the 32 rectified vertex coordinates.
Normal linearise_vertices(const Placement& p, const StarOutline& l, const StarOutline& r, const StereoCalibration& c,
                          const std::array<cv::Point3d, 8>& model) {
  auto values = [&](const Placement& q, double* out) {
    const std::array<cv::Point2d, 16> v = corners(q, c, model);
    for (int i = 0; i < 16; ++i) {
      const cv::Point2d& o = i < 8 ? l.vertices[i] : r.vertices[i - 8];
      out[2 * i] = o.x - v[i].x;
      out[2 * i + 1] = o.y - v[i].y;
    }
  };
  double res[32], moved[32], jac[32][7];
  values(p, res);
  for (int j = 0; j < 7; ++j) {
    const double h = derivative_step(p, j);
    values(p.moved(unit(j, h)), moved);
    for (int i = 0; i < 32; ++i) jac[i][j] = -(moved[i] - res[i]) / h;  // of the prediction
  }
  Normal n;
  for (int i = 0; i < 32; ++i) n.add(res[i], jac[i]);
  n.symmetrise();
  return n;
}

// The edge fit: each edge point's distance to its projected star edge. The distance of q from line i is
// lᵢ·h with h = (qx, qy, −1), linear in h, so an edge's rows enter the normal equations only through its
// points' moment matrix Mᵢ = Σ h hᵀ: JᵀJ = Σᵢ Sᵢᵀ Mᵢ Sᵢ, Jᵀr = −Σᵢ Sᵢᵀ Mᵢ lᵢ, Σ r² = Σᵢ lᵢᵀ Mᵢ lᵢ with Sᵢ
// the line's derivatives (the same sums as row by row, in 16 terms instead of one per point).
Normal linearise_edges(const Placement& p, const StarOutline& l, const StarOutline& r, const StereoCalibration& c,
                       const std::array<cv::Point3d, 8>& model) {
  const std::array<cv::Vec3d, 16> lines = edge_lines(corners(p, c, model));
  std::array<std::array<cv::Vec3d, 16>, 7> slopes;
  for (int j = 0; j < 7; ++j) {
    const double h = derivative_step(p, j);
    const std::array<cv::Vec3d, 16> moved = edge_lines(corners(p.moved(unit(j, h)), c, model));
    for (int i = 0; i < 16; ++i) slopes[j][i] = (moved[i] - lines[i]) / h;
  }
  Normal n;
  for (int i = 0; i < 16; ++i) {
    const std::vector<cv::Point2f>& points = (i < 8 ? l : r).edges[i % 8];
    if (points.empty()) continue;
    cv::Matx33d M = cv::Matx33d::zeros();
    for (const cv::Point2f& q : points) {
      const cv::Vec3d h(q.x, q.y, -1.0);
      M += h * h.t();
    }
    std::array<cv::Vec3d, 7> MS;
    for (int a = 0; a < 7; ++a) MS[a] = M * slopes[a][i];
    const cv::Vec3d Ml = M * lines[i];
    for (int a = 0; a < 7; ++a) {
      n.Jtr[a] -= slopes[a][i].dot(Ml);
      for (int b = a; b < 7; ++b) n.JtJ(a, b) += slopes[a][i].dot(MS[b]);
    }
    n.rss += lines[i].dot(Ml);
    n.rows += static_cast<int>(points.size());
  }
  n.symmetrise();
  return n;
}

using Linearise = std::function<Normal(const Placement&)>;

// Gauss-Newton on the normal equations; returns them at the solution.
bool gauss_newton(Placement& p, const Linearise& linearise, Normal& n, int max_iterations = 10) {
  for (int iteration = 0; iteration < max_iterations; ++iteration) {
    n = linearise(p);
    cv::Vec<double, 7> step;
    if (!cv::solve(n.JtJ, n.Jtr, step, cv::DECOMP_CHOLESKY)) return false;
    p = p.moved(step);
    if (cv::norm(step) < 1e-8) break;  // radians, metres, log scale: far below the noise
  }
  n = linearise(p);
  return true;
}

// The placement a pose describes (its rotation and centre back in the rectified left frame).
Placement placement_of(const StarPose& pose, const StereoCalibration& calibration) {
  return Placement{calibration.R1 * pose.R_CS, calibration.R1 * pose.t_C, pose.size_ratio};
}

// The pose of an edge fit's solution, with its covariance: the edge points' error from the residuals,
// floored, times the inverse normal matrix. Leaves `pose` invalid when the fit is degenerate.
void finish_pose(const Placement& p, const Normal& n, const StereoCalibration& calibration,
                 const StarPoseSettings& settings, StarPose& pose) {
  if (n.rows <= 7 || !(p.t[2] > 0.0)) return;
  pose.edge_sigma_px = std::max(std::sqrt(n.rss / (n.rows - 7.0)), settings.min_edge_sigma_px);
  cv::Matx<double, 7, 7> normal_inverse;
  if (cv::invert(n.JtJ, normal_inverse, cv::DECOMP_CHOLESKY) == 0.0) return;
  const cv::Matx<double, 7, 7> cov = pose.edge_sigma_px * pose.edge_sigma_px * normal_inverse;
  const cv::Matx33d attitude = cov.get_minor<3, 3>(0, 0), position = cov.get_minor<3, 3>(3, 3);
  // The rectified left frame is the left camera frame rotated by R1.
  const cv::Matx33d R1t = calibration.R1.t();
  pose.R_CS = R1t * p.R;
  pose.t_C = R1t * p.t;
  pose.attitude_cov_C = R1t * attitude * R1t.t();
  pose.position_cov_C = R1t * position * R1t.t();
  pose.size_ratio = p.scale;
  pose.valid = true;
}

}  // namespace

StarPose estimate_star_pose(const std::vector<cv::Point2f>& left, const std::vector<cv::Point2f>& right,
                            const StereoCalibration& calibration, const StarPoseSettings& settings) {
  StarPose pose;
  StarOutline l, r;
  const std::array<cv::Point3d, 8> model = star_model(settings);
  Placement p;
  Normal n;
  // Vertices first (a good start from the triangulation), then every edge point. The polygon's vertices
  // are tried first; when their fit is too poor, the radius method's in either view: far off the axis the
  // star's image is sheared and stretched, and the polygon may put a vertex on a long tip's flank (on the
  // tuning split three stars beyond 45° fitted to 8–10 px with the polygons and to 2 px with the radii).
  double best_rms = std::numeric_limits<double>::infinity();
  for (int attempt = 0; attempt < 4 && !(best_rms <= settings.max_rms_px); ++attempt) {
    const bool left_by_radius = attempt & 1, right_by_radius = attempt & 2;
    StarOutline la, ra;
    Placement pa;
    Normal na;
    if (!matched_outlines(left, right, la, ra, left_by_radius, right_by_radius) ||
        !initial_placement(la, ra, calibration, model, pa)) {
      continue;
    }
    auto vertices = [&](const Placement& q) { return linearise_vertices(q, la, ra, calibration, model); };
    if (!gauss_newton(pa, vertices, na)) continue;
    const double rms = std::sqrt(na.rss / 32.0);
    if (rms < best_rms) {
      best_rms = rms;
      pose.left_vertices_by_radius = left_by_radius;
      pose.right_vertices_by_radius = right_by_radius;
      l = la;
      r = ra;
      p = pa;
      n = na;
    }
  }
  if (!std::isfinite(best_rms)) return pose;  // no outline of eight vertices in a view
  pose.rms_px = best_rms;
  if (!(pose.rms_px <= settings.max_rms_px) || !(p.t[2] > 0.0)) return pose;
  auto edges = [&](const Placement& q) { return linearise_edges(q, l, r, calibration, model); };
  if (!gauss_newton(p, edges, n)) return pose;
  // The planar star's twin: turned half a turn about the line of sight through its centre it projects to
  // nearly the same outline with its tilt mirrored, and far away the views' disparities barely tell the
  // two apart, so the vertex start may fall on either. The twin is fitted too; the better fit stays.
  Placement twin{rotation_from_vector(CV_PI * p.t / cv::norm(p.t)) * p.R, p.t, p.scale};
  Normal twin_normal;
  if (gauss_newton(twin, edges, twin_normal) && twin_normal.rows == n.rows && twin_normal.rss < n.rss) {
    p = twin;
    n = twin_normal;
  }
  finish_pose(p, n, calibration, settings, pose);
  return pose;
}

std::array<std::array<cv::Point2d, 8>, 2> projected_star(const StarPose& pose, const StereoCalibration& calibration,
                                                         const StarPoseSettings& settings) {
  const std::array<cv::Point2d, 16> v = corners(placement_of(pose, calibration), calibration, star_model(settings));
  std::array<std::array<cv::Point2d, 8>, 2> out;
  for (int i = 0; i < 16; ++i) out[i / 8][i % 8] = v[i];
  return out;
}

StarPose refit_star_pose(const StarPose& start, const StarEdgePoints& points, const StereoCalibration& calibration,
                         const StarPoseSettings& settings) {
  StarPose pose;
  pose.rms_px = start.rms_px;
  pose.left_vertices_by_radius = start.left_vertices_by_radius;
  pose.right_vertices_by_radius = start.right_vertices_by_radius;
  const std::array<cv::Point3d, 8> model = star_model(settings);
  StarOutline outlines[2];
  for (int view = 0; view < 2; ++view) outlines[view].edges = points[view];
  Placement p = placement_of(start, calibration);
  Normal n;
  auto edges = [&](const Placement& q) { return linearise_edges(q, outlines[0], outlines[1], calibration, model); };
  // The start is the contours' fit, a pixel or so off: Gauss-Newton is within the noise in three steps.
  constexpr int kIterations = 3;
  if (!gauss_newton(p, edges, n, kIterations) || n.rows <= 7) return pose;
  // The points' distances from their fitted edges; those beyond 3 robust σ (and half a pixel) go.
  const std::array<cv::Vec3d, 16> lines = edge_lines(corners(p, calibration, model));
  std::vector<double> distance;
  for (int i = 0; i < 16; ++i) {
    for (const cv::Point2f& q : outlines[i / 8].edges[i % 8]) distance.push_back(std::fabs(lines[i].dot(cv::Vec3d(q.x, q.y, -1.0))));
  }
  std::vector<double> sorted = distance;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double gate = std::max(3.0 * 1.4826 * sorted[sorted.size() / 2], 0.5);
  size_t index = 0;
  bool dropped = false;
  for (int i = 0; i < 16; ++i) {
    std::vector<cv::Point2f>& kept = outlines[i / 8].edges[i % 8];
    std::vector<cv::Point2f> all;
    all.swap(kept);
    for (const cv::Point2f& q : all) {
      if (distance[index++] <= gate) kept.push_back(q);
      else dropped = true;
    }
  }
  if (dropped && !gauss_newton(p, edges, n, kIterations)) return pose;
  finish_pose(p, n, calibration, settings, pose);
  return pose;
}

cv::Vec2d plane_disparity_gradient(const cv::Matx33d& R_CS, const cv::Vec3d& t_C, const StereoCalibration& calibration) {
  // On the plane n · X = c (rectified left frame) a pixel x (from the principal point) sees depth
  // Z = c f / (n · (x, y, f)), so its disparity f b / Z = b (n_x x + n_y y + n_z f) / c is affine in x, y.
  const cv::Vec3d n = calibration.R1 * cv::Vec3d(R_CS(0, 2), R_CS(1, 2), R_CS(2, 2));
  const double c = n.dot(calibration.R1 * t_C);
  const double b = calibration.baseline();
  return cv::Vec2d(b * n[0] / c, b * n[1] / c);
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
