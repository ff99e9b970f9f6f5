#pragma once
/// @file
/// sample_affine_grid(): an image resampled in single precision on a rectangular grid of offsets
/// through an affine map (bilinear, with optional k x k anti-aliasing sub-samples per grid cell).
/// The windows of correlation matching (matching/correlation_matcher.hpp) are such grids: the
/// secondary image seen in the master geometry. Eigen and std only.
///
/// Conventions: pixels as in docs/conventions.md; the sample of offset o = (u, v) lies at
/// c + m o, with o in grid units (master pixels for correlation matching).

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <type_traits>
#include <cstdlib>
#include <string>
#include <vector>

#if defined(__GNUC__) && defined(__x86_64__) && !defined(DIACHRON_NO_RUNTIME_SIMD)
#include <immintrin.h>
#endif

#include <Eigen/Core>

#include <diachron/core/raster.hpp>

namespace diachron {

/// The reused buffers of sample_affine_grid (one per thread; allocated once, grown as needed).
struct AffineGridScratch {
  std::vector<double> col_x, col_y, row_x, row_y;  // m times each fine column's / row's offset
  std::vector<float> rel_x, rel_y;                  // a fine column's position from the grid's corner
  std::vector<float> fx, fy, v00, v10, v01, v11;    // one fine row: fractions and corner values
  std::vector<std::int32_t> i00, i10, i01, i11;     // the same corner values, integer pixels
  std::vector<std::int32_t> at;                     // one fine row: index of each top-left corner
  std::vector<float> fine;                          // one fine row's samples (k > 1)
  std::vector<float> line;                          // one grid row's sums of sub-samples
  bool gather = false;                              // the AVX2 gathers may serve the current grid
};

/// Samples `img` at c + m o for the offsets o = (first_x + i, first_y + j), 0 <= i < cols,
/// 0 <= j < rows, into out[j * stride + i] (float). With k > 1 each sample is the mean of k x k
/// bilinear sub-samples at o + ((sx + 0.5) / k - 0.5, (sy + 0.5) / k - 0.5), 0 <= sx, sy < k, which
/// spread over the grid cell: the low-pass filter of a secondary image finer than the grid.
///
/// The positions are computed in double precision as c + (m o_column + m o_row), the two products
/// taken once per column and row; the interpolation is in single precision (an 8-bit image's values
/// are exact in float, and a bilinear sample is off the double one by at most ~1e-5 grey levels).
/// A position on or between the outer pixel centres ([0, width - 1] x [0, height - 1]) is the
/// bilinear interpolation of its cell; a position outside is clamped to that range (its value is
/// that of the nearest border point: callers that need true values check the extent first).
///
/// Precondition: img at least 2 x 2, cols, rows, k >= 1, stride >= cols, out holds
/// (rows - 1) * stride + cols floats. Not checked (hot loop); correlation matching checks its
/// inputs before.
/// @tparam T an arithmetic pixel type.
template <class T>
void sample_affine_grid(const Raster<T>& img, const Eigen::Vector2d& c, const Eigen::Matrix2d& m, int first_x,
                        int first_y, int cols, int rows, int k, float* out, std::size_t stride,
                        AffineGridScratch& scratch);

// Implementation ---------------------------------------------------------------------------------

namespace detail {

// Bilinear value at (x, y), clamped to the outer pixel centres, in single precision.
template <class T>
inline float affine_grid_bilinear(const T* data, int width, int height, double x, double y) {
  x = std::min(std::max(x, 0.0), static_cast<double>(width - 1));
  y = std::min(std::max(y, 0.0), static_cast<double>(height - 1));
  const int x0 = std::min(static_cast<int>(x), width - 2);
  const int y0 = std::min(static_cast<int>(y), height - 2);
  const float fx = static_cast<float>(x - x0), fy = static_cast<float>(y - y0);
  const T* r0 = data + static_cast<std::size_t>(y0) * static_cast<std::size_t>(width) + x0;
  const T* r1 = r0 + width;
  const float v00 = static_cast<float>(r0[0]), v10 = static_cast<float>(r0[1]);
  const float v01 = static_cast<float>(r1[0]), v11 = static_cast<float>(r1[1]);
  const float top = v00 + fx * (v10 - v00);
  const float bottom = v01 + fx * (v11 - v01);
  return top + fy * (bottom - top);
}

}  // namespace detail

namespace detail {

#if defined(__GNUC__) && defined(__x86_64__) && !defined(DIACHRON_NO_RUNTIME_SIMD)
#define DIACHRON_RUNTIME_AVX2 1
#endif

// Whether the loops with an AVX2 twin may use it: the compiler can target it (GCC or Clang on
// x86-64, unless DIACHRON_NO_RUNTIME_SIMD is defined), the processor and the system have it, and
// DIACHRON_CORRELATION_SIMD=portable is not set in the environment (for comparisons). The twins
// multiply and add only, never fuse the two, so their results are bitwise those of the portable
// loops: the choice changes the speed, not the output.
inline bool runtime_avx2() {
#ifdef DIACHRON_RUNTIME_AVX2
  static const bool usable = [] {
    const char* forced = std::getenv("DIACHRON_CORRELATION_SIMD");
    if (forced && std::string(forced) == "portable") return false;
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2") != 0;
  }();
  return usable;
#else
  return false;
#endif
}

#ifdef DIACHRON_RUNTIME_AVX2
// affine_grid_row_inside for 8-bit images, eight samples at a time with AVX2 gathers: one 32-bit
// load per sample and row brings both horizontal neighbours. It reads up to two bytes right of
// the bottom-right neighbour, so the caller uses it only when the grid keeps them inside the image.
// The same operations as the portable loop in the same order (no fused multiply-add).
__attribute__((target("avx2"))) inline void affine_grid_row_u8_avx2(const std::uint8_t* origin, int width,
                                                                    std::int32_t max_x, std::int32_t max_y,
                                                                    const float* px, const float* py, float rx,
                                                                    float ry, std::size_t n, float* out) {
  const __m256 vrx = _mm256_set1_ps(rx), vry = _mm256_set1_ps(ry);
  const __m256i vmax_x = _mm256_set1_epi32(max_x), vmax_y = _mm256_set1_epi32(max_y);
  const __m256i vwidth = _mm256_set1_epi32(width), byte = _mm256_set1_epi32(0xFF);
  const int* top_row = reinterpret_cast<const int*>(origin);
  const int* bottom_row = reinterpret_cast<const int*>(origin + width);
  std::size_t q = 0;
  for (; q + 8 <= n; q += 8) {
    const __m256 x = _mm256_add_ps(_mm256_loadu_ps(px + q), vrx);
    const __m256 y = _mm256_add_ps(_mm256_loadu_ps(py + q), vry);
    const __m256i ix = _mm256_min_epi32(_mm256_cvttps_epi32(x), vmax_x);
    const __m256i iy = _mm256_min_epi32(_mm256_cvttps_epi32(y), vmax_y);
    const __m256 fx = _mm256_sub_ps(x, _mm256_cvtepi32_ps(ix));
    const __m256 fy = _mm256_sub_ps(y, _mm256_cvtepi32_ps(iy));
    const __m256i at = _mm256_add_epi32(_mm256_mullo_epi32(iy, vwidth), ix);
    const __m256i top = _mm256_i32gather_epi32(top_row, at, 1);
    const __m256i bottom = _mm256_i32gather_epi32(bottom_row, at, 1);
    const __m256 v00 = _mm256_cvtepi32_ps(_mm256_and_si256(top, byte));
    const __m256 v10 = _mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srli_epi32(top, 8), byte));
    const __m256 v01 = _mm256_cvtepi32_ps(_mm256_and_si256(bottom, byte));
    const __m256 v11 = _mm256_cvtepi32_ps(_mm256_and_si256(_mm256_srli_epi32(bottom, 8), byte));
    const __m256 upper = _mm256_add_ps(v00, _mm256_mul_ps(fx, _mm256_sub_ps(v10, v00)));
    const __m256 lower = _mm256_add_ps(v01, _mm256_mul_ps(fx, _mm256_sub_ps(v11, v01)));
    _mm256_storeu_ps(out + q, _mm256_add_ps(upper, _mm256_mul_ps(fy, _mm256_sub_ps(lower, upper))));
  }
  for (; q < n; ++q) {
    const float x = px[q] + rx, y = py[q] + ry;
    const std::int32_t ix = std::min(static_cast<std::int32_t>(x), max_x);
    const std::int32_t iy = std::min(static_cast<std::int32_t>(y), max_y);
    const float fx = x - static_cast<float>(ix), fy = y - static_cast<float>(iy);
    const std::uint8_t* p = origin + static_cast<std::ptrdiff_t>(iy) * width + ix;
    const float a = p[0], b = p[1], c = p[width], d = p[width + 1];
    const float upper = a + fx * (b - a);
    const float lower = c + fx * (d - c);
    out[q] = upper + fy * (lower - upper);
  }
}
#endif

