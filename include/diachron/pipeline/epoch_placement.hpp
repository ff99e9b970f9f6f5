#pragma once
/// @file
/// place_epochs(): every epoch of a site put into the reference epoch's frame by rough
/// co-registrations (Algorithm 1's first step for N epochs). Each free epoch is co-registered with
/// the reference directly; one that fails is co-registered with another free epoch already placed,
/// the best-trusted first, and carried on by that one's transform: a chain, which may grow as
/// epochs are placed (1954 through 1970 through 2014). A chain is no more trusted than its weakest
/// link. Generic over the pairwise co-registration, so any DSM matcher (or a test's fake) fits.

#include <algorithm>
#include <cstddef>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <diachron/core/error.hpp>
#include <diachron/geometry/helmert3.hpp>
#include <diachron/pipeline/rough_coregistration.hpp>

namespace diachron {

/// Where place_epochs put one epoch. Default: not placed.
struct EpochPlacement {
  bool placed = false;
  /// X_reference = scale R X_epoch + t; the identity for the reference itself.
  Helmert3 reference_from_epoch = Helmert3::identity();
  /// The co-registration that placed it (for a chain, the last link's, its `trust` lowered to the
  /// chain's weakest link), or the direct attempt's failure; default for the reference and for
  /// given transforms.
  RoughCoregistrationReport report;
  /// The epoch a chained placement went through.
  std::optional<std::size_t> via;
  /// The transform was given (not co-registered).
  bool given = false;
};

/// Places `count` epochs in the frame of epoch `reference`.
/// @param given per epoch, a transform into the reference known beforehand (nullopt: co-register
///        it); empty for none; its entry for the reference is ignored.
/// @param coregister callable `RoughCoregistrationReport(std::size_t from, std::size_t to)`: epoch
///        `from` co-registered with epoch `to` (report.epoch2_from_epoch1 maps from -> to), e.g.
///        rough_coregistration of their DSMs. Called for every free epoch not given (with `to` the
///        reference) in index order, then for chains, in order of the failed epochs and, for each,
///        of the placed epochs by trust (high first), then index.
/// @param on_attempt optional callable `void(std::size_t from, std::size_t to, const
///        RoughCoregistrationReport&)` told of every attempt (progress, logs).
/// Throws diachron::Error when `reference` >= count or `given` has another size than 0 or count.
template <class Coregister, class OnAttempt = void (*)(std::size_t, std::size_t, const RoughCoregistrationReport&)>
std::vector<EpochPlacement> place_epochs(std::size_t count, std::size_t reference,
                                         const std::vector<std::optional<Helmert3>>& given, Coregister&& coregister,
                                         OnAttempt&& on_attempt = [](std::size_t, std::size_t,
                                                                     const RoughCoregistrationReport&) {}) {
  DIACHRON_CHECK(reference < count, "place_epochs: reference " << reference << " outside [0, " << count << ")");
  DIACHRON_CHECK(given.empty() || given.size() == count,
                 "place_epochs: " << given.size() << " given transforms for " << count << " epochs");
  std::vector<EpochPlacement> out(count);
  out[reference].placed = true;
  for (std::size_t k = 0; k < count; ++k) {
    if (k == reference) continue;
    EpochPlacement& e = out[k];
    if (!given.empty() && given[k]) {
      e.placed = e.given = true;
      e.reference_from_epoch = *given[k];
      continue;
    }
    e.report = coregister(k, reference);
    on_attempt(k, reference, e.report);
    e.placed = e.report.success;
    if (e.placed) e.reference_from_epoch = e.report.epoch2_from_epoch1;
  }
  // A given transform counts as trusted: the user vouches for it.
  const auto trust = [&](std::size_t k) {
    return out[k].given ? static_cast<int>(RoughCoregistrationTrust::kHigh) : static_cast<int>(out[k].report.trust);
  };
  for (bool grew = true; grew;) {
    grew = false;
    std::vector<std::size_t> placed;  // free epochs placed, best-trusted first, then by index
    for (std::size_t k = 0; k < count; ++k)
      if (k != reference && out[k].placed) placed.push_back(k);
    std::stable_sort(placed.begin(), placed.end(), [&](std::size_t a, std::size_t b) { return trust(a) > trust(b); });
    for (std::size_t k = 0; k < count; ++k) {
      EpochPlacement& e = out[k];
      if (e.placed) continue;
      for (std::size_t f : placed) {
        RoughCoregistrationReport r = coregister(k, f);
        on_attempt(k, f, r);
        if (!r.success) continue;
        e.reference_from_epoch = out[f].reference_from_epoch * r.epoch2_from_epoch1;
        if (trust(f) < static_cast<int>(r.trust)) r.trust = static_cast<RoughCoregistrationTrust>(trust(f));
        e.report = std::move(r);
        e.via = f;
        e.placed = grew = true;
        break;
      }
    }
  }
  return out;
}

}  // namespace diachron
