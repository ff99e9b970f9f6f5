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
/// forward and three inverse FFTs per single-channel moving raster. Values are centred on the fixed
/// raster's mean (the moving ones on theirs) so that sums of squares keep their precision on heights
/// of thousands of metres. Holes are NaN.
///
/// Several channels (e.g. the two components of a gradient) correlate as one signal: the ZNCC of
/// the channels laid end to end, each centred on its own mean over the overlap, so
///   r = sum_c cov_c / sqrt(sum_c var_f,c * sum_c var_g,c).
/// The channels of one raster must share their holes. Two channels cost two forward and four
/// inverse FFTs per moving raster.
///
/// correlate() reuses work arrays held by the object: use one object per thread.
class MaskedNcc {
 public:
  using Complex = std::complex<double>;

  /// Throws diachron::Error for an empty fixed raster or non-positive moving sizes.
  MaskedNcc(const Raster<float>& fixed, int max_moving_width, int max_moving_height)
      : MaskedNcc(std::vector<Raster<float>>{fixed}, max_moving_width, max_moving_height) {}

  /// Channels of one signal, all the same size with the same holes; throws diachron::Error otherwise.
  MaskedNcc(const std::vector<Raster<float>>& fixed, int max_moving_width, int max_moving_height)
      : channels_(fixed.size()),
        fixed_width_(fixed.empty() ? 0 : fixed[0].width()),
        fixed_height_(fixed.empty() ? 0 : fixed[0].height()),
        fft_(next_power_of_two(std::max(1, fixed_width_ + max_moving_width - 1)),
             next_power_of_two(std::max(1, fixed_height_ + max_moving_height - 1))) {
    check_channels(fixed, "fixed");
    DIACHRON_CHECK(max_moving_width >= 1 && max_moving_height >= 1,
                   "masked NCC needs positive moving sizes, got " << max_moving_width << " x " << max_moving_height);
    max_moving_width_ = max_moving_width;
    max_moving_height_ = max_moving_height;
    transform_planes(fixed, planes_);
    const std::vector<std::vector<Complex>>& z = planes_;
    f1_.assign(channels_, std::vector<Complex>(fft_.size()));
    f2_.resize(fft_.size());
    m_.resize(fft_.size());
    for_each_frequency([&](std::size_t k, std::size_t mk) {
      for (std::size_t c = 0; c < channels_; ++c) f1_[c][k] = unpack(z, c, k, mk);
      f2_[k] = unpack(z, channels_, k, mk);
      m_[k] = unpack(z, channels_ + 1, k, mk);
    });
  }

  int fft_width() const { return fft_.width(); }
  int fft_height() const { return fft_.height(); }
  std::size_t channels() const { return channels_; }

  /// ZNCC for every shift at which the two rasters overlap. Throws diachron::Error for a moving
  /// raster larger than the constructor's bound. `min_overlap` >= 1 pixel pairs, `min_variance` >= 0.
  MaskedNccMap correlate(const Raster<float>& moving, int min_overlap, double min_variance) {
    return correlate(std::vector<Raster<float>>{moving}, min_overlap, min_variance);
  }

