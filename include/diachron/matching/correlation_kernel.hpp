#pragma once
/// @file
/// The arithmetic of a correlation surface in single precision: the measure's channels of a resampled
/// patch (CorrelationMeasure), a master window made zero-mean (CorrelationTemplate), a secondary
/// patch's channels with their integral images (CorrelationChannels), and the zero-mean normalised
/// correlation of the window with every window of the patch at integer shifts
/// (correlation_scores). matching/correlation_matcher.hpp composes them with the resampling of
/// matching/window_sampler.hpp; docs/correlation-matching.md ("Speed"). Eigen and std only.
///
/// Precision: the channels and the products are single precision, every row of products is summed
/// in float and the rows in double; the window sums and sums of squares come from integral images in
/// double over channels centred on their patch mean. A score is within ~1e-6 of the same formula in
/// double precision on 8-bit images (3.4e-7 on correlation_bench; the tests hold it to 1e-4). The
/// loops are plain C++ over contiguous arrays that the compiler turns into SIMD at the build's
/// baseline (SSE2 on x86-64); with GCC or Clang on x86-64 the cross term also has an AVX2 twin
/// chosen at run time (detail::runtime_avx2). Every score is the sum of the same terms in the same
/// order whatever the vector width, without fused multiply-adds, so the results depend neither on
/// it nor on the threads.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include <Eigen/Core>

#include <diachron/matching/window_sampler.hpp>  // detail::runtime_avx2

