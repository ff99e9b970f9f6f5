#pragma once
/// @file
/// Deterministic random streams. Every randomised algorithm derives its stream from the user's
/// seed and an item index (a RANSAC iteration, a tile, an epoch), never from a thread, so results
/// do not depend on the thread count (docs/conventions.md).

#include <cmath>
#include <cstddef>
#include <cstdint>

namespace diachron {

namespace detail {
__extension__ typedef unsigned __int128 uint128;  // GCC/Clang extension, fine under -Wpedantic

/// SplitMix64 finaliser: a bijective 64-bit mixer (Steele, Lea and Flood, OOPSLA 2014).
constexpr std::uint64_t mix64(std::uint64_t z) {
  z += 0x9e3779b97f4a7c15ULL;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}
}  // namespace detail

/// A xoshiro256** generator seeded from (seed, stream). Two streams with different indices are
/// statistically independent; the same (seed, stream) always yields the same sequence on every
/// platform (no std:: distributions, whose output is implementation-defined).
/// Not thread-safe: one stream per task.
///
/// Order of draws: never draw twice in one expression, as in `Vec2(r.uniform(), r.uniform())` or
/// `r.uniform01() * r.uniform()`. The order of a call's arguments and of an operator's operands is
/// unspecified, compilers differ (GCC evaluates those arguments right to left, clang left to
/// right), and the same seed then makes a different scene on each. Draw in separate statements.
/// The library's generators draw in the order GCC used when the documented figures were measured,
/// so a y is often drawn before its x.
class RandomStream {
 public:
  explicit RandomStream(std::uint64_t seed = 0, std::uint64_t stream = 0) {
    std::uint64_t s = detail::mix64(seed) ^ detail::mix64(stream + 0x632be59bd9b4e019ULL);
    for (auto& word : state_) {
      s = detail::mix64(s);
      word = s;
    }
  }

  /// Next raw 64-bit value.
  std::uint64_t next_u64() {
    const std::uint64_t result = rotl(state_[1] * 5, 7) * 9;
    const std::uint64_t t = state_[1] << 17;
    state_[2] ^= state_[0];
    state_[3] ^= state_[1];
    state_[1] ^= state_[2];
    state_[0] ^= state_[3];
    state_[2] ^= t;
    state_[3] = rotl(state_[3], 45);
    return result;
  }

  /// Uniform integer in [0, n), without modulo bias (Lemire's multiply-and-reject). n must be > 0.
  std::size_t uniform_index(std::size_t n) {
    const std::uint64_t range = static_cast<std::uint64_t>(n);
    std::uint64_t x = next_u64();
    detail::uint128 m = static_cast<detail::uint128>(x) * range;
    std::uint64_t low = static_cast<std::uint64_t>(m);
    if (low < range) {
      const std::uint64_t threshold = (0 - range) % range;
      while (low < threshold) {
        x = next_u64();
        m = static_cast<detail::uint128>(x) * range;
        low = static_cast<std::uint64_t>(m);
      }
    }
    return static_cast<std::size_t>(m >> 64);
  }

  /// Uniform double in [0, 1) with 53 random bits.
  double uniform01() { return static_cast<double>(next_u64() >> 11) * 0x1.0p-53; }

  /// Uniform double in [a, b).
  double uniform(double a, double b) { return a + (b - a) * uniform01(); }

  /// Standard normal variate (Marsaglia's polar method), reproducible across platforms.
  double normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u, v, s;
    do {
      u = 2.0 * uniform01() - 1.0;
      v = 2.0 * uniform01() - 1.0;
      s = u * u + v * v;
    } while (s >= 1.0 || s == 0.0);
    const double factor = std::sqrt(-2.0 * std::log(s) / s);
    spare_ = v * factor;
    has_spare_ = true;
    return u * factor;
  }

  /// Normal variate with the given mean and standard deviation.
  double normal(double mean, double sigma) { return mean + sigma * normal(); }

 private:
  static constexpr std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }

  std::uint64_t state_[4];
  double spare_ = 0.0;
  bool has_spare_ = false;
};

}  // namespace diachron
