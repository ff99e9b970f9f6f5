#pragma once
/// @file
/// The Estimator concept consumed by diachron::Ransac, with detection traits for its required and
/// optional members.
///
/// Requirements for Estimator (a pseudo-class; every member const or static, so one estimator
/// object can serve many threads at once):
/// @code
/// struct MyEstimator {
///   using Datum = ...;                         // one correspondence, e.g. PointPair2
///   using Model = ...;                         // default-constructible, copyable
///   static constexpr std::size_t kSampleSize;  // data in a minimal sample (>= 1)
///   static constexpr std::size_t kMaxModels;   // most models one minimal sample can give (>= 1)
///   using Sample = std::array<Datum, kSampleSize>;
///   using Models = diachron::StaticVector<Model, kMaxModels>;
///
///   // Models that fit the sample exactly (0 when the sample gives none: degenerate, NaN).
///   // Must never return a model with non-finite parameters.
///   Models minimal(const Sample& sample) const;
///
///   // Distance of `datum` from `model`, in data units (NOT squared): pixels for 2D, metres (target
///   // frame) for 3D. Must be >= 0; +inf or NaN counts as an outlier.
///   double residual(const Model& model, const Datum& datum) const;
///
///   // OPTIONAL. Weighted least-squares fit on any number of data (>= kSampleSize). `weights` is
///   // null for unit weights, otherwise weights[i] >= 0 belongs to data[i]. `initial` is the model
///   // being refined (iterative refiners start from it; closed-form ones may ignore it).
///   // Returns nullopt when the data do not determine a model.
///   // Without it, Ransac's Refit local optimisation and final refit are skipped.
///   std::optional<Model> refine(const Model& initial, const Subset<Datum>& data,
///                               const double* weights) const;
///
///   // OPTIONAL. A callable `double(const Datum&)` equal to residual(model, .), built once per
///   // model so that per-model work (cos/sin of an angle, scale * R) leaves the per-datum loop.
///   // Without it, Ransac calls residual(model, datum) directly.
///   auto residual_function(const Model& model) const;
///
///   // OPTIONAL. True when the sample cannot give a meaningful model (coincident or collinear
///   // points). Ransac draws another sample instead. Without it every sample is tried.
///   bool degenerate(const Sample& sample) const;
/// };
/// @endcode
/// Models: Similarity2Estimator (geometry/similarity2_estimator.hpp), Helmert3Estimator
/// (geometry/helmert3_estimator.hpp). docs/concepts.md walks through writing a new one.

#include <array>
#include <cstddef>
#include <optional>
#include <type_traits>
#include <utility>

#include <diachron/core/static_vector.hpp>
#include <diachron/core/subset.hpp>

namespace diachron {

namespace detail {

template <class E, class = void>
struct has_estimator_types : std::false_type {};
template <class E>
struct has_estimator_types<E, std::void_t<typename E::Datum, typename E::Model, typename E::Sample,
                                          typename E::Models, decltype(E::kSampleSize),
                                          decltype(E::kMaxModels)>> : std::true_type {};

template <class E, class = void>
struct has_minimal : std::false_type {};
template <class E>
struct has_minimal<E, std::void_t<decltype(std::declval<const E&>().minimal(
                          std::declval<const typename E::Sample&>()))>> : std::true_type {};

template <class E, class = void>
struct has_residual : std::false_type {};
template <class E>
struct has_residual<E, std::enable_if_t<std::is_convertible_v<
                           decltype(std::declval<const E&>().residual(
                               std::declval<const typename E::Model&>(),
                               std::declval<const typename E::Datum&>())),
                           double>>> : std::true_type {};

template <class E, class = void>
struct has_refine : std::false_type {};
template <class E>
struct has_refine<E, std::void_t<decltype(std::declval<const E&>().refine(
                         std::declval<const typename E::Model&>(),
                         std::declval<const Subset<typename E::Datum>&>(),
                         std::declval<const double*>()))>> : std::true_type {};

template <class E, class = void>
struct has_degenerate : std::false_type {};
template <class E>
struct has_degenerate<E, std::void_t<decltype(std::declval<const E&>().degenerate(
                             std::declval<const typename E::Sample&>()))>> : std::true_type {};

template <class E, class = void>
struct has_residual_function : std::false_type {};
template <class E>
struct has_residual_function<
    E, std::enable_if_t<std::is_convertible_v<
           decltype(std::declval<const E&>().residual_function(std::declval<const typename E::Model&>())(
               std::declval<const typename E::Datum&>())),
           double>>> : std::true_type {};

}  // namespace detail

/// True when E provides the optional `residual_function` (see the requirements above).
template <class E>
inline constexpr bool estimator_has_residual_function_v = [] {
  if constexpr (detail::has_estimator_types<E>::value) {
    return detail::has_residual_function<E>::value;
  } else {
    return false;
  }
}();

/// The fastest way to evaluate residuals of one model: the estimator's residual_function when it
/// has one, else a callable that forwards to residual(). Holds a reference to `estimator`.
template <class E>
auto make_residual_function(const E& estimator, const typename E::Model& model) {
  if constexpr (estimator_has_residual_function_v<E>) {
    return estimator.residual_function(model);
  } else {
    return [&estimator, model](const typename E::Datum& datum) { return estimator.residual(model, datum); };
  }
}

/// True when E has the types and constants the Estimator concept requires.
template <class E>
inline constexpr bool has_estimator_types_v = detail::has_estimator_types<E>::value;

/// True when E satisfies the required part of the Estimator concept.
template <class E>
inline constexpr bool is_estimator_v = [] {
  if constexpr (detail::has_estimator_types<E>::value) {
    return detail::has_minimal<E>::value && detail::has_residual<E>::value;
  } else {
    return false;
  }
}();

/// True when E provides the optional weighted least-squares `refine`.
template <class E>
inline constexpr bool estimator_has_refine_v = [] {
  if constexpr (detail::has_estimator_types<E>::value) {
    return detail::has_refine<E>::value;
  } else {
    return false;
  }
}();

/// True when E provides the optional `degenerate` sample test.
template <class E>
inline constexpr bool estimator_has_degenerate_v = [] {
  if constexpr (detail::has_estimator_types<E>::value) {
    return detail::has_degenerate<E>::value;
  } else {
    return false;
  }
}();

/// Compile-time check with messages that name the missing member; use at the top of any template
/// that consumes an Estimator.
template <class E>
constexpr bool check_estimator() {
  static_assert(has_estimator_types_v<E>,
                "Estimator must define Datum, Model, Sample, Models, kSampleSize and kMaxModels "
                "(see diachron/robust/estimator.hpp)");
  if constexpr (has_estimator_types_v<E>) {
    static_assert(detail::has_minimal<E>::value,
                  "Estimator must have `Models minimal(const Sample&) const`");
    static_assert(detail::has_residual<E>::value,
                  "Estimator must have `double residual(const Model&, const Datum&) const`");
    static_assert(E::kSampleSize >= 1, "Estimator::kSampleSize must be at least 1");
    static_assert(E::kMaxModels >= 1, "Estimator::kMaxModels must be at least 1");
  }
  return true;
}

}  // namespace diachron
