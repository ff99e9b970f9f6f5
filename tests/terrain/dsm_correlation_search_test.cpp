#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <diachron/core/error.hpp>
#include <diachron/core/progress.hpp>
#include <diachron/terrain/dsm_correlation_search.hpp>

namespace {

// Smooth terrain: a sum of Gaussian hills and hollows drawn by a small deterministic generator.
struct Terrain {
  std::vector<Eigen::Vector4d> bumps;  // x, y, sigma, amplitude
  explicit Terrain(std::uint64_t seed) {
    std::uint64_t s = seed;
    auto next = [&] {
      s = s * 6364136223846793005ULL + 1442695040888963407ULL;
      return static_cast<double>(s >> 11) / 9007199254740992.0;
    };
    for (int i = 0; i < 60; ++i)
      bumps.emplace_back(-40.0 + 200.0 * next(), -40.0 + 200.0 * next(), 4.0 + 10.0 * next(), (next() - 0.5) * 80.0);
  }
  double operator()(double x, double y) const {
    double z = 500.0;
    for (const auto& b : bumps) z += b[3] * std::exp(-((x - b[0]) * (x - b[0]) + (y - b[1]) * (y - b[1])) / (2.0 * b[2] * b[2]));
    return z;
  }
};

// Secondary: the terrain on a size x size grid of unit cells. Master: a w x h grid whose pixel p shows
// the terrain at truth(p) = ratio R(angle) p + t, with heights in the master frame's units.
struct Case {
  diachron::Dsm master, secondary;
  double ratio, angle;
  Eigen::Vector2d t;
  Eigen::Vector2d truth(const Eigen::Vector2d& p) const {
    return ratio * Eigen::Rotation2Dd(angle).toRotationMatrix() * p + t;
  }
};

Case make_case(const Terrain& secondary_terrain, const Terrain& master_terrain, double ratio, double angle_deg,
               const Eigen::Vector2d& master_centre_in_secondary, int w, int h, bool holes, int size = 120) {
  Case c;
  c.ratio = ratio;
  c.angle = angle_deg * diachron::kPi / 180.0;
  diachron::Raster<float> s(size, size);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) s(x, y) = static_cast<float>(secondary_terrain(x, y));
  const Eigen::Vector2d mc(0.5 * (w - 1), 0.5 * (h - 1));
  c.t = master_centre_in_secondary - ratio * Eigen::Rotation2Dd(c.angle).toRotationMatrix() * mc;
  diachron::Raster<float> m(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const Eigen::Vector2d q = c.truth(Eigen::Vector2d(x, y));
      // A master cell is `ratio` secondary cells: the master frame's unit is 1 / ratio of the
      // secondary's, for heights too (a 3D similarity), on another datum.
      m(x, y) = static_cast<float>((master_terrain(q.x(), q.y()) - 500.0) / ratio + 123.0);
    }
  if (holes) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    for (int y = 0; y < size; ++y)
      for (int x = 0; x < size; ++x)
        if (std::hypot(x - 30, y - 80) < 9 || std::hypot(x - 90, y - 20) < 6) s(x, y) = nan;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        if (std::hypot(x - 0.3 * w, y - 0.6 * h) < 5) m(x, y) = nan;
  }
  // Same handedness on both sides (north-up); the master's cell is 1 of its own units.
  c.secondary = diachron::Dsm(s, diachron::GeoTransform::north_up(0.0, size, 1.0));
  c.master = diachron::Dsm(m, diachron::GeoTransform::north_up(0.0, h, 1.0));
  return c;
}

// A coarser grid than the defaults (fewer hypotheses) keeps these tests quick.
diachron::DsmCorrelationSearchOptions quick_options() {
  diachron::DsmCorrelationSearchOptions o;
  o.angle_step_deg = 15.0;
  o.frame_scale_range = 1.6;
  return o;
}

double max_error_px(const Case& c, const diachron::DsmCorrelationResult& r) {
  double e = 0.0;
  for (const Eigen::Vector2d& p : {Eigen::Vector2d(0, 0), Eigen::Vector2d(c.master.width() - 1, 0),
                                   Eigen::Vector2d(0, c.master.height() - 1),
                                   Eigen::Vector2d(c.master.width() - 1, c.master.height() - 1)})
    e = std::max(e, (r(p) - c.truth(p)).norm());
  return e;
}

