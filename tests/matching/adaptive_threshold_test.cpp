// Tests for the adaptive ("a-contrario") score threshold of correlation_match
// (CorrelationMatchOptions::adaptive_threshold) and for grid interest points fed straight into it.
// Images are rendered from a continuous random texture, so every point's truth is known; an
// unrelated secondary image (another texture) has no true match at all.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include <catch2/catch.hpp>

#include <diachron/core/error.hpp>
#include <diachron/core/random.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/core/types.hpp>
#include <diachron/matching/correlation_matcher.hpp>
#include <diachron/matching/grid_interest_points.hpp>
#include <diachron/robust/chance_inliers.hpp>
#include <diachron/terrain/local_affine.hpp>
#include <diachron/terrain/transfer.hpp>

using diachron::CorrelationMatchOptions;
using diachron::CorrelationMatchResult;
using diachron::CorrelationOutcome;
using diachron::Raster;

namespace {

// Sinusoids of 5 to 25 px wavelength and Gaussian blobs of 2 to 5 px over a 400 px square, all
// `scale` times larger: no repetition. The coarser the texture, the higher chance's peaks.
struct ChanceTexture {
  std::vector<Eigen::Vector3d> waves;  // wave number x, y and phase
  std::vector<Eigen::Vector4d> blobs;  // x, y, sigma, amplitude
  explicit ChanceTexture(std::uint64_t seed, double scale) {
    diachron::RandomStream rng(seed);
    for (int i = 0; i < 16; ++i) {
      const double wavelength = scale * rng.uniform(5.0, 25.0);
      const double angle = rng.uniform(0.0, 2.0 * diachron::kPi);
      const double phase = rng.uniform(0.0, 2.0 * diachron::kPi);
      const double k = 2.0 * diachron::kPi / wavelength;
      waves.emplace_back(k * std::cos(angle), k * std::sin(angle), phase);
    }
    for (int i = 0; i < 300; ++i) {
      const double sigma = scale * rng.uniform(2.0, 5.0);
      const double y = rng.uniform(-20.0, 420.0);
      const double x = rng.uniform(-20.0, 420.0);
      const double amplitude = rng.uniform(-3.0, 3.0);
      blobs.emplace_back(x, y, sigma, amplitude);
    }
  }
  double operator()(const Eigen::Vector2d& p) const {
    double v = 0.0;
    for (const Eigen::Vector3d& w : waves) v += std::sin(w.x() * p.x() + w.y() * p.y() + w.z());
    for (const Eigen::Vector4d& b : blobs) {
      const double d2 = (p - b.head<2>()).squaredNorm(), s2 = b.z() * b.z();
      if (d2 < 30.0 * s2) v += b.w() * std::exp(-0.5 * d2 / s2);
    }
    return 128.0 + 10.0 * v;
  }
};

// The image whose pixel q shows the texture (seed, scale) at q - shift.
Raster<float> chance_image(std::uint64_t seed, int size, const Eigen::Vector2d& shift, double scale = 1.0) {
  const ChanceTexture texture(seed, scale);
  Raster<float> img(size, size);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) img(x, y) = static_cast<float>(texture(Eigen::Vector2d(x, y) - shift));
  return img;
}

const Eigen::Vector2d kChanceShift(3.3, -2.7);        // the secondary shows the master's texture moved by this
const Eigen::Vector2d kChancePredictionError(2.0, -1.5);  // the transfer's error, inside the search

// The transfer: the true shift plus the prediction error.
auto chance_transfer() {
  return diachron::make_map_transfer(
      [](const Eigen::Vector2d& p) { return Eigen::Vector2d(p + kChanceShift + kChancePredictionError); });
}

// Grid points of the master, 12 px cells.
std::vector<Eigen::Vector2d> chance_points(const Raster<float>& master) {
  diachron::GridInterestOptions g;
  g.cell_px = 12;
  std::vector<Eigen::Vector2d> out;
  for (const diachron::InterestPoint& p : diachron::grid_interest_points(master, g)) out.push_back(p.position);
  return out;
}