namespace diachron {

/// The similarity the correlation surface measures. All are zero-mean normalised correlations in
/// [-1, 1] over one or two channels computed on the resampled windows (master geometry).
enum class CorrelationMeasure : std::uint8_t {
  intensity,    ///< grey values (classic NCC): invariant to gain and offset
  gradient,     ///< the gradient vector (gx, gy): also ignores slow illumination ramps
  orientation,  ///< the doubled-angle gradient |g| (cos 2t, sin 2t): invariant to contrast inversion
                ///< (g and -g give the same vector), weighted by the gradient magnitude
};

/// "intensity", "gradient" or "orientation".
inline const char* to_string(CorrelationMeasure m) {
  return m == CorrelationMeasure::intensity ? "intensity"
         : m == CorrelationMeasure::gradient ? "gradient"
                                              : "orientation";
}

/// Shifts correlated side by side in correlation_scores (the lanes of its accumulators). A
/// CorrelationChannels row holds this many floats of zero padding after its columns.
constexpr int kCorrelationLanes = 16;

/// The channels of a secondary patch, each centred on its mean over the patch, with integral images
/// (double) of them and of their squares. Rows of `stride` floats: `cols` values, then zeros.
struct CorrelationChannels {
  int cols = 0, rows = 0, channels = 1;
  std::size_t stride = 0;
  std::vector<float> data[2];
  std::vector<double> sum[2], sum2[2];  ///< (rows + 1) x (cols + 1), a leading row and column of zeros
  std::vector<float> work;              ///< scratch of the orientation channels
};

/// A master window's channels, zero-mean, w x w row-major, and the sum of their squares.
struct CorrelationTemplate {
  int side = 0, channels = 1;
  std::vector<float> data[2];
  std::vector<float> work;
  double var = 0.0;    ///< sum over channels and pixels of the zero-mean values squared
  bool flat = true;    ///< no variance (var at most 1e-12 of the raw sum of squares, or 0)
};

/// The channels of `measure` on the inner (cols - 2) x (rows - 2) samples of a patch of cols x rows
/// floats (row j at patch + j * stride; the gradients are central differences, hence the 1 px
/// margin), centred on their means, with their integral images. Precondition: cols, rows >= 3.
inline void correlation_channels(CorrelationMeasure measure, const float* patch, int cols, int rows,
                                 std::size_t stride, CorrelationChannels& out);

/// The same for a master window: patch of (side + 2)^2 floats, channels made zero-mean over the
/// side x side window, their variance, and whether the window is flat.
inline void correlation_template(CorrelationMeasure measure, const float* patch, int side, std::size_t stride,
                                 CorrelationTemplate& out);

/// The zero-mean normalised correlation of `t` with the windows of `s` whose top-left corner is at
/// (x0 + dx, y0 + dy), 0 <= dx < nx, 0 <= dy < ny: surface(dy, dx), in [-1, 1], NaN where the
/// secondary window is flat (variance at most 1e-12 of its sum of squares). `cross` is a reused
/// buffer. Precondition: t not flat, t.channels == s.channels, x0 + nx - 1 + t.side <= s.cols,
/// y0 + ny - 1 + t.side <= s.rows, x0, y0 >= 0.
inline void correlation_scores(const CorrelationTemplate& t, const CorrelationChannels& s, int x0, int y0, int nx,
                               int ny, Eigen::MatrixXd& surface, std::vector<double>& cross);

// Implementation ---------------------------------------------------------------------------------

namespace detail {

// Channels of the inner samples of a patch into c0 (and c1), rows of out_stride floats.
inline int correlation_measure_channels(CorrelationMeasure measure, const float* patch, int cols, int rows,
                                        std::size_t stride, float* c0, float* c1, std::size_t out_stride,
                                        std::vector<float>& work) {
  const int inner_cols = cols - 2, inner_rows = rows - 2;
  for (int y = 0; y < inner_rows; ++y) {
    const float* up = patch + static_cast<std::size_t>(y) * stride + 1;
    const float* mid = up + stride;
    const float* down = mid + stride;
    float* o0 = c0 + static_cast<std::size_t>(y) * out_stride;
    if (measure == CorrelationMeasure::intensity) {
      std::copy(mid, mid + inner_cols, o0);
      continue;
    }
    float* o1 = c1 + static_cast<std::size_t>(y) * out_stride;
    for (int x = 0; x < inner_cols; ++x) {
      o0[x] = 0.5f * (mid[x + 1] - mid[x - 1]);
      o1[x] = 0.5f * (down[x] - up[x]);
    }
  }
  if (measure == CorrelationMeasure::intensity) return 1;
  if (measure == CorrelationMeasure::orientation) {
    // |g| (cos 2t, sin 2t) = ((gx^2 - gy^2), 2 gx gy) / |g|: the same for g and -g. Row by row, with
    // Eigen's SIMD square root (IEEE, so the same whatever the vector width).
    const Eigen::Index n = inner_cols;
    work.resize(2 * static_cast<std::size_t>(n));
    Eigen::Map<Eigen::ArrayXf> inv(work.data(), n), cross(work.data() + n, n);
    for (int y = 0; y < inner_rows; ++y) {
      Eigen::Map<Eigen::ArrayXf> gx(c0 + static_cast<std::size_t>(y) * out_stride, n);
      Eigen::Map<Eigen::ArrayXf> gy(c1 + static_cast<std::size_t>(y) * out_stride, n);
      inv = (gx.square() + gy.square()).sqrt();
      inv = (inv > 0.0f).select(inv.inverse(), 0.0f);
      cross = 2.0f * gx * gy * inv;
      gx = (gx.square() - gy.square()) * inv;
      gy = cross;
    }
  }
  return 2;
}

}  // namespace detail

inline void correlation_channels(CorrelationMeasure measure, const float* patch, int cols, int rows,
                                 std::size_t stride, CorrelationChannels& out) {
  const int inner_cols = cols - 2, inner_rows = rows - 2;
  out.cols = inner_cols;
  out.rows = inner_rows;
  out.stride = static_cast<std::size_t>(inner_cols) + kCorrelationLanes;
  const std::size_t n = out.stride * static_cast<std::size_t>(inner_rows);
  // The channels fill every row's first cols floats; the padding after them must be zero.
  for (int c = 0; c < (measure == CorrelationMeasure::intensity ? 1 : 2); ++c) {
    out.data[c].resize(n);
    for (int y = 0; y < inner_rows; ++y)
      std::fill_n(out.data[c].data() + static_cast<std::size_t>(y) * out.stride + inner_cols, kCorrelationLanes, 0.0f);
  }
  out.channels = detail::correlation_measure_channels(measure, patch, cols, rows, stride, out.data[0].data(),
                                                      out.data[1].data(), out.stride, out.work);
  const std::size_t s1 = static_cast<std::size_t>(inner_cols) + 1;
  const double count = static_cast<double>(inner_cols) * static_cast<double>(inner_rows);
  for (int c = 0; c < out.channels; ++c) {
    float* d = out.data[c].data();
    // Centred on the patch mean: smaller values, smaller rounding of the float products.
    double mean = 0.0;
    for (int y = 0; y < inner_rows; ++y) {
      const float* row = d + static_cast<std::size_t>(y) * out.stride;
      double r = 0.0;
      for (int x = 0; x < inner_cols; ++x) r += row[x];
      mean += r;
    }
    const float m = static_cast<float>(mean / count);
    std::vector<double>& sum = out.sum[c];
    std::vector<double>& sum2 = out.sum2[c];
    sum.assign(s1 * (static_cast<std::size_t>(inner_rows) + 1), 0.0);
    sum2.assign(sum.size(), 0.0);
    for (int y = 0; y < inner_rows; ++y) {
      float* row = d + static_cast<std::size_t>(y) * out.stride;
      double r = 0.0, r2 = 0.0;
      const double* above = sum.data() + static_cast<std::size_t>(y) * s1;
      const double* above2 = sum2.data() + static_cast<std::size_t>(y) * s1;
      double* here = sum.data() + static_cast<std::size_t>(y + 1) * s1;
      double* here2 = sum2.data() + static_cast<std::size_t>(y + 1) * s1;
      for (int x = 0; x < inner_cols; ++x) {
        row[x] -= m;
        const double v = row[x];
        r += v;
        r2 += v * v;
        here[x + 1] = above[x + 1] + r;
        here2[x + 1] = above2[x + 1] + r2;
      }
    }
  }
}

inline void correlation_template(CorrelationMeasure measure, const float* patch, int side, std::size_t stride,
                                 CorrelationTemplate& out) {
  out.side = side;
  const std::size_t n = static_cast<std::size_t>(side) * static_cast<std::size_t>(side);
  out.data[0].resize(n);
  if (measure != CorrelationMeasure::intensity) out.data[1].resize(n);
  out.channels = detail::correlation_measure_channels(measure, patch, side + 2, side + 2, stride, out.data[0].data(),
                                                      out.data[1].data(), static_cast<std::size_t>(side), out.work);
  double var = 0.0, scale = 0.0;
  for (int c = 0; c < out.channels; ++c) {
    float* d = out.data[c].data();
    double mean = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      mean += d[i];
      scale += static_cast<double>(d[i]) * d[i];
    }
    const float m = static_cast<float>(mean / static_cast<double>(n));
    for (std::size_t i = 0; i < n; ++i) {
      d[i] -= m;
      var += static_cast<double>(d[i]) * d[i];
    }
  }
  out.var = var;
  // Rounding of a constant window leaves a tiny relative variance: that is flat, not texture.
  out.flat = !(var > 1e-12 * std::max(1.0, scale)) || !std::isfinite(var);
}