// One fine row of samples, every position inside [0, width - 1] x [0, height - 1]: the positions
// relative to the integer corner (ox, oy) are floats (within 2^-16 px of the double ones for grids
// under 256 px), so that the compiler turns the arithmetic into SIMD; only the four corner loads
// of each sample are scalar.
template <class T>
void affine_grid_row_inside(const T* data, int width, int height, int ox, int oy, float rx, float ry,
                            std::size_t n, AffineGridScratch& s, float* out) {
  const float* px = s.rel_x.data();
  const float* py = s.rel_y.data();
#ifdef DIACHRON_RUNTIME_AVX2
  if constexpr (std::is_same_v<T, std::uint8_t>) {
    if (s.gather) {
      affine_grid_row_u8_avx2(data + static_cast<std::ptrdiff_t>(oy) * width + ox, width, width - 2 - ox,
                              height - 2 - oy, px, py, rx, ry, n, out);
      return;
    }
  }
#endif
  float* fx = s.fx.data();
  float* fy = s.fy.data();
  std::int32_t* at = s.at.data();
  const std::int32_t max_x = width - 2 - ox, max_y = height - 2 - oy;
  for (std::size_t q = 0; q < n; ++q) {
    const float x = px[q] + rx, y = py[q] + ry;
    const std::int32_t ix = std::min(static_cast<std::int32_t>(x), max_x);
    const std::int32_t iy = std::min(static_cast<std::int32_t>(y), max_y);
    fx[q] = x - static_cast<float>(ix);
    fy[q] = y - static_cast<float>(iy);
    at[q] = iy * width + ix;
  }
  const T* origin = data + static_cast<std::ptrdiff_t>(oy) * width + ox;
  // Small integer pixels are gathered as int32 and converted four at a time afterwards.
  using Corner = std::conditional_t<std::is_integral_v<T> && sizeof(T) <= 2, std::int32_t, float>;
  Corner* v00;
  Corner* v10;
  Corner* v01;
  Corner* v11;
  if constexpr (std::is_same_v<Corner, float>) {
    v00 = s.v00.data();
    v10 = s.v10.data();
    v01 = s.v01.data();
    v11 = s.v11.data();
  } else {
    v00 = s.i00.data();
    v10 = s.i10.data();
    v01 = s.i01.data();
    v11 = s.i11.data();
  }
  for (std::size_t q = 0; q < n; ++q) {
    const T* p = origin + at[q];
    v00[q] = static_cast<Corner>(p[0]);
    v10[q] = static_cast<Corner>(p[1]);
    v01[q] = static_cast<Corner>(p[width]);
    v11[q] = static_cast<Corner>(p[width + 1]);
  }
  for (std::size_t q = 0; q < n; ++q) {
    const float a = static_cast<float>(v00[q]), b = static_cast<float>(v10[q]);
    const float c = static_cast<float>(v01[q]), d = static_cast<float>(v11[q]);
    const float top = a + fx[q] * (b - a);
    const float bottom = c + fx[q] * (d - c);
    out[q] = top + fy[q] * (bottom - top);
  }
}