// The per-point threshold alone: the pair test (pair_significance) is off here, and has its own
// tests below.
CorrelationMatchOptions chance_options(bool adaptive) {
  CorrelationMatchOptions o;
  o.adaptive_threshold = adaptive;
  o.false_alarm_rate = 0.01;  // the tests' counts below assume 1 %, whatever the default
  o.pair_significance = 0.0;
  o.threads = 1;
  return o;
}

// P(X >= k), X binomial(n, p), by summing the terms directly.
double brute_binomial_tail(std::size_t n, double p, std::size_t k) {
  double sum = 0.0;
  for (std::size_t i = k; i <= n; ++i) {
    double log_term = std::lgamma(n + 1.0) - std::lgamma(i + 1.0) - std::lgamma(n - i + 1.0);
    log_term += static_cast<double>(i) * std::log(p) + static_cast<double>(n - i) * std::log1p(-p);
    sum += std::exp(log_term);
  }
  return sum;
}

// The value `brute` of the samples that at most floor(share n) samples exceed, by counting.
double brute_upper_quantile(const std::vector<double>& v, double share) {
  const std::size_t allowed = static_cast<std::size_t>(std::floor(share * static_cast<double>(v.size()) + 1e-9));
  double best = std::numeric_limits<double>::infinity();
  for (double candidate : v) {
    std::size_t above = 0;
    for (double x : v) above += x > candidate ? 1 : 0;
    if (above <= allowed) best = std::min(best, candidate);
  }
  return best;
}

}  // namespace

TEST_CASE("Adaptive threshold: it sits between chance peaks and true peaks", "[matching]") {
  const Raster<float> master = chance_image(11, 300, Eigen::Vector2d::Zero());
  const Raster<float> secondary = chance_image(11, 300, kChanceShift);
  const std::vector<Eigen::Vector2d> points = chance_points(master);
  REQUIRE(points.size() > 300);
  const CorrelationMatchResult r =
      diachron::correlation_match(master, secondary, points, chance_transfer(), chance_options(true));
  const diachron::CorrelationThreshold& t = r.threshold;
  REQUIRE(t.adaptive);
  CHECK(t.null_maxima.size() >= 200);
  CHECK(t.null_maxima.size() <= 256);
  // Chance gives peaks well above 0 over 625 shifts, but far below the true ones.
  CHECK(t.null_median > 0.1);
  CHECK(t.min_score == std::max(0.1, t.null_quantile));  // the floor; no ceiling by default
  CHECK(t.min_score >= t.null_q90);
  CHECK(t.min_score < 0.8);
  // Every point whose search holds its truth (all but those near the secondary's edge) is matched,
  // to the truth.
  std::size_t searched = 0, matched_right = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const diachron::CorrelationPeak& p = r.peaks[i];
    if (p.outcome == CorrelationOutcome::outside_secondary) continue;
    ++searched;
    CHECK(p.score > t.min_score);
    if (p.outcome == CorrelationOutcome::matched && (p.b - (points[i] + kChanceShift)).norm() < 0.1) ++matched_right;
  }
  REQUIRE(searched > 300);
  CHECK(matched_right == searched);
}