  /// The same for a signal of as many channels as the fixed one (same holes in every channel).
  /// `min_variance` applies to the sum over the channels.
  MaskedNccMap correlate(const std::vector<Raster<float>>& moving, int min_overlap, double min_variance) {
    DIACHRON_CHECK(moving.size() == channels_, "masked NCC: the moving signal has " << moving.size()
                                                   << " channels, the fixed one " << channels_);
    check_channels(moving, "moving");
    const int mw = moving[0].width(), mh = moving[0].height();
    DIACHRON_CHECK(mw <= max_moving_width_ && mh <= max_moving_height_,
                   "masked NCC: moving raster " << mw << " x " << mh << " exceeds the bound "
                                                << max_moving_width_ << " x " << max_moving_height_);
    DIACHRON_CHECK(min_overlap >= 1 && min_variance >= 0.0, "masked NCC needs min_overlap >= 1 and min_variance >= 0");
    transform_planes(moving, planes_);
    const std::vector<std::vector<Complex>>& g = planes_;
    // Products written out: std::complex's operator* checks for infinities and NaNs on every call
    // (C99 Annex G), which costs more than the FFTs here, and these values are always finite.
    const auto mul_conj = [](const Complex& x, const Complex& y) {  // x conj(y)
      return Complex(x.real() * y.real() + x.imag() * y.imag(), x.imag() * y.real() - x.real() * y.imag());
    };
    // The correlations, as spectra: 0 count, 1 sum of fixed squares, 2 sum of moving squares,
    // 3 cross sum (over the channels: the spectra add), then per channel the sums of fixed and of
    // moving. Each is real, so two share an inverse FFT: correlation j goes into buffer j / 2, in
    // the real part when j is even, else in the imaginary part (i times a Hermitian spectrum).
    std::vector<std::vector<Complex>>& out = out_;
    zeroed(out, (5 + 2 * channels_) / 2);
    const auto put = [&](std::size_t j, std::size_t k, const Complex& v) {
      Complex& o = out[j / 2][k];
      o = j % 2 ? Complex(o.real() - v.imag(), o.imag() + v.real()) : Complex(o.real() + v.real(), o.imag() + v.imag());
    };
    for_each_frequency([&](std::size_t k, std::size_t mk) {
      const Complex gm = unpack(g, channels_ + 1, k, mk);
      put(0, k, mul_conj(m_[k], gm));
      put(1, k, mul_conj(f2_[k], gm));
      put(2, k, mul_conj(m_[k], unpack(g, channels_, k, mk)));
      Complex cross(0.0, 0.0);
      for (std::size_t c = 0; c < channels_; ++c) {
        const Complex gc = unpack(g, c, k, mk);
        cross += mul_conj(f1_[c][k], gc);
        put(4 + 2 * c, k, mul_conj(f1_[c][k], gm));
        put(5 + 2 * c, k, mul_conj(m_[k], gc));
      }
      put(3, k, cross);
    });
    for (std::vector<Complex>& b : out) fft_.inverse(b);
    const auto sum = [&](std::size_t j, std::size_t k) { return j % 2 ? out[j / 2][k].imag() : out[j / 2][k].real(); };
    MaskedNccMap result;
    result.min_dx = -(mw - 1);
    result.min_dy = -(mh - 1);
    const int w = fixed_width_ + mw - 1, h = fixed_height_ + mh - 1;
    result.score = Raster<float>(w, h, std::numeric_limits<float>::quiet_NaN());
    result.overlap = Raster<int>(w, h, 0);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        // Shift d wraps to index d mod size: the correlation sum_q F(q + d) G(q).
        const int dx = x + result.min_dx, dy = y + result.min_dy;
        const int ix = (dx + fft_.width()) % fft_.width(), iy = (dy + fft_.height()) % fft_.height();
        const std::size_t k = static_cast<std::size_t>(iy) * fft_.width() + ix;
        const double n = std::round(sum(0, k));
        result.overlap(x, y) = static_cast<int>(n);
        if (n < min_overlap) continue;
        double vf = sum(1, k), vg = sum(2, k), cov = sum(3, k);
        for (std::size_t c = 0; c < channels_; ++c) {
          const double sf = sum(4 + 2 * c, k), sg = sum(5 + 2 * c, k);
          vf -= sf * sf / n;
          vg -= sg * sg / n;
          cov -= sf * sg / n;
        }
        if (vf <= min_variance * n || vg <= min_variance * n) continue;
        result.score(x, y) = static_cast<float>(std::clamp(cov / std::sqrt(vf * vg), -1.0, 1.0));
      }
    return result;
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

