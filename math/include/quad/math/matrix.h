// Small fixed-size matrices for the filters (2x2 covariance of the per-axis Kalman filter, 4x4 and
// the like). Storage is a plain array: no heap, sizes known at compile time.
#pragma once

#include "quad/math/scalar.h"

namespace quad {

template <int R, int C>
struct Matrix {
  static_assert(R > 0 && C > 0, "matrix dimensions must be positive");
  float a[R][C] = {};

  float& operator()(int r, int c) { return a[r][c]; }
  float operator()(int r, int c) const { return a[r][c]; }

  static Matrix zero() { return Matrix{}; }
  static Matrix identity() {
    static_assert(R == C, "identity needs a square matrix");
    Matrix m;
    for (int i = 0; i < R; ++i) m.a[i][i] = 1.0f;
    return m;
  }
};

template <int R, int C>
Matrix<R, C> operator+(const Matrix<R, C>& x, const Matrix<R, C>& y) {
  Matrix<R, C> r;
  for (int i = 0; i < R; ++i)
    for (int j = 0; j < C; ++j) r.a[i][j] = x.a[i][j] + y.a[i][j];
  return r;
}

template <int R, int C>
Matrix<R, C> operator-(const Matrix<R, C>& x, const Matrix<R, C>& y) {
  Matrix<R, C> r;
  for (int i = 0; i < R; ++i)
    for (int j = 0; j < C; ++j) r.a[i][j] = x.a[i][j] - y.a[i][j];
  return r;
}

template <int R, int C>
Matrix<R, C> operator*(const Matrix<R, C>& x, float s) {
  Matrix<R, C> r;
  for (int i = 0; i < R; ++i)
    for (int j = 0; j < C; ++j) r.a[i][j] = x.a[i][j] * s;
  return r;
}

template <int R, int K, int C>
Matrix<R, C> operator*(const Matrix<R, K>& x, const Matrix<K, C>& y) {
  Matrix<R, C> r;
  for (int i = 0; i < R; ++i)
    for (int j = 0; j < C; ++j) {
      float s = 0.0f;
      for (int k = 0; k < K; ++k) s += x.a[i][k] * y.a[k][j];
      r.a[i][j] = s;
    }
  return r;
}

template <int R, int C>
Matrix<C, R> transpose(const Matrix<R, C>& x) {
  Matrix<C, R> r;
  for (int i = 0; i < R; ++i)
    for (int j = 0; j < C; ++j) r.a[j][i] = x.a[i][j];
  return r;
}

template <int R, int C>
bool is_finite(const Matrix<R, C>& x) {
  for (int i = 0; i < R; ++i)
    for (int j = 0; j < C; ++j)
      if (!is_finite(x.a[i][j])) return false;
  return true;
}

// Symmetrise in place: (P + P^T)/2, to stop round-off from breaking a covariance's symmetry.
template <int N>
void symmetrize(Matrix<N, N>& p) {
  for (int i = 0; i < N; ++i)
    for (int j = i + 1; j < N; ++j) {
      const float m = 0.5f * (p.a[i][j] + p.a[j][i]);
      p.a[i][j] = m;
      p.a[j][i] = m;
    }
}

using Mat2 = Matrix<2, 2>;
using Vec2 = Matrix<2, 1>;

// Closed-form 2x2 inverse; returns false (and leaves `out` untouched) when the matrix is singular.
inline bool inverse(const Mat2& m, Mat2& out) {
  const float det = m.a[0][0] * m.a[1][1] - m.a[0][1] * m.a[1][0];
  if (!(absf(det) > 1e-30f) || !is_finite(det)) return false;
  const float inv = 1.0f / det;
  out.a[0][0] = m.a[1][1] * inv;
  out.a[0][1] = -m.a[0][1] * inv;
  out.a[1][0] = -m.a[1][0] * inv;
  out.a[1][1] = m.a[0][0] * inv;
  return true;
}

}  // namespace quad