TEST_CASE("Adaptive threshold: an unrelated secondary image gives almost no match", "[matching]") {
  // Twice coarser texture: chance's best peaks over the 25 x 25 shifts reach 0.3 to 0.5.
  const Raster<float> master = chance_image(11, 300, Eigen::Vector2d::Zero(), 2.0);
  const Raster<float> unrelated = chance_image(12, 300, kChanceShift, 2.0);
  const std::vector<Eigen::Vector2d> points = chance_points(master);
  const CorrelationMatchResult fixed =
      diachron::correlation_match(master, unrelated, points, chance_transfer(), chance_options(false));
  const CorrelationMatchResult adaptive =
      diachron::correlation_match(master, unrelated, points, chance_transfer(), chance_options(true));
  REQUIRE(adaptive.threshold.adaptive);
  const std::size_t searched = points.size() - adaptive.outside_secondary - adaptive.outside_master;
  REQUIRE(searched > 300);
  // Every match here is wrong. The fixed 0.3 passes many of chance's peaks; the adaptive threshold
  // lets through about its false-alarm rate (1 %), the margin test removing some of those.
  INFO("fixed 0.3: " << fixed.matches.size() << " wrong matches of " << searched << "; adaptive (threshold "
                     << adaptive.threshold.min_score << "): " << adaptive.matches.size());
  CHECK(fixed.matches.size() > searched / 10);
  CHECK(adaptive.matches.size() <= searched / 40);
  CHECK(adaptive.threshold.min_score > 0.3);
  // A ceiling at the fixed threshold makes the adaptive one never stricter than it.
  CorrelationMatchOptions capped = chance_options(true);
  capped.adaptive_ceiling = 0.3;
  const CorrelationMatchResult at_ceiling =
      diachron::correlation_match(master, unrelated, points, chance_transfer(), capped);
  CHECK(at_ceiling.threshold.adaptive);
  CHECK(at_ceiling.threshold.min_score == 0.3);
  CHECK(at_ceiling.threshold.null_quantile == adaptive.threshold.null_quantile);
  CHECK(at_ceiling.point_index == fixed.point_index);
}

TEST_CASE("Adaptive threshold: deterministic whatever the thread count, driven by its seed", "[matching]") {
  const Raster<float> master = chance_image(11, 300, Eigen::Vector2d::Zero());
  const Raster<float> secondary = chance_image(12, 300, kChanceShift);
  const std::vector<Eigen::Vector2d> points = chance_points(master);
  CorrelationMatchOptions one = chance_options(true), two = one, all = one, other_seed = one;
  two.threads = 2;
  all.threads = 0;
  other_seed.seed = 5;
  const CorrelationMatchResult r1 = diachron::correlation_match(master, secondary, points, chance_transfer(), one);
  const CorrelationMatchResult r2 = diachron::correlation_match(master, secondary, points, chance_transfer(), two);
  const CorrelationMatchResult r0 = diachron::correlation_match(master, secondary, points, chance_transfer(), all);
  REQUIRE(r1.threshold.null_maxima.size() > 100);
  CHECK(r1.threshold.null_maxima == r2.threshold.null_maxima);
  CHECK(r1.threshold.null_maxima == r0.threshold.null_maxima);
  CHECK(r1.threshold.min_score == r2.threshold.min_score);
  CHECK(r1.point_index == r2.point_index);
  CHECK(r1.point_index == r0.point_index);
  const CorrelationMatchResult rs =
      diachron::correlation_match(master, secondary, points, chance_transfer(), other_seed);
  CHECK(rs.threshold.null_maxima != r1.threshold.null_maxima);
}

TEST_CASE("Adaptive threshold: its quantiles are the brute-force ones of its null samples", "[matching]") {
  using diachron::correlation_upper_quantile;
  CHECK(std::isnan(correlation_upper_quantile({}, 0.1)));
  const std::vector<double> ten = {0.5, 0.1, 0.9, 0.3, 0.7, 0.2, 1.0, 0.4, 0.8, 0.6};
  CHECK(correlation_upper_quantile(ten, 0.0) == 1.0);
  CHECK(correlation_upper_quantile(ten, 0.1) == 0.9);
  CHECK(correlation_upper_quantile(ten, 0.25) == 0.8);  // 2 of 10 may exceed it
  CHECK(correlation_upper_quantile(ten, 0.5) == 0.5);
  CHECK(correlation_upper_quantile(ten, 1.0) == 0.1);
  CHECK_THROWS_AS(correlation_upper_quantile(ten, 1.5), diachron::Error);

  const Raster<float> master = chance_image(11, 300, Eigen::Vector2d::Zero());
  const Raster<float> secondary = chance_image(11, 300, kChanceShift);
  const std::vector<Eigen::Vector2d> points = chance_points(master);
  for (const double alpha : {0.01, 0.05, 0.2}) {
    CAPTURE(alpha);
    CorrelationMatchOptions o = chance_options(true);
    o.false_alarm_rate = alpha;
    o.adaptive_floor = -1.0;
    const diachron::CorrelationThreshold t =
        diachron::correlation_match(master, secondary, points, chance_transfer(), o).threshold;
    REQUIRE(t.null_maxima.size() > 100);
    CHECK(t.null_quantile == brute_upper_quantile(t.null_maxima, alpha));
    CHECK(t.min_score == t.null_quantile);
    CHECK(t.null_median == brute_upper_quantile(t.null_maxima, 0.5));
    CHECK(t.null_q90 == brute_upper_quantile(t.null_maxima, 0.1));
    CHECK(t.null_q99 == brute_upper_quantile(t.null_maxima, 0.01));
    CHECK(t.null_max == *std::max_element(t.null_maxima.begin(), t.null_maxima.end()));
  }
}

