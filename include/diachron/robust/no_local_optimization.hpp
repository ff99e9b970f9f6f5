#pragma once
/// @file
/// The LocalOptimization concept of diachron::Ransac and its empty model, NoLocalOptimization.
///
/// Requirements for LocalOptimization (a pseudo-class):
/// @code
/// struct MyLocalOptimization {
///   // Called, sequentially and in iteration order, each time a hypothesis has STRICTLY beaten the
///   // best so far; `model` is that hypothesis and `support` its complete support.
///   // Either replaces both by a model whose complete support has a strictly larger score and
///   // returns true, or leaves both untouched and returns false. May allocate (it runs rarely).
///   // Adds the residuals it computes to `residual_evaluations`.
///   // Must not call problem.estimator().refine with fewer than Estimator::kSampleSize data.
///   template <class Estimator, class Scoring>
///   bool optimize(const RansacProblem<Estimator, Scoring>& problem,
///                 typename Estimator::Model& model, Support& support,
///                 std::size_t& residual_evaluations) const;
/// };
/// @endcode
/// Models: NoLocalOptimization (this header), Refit (robust/refit_local_optimization.hpp).

#include <cstddef>
#include <type_traits>
#include <utility>

#include <diachron/robust/ransac_problem.hpp>

namespace diachron {

namespace detail {

template <class L, class E, class S, class = void>
struct is_local_optimization : std::false_type {};
template <class L, class E, class S>
struct is_local_optimization<
    L, E, S,
    std::enable_if_t<std::is_convertible_v<
        decltype(std::declval<const L&>().optimize(
            std::declval<const RansacProblem<E, S>&>(), std::declval<typename E::Model&>(),
            std::declval<Support&>(), std::declval<std::size_t&>())),
        bool>>> : std::true_type {};

}  // namespace detail

/// True when L satisfies the LocalOptimization concept for estimator E and scoring S (see the
/// requirements at the top of this header).
template <class L, class E, class S>
inline constexpr bool is_local_optimization_v = detail::is_local_optimization<L, E, S>::value;

/// Keeps every hypothesis as the minimal solver gave it: plain RANSAC, as in the paper.
struct NoLocalOptimization {
  template <class Estimator, class Scoring>
  bool optimize(const RansacProblem<Estimator, Scoring>& /*problem*/,
                typename Estimator::Model& /*model*/, Support& /*support*/,
                std::size_t& /*residual_evaluations*/) const {
    return false;
  }
};

}  // namespace diachron
