// Tests for validation/ground_filter.hpp: the 3D Helmert RANSAC filter of precise matching.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <set>
#include <vector>

#include <catch2/catch.hpp>
#include <Eigen/Geometry>

#include <diachron/core/random.hpp>
#include <diachron/terrain/transfer.hpp>
#include <diachron/validation/ground_filter.hpp>

#include "terrain/pinhole_test_frame.hpp"

using diachron::GroundFilterOptions;
using diachron::GroundFilterResult;
using diachron::Helmert3;
using diachron::PointMatch;
using diachron::PointMatches;

namespace {

// A DSM-like lift in a UTM frame: pixel -> (E, N, Z) on rolling terrain, 2 m per pixel.
Eigen::Vector3d ground(const Eigen::Vector2d& px) {
  const double e = 512000.0 + 2.0 * px.x(), n = 5042000.0 - 2.0 * px.y();
  return {e, n, 300.0 + 40.0 * std::sin(px.x() / 90.0) * std::cos(px.y() / 70.0)};
}

// The rough Helmert left an error `correction`: the master lift gives correction^-1 of the truth,
// so correction maps the lifted master points onto the secondary ones.
struct Scene {
  Helmert3 correction = Helmert3::from_yaw_pitch_roll(1.0004, 0.002, -0.001, 0.0005, {3.0, -2.0, 1.5});
  Eigen::Vector2d shift{37.25, -21.5};  // secondary pixel = master pixel + shift, for true matches
  double gsd = 2.0;

  std::optional<Eigen::Vector3d> master(const Eigen::Vector2d& a) const {
    return correction.inverse()(ground(Eigen::Vector2d(a + shift)));
  }
  std::optional<Eigen::Vector3d> secondary(const Eigen::Vector2d& b) const { return ground(b); }
};

// `inliers` true matches then `outliers` whose b is 40 to 200 px off (80 to 400 m, the threshold is
// 20 m), in shuffled order; `is_inlier` says which is which.
PointMatches make_matches(const Scene& scene, std::size_t inliers, std::size_t outliers, std::vector<char>& is_inlier,
                          std::uint64_t seed = 1) {
  diachron::RandomStream rng(seed);
  PointMatches matches;
  is_inlier.clear();
  for (std::size_t i = 0; i < inliers + outliers; ++i) {
    PointMatch m;
    // One draw per statement, y before x: the order of a call's arguments is unspecified
    // (core/random.hpp, "Order of draws").
    const double ay = rng.uniform(0.0, 1500.0);
    m.a = Eigen::Vector2d(rng.uniform(0.0, 1500.0), ay);
    m.b = m.a + scene.shift;
    const bool in = i < inliers;
    if (!in) {
      const double angle = rng.uniform(0.0, 2.0 * diachron::kPi), r = rng.uniform(40.0, 200.0);
      m.b += r * Eigen::Vector2d(std::cos(angle), std::sin(angle));
    }
    matches.push_back(m);
    is_inlier.push_back(in ? 1 : 0);
  }
  for (std::size_t i = matches.size(); i > 1; --i) {
    const std::size_t j = rng.uniform_index(i);
    std::swap(matches[i - 1], matches[j]);
    std::swap(is_inlier[i - 1], is_inlier[j]);
  }
  return matches;
}

}  // namespace

TEST_CASE("GroundFilter: lifts are DsmLift or any callable", "[validation]") {
  using Frame = diachron::test::PinholeFrame;
  using Transfer = diachron::DsmTransfer<Frame, Frame, Helmert3>;
  STATIC_REQUIRE(diachron::is_lift_v<diachron::DsmLift<Frame>>);
  const auto wrapped = [](const Transfer* t) {
    return [t](const Eigen::Vector2d& px) { return t->secondary_point(px); };
  };
  STATIC_REQUIRE(diachron::is_lift_v<decltype(wrapped(nullptr))>);
  STATIC_REQUIRE_FALSE(diachron::is_lift_v<Transfer>);  // a Transfer gives pixels, not points
  STATIC_REQUIRE_FALSE(diachron::is_lift_v<int>);
}