TEST_CASE("Pair test: an unrelated pair gives no match, and says why", "[matching]") {
  // The coarse unrelated textures of the test above: about 1 % of the points pass the adaptive
  // threshold, as many as chance lets through.
  const Raster<float> master = chance_image(11, 300, Eigen::Vector2d::Zero(), 2.0);
  const Raster<float> unrelated = chance_image(12, 300, kChanceShift, 2.0);
  const std::vector<Eigen::Vector2d> points = chance_points(master);
  const CorrelationMatchResult untested =
      diachron::correlation_match(master, unrelated, points, chance_transfer(), chance_options(true));
  CorrelationMatchOptions o = chance_options(true);
  o.pair_significance = 1e-3;
  const CorrelationMatchResult r = diachron::correlation_match(master, unrelated, points, chance_transfer(), o);
  const diachron::CorrelationThreshold& t = r.threshold;
  REQUIRE(t.adaptive);
  INFO(untested.matches.size() << " of " << t.judged << " judged points pass; null rate " << t.null_match_rate
                               << ", bound " << t.null_match_rate_bound << ", P(chance) " << t.chance_probability);
  REQUIRE(untested.matches.size() > 0);  // there is something to refuse
  CHECK(t.rejected_as_chance);
  CHECK(t.chance_probability > 1e-3);
  CHECK_FALSE(r.success);
  CHECK(r.matches.empty());
  CHECK(r.point_index.empty());
  CHECK(r.chance == untested.matches.size());
  CHECK(t.passed == untested.matches.size());
  CHECK(t.judged == untested.matches.size() + untested.low_score + untested.ambiguous + untested.at_border);
  for (std::size_t k = 0; k < untested.point_index.size(); ++k)
    CHECK(r.peaks[untested.point_index[k]].outcome == CorrelationOutcome::chance);
  // The statistics: a rate of null peaks that would have matched, its bound, the binomial tail.
  std::size_t above = 0;
  for (double v : t.null_maxima) above += v >= t.min_score ? 1 : 0;
  CHECK(t.null_match_rate >= 0.0);
  CHECK(t.null_match_rate <= static_cast<double>(above) / static_cast<double>(t.null_maxima.size()));
  CHECK(t.null_match_rate_bound ==
        Approx(diachron::wilson_upper_bound(t.null_match_rate, static_cast<double>(t.null_maxima.size()), 3.09)));
  CHECK(t.chance_probability == Approx(brute_binomial_tail(t.judged, t.null_match_rate_bound, t.passed)));
}

