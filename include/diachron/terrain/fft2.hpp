#pragma once
/// @file
/// A small 2D complex FFT (radix 2) for correlation searches over rasters: sizes are powers of two,
/// row-major, unnormalised forward transform, inverse divided by the element count. Eigen + std only;
/// written here so that the headers need no FFT library and stay warning-free.

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
/// factors of each length are computed once per object, so one Fft2 serves many transforms of a size.
class Fft2 {
 public:
  using Complex = std::complex<double>;

  /// Throws diachron::Error unless width and height are powers of two >= 1.
  Fft2(int width, int height) : width_(width), height_(height) {
    DIACHRON_CHECK(width >= 1 && height >= 1 && (width & (width - 1)) == 0 && (height & (height - 1)) == 0,
                   "Fft2 needs power-of-two sizes, got " << width << " x " << height);
    make_twiddles(width_, twiddles_x_);
    make_twiddles(height_, twiddles_y_);
    column_.resize(static_cast<std::size_t>(height_));
  }

  int width() const { return width_; }
  int height() const { return height_; }
  std::size_t size() const { return static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_); }

  /// Forward transform (exp(-2 pi i k n / N)), no scaling.
  void forward(std::vector<Complex>& data) { transform(data, false); }
  /// Inverse transform, divided by width x height, so inverse(forward(x)) == x.
  void inverse(std::vector<Complex>& data) {
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

  // Iterative Cooley-Tukey on `n` elements `stride` apart; inverse uses the conjugate twiddles.
  static void fft1(Complex* a, int n, const std::vector<Complex>& tw, bool inverse) {
    for (int i = 1, j = 0; i < n; ++i) {
      int bit = n >> 1;
      for (; j & bit; bit >>= 1) j ^= bit;
      j ^= bit;
      if (i < j) std::swap(a[i], a[j]);
    }
    for (int len = 2; len <= n; len <<= 1) {
      const int half = len / 2, step = n / len;
      for (int i = 0; i < n; i += len)
        for (int k = 0; k < half; ++k) {
          const Complex w = tw[static_cast<std::size_t>(k * step)];
          const double wr = w.real(), wi = inverse ? -w.imag() : w.imag();
          // Written out: std::complex's operator* handles infinities (C99 Annex G) at a large cost.
          const Complex x = a[i + k + half];
          const Complex u = a[i + k], v(x.real() * wr - x.imag() * wi, x.real() * wi + x.imag() * wr);
          a[i + k] = u + v;
          a[i + k + half] = u - v;
        }
    }
  }

  void transform(std::vector<Complex>& data, bool inverse) {
    DIACHRON_CHECK(data.size() == size(), "Fft2: data has " << data.size() << " elements, expected " << size());
    for (int y = 0; y < height_; ++y) fft1(data.data() + static_cast<std::size_t>(y) * width_, width_, twiddles_x_, inverse);
    // Columns through a contiguous buffer: strided butterflies are slow on large rasters.
    for (int x = 0; x < width_; ++x) {
      for (int y = 0; y < height_; ++y) column_[static_cast<std::size_t>(y)] = data[static_cast<std::size_t>(y) * width_ + x];
      fft1(column_.data(), height_, twiddles_y_, inverse);
      for (int y = 0; y < height_; ++y) data[static_cast<std::size_t>(y) * width_ + x] = column_[static_cast<std::size_t>(y)];
    }
  }

  int width_, height_;
  std::vector<Complex> twiddles_x_, twiddles_y_, column_;
};

}  // namespace diachron