// The search found the case's similarity: its scale within `scale_tolerance` (relative), its angle
// within 2 degrees, the master's corners within 2 secondary pixels, at a high score.
void check_recovered(const Case& c, const diachron::DsmCorrelationResult& r, double scale_tolerance) {
  INFO(r.message);
  REQUIRE(r.success);
  CHECK(r.scale == Approx(c.ratio).epsilon(scale_tolerance));
  CHECK(std::abs(std::remainder(r.angle - c.angle, 2.0 * diachron::kPi)) < diachron::deg_to_rad(2.0));
  // The master's corners lie up to 30 secondary pixels from its centre: about a pixel of precision.
  CHECK(max_error_px(c, r) < 2.0);
  CHECK(r.score > 0.95);
}

}  // namespace

TEST_CASE("DsmCorrelationSearch: recovers a known rotation, scale and shift, height units and datum aside", "[terrain]") {
  const Terrain terrain(11);
  const Case c = make_case(terrain, terrain, 1.4, 127.0, {42.0, 38.0}, 32, 28, false, 84);
  const diachron::DsmCorrelationResult r = diachron::dsm_correlation_search(c.master, c.secondary);
  check_recovered(c, r, 0.02);
  INFO(r.message);
  CHECK_FALSE(r.mirrored);
  CHECK(r.hypotheses > 100);
  CHECK(r.height_gain == Approx(r.expected_gain).epsilon(0.05));
  // Correspondences lie on the truth: secondary X/Y of each is where the truth puts its master cell.
  const std::vector<diachron::PointPair3> pairs = diachron::dsm_correlation_correspondences(c.master, c.secondary, r, 200);
  CHECK(pairs.size() > 100);
}

TEST_CASE("DsmCorrelationSearch: partial overlap and holes on both sides", "[terrain]") {
  const Terrain terrain(23);
  // The master's centre maps near the secondary's right edge: about half of it lies outside.
  const Case c = make_case(terrain, terrain, 0.8, -64.0, {112.0, 60.0}, 70, 60, true);
  const diachron::DsmCorrelationResult r = diachron::dsm_correlation_search(c.master, c.secondary, quick_options());
  INFO(r.message);
  REQUIRE(r.success);
  CHECK(max_error_px(c, r) < 2.0);
}

TEST_CASE("DsmCorrelationSearch: the result does not depend on the threads", "[terrain]") {
  const Terrain terrain(23);
  // Holes on both sides, so that scales see different valid counts and take different times.
  const Case c = make_case(terrain, terrain, 1.2, -64.0, {44.0, 40.0}, 32, 28, true, 84);
  diachron::DsmCorrelationSearchOptions o = quick_options();
  o.threads = 1;
  const diachron::DsmCorrelationResult one = diachron::dsm_correlation_search(c.master, c.secondary, o);
  // 3 threads on fewer cores: more workers than cores, items handed out unevenly.
  for (std::size_t threads : {std::size_t{2}, std::size_t{3}}) {
    o.threads = threads;
    const diachron::DsmCorrelationResult many = diachron::dsm_correlation_search(c.master, c.secondary, o);
    INFO("threads " << threads);
    CHECK(many.success == one.success);
    CHECK(many.hypotheses == one.hypotheses);
    // Bit for bit: each scale and candidate is computed alone, and gathered in a fixed order.
    CHECK(many.scale == one.scale);
    CHECK(many.angle == one.angle);
    CHECK(many.translation == one.translation);
    CHECK(many.score == one.score);
    CHECK(many.strength == one.strength);
    CHECK(many.runner_up_strength == one.runner_up_strength);
    CHECK(many.height_gain == one.height_gain);
    CHECK(many.tiles.agree == one.tiles.agree);
    CHECK(many.tile_chance == one.tile_chance);
    CHECK(many.message == one.message);
  }
  CHECK(one.success);
}