TEST_CASE("Pair test: a related pair keeps every match, also with most of it unrelated", "[matching]") {
  const Raster<float> master = chance_image(11, 300, Eigen::Vector2d::Zero());
  const Raster<float> secondary = chance_image(11, 300, kChanceShift);
  // Only the top 60 rows of the secondary show the master's texture; the rest is another texture.
  Raster<float> mostly_unrelated = chance_image(12, 300, kChanceShift);
  for (int y = 0; y < 60; ++y)
    for (int x = 0; x < 300; ++x) mostly_unrelated(x, y) = secondary(x, y);
  const std::vector<Eigen::Vector2d> points = chance_points(master);
  CorrelationMatchOptions tested = chance_options(true);
  tested.pair_significance = 1e-3;
  for (const Raster<float>* image : std::vector<const Raster<float>*>{&secondary, &mostly_unrelated}) {
    const CorrelationMatchResult untested =
        diachron::correlation_match(master, *image, points, chance_transfer(), chance_options(true));
    const CorrelationMatchResult r = diachron::correlation_match(master, *image, points, chance_transfer(), tested);
    INFO(r.threshold.passed << " of " << r.threshold.judged << " pass; bound " << r.threshold.null_match_rate_bound
                            << ", P(chance) " << r.threshold.chance_probability);
    CHECK_FALSE(r.threshold.rejected_as_chance);
    CHECK(r.threshold.chance_probability < 1e-6);
    CHECK(r.chance == 0);
    CHECK(r.point_index == untested.point_index);
    if (image == &mostly_unrelated) CHECK(r.threshold.passed < r.threshold.judged / 4);
  }
  // Off (0), or without an adaptive threshold, the test does not run.
  CorrelationMatchOptions off = tested;
  off.pair_significance = 0.0;
  CHECK(std::isnan(diachron::correlation_match(master, secondary, points, chance_transfer(), off)
                       .threshold.chance_probability));
  CHECK(std::isnan(diachron::correlation_match(master, secondary, points, chance_transfer(), chance_options(false))
                       .threshold.chance_probability));
}

TEST_CASE("Adaptive threshold: a quarter of the eligible points as null surfaces, 256 to null_surfaces", "[matching]") {
  const Raster<float> master = chance_image(11, 300, Eigen::Vector2d::Zero());
  const Raster<float> secondary = chance_image(11, 300, kChanceShift);
  diachron::GridInterestOptions g;
  g.cell_px = 5;
  std::vector<Eigen::Vector2d> dense;
  for (const diachron::InterestPoint& p : diachron::grid_interest_points(master, g)) dense.push_back(p.position);
  const std::vector<Eigen::Vector2d> sparse = chance_points(master);
  CorrelationMatchOptions o = chance_options(true);
  o.null_surfaces = 400;
  const CorrelationMatchResult rd = diachron::correlation_match(master, secondary, dense, chance_transfer(), o);
  const CorrelationMatchResult rs = diachron::correlation_match(master, secondary, sparse, chance_transfer(), o);
  const std::size_t eligible_dense = dense.size() - rd.outside_secondary - rd.outside_master;
  const std::size_t eligible_sparse = sparse.size() - rs.outside_secondary - rs.outside_master;
  REQUIRE(eligible_dense / 4 > 400);
  REQUIRE(eligible_sparse / 4 < 256);
  // Every draw finds a place inside this image pair for most surfaces; a few leave it.
  CHECK(rd.threshold.null_maxima.size() <= 400);
  CHECK(rd.threshold.null_maxima.size() > 300);
  CHECK(rs.threshold.null_maxima.size() <= 256);
  CHECK(rs.threshold.null_maxima.size() > 200);
}

TEST_CASE("Pair test: on by default with the adaptive threshold", "[matching]") {
  const CorrelationMatchOptions defaults;
  CHECK(defaults.adaptive_threshold);
  CHECK(defaults.pair_significance == 1e-3);
  CHECK(defaults.false_alarm_rate == 0.05);
}

TEST_CASE("Adaptive threshold: the displaced searches miss the true peak", "[matching]") {
  // A single point: every null surface is its own, around its prediction displaced by 2 R + w or
  // more, so none holds the true peak (a score of about 1 on this noise-free pair).
  const Raster<float> master = chance_image(11, 300, Eigen::Vector2d::Zero());
  const Raster<float> secondary = chance_image(11, 300, kChanceShift);
  const std::vector<Eigen::Vector2d> points = {Eigen::Vector2d(150.0, 150.0)};
  CorrelationMatchOptions o = chance_options(true);
  o.null_surfaces = 40;
  o.min_null_surfaces = 40;
  const CorrelationMatchResult r = diachron::correlation_match(master, secondary, points, chance_transfer(), o);
  REQUIRE(r.threshold.null_maxima.size() == 40);
  REQUIRE(r.matches.size() == 1);
  CHECK(r.matches[0].score > 0.99);
  CHECK(r.threshold.null_max < 0.9);
}