namespace detail {

// The cross terms of one row of shifts: cross[dx] += sum over channels c, window rows j and columns
// i of m_c[j][i] * s_c[dy + j][dx + i], lane by lane in blocks of kCorrelationLanes shifts. Each
// window row's products are summed in float in the order of i, the rows in double in the order of
// (c, j): the same operations on every lane whatever the vector width.
using CorrelationCrossRow = void (*)(const CorrelationTemplate& t, const CorrelationChannels& s, int x0, int y, int blocks,
                                     double* cross);

inline void correlation_cross_row_portable(const CorrelationTemplate& t, const CorrelationChannels& s, int x0, int y,
                                           int blocks, double* cross) {
  constexpr int L = kCorrelationLanes;
  // Eigen's fixed-size arrays are its SIMD packets (SSE2: four of four floats), one multiply and one
  // add per packet and pixel. Two window rows at a time, each with its own sums: independent
  // additions keep the adder busy where one sum would wait on its previous addition.
  using Lanes = Eigen::Array<float, L, 1>;
  const int w = t.side;
  for (int c = 0; c < t.channels; ++c) {
    const float* m = t.data[c].data();
    const float* base = s.data[c].data() + static_cast<std::size_t>(y) * s.stride + x0;
    for (int b = 0; b < blocks; ++b) {
      double* out = cross + static_cast<std::size_t>(b) * L;
      int j = 0;
      for (; j + 2 <= w; j += 2) {
        const float* m0 = m + static_cast<std::size_t>(j) * static_cast<std::size_t>(w);
        const float* m1 = m0 + w;
        const float* s0 = base + static_cast<std::size_t>(j) * s.stride + b * L;
        const float* s1 = s0 + s.stride;
        Lanes acc0 = Lanes::Zero(), acc1 = Lanes::Zero();
        for (int i = 0; i < w; ++i) {
          acc0 += m0[i] * Eigen::Map<const Lanes>(s0 + i);
          acc1 += m1[i] * Eigen::Map<const Lanes>(s1 + i);
        }
        for (int d = 0; d < L; ++d) out[d] += acc0[d];
        for (int d = 0; d < L; ++d) out[d] += acc1[d];
      }
      for (; j < w; ++j) {
        const float* m0 = m + static_cast<std::size_t>(j) * static_cast<std::size_t>(w);
        const float* s0 = base + static_cast<std::size_t>(j) * s.stride + b * L;
        Lanes acc0 = Lanes::Zero();
        for (int i = 0; i < w; ++i) acc0 += m0[i] * Eigen::Map<const Lanes>(s0 + i);
        for (int d = 0; d < L; ++d) out[d] += acc0[d];
      }
    }
  }
}

#ifdef DIACHRON_RUNTIME_AVX2
// The same sums in 256-bit registers, for processors that have AVX2 (chosen at run time; the build
// itself stays at its baseline), four window rows at a time. Multiplies and adds only, never a fused
// multiply-add: every lane rounds exactly as the portable loop's, so the scores are bitwise the same
// on any x86-64.
__attribute__((target("avx2"))) inline void correlation_cross_row_avx2(const CorrelationTemplate& t,
                                                                       const CorrelationChannels& s, int x0, int y,
                                                                       int blocks, double* cross) {
  typedef float Lanes8 __attribute__((vector_size(32)));
  constexpr int L = kCorrelationLanes;
  static_assert(L == 16, "correlation_cross_row_avx2 holds a block in two registers");
  constexpr int kRows = 4;
  const int w = t.side;
  for (int c = 0; c < t.channels; ++c) {
    const float* m = t.data[c].data();
    const float* base = s.data[c].data() + static_cast<std::size_t>(y) * s.stride + x0;
    for (int b = 0; b < blocks; ++b) {
      double* out = cross + static_cast<std::size_t>(b) * L;
      int j = 0;
      for (; j + kRows <= w; j += kRows) {
        const float* mr[kRows];
        const float* sr[kRows];
        for (int r = 0; r < kRows; ++r) {
          mr[r] = m + static_cast<std::size_t>(j + r) * static_cast<std::size_t>(w);
          sr[r] = base + static_cast<std::size_t>(j + r) * s.stride + b * L;
        }
        Lanes8 lo[kRows] = {}, hi[kRows] = {};
        for (int i = 0; i < w; ++i)
          for (int r = 0; r < kRows; ++r) {
            const float mi = mr[r][i];
            Lanes8 a, bb;
            __builtin_memcpy(&a, sr[r] + i, sizeof a);
            __builtin_memcpy(&bb, sr[r] + i + 8, sizeof bb);
            const Lanes8 product_lo = mi * a, product_hi = mi * bb;
            lo[r] += product_lo;
            hi[r] += product_hi;
          }
        for (int r = 0; r < kRows; ++r)
          for (int d = 0; d < 8; ++d) {
            out[d] += lo[r][d];
            out[d + 8] += hi[r][d];
          }
      }
      for (; j < w; ++j) {
        const float* m0 = m + static_cast<std::size_t>(j) * static_cast<std::size_t>(w);
        const float* s0 = base + static_cast<std::size_t>(j) * s.stride + b * L;
        Lanes8 lo = {}, hi = {};
        for (int i = 0; i < w; ++i) {
          const float mi = m0[i];
          Lanes8 a, bb;
          __builtin_memcpy(&a, s0 + i, sizeof a);
          __builtin_memcpy(&bb, s0 + i + 8, sizeof bb);
          const Lanes8 product_lo = mi * a, product_hi = mi * bb;
          lo += product_lo;
          hi += product_hi;
        }
        for (int d = 0; d < 8; ++d) {
          out[d] += lo[d];
          out[d + 8] += hi[d];
        }
      }
    }
  }
}
#endif

// The cross-row loop for this processor (detail::runtime_avx2, matching/window_sampler.hpp).
inline CorrelationCrossRow correlation_cross_row() {
#ifdef DIACHRON_RUNTIME_AVX2
  if (runtime_avx2()) return &correlation_cross_row_avx2;
#endif
  return &correlation_cross_row_portable;
}

}  // namespace detail