TEST_CASE("DsmCorrelationSearch: progress counts the scales, then the candidates", "[terrain]") {
  const Terrain terrain(11);
  const Case c = make_case(terrain, terrain, 1.4, 127.0, {42.0, 38.0}, 32, 28, false, 84);
  diachron::DsmCorrelationSearchOptions o = quick_options();
  o.threads = 2;
  std::vector<diachron::ProgressEvent> events;
  o.progress = [&](const diachron::ProgressEvent& e) { events.push_back(e); };  // the library serialises the calls
  const diachron::DsmCorrelationResult r = diachron::dsm_correlation_search(c.master, c.secondary, o);
  REQUIRE(r.success);
  std::map<std::string, std::vector<std::size_t>> done;
  std::vector<std::string> order;
  for (const auto& e : events) {
    if (done.find(e.stage) == done.end()) order.push_back(e.stage);
    done[e.stage].push_back(e.done);
    CHECK(e.done <= e.total);
  }
  REQUIRE(order == std::vector<std::string>{"correlation search: coarse scales", "correlation search: candidates"});
  // frame_scale_range 1.6 at 4 scales per octave: ceil(log2(1.6) * 4) = 3 on each side of the ratio.
  CHECK(done[order[0]] == std::vector<std::size_t>{0, 1, 2, 3, 4, 5, 6, 7});
  CHECK(done[order[1]] == std::vector<std::size_t>{0, 1, 2, 3, 4});
  CHECK(events.back().total == 4);
}

TEST_CASE("DsmCorrelationSearch: CorrelationStrength::samples counts pixels, share counts the footprint", "[terrain]") {
  using diachron::detail::correlation_strength;
  // Share: a whole small template and a whole large one weigh the same; samples: the large one more.
  CHECK(correlation_strength(0.9, 100.0, 100.0) == Approx(correlation_strength(0.9, 1000.0, 1000.0)));
  CHECK(correlation_strength(0.9, 400.0, 1024.0, false) == Approx(std::atanh(0.9) * std::sqrt(400.0 / 1024.0)));
  CHECK(correlation_strength(0.9, 4096.0, 1024.0, false) == Approx(2.0 * std::atanh(0.9)));
  CHECK(correlation_strength(0.9, 4096.0, 1024.0) == Approx(std::atanh(0.9)));  // capped at the whole reference
  // The whole search with each (and with the heights, the earlier default): the same answer.
  const Terrain terrain(23);
  const Case c = make_case(terrain, terrain, 0.8, -64.0, {112.0, 60.0}, 70, 60, true);
  using diachron::CorrelationSignal;
  using diachron::CorrelationStrength;
  for (const auto& [signal, strength] : {std::pair{CorrelationSignal::gradient, CorrelationStrength::samples},
                                         std::pair{CorrelationSignal::gradient, CorrelationStrength::share},
                                         std::pair{CorrelationSignal::heights, CorrelationStrength::share}}) {
    diachron::DsmCorrelationSearchOptions o = quick_options();
    o.signal = signal;
    o.strength = strength;
    const diachron::DsmCorrelationResult r = diachron::dsm_correlation_search(c.master, c.secondary, o);
    INFO(r.message);
    REQUIRE(r.success);
    CHECK(max_error_px(c, r) < 2.0);
    CHECK(r.strength > r.runner_up_strength + o.min_margin);
  }
}