TEST_CASE("Adaptive threshold: too few null surfaces keep min_score", "[matching]") {
  // A 100 px secondary image: a search of +-12 px with its 21 px window needs its centre in
  // [23, 76]^2, which every displaced prediction (45 px or more along an axis) leaves.
  const Raster<float> master = chance_image(11, 100, Eigen::Vector2d::Zero());
  const Raster<float> secondary = chance_image(11, 100, kChanceShift);
  const std::vector<Eigen::Vector2d> points = {Eigen::Vector2d(48.0, 52.0), Eigen::Vector2d(52.0, 48.0)};
  CorrelationMatchOptions o = chance_options(true);
  o.min_score = 0.42;
  const CorrelationMatchResult r = diachron::correlation_match(master, secondary, points, chance_transfer(), o);
  CHECK_FALSE(r.threshold.adaptive);
  CHECK(r.threshold.null_maxima.empty());
  CHECK(std::isnan(r.threshold.null_quantile));
  CHECK(r.threshold.min_score == 0.42);
  const CorrelationMatchResult fixed =
      diachron::correlation_match(master, secondary, points, chance_transfer(), [&] {
        CorrelationMatchOptions f = o;
        f.adaptive_threshold = false;
        return f;
      }());
  REQUIRE(fixed.matches.size() == 2);
  CHECK(r.point_index == fixed.point_index);
}

TEST_CASE("Adaptive threshold: off, the matches are correlate_point's with min_score", "[matching]") {
  // Unrelated, coarse textures: many scores on either side of 0.3.
  const Raster<float> master = chance_image(11, 300, Eigen::Vector2d::Zero(), 2.0);
  const Raster<float> secondary = chance_image(12, 300, kChanceShift, 2.0);
  const std::vector<Eigen::Vector2d> points = chance_points(master);
  const auto transfer = chance_transfer();
  const CorrelationMatchOptions o = chance_options(false);
  const CorrelationMatchResult r = diachron::correlation_match(master, secondary, points, transfer, o);
  CHECK_FALSE(r.threshold.adaptive);
  CHECK(r.threshold.min_score == o.min_score);
  CHECK(r.threshold.null_maxima.empty());
  REQUIRE(r.low_score > 50);
  REQUIRE(r.matches.size() > 10);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector2d b0 = *transfer(points[i]);
    if (r.peaks[i].outcome == CorrelationOutcome::outside_secondary) continue;
    const diachron::CorrelationPeak p = diachron::correlate_point(
        master, points[i], secondary, b0, *diachron::local_affine(transfer, points[i], o.affine_step()), o);
    CHECK(p.outcome == r.peaks[i].outcome);
    if (p.outcome == CorrelationOutcome::matched) {
      CHECK(p.b == r.peaks[i].b);
      CHECK(p.score == r.peaks[i].score);
    }
  }
  // On, the verdicts are those of the fixed threshold set to the adaptive one.
  const CorrelationMatchResult on =
      diachron::correlation_match(master, secondary, points, transfer, chance_options(true));
  CorrelationMatchOptions same = o;
  same.min_score = on.threshold.min_score;
  const CorrelationMatchResult as_fixed = diachron::correlation_match(master, secondary, points, transfer, same);
  CHECK(on.point_index == as_fixed.point_index);
  CHECK(on.low_score == as_fixed.low_score);
}

