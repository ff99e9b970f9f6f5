#pragma once
/// @file
/// Zero-mean normalised cross-correlation of two rasters with holes, over every integer shift at
/// once, through FFTs (the masked formulation of Padfield, "Masked object registration in the
/// Fourier domain", IEEE TIP 2012): each sum over the overlap of the two valid masks (count, sums,
/// sums of squares, cross sum) is a correlation of masked images, so partial overlap and holes are
/// exact, not approximated by zero-filling.

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstddef>
#include <limits>
#include <vector>

#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/terrain/fft2.hpp>

namespace diachron {

/// ZNCC of a moving raster against a fixed one for every integer shift d: the moving pixel q lies on
/// the fixed pixel q + d. `score` is NaN where the overlap has fewer than `min_overlap` valid pixel
/// pairs or either side is flat there (variance below `min_variance`, in squared raster units).
struct MaskedNccMap {
  int min_dx = 0, min_dy = 0;  ///< the shift of element (0, 0)
  Raster<float> score;         ///< ZNCC in [-1, 1], NaN where undefined
  Raster<int> overlap;         ///< valid pixel pairs in the overlap

  /// The shift with the highest score; false when every score is NaN.
  bool best(int& dx, int& dy, double& value) const {
    value = -std::numeric_limits<double>::infinity();
    bool found = false;
    for (int y = 0; y < score.height(); ++y)
      for (int x = 0; x < score.width(); ++x) {
        const double s = score(x, y);
        if (!std::isnan(s) && s > value) {  // strict: ties keep the first in raster order
          value = s;
          dx = x + min_dx;
          dy = y + min_dy;
          found = true;
        }
      }
    return found;
  }
};

/// The fixed side of masked NCC: its masked spectra are computed once for an FFT size large enough
/// for moving rasters up to `max_moving_width` x `max_moving_height`; correlate() then costs two
/// forward (two) and inverse (three) FFTs per moving raster. Values are centred on the fixed raster's mean
/// (the moving ones on theirs) so that sums of squares keep their precision on heights of thousands
/// of metres. Holes are NaN.
class MaskedNcc {
 public:
  using Complex = std::complex<double>;

  /// Throws diachron::Error for an empty fixed raster or non-positive moving sizes.
  MaskedNcc(const Raster<float>& fixed, int max_moving_width, int max_moving_height)
      : fixed_width_(fixed.width()), fixed_height_(fixed.height()),
        fft_(next_power_of_two(std::max(1, fixed.width() + max_moving_width - 1)),
             next_power_of_two(std::max(1, fixed.height() + max_moving_height - 1))) {
    DIACHRON_CHECK(!fixed.empty(), "masked NCC needs a non-empty fixed raster");
    DIACHRON_CHECK(max_moving_width >= 1 && max_moving_height >= 1,
                   "masked NCC needs positive moving sizes, got " << max_moving_width << " x " << max_moving_height);
    max_moving_width_ = max_moving_width;
    max_moving_height_ = max_moving_height;
    const double mean = valid_mean(fixed);
    std::vector<Complex> f1(fft_.size()), f2(fft_.size()), m(fft_.size());
    for (int y = 0; y < fixed.height(); ++y)
      for (int x = 0; x < fixed.width(); ++x) {
        const float v = fixed(x, y);
        if (std::isnan(v)) continue;
        const double c = v - mean;
        const std::size_t i = static_cast<std::size_t>(y) * fft_.width() + x;
        f1[i] = c;
        f2[i] = c * c;
        m[i] = 1.0;
      }
    fft_.forward(f1);
    fft_.forward(f2);
    fft_.forward(m);
    f1_ = std::move(f1);
    f2_ = std::move(f2);
    m_ = std::move(m);
  }

  int fft_width() const { return fft_.width(); }
  int fft_height() const { return fft_.height(); }