// line[i] += the sum of fine[i K .. i K + K - 1], in that order (a fixed K lets the compiler
// vectorise the strided loads).
template <int K>
inline void affine_grid_add_cells_fixed(const float* fine, int cols, float* line) {
  for (int i = 0; i < cols; ++i) {
    float sum = fine[static_cast<std::size_t>(i) * K];
    for (int sx = 1; sx < K; ++sx) sum += fine[static_cast<std::size_t>(i) * K + static_cast<std::size_t>(sx)];
    line[i] += sum;
  }
}

inline void affine_grid_add_cells(const float* fine, int cols, int k, float* line) {
  switch (k) {
    case 2: affine_grid_add_cells_fixed<2>(fine, cols, line); return;
    case 3: affine_grid_add_cells_fixed<3>(fine, cols, line); return;
    case 4: affine_grid_add_cells_fixed<4>(fine, cols, line); return;
    default:
      for (int i = 0; i < cols; ++i) {
        float sum = fine[static_cast<std::size_t>(i) * static_cast<std::size_t>(k)];
        for (int sx = 1; sx < k; ++sx)
          sum += fine[static_cast<std::size_t>(i) * static_cast<std::size_t>(k) + static_cast<std::size_t>(sx)];
        line[i] += sum;
      }
  }
}

}  // namespace detail

