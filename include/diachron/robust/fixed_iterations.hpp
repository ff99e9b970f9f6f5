#pragma once
/// @file
/// The Termination concept of diachron::Ransac and its simplest model, FixedIterations.
///
/// Requirements for Termination (a pseudo-class). It has ONE of the two forms of
/// required_iterations; the second sees the whole state of the run.
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
///
///   // OR: the same question, given everything Ransac knows after `state.iterations` iterations
///   // (see TerminationState: the iteration count, the sampler's pool size and, on request, the
///   // best model's inlier indices). Same rules.
///   std::size_t required_iterations(const RansacOptions& options,
///                                   const TerminationState& state) const;
///
///   // OPTIONAL. When true, Ransac fills TerminationState::best_inlier_indices: one more pass over
///   // the data each time the best model changes (rarely, and deterministically).
///   static constexpr bool kNeedsBestInliers = true;
///
///   // OPTIONAL. Called once per run, before the first required_iterations, on Ransac's own copy
///   // of the policy (precomputation that depends on the data size; a run never changes the
///   // user's object).
///   void prepare(std::size_t num_data, std::size_t sample_size);
/// };
/// @endcode
/// Models: FixedIterations (this header), Adaptive (robust/adaptive_termination.hpp),
/// ProsacTermination (robust/prosac_termination.hpp).

#include <cstddef>
#include <type_traits>
#include <utility>
#include <vector>

#include <diachron/robust/ransac_options.hpp>

namespace diachron {

/// What a Termination policy may know about a run (the second form of required_iterations).
struct TerminationState {
  /// Iterations done so far (minimal samples drawn, redraws of degenerate samples not counted):
  /// 0 before the first.
  std::size_t iterations = 0;
  /// Inliers of the best model so far; 0 before there is one.
  std::size_t best_inliers = 0;
  /// Data in the run, and data in a minimal sample (Estimator::kSampleSize).
  std::size_t num_data = 0;
  std::size_t sample_size = 0;
  /// Data the sampler draws the next sample from: the sampler's pool_size(iterations) when it has
  /// one (ProsacSampler: the top n of the quality-sorted data), else num_data.
  std::size_t pool_size = 0;
  /// The best model's inliers, as increasing indices into the data; null unless the policy sets
  /// kNeedsBestInliers and there is a best model. Valid during the call only.
  const std::vector<std::size_t>* best_inlier_indices = nullptr;
};

namespace detail {

template <class T, class = void>
struct has_plain_required_iterations : std::false_type {};
template <class T>
struct has_plain_required_iterations<
    T, std::enable_if_t<std::is_convertible_v<
           decltype(std::declval<const T&>().required_iterations(
               std::declval<const RansacOptions&>(), std::size_t{}, std::size_t{}, std::size_t{})),
           std::size_t>>> : std::true_type {};

template <class T, class = void>
struct has_state_required_iterations : std::false_type {};
template <class T>
struct has_state_required_iterations<
    T, std::enable_if_t<std::is_convertible_v<
           decltype(std::declval<const T&>().required_iterations(
               std::declval<const RansacOptions&>(), std::declval<const TerminationState&>())),
           std::size_t>>> : std::true_type {};

template <class T, class = void>
struct termination_needs_best_inliers : std::false_type {};
template <class T>
struct termination_needs_best_inliers<T, std::enable_if_t<T::kNeedsBestInliers>>
    : std::true_type {};

template <class T, class = void>
struct termination_has_prepare : std::false_type {};
template <class T>
struct termination_has_prepare<
    T, std::void_t<decltype(std::declval<T&>().prepare(std::size_t{}, std::size_t{}))>>
    : std::true_type {};

}  // namespace detail

/// True when T satisfies the Termination concept (see the requirements at the top of this header).
template <class T>
inline constexpr bool is_termination_v = detail::has_plain_required_iterations<T>::value ||
                                         detail::has_state_required_iterations<T>::value;

/// The answer of Termination `termination` to `state`, through whichever form it has (the state
/// form when it has both).
template <class T>
std::size_t required_iterations(const T& termination, const RansacOptions& options,
                                const TerminationState& state) {
  if constexpr (detail::has_state_required_iterations<T>::value) {
    return termination.required_iterations(options, state);
  } else {
    return termination.required_iterations(options, state.best_inliers, state.num_data,
                                           state.sample_size);
  }
}

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
