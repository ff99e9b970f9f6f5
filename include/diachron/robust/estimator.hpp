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
///   using Sample = std::array<Datum, kSampleSize>;   // exactly this: Ransac fills it by index
///   using Models = diachron::StaticVector<Model, kMaxModels>;  // or any container of Model
///                                              // with empty(), size(), begin() and end()
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
/// Each OPTIONAL member is used only with exactly this signature (const included). A member of that
/// name with another signature is an error that check_estimator names, never silently ignored.
/// Models: Similarity2Estimator (geometry/similarity2_estimator.hpp), Helmert3Estimator
/// (geometry/helmert3_estimator.hpp), Homography2Estimator (geometry/homography2_estimator.hpp).
/// docs/concepts.md walks through writing a new one.

#include <array>
#include <cstddef>
#include <optional>
#include <type_traits>
#include <utility>

#include <diachron/core/static_vector.hpp>
#include <diachron/core/subset.hpp>

namespace diachron {

namespace detail {

// One trait per required type and constant, so that a failed check names the member missing.
template <class E, class = void>
struct has_datum_type : std::false_type {};
template <class E>
struct has_datum_type<E, std::void_t<typename E::Datum>> : std::true_type {};

template <class E, class = void>
struct has_model_type : std::false_type {};
template <class E>
struct has_model_type<E, std::void_t<typename E::Model>> : std::true_type {};

template <class E, class = void>
struct has_sample_type : std::false_type {};
template <class E>
struct has_sample_type<E, std::void_t<typename E::Sample>> : std::true_type {};

template <class E, class = void>
struct has_models_type : std::false_type {};
template <class E>
struct has_models_type<E, std::void_t<typename E::Models>> : std::true_type {};

// The constants must be compile-time std::size_t values (integral_constant rejects anything else).
template <class E, class = void>
struct has_sample_size : std::false_type {};
template <class E>
struct has_sample_size<E, std::void_t<std::integral_constant<std::size_t, E::kSampleSize>>>
    : std::true_type {};

template <class E, class = void>
struct has_max_models : std::false_type {};
template <class E>
struct has_max_models<E, std::void_t<std::integral_constant<std::size_t, E::kMaxModels>>>
    : std::true_type {};

template <class E>
struct has_estimator_types
    : std::conjunction<has_datum_type<E>, has_model_type<E>, has_sample_type<E>,
                       has_models_type<E>, has_sample_size<E>, has_max_models<E>> {};

// Ransac fills a Sample by index (sample[k] = data[i], k < kSampleSize) and needs no allocation
// for it: a std::vector<Datum> would compile and write past its end.
template <class E>
inline constexpr bool sample_is_array_v =
    std::is_same_v<typename E::Sample, std::array<typename E::Datum, E::kSampleSize>>;

// What Ransac does with Models: empty(), size() and a range-for over const Model&.
template <class E, class = void>
struct models_is_container : std::false_type {};
template <class E>
struct models_is_container<
    E, std::enable_if_t<
           std::is_convertible_v<decltype(std::declval<const typename E::Models&>().empty()),
                                 bool> &&
           std::is_convertible_v<decltype(std::declval<const typename E::Models&>().size()),
                                 std::size_t> &&
           std::is_convertible_v<decltype(*std::declval<const typename E::Models&>().begin()),
                                 const typename E::Model&> &&
           std::is_same_v<decltype(std::declval<const typename E::Models&>().begin()),
                          decltype(std::declval<const typename E::Models&>().end())>>>
    : std::true_type {};

template <class E, class = void>
struct has_minimal : std::false_type {};
template <class E>
struct has_minimal<E, std::enable_if_t<std::is_convertible_v<
                          decltype(std::declval<const E&>().minimal(
                              std::declval<const typename E::Sample&>())),
                          typename E::Models>>> : std::true_type {};

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
struct has_refine<E, std::enable_if_t<std::is_same_v<
                         decltype(std::declval<const E&>().refine(
                             std::declval<const typename E::Model&>(),
                             std::declval<const Subset<typename E::Datum>&>(),
                             std::declval<const double*>())),
                         std::optional<typename E::Model>>>> : std::true_type {};

template <class E, class = void>
struct has_degenerate : std::false_type {};
template <class E>
struct has_degenerate<E, std::enable_if_t<std::is_convertible_v<
                             decltype(std::declval<const E&>().degenerate(
                                 std::declval<const typename E::Sample&>())),
                             bool>>> : std::true_type {};

template <class E, class = void>
struct has_residual_function : std::false_type {};
template <class E>
struct has_residual_function<
    E, std::enable_if_t<std::is_convertible_v<
           decltype(std::declval<const E&>().residual_function(std::declval<const typename E::Model&>())(
               std::declval<const typename E::Datum&>())),
           double>>> : std::true_type {};

// Whether E declares a member of a given name at all, whatever its signature, const-ness, access
// or overloads: in a class derived from both E and a probe that declares the name, naming it is
// ambiguous exactly when E declares it too. An optional member that is declared but does not match
// the concept would otherwise be ignored without a word (a non-const refine: no local
// optimisation, no final refit). Final classes and non-classes cannot be probed and count as
// declaring nothing.
struct OptionalMemberNames {
  int refine;
  int degenerate;
  int residual_function;
};
template <class E>
struct OptionalMemberProbe : E, OptionalMemberNames {};

template <class E, class = void>
struct declares_refine : std::true_type {};
template <class E>
struct declares_refine<E, std::void_t<decltype(&OptionalMemberProbe<E>::refine)>>
    : std::false_type {};
template <class E, class = void>
struct declares_degenerate : std::true_type {};
template <class E>
struct declares_degenerate<E, std::void_t<decltype(&OptionalMemberProbe<E>::degenerate)>>
    : std::false_type {};
template <class E, class = void>
struct declares_residual_function : std::true_type {};
template <class E>
struct declares_residual_function<
    E, std::void_t<decltype(&OptionalMemberProbe<E>::residual_function)>> : std::false_type {};

template <class E>
inline constexpr bool probeable_v = std::is_class_v<E> && !std::is_final_v<E>;

}  // namespace detail

/// True when E has all six types and constants the Estimator concept requires.
template <class E>
inline constexpr bool has_estimator_types_v = detail::has_estimator_types<E>::value;

/// True when E provides the optional `residual_function` (see the requirements above).
template <class E>
inline constexpr bool estimator_has_residual_function_v = [] {
  if constexpr (has_estimator_types_v<E>) {
    return detail::has_residual_function<E>::value;
  } else {
    return false;
  }
}();

/// True when E provides the optional weighted least-squares `refine` with the concept's signature
/// (const, returning std::optional<Model>). Without it Ransac skips local optimisation and the
/// final refit, so estimators meant to have one should assert it:
/// `static_assert(diachron::estimator_has_refine_v<MyEstimator>);`.
template <class E>
inline constexpr bool estimator_has_refine_v = [] {
  if constexpr (has_estimator_types_v<E>) {
    return detail::has_refine<E>::value;
  } else {
    return false;
  }
}();

/// True when E provides the optional `degenerate` sample test.
template <class E>
inline constexpr bool estimator_has_degenerate_v = [] {
  if constexpr (has_estimator_types_v<E>) {
    return detail::has_degenerate<E>::value;
  } else {
    return false;
  }
}();

/// True when E declares a member named `refine`, `degenerate` or `residual_function` that does not
/// have the concept's signature: Ransac would silently ignore it, so the Estimator concept rejects
/// it (check_estimator names it).
template <class E>
inline constexpr bool estimator_has_mismatched_optional_v = [] {
  if constexpr (has_estimator_types_v<E> && detail::probeable_v<E>) {
    return (detail::declares_refine<E>::value && !detail::has_refine<E>::value) ||
           (detail::declares_degenerate<E>::value && !detail::has_degenerate<E>::value) ||
           (detail::declares_residual_function<E>::value &&
            !detail::has_residual_function<E>::value);
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

/// True when E satisfies the Estimator concept: every required member as specified, and no
/// optional member declared with another signature.
template <class E>
inline constexpr bool is_estimator_v = [] {
  if constexpr (has_estimator_types_v<E>) {
    return E::kSampleSize >= 1 && E::kMaxModels >= 1 && detail::sample_is_array_v<E> &&
           detail::models_is_container<E>::value && detail::has_minimal<E>::value &&
           detail::has_residual<E>::value && !estimator_has_mismatched_optional_v<E>;
  } else {
    return false;
  }
}();

/// Compile-time check of the Estimator concept, one static_assert per member so that the message
/// names the member that is missing or wrong; use at the top of any template that consumes an
/// Estimator. Returns true when it compiles.
template <class E>
constexpr bool check_estimator() {
  static_assert(detail::has_datum_type<E>::value,
                "Estimator must define `using Datum = ...;` (one datum, e.g. PointPair2)");
  static_assert(detail::has_model_type<E>::value,
                "Estimator must define `using Model = ...;` (what minimal() and refine() return)");
  static_assert(detail::has_sample_size<E>::value,
                "Estimator must define `static constexpr std::size_t kSampleSize` (data in a "
                "minimal sample)");
  static_assert(detail::has_max_models<E>::value,
                "Estimator must define `static constexpr std::size_t kMaxModels` (most models one "
                "minimal sample can give)");
  static_assert(detail::has_sample_type<E>::value,
                "Estimator must define `using Sample = std::array<Datum, kSampleSize>;`");
  static_assert(detail::has_models_type<E>::value,
                "Estimator must define `using Models = diachron::StaticVector<Model, kMaxModels>;`");
  if constexpr (has_estimator_types_v<E>) {
    static_assert(E::kSampleSize >= 1, "Estimator::kSampleSize must be at least 1");
    static_assert(E::kMaxModels >= 1, "Estimator::kMaxModels must be at least 1");
    static_assert(detail::sample_is_array_v<E>,
                  "Estimator::Sample must be exactly std::array<Datum, kSampleSize>: Ransac "
                  "writes sample[0] to sample[kSampleSize - 1] into a default-constructed Sample");
    static_assert(detail::models_is_container<E>::value,
                  "Estimator::Models must be a container of Model with empty(), size(), begin() "
                  "and end(), e.g. diachron::StaticVector<Model, kMaxModels>");
    static_assert(detail::has_minimal<E>::value,
                  "Estimator must have `Models minimal(const Sample&) const`");
    static_assert(detail::has_residual<E>::value,
                  "Estimator must have `double residual(const Model&, const Datum&) const`");
    if constexpr (detail::probeable_v<E>) {
      static_assert(!detail::declares_refine<E>::value || detail::has_refine<E>::value,
                    "Estimator declares `refine`, but not as `std::optional<Model> refine(const "
                    "Model&, const Subset<Datum>&, const double*) const`: Ransac would skip local "
                    "optimisation and the final refit. Fix the signature (const included) or "
                    "rename the member");
      static_assert(!detail::declares_degenerate<E>::value || detail::has_degenerate<E>::value,
                    "Estimator declares `degenerate`, but not as `bool degenerate(const Sample&) "
                    "const`: Ransac would never call it. Fix the signature or rename the member");
      static_assert(
          !detail::declares_residual_function<E>::value ||
              detail::has_residual_function<E>::value,
          "Estimator declares `residual_function`, but not as a const member taking `const "
          "Model&` and returning a callable `double(const Datum&)`: Ransac would never call it. "
          "Fix the signature or rename the member");
    }
  }
  return true;
}

}  // namespace diachron