  static void check_channels(const std::vector<Raster<float>>& r, const char* which) {
    DIACHRON_CHECK(!r.empty() && !r[0].empty(), "masked NCC needs a non-empty " << which << " raster");
    for (std::size_t c = 1; c < r.size(); ++c) {
      DIACHRON_CHECK(r[c].width() == r[0].width() && r[c].height() == r[0].height(),
                     "masked NCC: the " << which << " channels differ in size");
      for (int y = 0; y < r[0].height(); ++y)
        for (int x = 0; x < r[0].width(); ++x)
          DIACHRON_CHECK(std::isnan(r[c](x, y)) == std::isnan(r[0](x, y)),
                         "masked NCC: the " << which << " channels differ in their holes at (" << x << ", " << y << ")");
    }
  }

  // The real planes of a signal, zero-padded to the FFT size and transformed two to a complex FFT:
  // plane p lies in buffer p / 2, in the real part when p is even, else in the imaginary part (see
  // unpack). Planes: each channel centred on its mean, then the sum of their squares, then the mask.
  void transform_planes(const std::vector<Raster<float>>& signal, std::vector<std::vector<Complex>>& z) {
    zeroed(z, (channels_ + 3) / 2);
    const auto add = [&](std::size_t p, std::size_t i, double v) {
      Complex& c = z[p / 2][i];
      c = p % 2 ? Complex(c.real(), c.imag() + v) : Complex(c.real() + v, c.imag());
    };
    for (std::size_t c = 0; c < channels_; ++c) {
      const double mean = valid_mean(signal[c]);
      for (int y = 0; y < signal[c].height(); ++y)
        for (int x = 0; x < signal[c].width(); ++x) {
          const float v = signal[c](x, y);
          if (std::isnan(v)) continue;
          const double d = v - mean;
          const std::size_t i = static_cast<std::size_t>(y) * fft_.width() + x;
          add(c, i, d);
          add(channels_, i, d * d);
          if (c == 0) add(channels_ + 1, i, 1.0);
        }
    }
    for (std::vector<Complex>& b : z) fft_.forward(b);
  }

  // `buffers` as `count` zeroed arrays of the FFT size, their memory reused from the last call:
  // allocating and faulting in fresh arrays took about as long as the FFTs themselves.
  void zeroed(std::vector<std::vector<Complex>>& buffers, std::size_t count) const {
    buffers.resize(count);
    for (std::vector<Complex>& b : buffers) b.assign(fft_.size(), Complex(0.0, 0.0));
  }

  // Calls f(k, mk) for every frequency index k, with mk the index of -k.
  template <class F>
  void for_each_frequency(F&& f) const {
    const int fw = fft_.width(), fh = fft_.height();
    for (int ky = 0; ky < fh; ++ky)
      for (int kx = 0; kx < fw; ++kx)
        f(static_cast<std::size_t>(ky) * fw + kx,
          static_cast<std::size_t>((fh - ky) % fh) * fw + static_cast<std::size_t>((fw - kx) % fw));
  }

  // The spectrum of real plane p at k, separated from the shared transform Z by the symmetry of real
  // spectra: X[k] = (Z[k] + conj Z[-k]) / 2 for the real part's plane, Y[k] = (Z[k] - conj Z[-k]) / 2i
  // for the imaginary part's.
  static Complex unpack(const std::vector<std::vector<Complex>>& z, std::size_t p, std::size_t k, std::size_t mk) {
    const Complex a = z[p / 2][k], b = std::conj(z[p / 2][mk]);
    if (p % 2 == 0) return Complex(0.5 * (a.real() + b.real()), 0.5 * (a.imag() + b.imag()));
    return Complex(0.5 * (a.imag() - b.imag()), -0.5 * (a.real() - b.real()));
  }

  std::size_t channels_;
  int fixed_width_, fixed_height_;
  int max_moving_width_ = 0, max_moving_height_ = 0;
  Fft2 fft_;
  std::vector<std::vector<Complex>> f1_;  ///< per channel: the centred values' spectrum
  std::vector<Complex> f2_, m_;           ///< the sum of squares' and the mask's spectra
  std::vector<std::vector<Complex>> planes_, out_;  ///< correlate()'s work arrays, kept between calls
};