TEST_CASE("DsmCorrelationSearch: with the margin out of reach, the tiles answer, unless two places hold", "[terrain]") {
  const Terrain terrain(11);
  const Case c = make_case(terrain, terrain, 1.4, 127.0, {42.0, 38.0}, 32, 28, false, 84);
  diachron::DsmCorrelationSearchOptions o = quick_options();
  o.min_margin = 1.99;  // no winner stands out by that much
  const diachron::DsmCorrelationResult by_tiles = diachron::dsm_correlation_search(c.master, c.secondary, o);
  INFO(by_tiles.message);
  REQUIRE(by_tiles.success);
  CHECK(by_tiles.by_tiles);
  CHECK(max_error_px(c, by_tiles) < 2.0);
  CHECK(by_tiles.tiles.tiles >= 8);
  CHECK(by_tiles.tile_chance <= o.max_tile_chance);
  CHECK(by_tiles.competitor_tile_chance > o.max_tile_chance);
  CHECK(by_tiles.message.find("tiles agree") != std::string::npos);
  // The same without the alternative: no answer, and the message says why.
  o.max_tile_chance = 0.0;
  const diachron::DsmCorrelationResult margin_only = diachron::dsm_correlation_search(c.master, c.secondary, o);
  CHECK_FALSE(margin_only.success);
  CHECK_FALSE(margin_only.by_tiles);
  CHECK(margin_only.message.find("margin below") != std::string::npos);

  // The secondary holds the master's ground twice, side by side: the winner's tiles agree, and so do
  // those of the candidate at the other copy, so there is no answer by tiles.
  o.max_tile_chance = 1e-3;
  diachron::Raster<float> twice(168, 84);
  for (int y = 0; y < 84; ++y)
    for (int x = 0; x < 168; ++x) twice(x, y) = c.secondary.heights()(x % 84, y);
  const diachron::Dsm secondary(twice, diachron::GeoTransform::north_up(0.0, 84, 1.0));
  const diachron::DsmCorrelationResult two = diachron::dsm_correlation_search(c.master, secondary, o);
  INFO(two.message);
  CHECK_FALSE(two.success);
  CHECK(two.tile_chance <= o.max_tile_chance);
  CHECK(two.competitor_tile_chance <= o.max_tile_chance);
}

TEST_CASE("DsmCorrelationSearch: no answer on unrelated DSMs", "[terrain]") {
  const Case c = make_case(Terrain(5), Terrain(99), 1.2, 30.0, {60.0, 60.0}, 40, 40, false);
  const diachron::DsmCorrelationResult r = diachron::dsm_correlation_search(c.master, c.secondary, quick_options());
  INFO(r.message);
  CHECK_FALSE(r.success);
  CHECK_FALSE(r.by_tiles);
  CHECK_FALSE(r.message.empty());
}

TEST_CASE("DsmCorrelationSearch: bad input throws diachron::Error", "[terrain]") {
  const Terrain terrain(1);
  const Case c = make_case(terrain, terrain, 1.0, 0.0, {60.0, 60.0}, 30, 30, false);
  CHECK_THROWS_AS(diachron::dsm_correlation_search(diachron::Dsm(), c.secondary), diachron::Error);
  diachron::DsmCorrelationSearchOptions o;
  o.frame_scale_range = 0.5;
  CHECK_THROWS_AS(diachron::dsm_correlation_search(c.master, c.secondary, o), diachron::Error);
  o = {};
  o.angle_step_deg = 0.0;
  CHECK_THROWS_AS(diachron::dsm_correlation_search(c.master, c.secondary, o), diachron::Error);
  diachron::DsmCorrelationResult r;
  CHECK_THROWS_AS(diachron::dsm_correlation_correspondences(c.master, c.secondary, r, 0), diachron::Error);
}

TEST_CASE("DsmCorrelationSearch: the gradient signal finds a master tilted against the secondary", "[terrain]") {
  const Terrain terrain(11);
  Case c = make_case(terrain, terrain, 1.4, 127.0, {42.0, 38.0}, 32, 28, false, 84);
  // A tilt between the frames: a plane of 0.6 and 0.4 height units per master cell. The gradient
  // of a plane is constant, and each channel is centred on its mean: the tilt drops out.
  diachron::Raster<float> m = c.master.heights();
  for (int y = 0; y < m.height(); ++y)
    for (int x = 0; x < m.width(); ++x) m(x, y) += static_cast<float>(0.6 * x + 0.4 * y);
  c.master = diachron::Dsm(m, c.master.transform());
  diachron::DsmCorrelationSearchOptions o;
  o.signal = diachron::CorrelationSignal::gradient;
  const diachron::DsmCorrelationResult r = diachron::dsm_correlation_search(c.master, c.secondary, o);
  check_recovered(c, r, 0.03);
  // The heights themselves carry the tilt's plane and do not find this master.
  diachron::DsmCorrelationSearchOptions heights = o;
  heights.signal = diachron::CorrelationSignal::heights;
  const diachron::DsmCorrelationResult h = diachron::dsm_correlation_search(c.master, c.secondary, heights);
  INFO("heights: " << h.message);
  CHECK_FALSE((h.success && max_error_px(c, h) < 2.0));
}
