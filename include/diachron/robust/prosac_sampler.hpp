#pragma once
/// @file
/// PROSAC sampling (Chum and Matas, "Matching with PROSAC - progressive sample consensus", CVPR
/// 2005): the data are sorted by decreasing quality (best match first) and early samples come from
/// the best-ranked data, growing towards the whole set. Models the Sampler concept of
/// robust/uniform_sampler.hpp.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

#include <diachron/core/error.hpp>
#include <diachron/core/random.hpp>
#include <diachron/robust/uniform_sampler.hpp>

namespace diachron {

/// Progressive sampler. Precondition: the input of Ransac::run is sorted by decreasing quality
/// (index 0 the most trustworthy), e.g. by increasing descriptor distance or ratio.
///
/// The sample of iteration t (1-based here) depends only on t and its random stream: the growth
/// function of the paper gives the pool size n(t), the smallest n with T'_n >= t, and the sample is
/// the n-th datum plus sample_size - 1 distinct data from the n - 1 before it. Once t exceeds
/// T'_N the draw is uniform over all data. Because nothing depends on earlier draws, the sampler is
/// deterministic from (seed, iteration) and safe for parallel batches, unlike PROSAC's original
/// sequential formulation. The paper's stopping rule (non-randomness, maximality) is a Termination
/// policy, ProsacTermination (robust/prosac_termination.hpp); pool_size() tells Termination
/// policies the pool of each iteration.
///
/// Memory: prepare() builds a table of N - sample_size + 1 integers.
class ProsacSampler {
 public:
  /// T_N = 200000, the paper's value.
  ProsacSampler() = default;

  /// @param growth_samples T_N of the paper: number of samples after which the pool has grown to
  ///        all data. Must be finite and >= 1 (throws diachron::Error otherwise).
  explicit ProsacSampler(double growth_samples) : growth_samples_(growth_samples) {
    DIACHRON_CHECK(std::isfinite(growth_samples) && growth_samples >= 1.0,
                   "ProsacSampler growth_samples must be finite and >= 1, got " << growth_samples);
  }

  void prepare(std::size_t num_data, std::size_t sample_size) {
    num_data_ = num_data;
    sample_size_ = sample_size;
    const std::size_t m = sample_size;
    // T_n, the expected number of samples drawn from the top n among T_N uniform samples:
    // T_m = T_N * prod_{i<m} (m - i) / (N - i), T_{n+1} = T_n (n + 1) / (n + 1 - m).
    double t_n = growth_samples_;
    for (std::size_t i = 0; i < m; ++i) {
      t_n *= static_cast<double>(m - i) / static_cast<double>(num_data - i);
    }
    last_sample_.assign(num_data - m + 1, 0);
    double t_prime = 1.0;  // T'_m = 1: the very first sample is the m best data.
    last_sample_[0] = 1;
    const double cap = static_cast<double>(std::numeric_limits<std::size_t>::max() / 2);
    for (std::size_t n = m; n < num_data; ++n) {
      const double t_next = t_n * static_cast<double>(n + 1) / static_cast<double>(n + 1 - m);
      t_prime = std::min(cap, t_prime + std::ceil(t_next - t_n));
      t_n = t_next;
      last_sample_[n + 1 - m] = static_cast<std::size_t>(t_prime);
    }
  }

  void draw(std::size_t iteration, RandomStream& rng, std::size_t* indices) const {
    const std::size_t t = iteration + 1;
    const std::size_t m = sample_size_;
    if (t > last_sample_.back()) {
      detail::draw_distinct(rng, 0, num_data_, m, indices);
      return;
    }
    const std::size_t n = m + static_cast<std::size_t>(
                                  std::lower_bound(last_sample_.begin(), last_sample_.end(), t) -
                                  last_sample_.begin());
    detail::draw_distinct(rng, 0, n - 1, m - 1, indices);
    indices[m - 1] = n - 1;
  }

  /// Size of the pool iteration `iteration` (0-based) draws from; num_data once growth is over.
  /// For tests and diagnostics. Requires prepare().
  std::size_t pool_size(std::size_t iteration) const {
    const std::size_t t = iteration + 1;
    if (t > last_sample_.back()) return num_data_;
    return sample_size_ + static_cast<std::size_t>(std::lower_bound(last_sample_.begin(),
                                                                    last_sample_.end(), t) -
                                                   last_sample_.begin());
  }

 private:
  double growth_samples_ = 200000.0;
  std::size_t num_data_ = 0;
  std::size_t sample_size_ = 0;
  // last_sample_[n - m] = T'_n: the last (1-based) iteration whose pool is the top n.
  std::vector<std::size_t> last_sample_;
};

static_assert(is_sampler_v<ProsacSampler>, "ProsacSampler must model the Sampler concept");

}  // namespace diachron
