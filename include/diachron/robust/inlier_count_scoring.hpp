#pragma once
/// @file
/// The Scoring concept of diachron::Ransac and classic RANSAC scoring, InlierCount.
///
/// Requirements for Scoring (a pseudo-class):
/// @code
/// struct MyScoring {
///   // Contribution of one datum to a model's score, from its residual r (data units, >= 0; +inf
///   // or NaN for a datum the model cannot explain) and the inlier threshold t > 0.
///   // Must lie in [0, 1] and be 0 whenever r > t or r is NaN. A larger sum is a better model;
///   // Ransac keeps a hypothesis only when its sum is STRICTLY larger than the best so far.
///   double gain(double residual, double threshold) const;
///
///   // When true, Ransac stops scoring a hypothesis as soon as the data left, each adding at most
///   // 1, can no longer lift its sum strictly above the best so far (with a margin for rounding):
///   // an exact bound, which changes nothing but the residual evaluations. It also enables the
///   // bail-out test (RansacOptions::bail_out_risk, robust/bail_out.hpp), which drops hypotheses
///   // whose score on a random sample is, with high confidence, below the best's. False scores
///   // every hypothesis on all data.
///   bool early_exit;
///
///   // OPTIONAL. A callable double(double squared_residual) giving the gain of an INLIER from its
///   // squared residual r2 (finite, 0 <= r2 <= squared_threshold, which Ransac picks so that
///   // this is exactly sqrt(r2) <= t): gain(sqrt(r2), t) up to rounding, in [0, 1]. Ransac
///   // multiplies it by the 0/1 inlier flag itself, so it needs no test and no branch. Lets
///   // Ransac score without a sqrt, a division or a branch per datum when the estimator's
///   // residual function has squared() (see robust/ransac_problem.hpp).
///   auto inlier_gain(double squared_threshold) const;
/// };
/// @endcode
/// Models: InlierCount (this header), Msac (robust/msac_scoring.hpp).
/// Because every gain is in [0, 1], the score reads as "effective inliers" for every model and the
/// early-exit bound needs no knowledge of the policy.

#include <type_traits>
#include <utility>

namespace diachron {

namespace detail {

template <class S, class = void>
struct is_scoring : std::false_type {};
template <class S>
struct is_scoring<
    S, std::enable_if_t<std::is_convertible_v<decltype(std::declval<const S&>().gain(0.0, 1.0)),
                                              double> &&
                        std::is_convertible_v<decltype(std::declval<const S&>().early_exit), bool>>>
    : std::true_type {};

}  // namespace detail

/// True when S satisfies the Scoring concept (see the requirements at the top of this header).
template <class S>
inline constexpr bool is_scoring_v = detail::is_scoring<S>::value;

/// Classic RANSAC (Fischler and Bolles 1981): the score is the number of inliers,
/// `residual <= threshold`. The paper's configuration.
struct InlierCount {
  /// Stop scoring a hypothesis once it cannot beat the best (exact; see the concept).
  bool early_exit = true;

  double gain(double residual, double threshold) const { return residual <= threshold ? 1.0 : 0.0; }

  /// The gain of an inlier from its squared residual (see the concept): always 1.
  auto inlier_gain(double squared_threshold) const {
    static_cast<void>(squared_threshold);
    return [](double) { return 1.0; };
  }
};

static_assert(is_scoring_v<InlierCount>, "InlierCount must model the Scoring concept");

}  // namespace diachron