namespace detail {

/// Sums over the pixel pairs of one channel's overlap at a shift (moving pixel q on fixed pixel q + d).
struct OverlapMoments {
  double n = 0.0, sf = 0.0, sg = 0.0, sff = 0.0, sgg = 0.0, sfg = 0.0;

  /// The centred sums (n times the variances and the covariance); valid when n >= 1.
  double var_fixed() const { return sff - sf * sf / n; }
  double var_moving() const { return sgg - sg * sg / n; }
  double cov() const { return sfg - sf * sg / n; }
};

inline OverlapMoments overlap_moments(const Raster<float>& fixed, const Raster<float>& moving, int dx, int dy) {
  OverlapMoments m;
  const int y0 = std::max(0, -dy), y1 = std::min(moving.height(), fixed.height() - dy);
  const int x0 = std::max(0, -dx), x1 = std::min(moving.width(), fixed.width() - dx);
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) {
      const float g = moving(x, y), f = fixed(x + dx, y + dy);
      if (std::isnan(g) || std::isnan(f)) continue;
      m.n += 1.0;
      m.sf += f;
      m.sg += g;
      m.sff += static_cast<double>(f) * f;
      m.sgg += static_cast<double>(g) * g;
      m.sfg += static_cast<double>(f) * g;
    }
  return m;
}

/// ZNCC from the summed centred moments (variances and covariance over all channels), NaN under
/// the rules of MaskedNccMap::score.
inline double zncc_from_moments(double n, double vf, double vg, double cov, int min_overlap, double min_variance) {
  if (n < min_overlap || n < 1.0) return std::numeric_limits<double>::quiet_NaN();
  if (vf <= min_variance * n || vg <= min_variance * n) return std::numeric_limits<double>::quiet_NaN();
  return std::clamp(cov / std::sqrt(vf * vg), -1.0, 1.0);
}

}  // namespace detail

/// ZNCC of `moving` against `fixed` at one integer shift (moving pixel q on fixed pixel q + (dx, dy)),
/// summed directly over the overlap: the reference for MaskedNcc, and cheaper than an FFT when only
/// a few shifts are wanted. NaN under the same rules as MaskedNccMap::score; `overlap`, when given,
/// receives the number of valid pixel pairs.
inline double masked_ncc_at(const Raster<float>& fixed, const Raster<float>& moving, int dx, int dy,
                            int min_overlap, double min_variance, int* overlap = nullptr) {
  const detail::OverlapMoments m = detail::overlap_moments(fixed, moving, dx, dy);
  if (overlap) *overlap = static_cast<int>(m.n);
  if (m.n < 1.0) return std::numeric_limits<double>::quiet_NaN();
  return detail::zncc_from_moments(m.n, m.var_fixed(), m.var_moving(), m.cov(), min_overlap, min_variance);
}

/// masked_ncc_at() for a signal of several channels (same sizes and holes in each), as
/// MaskedNcc::correlate: the channels laid end to end, each centred on its own mean over the overlap.
inline double masked_ncc_at(const std::vector<Raster<float>>& fixed, const std::vector<Raster<float>>& moving, int dx,
                            int dy, int min_overlap, double min_variance, int* overlap = nullptr) {
  DIACHRON_CHECK(!fixed.empty() && fixed.size() == moving.size(), "masked_ncc_at: the signals differ in channels");
  double n = 0.0, vf = 0.0, vg = 0.0, cov = 0.0;
  for (std::size_t c = 0; c < fixed.size(); ++c) {
    const detail::OverlapMoments m = detail::overlap_moments(fixed[c], moving[c], dx, dy);
    n = m.n;
    if (m.n < 1.0) break;
    vf += m.var_fixed();
    vg += m.var_moving();
    cov += m.cov();
  }
  if (overlap) *overlap = static_cast<int>(n);
  return detail::zncc_from_moments(n, vf, vg, cov, min_overlap, min_variance);
}

}  // namespace diachron
