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
    std::vector<std::vector<Complex>> spectra = forward_real(planes_of(fixed));
    m_ = std::move(spectra.back());
    spectra.pop_back();
    f2_ = std::move(spectra.back());
    spectra.pop_back();
    f1_ = std::move(spectra);
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
    const std::vector<std::vector<Complex>> g = forward_real(planes_of(moving));
    const std::vector<Complex>& gm = g[channels_ + 1];
    const std::vector<Complex>& g2 = g[channels_];
    // Products written out: std::complex's operator* checks for infinities and NaNs on every call
    // (C99 Annex G), which costs more than the FFTs here, and these values are always finite.
    const auto mul_conj = [](const Complex& x, const Complex& y) {  // x conj(y)
      return Complex(x.real() * y.real() + x.imag() * y.imag(), x.imag() * y.real() - x.real() * y.imag());
    };
    // The correlations, as spectra: count, sum of fixed squares, sum of moving squares, cross sum
    // (over the channels: the spectra add), then per channel the sums of fixed and of moving.
    const std::size_t n_out = 4 + 2 * channels_;
    std::vector<std::vector<Complex>> out(n_out, std::vector<Complex>(fft_.size()));
    for (std::size_t k = 0; k < fft_.size(); ++k) {
      out[0][k] = mul_conj(m_[k], gm[k]);
      out[1][k] = mul_conj(f2_[k], gm[k]);
      out[2][k] = mul_conj(m_[k], g2[k]);
      Complex cross(0.0, 0.0);
      for (std::size_t c = 0; c < channels_; ++c) {
        cross += mul_conj(f1_[c][k], g[c][k]);
        out[4 + 2 * c][k] = mul_conj(f1_[c][k], gm[k]);
        out[5 + 2 * c][k] = mul_conj(m_[k], g[c][k]);
      }
      out[3][k] = cross;
    }
    const std::vector<std::vector<double>> sums = inverse_real(out);
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
        const double n = std::round(sums[0][k]);
        result.overlap(x, y) = static_cast<int>(n);
        if (n < min_overlap) continue;
        double vf = sums[1][k], vg = sums[2][k], cov = sums[3][k];
        for (std::size_t c = 0; c < channels_; ++c) {
          const double sf = sums[4 + 2 * c][k], sg = sums[5 + 2 * c][k];
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

  // The real planes a signal contributes, zero-padded to the FFT size: each channel centred on its
  // mean, then the sum of their squares, then the mask.
  std::vector<std::vector<double>> planes_of(const std::vector<Raster<float>>& signal) const {
    std::vector<std::vector<double>> planes(channels_ + 2, std::vector<double>(fft_.size(), 0.0));
    for (std::size_t c = 0; c < channels_; ++c) {
      const double mean = valid_mean(signal[c]);
      for (int y = 0; y < signal[c].height(); ++y)
        for (int x = 0; x < signal[c].width(); ++x) {
          const float v = signal[c](x, y);
          if (std::isnan(v)) continue;
          const double d = v - mean;
          const std::size_t i = static_cast<std::size_t>(y) * fft_.width() + x;
          planes[c][i] = d;
          planes[channels_][i] += d * d;
          planes[channels_ + 1][i] = 1.0;
        }
    }
    return planes;
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

  // Spectra of real planes, two per complex FFT (one in the imaginary part), separated by the
  // symmetry of real spectra: X[k] = (Z[k] + conj Z[-k]) / 2, Y[k] = (Z[k] - conj Z[-k]) / 2i.
  std::vector<std::vector<Complex>> forward_real(const std::vector<std::vector<double>>& planes) {
    std::vector<std::vector<Complex>> out(planes.size());
    const int fw = fft_.width(), fh = fft_.height();
    for (std::size_t p = 0; p < planes.size(); p += 2) {
      const bool pair = p + 1 < planes.size();
      std::vector<Complex> z(fft_.size());
      for (std::size_t i = 0; i < z.size(); ++i) z[i] = Complex(planes[p][i], pair ? planes[p + 1][i] : 0.0);
      fft_.forward(z);
      if (!pair) {
        out[p] = std::move(z);
        continue;
      }
      out[p].resize(z.size());
      out[p + 1].resize(z.size());
      for (int ky = 0; ky < fh; ++ky)
        for (int kx = 0; kx < fw; ++kx) {
          const std::size_t k = static_cast<std::size_t>(ky) * fw + kx;
          const std::size_t mk = static_cast<std::size_t>((fh - ky) % fh) * fw + static_cast<std::size_t>((fw - kx) % fw);
          const Complex a = z[k], b = std::conj(z[mk]);
          out[p][k] = Complex(0.5 * (a.real() + b.real()), 0.5 * (a.imag() + b.imag()));
          out[p + 1][k] = Complex(0.5 * (a.imag() - b.imag()), -0.5 * (a.real() - b.real()));
        }
    }
    return out;
  }

  // Real correlations from their spectra, two per inverse FFT: each is real, so one goes in the
  // real part and one in the imaginary part (i times a Hermitian spectrum).
  std::vector<std::vector<double>> inverse_real(std::vector<std::vector<Complex>>& spectra) {
    std::vector<std::vector<double>> out(spectra.size(), std::vector<double>(fft_.size()));
    for (std::size_t p = 0; p < spectra.size(); p += 2) {
      std::vector<Complex>& z = spectra[p];
      if (p + 1 < spectra.size())
        for (std::size_t k = 0; k < z.size(); ++k) {
          const Complex y = spectra[p + 1][k];
          z[k] = Complex(z[k].real() - y.imag(), z[k].imag() + y.real());  // x + i y
        }
      fft_.inverse(z);
      for (std::size_t k = 0; k < z.size(); ++k) {
        out[p][k] = z[k].real();
        if (p + 1 < spectra.size()) out[p + 1][k] = z[k].imag();
      }
    }
    return out;
  }

  std::size_t channels_;
  int fixed_width_, fixed_height_;
  int max_moving_width_ = 0, max_moving_height_ = 0;
  Fft2 fft_;
  std::vector<std::vector<Complex>> f1_;
  std::vector<Complex> f2_, m_;
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

/// masked_ncc_at() for a signal of several channels (same sizes and holes in each), as
/// MaskedNcc::correlate: the channels laid end to end, each centred on its own mean over the overlap.
inline double masked_ncc_at(const std::vector<Raster<float>>& fixed, const std::vector<Raster<float>>& moving, int dx,
                            int dy, int min_overlap, double min_variance, int* overlap = nullptr) {
  DIACHRON_CHECK(!fixed.empty() && fixed.size() == moving.size(), "masked_ncc_at: the signals differ in channels");
  if (fixed.size() == 1) return masked_ncc_at(fixed[0], moving[0], dx, dy, min_overlap, min_variance, overlap);
  const Raster<float>& f0 = fixed[0];
  const Raster<float>& g0 = moving[0];
  double n = 0.0, vf = 0.0, vg = 0.0, cov = 0.0;
  const int y0 = std::max(0, -dy), y1 = std::min(g0.height(), f0.height() - dy);
  const int x0 = std::max(0, -dx), x1 = std::min(g0.width(), f0.width() - dx);
  for (std::size_t c = 0; c < fixed.size(); ++c) {
    double cn = 0.0, sf = 0.0, sg = 0.0, sff = 0.0, sgg = 0.0, sfg = 0.0;
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) {
        const float g = moving[c](x, y), f = fixed[c](x + dx, y + dy);
        if (std::isnan(g) || std::isnan(f)) continue;
        cn += 1.0;
        sf += f;
        sg += g;
        sff += static_cast<double>(f) * f;
        sgg += static_cast<double>(g) * g;
        sfg += static_cast<double>(f) * g;
      }
    n = cn;
    if (cn < 1.0) break;
    vf += sff - sf * sf / cn;
    vg += sgg - sg * sg / cn;
    cov += sfg - sf * sg / cn;
  }
  if (overlap) *overlap = static_cast<int>(n);
  if (n < min_overlap || n < 1.0) return std::numeric_limits<double>::quiet_NaN();
  if (vf <= min_variance * n || vg <= min_variance * n) return std::numeric_limits<double>::quiet_NaN();
  return std::clamp(cov / std::sqrt(vf * vg), -1.0, 1.0);
}

}  // namespace diachron