TEST_CASE("GroundFilter: Nominal, exact recovery in a UTM frame", "[validation]") {
  const Scene scene;
  std::vector<char> truth;
  const PointMatches matches = make_matches(scene, 150, 100, truth);
  const auto master = [&](const Eigen::Vector2d& a) { return scene.master(a); };
  const auto secondary = [&](const Eigen::Vector2d& b) { return scene.secondary(b); };

  const GroundFilterResult r = diachron::ground_filter(matches, master, secondary, scene.gsd);
  REQUIRE(r.success);
  CHECK(r.message.empty());
  REQUIRE(r.size() == matches.size());
  REQUIRE(r.score.size() == matches.size());
  CHECK(r.lifted == matches.size());
  CHECK(r.threshold == Approx(20.0));
  CHECK(r.iterations == 1000);  // the paper's fixed count
  CHECK(r.kept() == 150);
  for (std::size_t i = 0; i < matches.size(); ++i) {
    INFO("match " << i);
    CHECK(static_cast<bool>(r.keep[i]) == static_cast<bool>(truth[i]));
    if (truth[i])
      CHECK(r.score[i] < 1e-6);  // metres, at northings of 5e6: the solve was centred
    else
      CHECK(r.score[i] > r.threshold);
  }
  CHECK(r.rms < 1e-6);
  // The model is the correction, in the uncentred frame.
  const Eigen::Vector3d probe = ground(Eigen::Vector2d(700.0, 800.0));
  CHECK((r.model(probe) - scene.correction(probe)).norm() < 1e-6);
  CHECK(r.model.scale == Approx(scene.correction.scale).epsilon(1e-9));

  const std::vector<PointMatch> kept = diachron::select_kept(matches, r);
  CHECK(kept.size() == 150);
}

TEST_CASE("GroundFilter: each inlier kept once, minimum support", "[validation]") {
  // MicMac lists its 3 seeds twice; 10 inliers must give 10 kept matches, not 13.
  const Scene scene;
  std::vector<char> truth;
  const PointMatches matches = make_matches(scene, 10, 30, truth, 7);
  const auto master = [&](const Eigen::Vector2d& a) { return scene.master(a); };
  const auto secondary = [&](const Eigen::Vector2d& b) { return scene.secondary(b); };
  const GroundFilterResult r = diachron::ground_filter(matches, master, secondary, scene.gsd);
  REQUIRE(r.success);
  CHECK(r.kept() == 10);
  for (std::size_t i = 0; i < matches.size(); ++i) CHECK(static_cast<bool>(r.keep[i]) == static_cast<bool>(truth[i]));
  CHECK(diachron::select_kept(matches, r).size() == 10);
}

TEST_CASE("GroundFilter: matches that do not lift are counted, scored NaN and dropped", "[validation]") {
  const Scene scene;
  std::vector<char> truth;
  const PointMatches matches = make_matches(scene, 120, 40, truth, 3);
  // No DSM west of x = 200 (master) or south of y = 1300 (secondary), and a non-finite point.
  const auto master = [&](const Eigen::Vector2d& a) -> std::optional<Eigen::Vector3d> {
    if (a.x() < 200.0) return std::nullopt;
    if (a.y() < 50.0) return Eigen::Vector3d(std::nan(""), 0.0, 0.0);
    return scene.master(a);
  };
  const auto secondary = [&](const Eigen::Vector2d& b) -> std::optional<Eigen::Vector3d> {
    if (b.y() > 1300.0) return std::nullopt;
    return scene.secondary(b);
  };
  const GroundFilterResult r = diachron::ground_filter(matches, master, secondary, scene.gsd);
  REQUIRE(r.success);
  std::size_t no_master = 0, no_secondary = 0;
  for (std::size_t i = 0; i < matches.size(); ++i) {
    INFO("match " << i);
    const bool m_fail = matches[i].a.x() < 200.0 || matches[i].a.y() < 50.0;
    const bool s_fail = !m_fail && matches[i].b.y() > 1300.0;
    no_master += m_fail;
    no_secondary += s_fail;
    if (m_fail || s_fail) {
      CHECK(std::isnan(r.score[i]));
      CHECK(r.keep[i] == 0);
    } else {
      CHECK(static_cast<bool>(r.keep[i]) == static_cast<bool>(truth[i]));
    }
  }
  REQUIRE(no_master > 0);
  REQUIRE(no_secondary > 0);
  CHECK(r.master_not_lifted == no_master);
  CHECK(r.secondary_not_lifted == no_secondary);
  CHECK(r.lifted == matches.size() - no_master - no_secondary);
}

