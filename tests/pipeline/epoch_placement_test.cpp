// place_epochs with a fake pairwise co-registration that knows every epoch's true transform and
// succeeds only for the pairs it is told: direct placements, chains through the best-trusted epoch,
// a chain through an epoch placed by a chain, the weakest link's trust, given transforms, and an
// epoch nothing reaches.

#include <cmath>
#include <map>
#include <optional>
#include <utility>
#include <vector>

#include <catch2/catch.hpp>

#include <diachron/core/error.hpp>
#include <diachron/geometry/rotation.hpp>
#include <diachron/pipeline/epoch_placement.hpp>

using namespace diachron;

namespace {

using Trust = RoughCoregistrationTrust;

// Epoch k's true transform into a common world frame.
Helmert3 world_from(std::size_t k) {
  const double a = 0.3 + 0.4 * static_cast<double>(k);
  return {1.0 + 0.1 * static_cast<double>(k), rotation_from_axis_angle<double>(Eigen::Vector3d(0.2, -0.1, 1.0).normalized() * a),
          Eigen::Vector3d(10.0 * static_cast<double>(k), -5.0, 2.0 * static_cast<double>(k))};
}

// Co-registers `from` with `to` when the pair is in `works` (with that trust), exactly.
struct FakeCoregistration {
  std::map<std::pair<std::size_t, std::size_t>, Trust> works;
  std::vector<std::pair<std::size_t, std::size_t>>* calls = nullptr;
  RoughCoregistrationReport operator()(std::size_t from, std::size_t to) const {
    if (calls) calls->push_back({from, to});
    RoughCoregistrationReport r;
    const auto it = works.find({from, to});
    if (it == works.end()) {
      r.message = "no overlap";
      return r;
    }
    r.success = true;
    r.trust = it->second;
    r.epoch2_from_epoch1 = world_from(to).inverse() * world_from(from);
    r.message = "ok";
    return r;
  }
};

void check_placed(const EpochPlacement& p, std::size_t k, std::size_t reference) {
  REQUIRE(p.placed);
  const Helmert3 truth = world_from(reference).inverse() * world_from(k);
  const Eigen::Vector3d x(3.0, -7.0, 11.0);
  CHECK((p.reference_from_epoch(x) - truth(x)).norm() < 1e-9);
}

}  // namespace

TEST_CASE("place_epochs: direct, then chains through the best-trusted placed epoch", "[pipeline]") {
  // Reference 3. Epoch 1 directly (high), epoch 2 directly (low), epoch 0 only with 2 and 1 (tried
  // in that order of trust: 1 first), epoch 4 only with 0 (a chain through a chain).
  std::vector<std::pair<std::size_t, std::size_t>> calls;
  FakeCoregistration fake;
  fake.works = {{{1, 3}, Trust::kHigh}, {{2, 3}, Trust::kLow}, {{0, 2}, Trust::kHigh}, {{0, 1}, Trust::kHigh},
                {{4, 0}, Trust::kHigh}};
  fake.calls = &calls;
  std::vector<std::string> told;
  const std::vector<EpochPlacement> p =
      place_epochs(5, 3, {}, fake, [&](std::size_t from, std::size_t to, const RoughCoregistrationReport& r) {
        told.push_back(std::to_string(from) + "->" + std::to_string(to) + (r.success ? " ok" : " no"));
      });
  REQUIRE(p.size() == 5);
  for (std::size_t k = 0; k < 5; ++k) check_placed(p[k], k, 3);
  CHECK_FALSE(p[1].via);
  CHECK_FALSE(p[2].via);
  CHECK(p[0].via == std::optional<std::size_t>(1));  // the high-trust epoch first
  CHECK(p[4].via == std::optional<std::size_t>(0));
  CHECK(p[1].report.trust == Trust::kHigh);
  CHECK(p[2].report.trust == Trust::kLow);
  CHECK(p[0].report.trust == Trust::kHigh);
  // Direct attempts in index order; then epoch 0 through 1 (yes), epoch 4 through 1 and 2 (no); then,
  // with 0 placed and as trusted as 1, epoch 4 through 0 first (yes).
  const std::vector<std::pair<std::size_t, std::size_t>> expected = {{0, 3}, {1, 3}, {2, 3}, {4, 3},
                                                                     {0, 1}, {4, 1}, {4, 2}, {4, 0}};
  CHECK(calls == expected);
  CHECK(told.size() == calls.size());
  CHECK(told.front() == "0->3 no");
}

TEST_CASE("place_epochs: a chain is no more trusted than its weakest link", "[pipeline]") {
  FakeCoregistration fake;
  fake.works = {{{1, 2}, Trust::kLow}, {{0, 1}, Trust::kHigh}};
  const std::vector<EpochPlacement> p = place_epochs(3, 2, {}, fake);
  check_placed(p[0], 0, 2);
  CHECK(p[0].via == std::optional<std::size_t>(1));
  CHECK(p[0].report.trust == Trust::kLow);
}

TEST_CASE("place_epochs: given transforms are used as they are and may carry a chain", "[pipeline]") {
  std::vector<std::pair<std::size_t, std::size_t>> calls;
  FakeCoregistration fake;
  fake.works = {{{0, 1}, Trust::kHigh}};
  fake.calls = &calls;
  const Helmert3 given = world_from(2).inverse() * world_from(1);
  const std::vector<EpochPlacement> p = place_epochs(3, 2, {std::nullopt, given, std::nullopt}, fake);
  CHECK(p[1].given);
  check_placed(p[1], 1, 2);
  check_placed(p[0], 0, 2);
  CHECK(p[0].via == std::optional<std::size_t>(1));
  CHECK(calls == std::vector<std::pair<std::size_t, std::size_t>>{{0, 2}, {0, 1}});  // never 1 -> 2
}

TEST_CASE("place_epochs: an epoch nothing reaches stays unplaced with its direct failure", "[pipeline]") {
  FakeCoregistration fake;
  fake.works = {{{1, 2}, Trust::kHigh}};
  const std::vector<EpochPlacement> p = place_epochs(3, 2, {}, fake);
  CHECK(p[2].placed);  // the reference
  CHECK(p[1].placed);
  CHECK_FALSE(p[0].placed);
  CHECK_FALSE(p[0].report.success);
  CHECK(p[0].report.message == "no overlap");
  CHECK_THROWS_AS(place_epochs(3, 3, {}, fake), Error);
  CHECK_THROWS_AS(place_epochs(3, 2, {std::nullopt}, fake), Error);
}
