#pragma once
/// Small plain-old-data vector and matrix types usable on host and device. Float everywhere
/// (as SLAMBench's KFusion), with double used only where the reference does (the ICP solve).

#include <cmath>

#include "core/platform.hpp"

namespace kfx {

/// 2-vector of floats.
struct Vec2f {
  float x, y;
};

/// 3-vector of floats (points in metres, normals, directions).
struct Vec3f {
  float x, y, z;
};

/// 3-vector of ints (voxel coordinates).
struct Vec3i {
  int x, y, z;
};

KFX_HD KFX_INLINE Vec3f make_vec3f(float x, float y, float z) { return Vec3f{x, y, z}; }
KFX_HD KFX_INLINE Vec3f operator+(Vec3f a, Vec3f b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
KFX_HD KFX_INLINE Vec3f operator-(Vec3f a, Vec3f b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
KFX_HD KFX_INLINE Vec3f operator-(Vec3f a) { return {-a.x, -a.y, -a.z}; }
KFX_HD KFX_INLINE Vec3f operator*(Vec3f a, float s) { return {a.x * s, a.y * s, a.z * s}; }
KFX_HD KFX_INLINE Vec3f operator*(float s, Vec3f a) { return {a.x * s, a.y * s, a.z * s}; }
KFX_HD KFX_INLINE Vec3f operator*(Vec3f a, Vec3f b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
KFX_HD KFX_INLINE Vec3f& operator+=(Vec3f& a, Vec3f b) {
  a.x += b.x;
  a.y += b.y;
  a.z += b.z;
  return a;
}
KFX_HD KFX_INLINE float dot(Vec3f a, Vec3f b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
KFX_HD KFX_INLINE Vec3f cross(Vec3f a, Vec3f b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
KFX_HD KFX_INLINE float length(Vec3f a) { return sqrtf(dot(a, a)); }
/// Unit vector along `a`; the caller guarantees a non-zero length.
KFX_HD KFX_INLINE Vec3f normalize(Vec3f a) { return a * (1.0f / sqrtf(dot(a, a))); }

/// Row-major 4×4 float matrix, used for rigid poses (last row 0 0 0 1) and camera matrices.
struct Mat4f {
  float m[4][4];

  /// The identity matrix.
  KFX_HD static Mat4f identity() {
    Mat4f r{};
    for (int i = 0; i < 4; ++i) r.m[i][i] = 1.0f;
    return r;
  }
  /// A pure translation by `t`.
  KFX_HD static Mat4f translation(Vec3f t) {
    Mat4f r = identity();
    r.m[0][3] = t.x;
    r.m[1][3] = t.y;
    r.m[2][3] = t.z;
    return r;
  }
  /// The translation column.
  KFX_HD Vec3f translation_part() const { return {m[0][3], m[1][3], m[2][3]}; }
};

/// Matrix product a·b.
KFX_HD KFX_INLINE Mat4f operator*(const Mat4f& a, const Mat4f& b) {
  Mat4f r;
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) {
      r.m[i][j] = a.m[i][0] * b.m[0][j] + a.m[i][1] * b.m[1][j] + a.m[i][2] * b.m[2][j] +
                  a.m[i][3] * b.m[3][j];
    }
  }
  return r;
}

/// Affine transform of a point: upper 3×4 of `a` times (p, 1).
KFX_HD KFX_INLINE Vec3f operator*(const Mat4f& a, Vec3f p) {
  return {a.m[0][0] * p.x + a.m[0][1] * p.y + a.m[0][2] * p.z + a.m[0][3],
          a.m[1][0] * p.x + a.m[1][1] * p.y + a.m[1][2] * p.z + a.m[1][3],
          a.m[2][0] * p.x + a.m[2][1] * p.y + a.m[2][2] * p.z + a.m[2][3]};
}

/// Linear part only: upper-left 3×3 of `a` times v (directions, normals).
KFX_HD KFX_INLINE Vec3f rotate(const Mat4f& a, Vec3f v) {
  return {a.m[0][0] * v.x + a.m[0][1] * v.y + a.m[0][2] * v.z,
          a.m[1][0] * v.x + a.m[1][1] * v.y + a.m[1][2] * v.z,
          a.m[2][0] * v.x + a.m[2][1] * v.y + a.m[2][2] * v.z};
}

/// Inverse of a rigid transform [R t; 0 1]: [Rᵀ −Rᵀt; 0 1].
KFX_HD KFX_INLINE Mat4f rigid_inverse(const Mat4f& a) {
  Mat4f r = Mat4f::identity();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) r.m[i][j] = a.m[j][i];
  }
  for (int i = 0; i < 3; ++i) {
    r.m[i][3] = -(r.m[i][0] * a.m[0][3] + r.m[i][1] * a.m[1][3] + r.m[i][2] * a.m[2][3]);
  }
  return r;
}

/// Float min/max. NOTE: the host versions are the plain comparisons, which compile to one
/// instruction; libm's fminf/fmaxf are out-of-line calls without -ffast-math. They differ from
/// fminf/fmaxf only for NaN inputs, which the kernels never pass.
KFX_HD KFX_INLINE float min_f(float a, float b) {
#if defined(__CUDA_ARCH__)
  return fminf(a, b);
#else
  return b < a ? b : a;
#endif
}
KFX_HD KFX_INLINE float max_f(float a, float b) {
#if defined(__CUDA_ARCH__)
  return fmaxf(a, b);
#else
  return a < b ? b : a;
#endif
}
KFX_HD KFX_INLINE float clampf(float v, float lo, float hi) { return min_f(max_f(v, lo), hi); }
KFX_HD KFX_INLINE int clampi(int v, int lo, int hi) { return v < lo ? lo : (v > hi ? hi : v); }
KFX_HD KFX_INLINE int mini(int a, int b) { return a < b ? a : b; }
KFX_HD KFX_INLINE int maxi(int a, int b) { return a > b ? a : b; }

}  // namespace kfx