TEST_CASE("GroundFilter: too few lifted pairs give no verdict", "[validation]") {
  const Scene scene;
  std::vector<char> truth;
  const PointMatches matches = make_matches(scene, 9, 0, truth);
  const auto master = [&](const Eigen::Vector2d& a) { return scene.master(a); };
  const auto secondary = [&](const Eigen::Vector2d& b) { return scene.secondary(b); };
  const GroundFilterResult r = diachron::ground_filter(matches, master, secondary, scene.gsd);
  CHECK_FALSE(r.success);
  CHECK_THAT(r.message, Catch::Contains("9 of 9") && Catch::Contains("fewer than 10"));
  CHECK(r.size() == 9);
  CHECK(r.kept() == 0);
  CHECK(r.lifted == 9);
  CHECK(r.iterations == 0);

  GroundFilterOptions options;
  options.min_pairs = 9;
  CHECK(diachron::ground_filter(matches, master, secondary, scene.gsd, options).success);

  const GroundFilterResult empty = diachron::ground_filter(PointMatches{}, master, secondary, scene.gsd);
  CHECK_FALSE(empty.success);
  CHECK(empty.size() == 0);

  // All outliers: no model with support.
  const PointMatches wrong = make_matches(scene, 0, 30, truth, 11);
  const GroundFilterResult none = diachron::ground_filter(wrong, master, secondary, scene.gsd);
  CHECK_FALSE(none.success);
  CHECK_THAT(none.message, Catch::Contains("no Helmert"));
  CHECK(none.kept() == 0);

  const GroundFilterResult fresh;
  CHECK_FALSE(fresh.success);
  CHECK(fresh.size() == 0);
}

TEST_CASE("GroundFilter: deterministic whatever the threads", "[validation]") {
  const Scene scene;
  std::vector<char> truth;
  PointMatches matches = make_matches(scene, 100, 100, truth, 5);
  // Noise so that the model depends on which inliers are found.
  diachron::RandomStream rng(9);
  for (PointMatch& m : matches) {
    const double dy = rng.normal(0.0, 1.0);  // y before x, as in make_matches
    m.b += Eigen::Vector2d(rng.normal(0.0, 1.0), dy);
  }
  const auto master = [&](const Eigen::Vector2d& a) { return scene.master(a); };
  const auto secondary = [&](const Eigen::Vector2d& b) { return scene.secondary(b); };
  GroundFilterOptions options;
  options.threads = 1;
  const GroundFilterResult one = diachron::ground_filter(matches, master, secondary, scene.gsd, options);
  options.threads = 4;
  options.ransac.threads = 3;
  const GroundFilterResult four = diachron::ground_filter(matches, master, secondary, scene.gsd, options);
  REQUIRE(one.success);
  CHECK(one.keep == four.keep);
  for (std::size_t i = 0; i < matches.size(); ++i) CHECK(one.score[i] == four.score[i]);
  CHECK(one.model.translation == four.model.translation);
  CHECK(one.model.rotation == four.model.rotation);
  CHECK(one.rms == four.rms);
  CHECK(one.kept() >= 95);  // 1 px noise is 2 m against a 20 m threshold
}

TEST_CASE("GroundFilter: Options and invalid input", "[validation]") {
  const Scene scene;
  std::vector<char> truth;
  PointMatches matches = make_matches(scene, 20, 0, truth);
  const auto master = [&](const Eigen::Vector2d& a) { return scene.master(a); };
  const auto secondary = [&](const Eigen::Vector2d& b) { return scene.secondary(b); };

  GroundFilterOptions defaults;
  CHECK(defaults.threshold_gsd == 10.0);
  CHECK(defaults.min_pairs == 10);
  CHECK(defaults.ransac.max_iterations == 1000);
  CHECK(defaults.ransac.confidence == 1.0);
  CHECK(defaults.ransac.seed == 0);
  CHECK_NOTHROW(defaults.check());

  GroundFilterOptions o;
  o.threshold_gsd = 0.0;
  CHECK_THROWS_WITH(o.check(), Catch::Contains("threshold_gsd"));
  o = {};
  o.min_pairs = 3;
  CHECK_THROWS_WITH(diachron::ground_filter(matches, master, secondary, scene.gsd, o), Catch::Contains("min_pairs"));
  o = {};
  o.ransac.confidence = 0.0;
  CHECK_THROWS_AS(o.check(), diachron::Error);

  CHECK_THROWS_WITH(diachron::ground_filter(matches, master, secondary, 0.0), Catch::Contains("secondary_gsd"));

  // min_threshold raises the GSD threshold (20 m here) and never lowers it.
  o = {};
  o.min_threshold = 35.0;
  CHECK(diachron::ground_filter(matches, master, secondary, scene.gsd, o).threshold == 35.0);
  o.min_threshold = 5.0;
  CHECK(diachron::ground_filter(matches, master, secondary, scene.gsd, o).threshold == Approx(20.0));
  o.min_threshold = -1.0;
  CHECK_THROWS_WITH(o.check(), Catch::Contains("min_threshold must be finite and >= 0"));
  CHECK_THROWS_AS(diachron::ground_filter(matches, master, secondary, std::nan("")), diachron::Error);
  matches[4].b.x() = std::nan("");
  CHECK_THROWS_WITH(diachron::ground_filter(matches, master, secondary, scene.gsd), Catch::Contains("match 4"));
}
