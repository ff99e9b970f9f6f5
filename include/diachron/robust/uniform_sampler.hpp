#pragma once
/// @file
/// The Sampler concept of diachron::Ransac and its plain model, UniformSampler.
///
/// Requirements for Sampler (a pseudo-class):
/// @code
/// struct MySampler {
///   // Called once per run, single-threaded, before any draw: `num_data >= sample_size >= 1`.
///   // Ransac calls it on its own copy of the sampler, so a run never changes the user's object.
///   void prepare(std::size_t num_data, std::size_t sample_size);
///
///   // Writes `sample_size` DISTINCT indices in [0, num_data) to `indices` for hypothesis number
///   // `iteration` (0-based). `rng` is that iteration's stream, RandomStream(seed, iteration); a
///   // sample redrawn after a degenerate one reuses the same stream. The draw must depend only on
///   // (iteration, the values drawn from rng), never on earlier calls, because workers call it
///   // concurrently and in any order: hence const.
///   void draw(std::size_t iteration, RandomStream& rng, std::size_t* indices) const;
///
///   // OPTIONAL. Number of data (the first ones) that hypothesis number `iteration` is drawn from,
///   // for Termination policies that read TerminationState::pool_size. Without it the pool is
///   // all data.
///   std::size_t pool_size(std::size_t iteration) const;
/// };
/// @endcode
/// Models: UniformSampler (this header), ProsacSampler (robust/prosac_sampler.hpp).

#include <cstddef>
#include <type_traits>
#include <utility>

#include <diachron/core/random.hpp>

namespace diachron {

namespace detail {

template <class S, class = void>
struct is_sampler : std::false_type {};
template <class S>
struct is_sampler<S, std::void_t<decltype(std::declval<S&>().prepare(std::size_t{}, std::size_t{})),
                                 decltype(std::declval<const S&>().draw(
                                     std::size_t{}, std::declval<RandomStream&>(),
                                     std::declval<std::size_t*>()))>> : std::true_type {};

/// Writes `count` distinct indices drawn uniformly from [offset, offset + range) to `out`, with
/// exactly `count` random draws (Floyd's algorithm; Bentley, CACM 30(9) 1987). The order of the
/// indices is not random, which minimal solvers do not care about. Requires count <= range.
inline void draw_distinct(RandomStream& rng, std::size_t offset, std::size_t range,
                          std::size_t count, std::size_t* out) {
  std::size_t filled = 0;
  for (std::size_t j = range - count; j < range; ++j) {
    const std::size_t t = offset + rng.uniform_index(j + 1);
    bool taken = false;
    for (std::size_t k = 0; k < filled; ++k) taken = taken || out[k] == t;
    out[filled++] = taken ? offset + j : t;
  }
}

template <class S, class = void>
struct sampler_has_pool_size : std::false_type {};
template <class S>
struct sampler_has_pool_size<S, std::enable_if_t<std::is_convertible_v<
                                    decltype(std::declval<const S&>().pool_size(std::size_t{})),
                                    std::size_t>>> : std::true_type {};

}  // namespace detail

/// True when S satisfies the Sampler concept (see the requirements at the top of this header).
template <class S>
inline constexpr bool is_sampler_v = detail::is_sampler<S>::value;

/// Every subset of `sample_size` data equally likely, independently for every iteration.
/// Stateless apart from the sizes; any number of threads may draw at once.
class UniformSampler {
 public:
  void prepare(std::size_t num_data, std::size_t sample_size) {
    num_data_ = num_data;
    sample_size_ = sample_size;
  }

  void draw(std::size_t /*iteration*/, RandomStream& rng, std::size_t* indices) const {
    detail::draw_distinct(rng, 0, num_data_, sample_size_, indices);
  }

 private:
  std::size_t num_data_ = 0;
  std::size_t sample_size_ = 0;
};

static_assert(is_sampler_v<UniformSampler>, "UniformSampler must model the Sampler concept");

}  // namespace diachron