template <class T>
void sample_affine_grid(const Raster<T>& img, const Eigen::Vector2d& c, const Eigen::Matrix2d& m, int first_x,
                        int first_y, int cols, int rows, int k, float* out, std::size_t stride,
                        AffineGridScratch& scratch) {
  static_assert(std::is_arithmetic_v<T>, "sample_affine_grid: the pixel type must be arithmetic");
  const std::size_t fine_cols = static_cast<std::size_t>(cols) * static_cast<std::size_t>(k);
  const std::size_t fine_rows = static_cast<std::size_t>(rows) * static_cast<std::size_t>(k);
  scratch.col_x.resize(fine_cols);
  scratch.col_y.resize(fine_cols);
  scratch.row_x.resize(fine_rows);
  scratch.row_y.resize(fine_rows);
  scratch.line.resize(static_cast<std::size_t>(cols));
  const double sub0 = 0.5 / k - 0.5, sub_step = 1.0 / k;
  for (std::size_t q = 0; q < fine_cols; ++q) {
    const double o = first_x + static_cast<int>(q / static_cast<std::size_t>(k)) +
                     (sub0 + sub_step * static_cast<double>(q % static_cast<std::size_t>(k)));
    scratch.col_x[q] = c.x() + m(0, 0) * o;
    scratch.col_y[q] = c.y() + m(1, 0) * o;
  }
  for (std::size_t q = 0; q < fine_rows; ++q) {
    const double o = first_y + static_cast<int>(q / static_cast<std::size_t>(k)) +
                     (sub0 + sub_step * static_cast<double>(q % static_cast<std::size_t>(k)));
    scratch.row_x[q] = m(0, 1) * o;
    scratch.row_y[q] = m(1, 1) * o;
  }
  const T* data = img.data();
  const int width = img.width(), height = img.height();
  // The positions are sums of a column's and a row's term, each linear in its index: their extremes
  // are at the ends.
  const auto lo = [](const std::vector<double>& v) { return std::min(v.front(), v.back()); };
  const auto hi = [](const std::vector<double>& v) { return std::max(v.front(), v.back()); };
  const double min_x = lo(scratch.col_x) + lo(scratch.row_x), max_x = hi(scratch.col_x) + hi(scratch.row_x);
  const double min_y = lo(scratch.col_y) + lo(scratch.row_y), max_y = hi(scratch.col_y) + hi(scratch.row_y);
  // Inside, with relative positions below 4096 px (float steps of 2^-12 px at most).
  const bool inside = min_x >= 0.0 && min_y >= 0.0 && max_x <= width - 1 && max_y <= height - 1 &&
                      max_x - min_x < 4096.0 && max_y - min_y < 4096.0;
  float* line = scratch.line.data();
  const float norm = 1.0f / static_cast<float>(k * k);
  if (inside) {
    const int ox = static_cast<int>(min_x), oy = static_cast<int>(min_y);
    // The gathers read two bytes beyond a sample's right neighbours: inside the image unless the
    // grid reaches both the last two columns and the last row.
    scratch.gather = detail::runtime_avx2() && (max_y < height - 2 || max_x < width - 3);
    scratch.rel_x.resize(fine_cols);
    scratch.rel_y.resize(fine_cols);
    for (std::size_t q = 0; q < fine_cols; ++q) {
      scratch.rel_x[q] = static_cast<float>(scratch.col_x[q] - ox);
      scratch.rel_y[q] = static_cast<float>(scratch.col_y[q] - oy);
    }
    for (std::vector<float>* v :
         {&scratch.fx, &scratch.fy, &scratch.v00, &scratch.v10, &scratch.v01, &scratch.v11, &scratch.fine})
      v->resize(fine_cols);
    for (std::vector<std::int32_t>* v : {&scratch.at, &scratch.i00, &scratch.i10, &scratch.i01, &scratch.i11})
      v->resize(fine_cols);
    for (int j = 0; j < rows; ++j) {
      float* o = out + static_cast<std::size_t>(j) * stride;
      if (k == 1) {
        detail::affine_grid_row_inside(data, width, height, ox, oy, static_cast<float>(scratch.row_x[static_cast<std::size_t>(j)]),
                                       static_cast<float>(scratch.row_y[static_cast<std::size_t>(j)]), fine_cols, scratch, o);
        continue;
      }
      std::fill(line, line + cols, 0.0f);
      for (int sy = 0; sy < k; ++sy) {
        const std::size_t qy = static_cast<std::size_t>(j) * static_cast<std::size_t>(k) + static_cast<std::size_t>(sy);
        detail::affine_grid_row_inside(data, width, height, ox, oy, static_cast<float>(scratch.row_x[qy]),
                                       static_cast<float>(scratch.row_y[qy]), fine_cols, scratch, scratch.fine.data());
        detail::affine_grid_add_cells(scratch.fine.data(), cols, k, line);
      }
      for (int i = 0; i < cols; ++i) o[i] = line[i] * norm;
    }
    return;
  }
  const double* col_x = scratch.col_x.data();
  const double* col_y = scratch.col_y.data();
  if (k == 1) {
    for (int j = 0; j < rows; ++j) {
      const double rx = scratch.row_x[static_cast<std::size_t>(j)], ry = scratch.row_y[static_cast<std::size_t>(j)];
      float* o = out + static_cast<std::size_t>(j) * stride;
      for (int i = 0; i < cols; ++i) o[i] = detail::affine_grid_bilinear(data, width, height, col_x[i] + rx, col_y[i] + ry);
    }
    return;
  }
  for (int j = 0; j < rows; ++j) {
    std::fill(line, line + cols, 0.0f);
    for (int sy = 0; sy < k; ++sy) {
      const std::size_t qy = static_cast<std::size_t>(j) * static_cast<std::size_t>(k) + static_cast<std::size_t>(sy);
      const double rx = scratch.row_x[qy], ry = scratch.row_y[qy];
      std::size_t q = 0;
      for (int i = 0; i < cols; ++i) {
        float sum = 0.0f;
        for (int sx = 0; sx < k; ++sx, ++q) sum += detail::affine_grid_bilinear(data, width, height, col_x[q] + rx, col_y[q] + ry);
        line[i] += sum;
      }
    }
    float* o = out + static_cast<std::size_t>(j) * stride;
    for (int i = 0; i < cols; ++i) o[i] = line[i] * norm;
  }
}

}  // namespace diachron