  /// ZNCC for every shift at which the two rasters overlap. Throws diachron::Error for a moving
  /// raster larger than the constructor's bound. `min_overlap` >= 1 pixel pairs, `min_variance` >= 0.
  MaskedNccMap correlate(const Raster<float>& moving, int min_overlap, double min_variance) {
    DIACHRON_CHECK(!moving.empty() && moving.width() <= max_moving_width_ && moving.height() <= max_moving_height_,
                   "masked NCC: moving raster " << moving.width() << " x " << moving.height() << " exceeds the bound "
                                                << max_moving_width_ << " x " << max_moving_height_ << " or is empty");
    DIACHRON_CHECK(min_overlap >= 1 && min_variance >= 0.0, "masked NCC needs min_overlap >= 1 and min_variance >= 0");
    const double mean = valid_mean(moving);
    // Two real rasters per forward FFT (one in the imaginary part), separated by the symmetry of
    // real spectra: X[k] = (Z[k] + conj Z[-k]) / 2, Y[k] = (Z[k] - conj Z[-k]) / 2i.
    std::vector<Complex> z(fft_.size()), gm(fft_.size());
    for (int y = 0; y < moving.height(); ++y)
      for (int x = 0; x < moving.width(); ++x) {
        const float v = moving(x, y);
        if (std::isnan(v)) continue;
        const double c = v - mean;
        const std::size_t i = static_cast<std::size_t>(y) * fft_.width() + x;
        z[i] = Complex(c, c * c);
        gm[i] = 1.0;
      }
    fft_.forward(z);
    fft_.forward(gm);
    std::vector<Complex> g1(fft_.size()), g2(fft_.size());
    const int fw = fft_.width(), fh = fft_.height();
    for (int ky = 0; ky < fh; ++ky)
      for (int kx = 0; kx < fw; ++kx) {
        const std::size_t k = static_cast<std::size_t>(ky) * fw + kx;
        const std::size_t mk = static_cast<std::size_t>((fh - ky) % fh) * fw + static_cast<std::size_t>((fw - kx) % fw);
        const Complex a = z[k], b = std::conj(z[mk]);
        g1[k] = Complex(0.5 * (a.real() + b.real()), 0.5 * (a.imag() + b.imag()));
        g2[k] = Complex(0.5 * (a.imag() - b.imag()), -0.5 * (a.real() - b.real()));
      }
    // Six correlations, two per inverse FFT: each is real, so one goes in the real part and one in
    // the imaginary part (i times a Hermitian spectrum).
    std::vector<Complex> a(fft_.size()), b(fft_.size()), c(fft_.size());
    // Products written out: std::complex's operator* checks for infinities and NaNs on every call
    // (C99 Annex G), which costs more than the FFTs here, and these values are always finite.
    const auto mul_conj = [](const Complex& x, const Complex& y) {  // x conj(y)
      return Complex(x.real() * y.real() + x.imag() * y.imag(), x.imag() * y.real() - x.real() * y.imag());
    };
    const auto plus_i = [](const Complex& x, const Complex& y) {  // x + i y
      return Complex(x.real() - y.imag(), x.imag() + y.real());
    };
    for (std::size_t k = 0; k < fft_.size(); ++k) {
      a[k] = plus_i(mul_conj(m_[k], gm[k]), mul_conj(f1_[k], gm[k]));   // count, sum of fixed
      b[k] = plus_i(mul_conj(m_[k], g1[k]), mul_conj(f2_[k], gm[k]));   // sum of moving, sum of fixed^2
      c[k] = plus_i(mul_conj(m_[k], g2[k]), mul_conj(f1_[k], g1[k]));   // sum of moving^2, cross sum
    }
    fft_.inverse(a);
    fft_.inverse(b);
    fft_.inverse(c);
    MaskedNccMap out;
    out.min_dx = -(moving.width() - 1);
    out.min_dy = -(moving.height() - 1);
    const int w = fixed_width_ + moving.width() - 1, h = fixed_height_ + moving.height() - 1;
    out.score = Raster<float>(w, h, std::numeric_limits<float>::quiet_NaN());
    out.overlap = Raster<int>(w, h, 0);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        // Shift d wraps to index d mod size: the correlation sum_q F(q + d) G(q).
        const int dx = x + out.min_dx, dy = y + out.min_dy;
        const int ix = (dx + fft_.width()) % fft_.width(), iy = (dy + fft_.height()) % fft_.height();
        const std::size_t k = static_cast<std::size_t>(iy) * fft_.width() + ix;
        const double n = std::round(a[k].real());
        out.overlap(x, y) = static_cast<int>(n);
        if (n < min_overlap) continue;
        const double sf = a[k].imag(), sg = b[k].real(), sff = b[k].imag(), sgg = c[k].real(), sfg = c[k].imag();
        const double vf = sff - sf * sf / n, vg = sgg - sg * sg / n;
        if (vf <= min_variance * n || vg <= min_variance * n) continue;
        const double r = (sfg - sf * sg / n) / std::sqrt(vf * vg);
        out.score(x, y) = static_cast<float>(std::clamp(r, -1.0, 1.0));
      }
    return out;
  }

 private:
  static double valid_mean(const Raster<float>& r) {
    double sum = 0.0;
    std::size_t n = 0;
    for (float v : r)
      if (!std::isnan(v)) {
        sum += v;
        ++n;
      }
    return n ? sum / static_cast<double>(n) : 0.0;
  }

  int fixed_width_, fixed_height_;
  int max_moving_width_ = 0, max_moving_height_ = 0;
  Fft2 fft_;
  std::vector<Complex> f1_, f2_, m_;
};

/// ZNCC of `moving` against `fixed` at one integer shift (moving pixel q on fixed pixel q + (dx, dy)),
/// summed directly over the overlap: the reference for MaskedNcc, and cheaper than an FFT when only
/// a few shifts are wanted. NaN under the same rules as MaskedNccMap::score; `overlap`, when given,
/// receives the number of valid pixel pairs.
inline double masked_ncc_at(const Raster<float>& fixed, const Raster<float>& moving, int dx, int dy,
                            int min_overlap, double min_variance, int* overlap = nullptr) {
  double n = 0.0, sf = 0.0, sg = 0.0, sff = 0.0, sgg = 0.0, sfg = 0.0;
  const int y0 = std::max(0, -dy), y1 = std::min(moving.height(), fixed.height() - dy);
  const int x0 = std::max(0, -dx), x1 = std::min(moving.width(), fixed.width() - dx);
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) {
      const float g = moving(x, y), f = fixed(x + dx, y + dy);
      if (std::isnan(g) || std::isnan(f)) continue;
      n += 1.0;
      sf += f;
      sg += g;
      sff += static_cast<double>(f) * f;
      sgg += static_cast<double>(g) * g;
      sfg += static_cast<double>(f) * g;
    }
  if (overlap) *overlap = static_cast<int>(n);
  if (n < min_overlap || n < 1.0) return std::numeric_limits<double>::quiet_NaN();
  const double vf = sff - sf * sf / n, vg = sgg - sg * sg / n;
  if (vf <= min_variance * n || vg <= min_variance * n) return std::numeric_limits<double>::quiet_NaN();
  return std::clamp((sfg - sf * sg / n) / std::sqrt(vf * vg), -1.0, 1.0);
}

}  // namespace diachron
