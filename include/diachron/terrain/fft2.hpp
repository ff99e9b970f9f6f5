#pragma once
/// @file
/// A small 2D complex FFT (radix 2) for correlation searches over rasters: sizes are powers of two,
/// row-major, unnormalised forward transform, inverse divided by the element count. Eigen + std only;
/// written here so that the headers need no FFT library and stay warning-free.

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstddef>
#include <utility>
#include <vector>

#include <diachron/core/error.hpp>
#include <diachron/core/types.hpp>

namespace diachron {

/// The smallest power of two >= n (n >= 1).
inline int next_power_of_two(int n) {
  DIACHRON_CHECK(n >= 1 && n <= (1 << 28), "next_power_of_two needs 1 <= n <= 2^28, got " << n);
  int p = 1;
  while (p < n) p <<= 1;
  return p;
}

/// In-place 2D FFT of a width x height row-major complex array (both powers of two). The twiddle
/// factors and bit-reversal permutations of each length are computed once per object, so one Fft2
/// serves many transforms of a size.
class Fft2 {
 public:
  using Complex = std::complex<double>;

  /// Throws diachron::Error unless width and height are powers of two >= 1.
  Fft2(int width, int height) : width_(width), height_(height) {
    DIACHRON_CHECK(width >= 1 && height >= 1 && (width & (width - 1)) == 0 && (height & (height - 1)) == 0,
                   "Fft2 needs power-of-two sizes, got " << width << " x " << height);
    make_twiddles(width_, twiddles_x_);
    make_twiddles(height_, twiddles_y_);
    make_reversal(width_, reversal_x_);
    make_reversal(height_, reversal_y_);
  }

  int width() const { return width_; }
  int height() const { return height_; }
  std::size_t size() const { return static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_); }

  /// Forward transform (exp(-2 pi i k n / N)), no scaling.
  void forward(std::vector<Complex>& data) const { transform(data, false); }
  /// Inverse transform, divided by width x height, so inverse(forward(x)) == x.
  void inverse(std::vector<Complex>& data) const {
    transform(data, true);
    const double k = 1.0 / static_cast<double>(size());
    for (Complex& c : data) c *= k;
  }

 private:
  static void make_twiddles(int n, std::vector<Complex>& out) {
    out.resize(static_cast<std::size_t>(n / 2 > 0 ? n / 2 : 1));
    for (int k = 0; k < n / 2; ++k) {
      const double a = -2.0 * kPi * k / n;
      out[static_cast<std::size_t>(k)] = Complex(std::cos(a), std::sin(a));
    }
  }

  static void make_reversal(int n, std::vector<int>& out) {
    out.assign(static_cast<std::size_t>(n), 0);
    for (int i = 1, j = 0; i < n; ++i) {
      int bit = n >> 1;
      for (; j & bit; bit >>= 1) j ^= bit;
      j ^= bit;
      out[static_cast<std::size_t>(i)] = j;
    }
  }

  // One radix-2 butterfly stage pass, written out on doubles: std::complex's operator* handles
  // infinities (C99 Annex G) at a large cost, and GCC vectorises the plain loop. `count` pairs of
  // complex values, p[x] and q[x], become p + w q and p - w q.
  static void butterflies(double* p, double* q, int count, double wr, double wi) {
    for (int x = 0; x < count; ++x) {
      const double qr = q[2 * x], qi = q[2 * x + 1];
      const double vr = qr * wr - qi * wi, vi = qr * wi + qi * wr;
      const double ur = p[2 * x], ui = p[2 * x + 1];
      p[2 * x] = ur + vr;
      p[2 * x + 1] = ui + vi;
      q[2 * x] = ur - vr;
      q[2 * x + 1] = ui - vi;
    }
  }

  // Iterative Cooley-Tukey over n "elements" of `width` complex values each, `width` apart: with
  // width 1 a row's FFT; with the row length, the FFTs of all columns at once, each butterfly
  // running along two whole rows (contiguous, where a column's elements are a row apart).
  static void fft(Complex* a, int n, int width, const std::vector<Complex>& tw, const std::vector<int>& reversal,
                  bool inverse) {
    const std::size_t w = static_cast<std::size_t>(width);
    for (int i = 0; i < n; ++i) {
      const int j = reversal[static_cast<std::size_t>(i)];
      if (i < j) std::swap_ranges(a + i * w, a + (i + 1) * w, a + j * w);
    }
    for (int len = 2; len <= n; len <<= 1) {
      const int half = len / 2, step = n / len;
      for (int k = 0; k < half; ++k) {
        const Complex t = tw[static_cast<std::size_t>(k * step)];
        const double wr = t.real(), wi = inverse ? -t.imag() : t.imag();
        for (int i = 0; i < n; i += len)
          butterflies(reinterpret_cast<double*>(a + (i + k) * w), reinterpret_cast<double*>(a + (i + k + half) * w),
                      width, wr, wi);
      }
    }
  }

  void transform(std::vector<Complex>& data, bool inverse) const {
    DIACHRON_CHECK(data.size() == size(), "Fft2: data has " << data.size() << " elements, expected " << size());
    for (int y = 0; y < height_; ++y)
      fft(data.data() + static_cast<std::size_t>(y) * width_, width_, 1, twiddles_x_, reversal_x_, inverse);
    fft(data.data(), height_, width_, twiddles_y_, reversal_y_, inverse);
  }

  int width_, height_;
  std::vector<Complex> twiddles_x_, twiddles_y_;
  std::vector<int> reversal_x_, reversal_y_;
};

}  // namespace diachron
