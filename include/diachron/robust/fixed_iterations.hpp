#pragma once
/// @file
/// The Termination concept of diachron::Ransac and its simplest model, FixedIterations.
///
/// Requirements for Termination (a pseudo-class):
/// @code
/// struct MyTermination {
///   // Total number of iterations the run needs, given the best model so far: `best_inliers` of
///   // its data are inliers among `num_data`, and samples hold `sample_size` data. Ransac calls it
///   // once before the first iteration (best_inliers = 0) and after every iteration, and stops as
///   // soon as the iterations done reach the answer. Ransac clamps the answer to
///   // [1, options.max_iterations], so returning SIZE_MAX means "as many as allowed".
///   // Must be a pure function of its arguments (the result must not depend on threads).
///   std::size_t required_iterations(const RansacOptions& options, std::size_t best_inliers,
///                                   std::size_t num_data, std::size_t sample_size) const;
/// };
/// @endcode
/// Models: FixedIterations (this header), Adaptive (robust/adaptive_termination.hpp).

#include <cstddef>
#include <type_traits>
#include <utility>

#include <diachron/robust/ransac_options.hpp>

namespace diachron {

namespace detail {

template <class T, class = void>
struct is_termination : std::false_type {};
template <class T>
struct is_termination<
    T, std::enable_if_t<std::is_convertible_v<
           decltype(std::declval<const T&>().required_iterations(
               std::declval<const RansacOptions&>(), std::size_t{}, std::size_t{}, std::size_t{})),
           std::size_t>>> : std::true_type {};

}  // namespace detail

/// True when T satisfies the Termination concept (see the requirements at the top of this header).
template <class T>
inline constexpr bool is_termination_v = detail::is_termination<T>::value;

/// Always runs exactly RansacOptions::max_iterations iterations, whatever the data: the paper's
/// behaviour (1000 iterations). min_iterations and confidence are ignored.
struct FixedIterations {
  std::size_t required_iterations(const RansacOptions& options, std::size_t /*best_inliers*/,
                                  std::size_t /*num_data*/, std::size_t /*sample_size*/) const {
    return options.max_iterations;
  }
};

static_assert(is_termination_v<FixedIterations>,
              "FixedIterations must model the Termination concept");

}  // namespace diachron