TEST_CASE("Adaptive threshold: invalid options name their field", "[matching]") {
  const auto throws_naming = [](void (*set)(CorrelationMatchOptions&), const char* field) {
    CorrelationMatchOptions o;
    set(o);
    CHECK_THROWS_WITH(o.check(), Catch::Contains(field));
  };
  throws_naming([](CorrelationMatchOptions& o) { o.false_alarm_rate = 0.0; }, "false_alarm_rate");
  throws_naming([](CorrelationMatchOptions& o) { o.false_alarm_rate = 0.6; }, "false_alarm_rate");
  throws_naming([](CorrelationMatchOptions& o) { o.false_alarm_rate = std::nan(""); }, "false_alarm_rate");
  throws_naming([](CorrelationMatchOptions& o) { o.adaptive_floor = 1.5; }, "adaptive_floor");
  throws_naming([](CorrelationMatchOptions& o) { o.adaptive_ceiling = 0.05; }, "adaptive_ceiling");
  throws_naming([](CorrelationMatchOptions& o) { o.adaptive_ceiling = 1.5; }, "adaptive_ceiling");
  throws_naming([](CorrelationMatchOptions& o) { o.null_surfaces = 0; }, "null_surfaces");
  throws_naming([](CorrelationMatchOptions& o) { o.min_null_surfaces = 0; }, "min_null_surfaces");
  throws_naming([](CorrelationMatchOptions& o) { o.min_null_surfaces = o.null_surfaces + 1; }, "min_null_surfaces");
  throws_naming([](CorrelationMatchOptions& o) { o.pair_significance = -0.1; }, "pair_significance");
  throws_naming([](CorrelationMatchOptions& o) { o.pair_significance = 1.0; }, "pair_significance");
}

TEST_CASE("Grid points into correlation: the overload equals the converted call", "[matching]") {
  const Raster<float> master = chance_image(11, 300, Eigen::Vector2d::Zero());
  const Raster<float> secondary = chance_image(11, 300, kChanceShift);
  const std::vector<diachron::InterestPoint> grid = diachron::grid_interest_points(master);
  REQUIRE(grid.size() > 40);
  std::vector<Eigen::Vector2d> positions;
  for (const diachron::InterestPoint& p : grid) positions.push_back(p.position);
  for (const bool adaptive : {false, true}) {
    const CorrelationMatchResult direct =
        diachron::correlation_match(master, secondary, grid, chance_transfer(), chance_options(adaptive));
    const CorrelationMatchResult converted =
        diachron::correlation_match(master, secondary, positions, chance_transfer(), chance_options(adaptive));
    REQUIRE(direct.matches.size() == converted.matches.size());
    CHECK(direct.point_index == converted.point_index);
    for (std::size_t k = 0; k < direct.matches.size(); ++k) {
      CHECK(direct.matches[k].a == converted.matches[k].a);
      CHECK(direct.matches[k].b == converted.matches[k].b);
      CHECK(direct.matches[k].score == converted.matches[k].score);
    }
    CHECK(direct.threshold.null_maxima == converted.threshold.null_maxima);
  }
}

TEST_CASE("Grid points into correlation: default windows agree, no point is outside the master", "[matching]") {
  const Raster<float> master = chance_image(11, 300, Eigen::Vector2d::Zero());
  const Raster<float> secondary = chance_image(11, 300, Eigen::Vector2d::Zero());
  const auto identity = diachron::make_map_transfer([](const Eigen::Vector2d& p) { return p; });
  for (const int cell : {32, 4}) {
    CAPTURE(cell);
    diachron::GridInterestOptions g;
    g.cell_px = cell;
    const std::vector<diachron::InterestPoint> grid = diachron::grid_interest_points(master, g);
    const CorrelationMatchResult r = diachron::correlation_match(master, secondary, grid, identity);
    CHECK(r.outside_master == 0);
    // Grid points reach the margin, so a grid window narrower than the correlation's does leave it.
    g.window_px = 15;
    const CorrelationMatchResult narrow =
        diachron::correlation_match(master, secondary, diachron::grid_interest_points(master, g), identity);
    if (cell == 4) CHECK(narrow.outside_master > 0);
  }
  CHECK(diachron::GridInterestOptions{}.window_px == CorrelationMatchOptions{}.window_px);
}