inline void correlation_scores(const CorrelationTemplate& t, const CorrelationChannels& s, int x0, int y0, int nx,
                               int ny, Eigen::MatrixXd& surface, std::vector<double>& cross) {
  constexpr int L = kCorrelationLanes;
  const int w = t.side;
  const int blocks = (nx + L - 1) / L;
  surface.resize(ny, nx);
  cross.resize(static_cast<std::size_t>(blocks) * L);
  const double n = static_cast<double>(w) * static_cast<double>(w);
  const std::size_t s1 = static_cast<std::size_t>(s.cols) + 1;
  const detail::CorrelationCrossRow cross_row = detail::correlation_cross_row();
  // One row of shifts at a time: the cross terms, then the secondary windows' variances from the
  // integral images, then the scores (Eigen's SIMD square root and division, IEEE as the scalar ones).
  using Row = Eigen::Array<double, Eigen::Dynamic, 1>;
  Row var(nx), scale(nx), score(nx);
  for (int dy = 0; dy < ny; ++dy) {
    std::fill(cross.begin(), cross.end(), 0.0);
    cross_row(t, s, x0, y0 + dy, blocks, cross.data());
    var.setZero();
    scale.setZero();
    const std::size_t top = static_cast<std::size_t>(y0 + dy) * s1 + static_cast<std::size_t>(x0);
    const std::size_t bottom = top + static_cast<std::size_t>(w) * s1;
    for (int c = 0; c < t.channels; ++c) {
      const double* I = s.sum[c].data();
      const double* I2 = s.sum2[c].data();
      for (int dx = 0; dx < nx; ++dx) {
        const double sum = I[bottom + w + dx] - I[top + w + dx] - I[bottom + dx] + I[top + dx];
        const double sum2 = I2[bottom + w + dx] - I2[top + w + dx] - I2[bottom + dx] + I2[top + dx];
        var[dx] += sum2 - sum * sum / n;
        scale[dx] += sum2;
      }
    }
    const Eigen::Map<const Row> cross_terms(cross.data(), nx);
    score = (cross_terms / (t.var * var.max(0.0)).sqrt()).max(-1.0).min(1.0);
    for (int dx = 0; dx < nx; ++dx)
      surface(dy, dx) = var[dx] > 1e-12 * std::max(1.0, scale[dx]) ? score[dx] : std::numeric_limits<double>::quiet_NaN();
  }
}

}  // namespace diachron
