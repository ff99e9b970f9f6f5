#include <catch2/catch.hpp>

#include <cmath>
#include <cstddef>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <diachron/core/random.hpp>
#include <diachron/core/types.hpp>
#include <diachron/geometry/homography.hpp>
#include <diachron/geometry/similarity2.hpp>
#include <diachron/matching/guided_matcher.hpp>
#include <diachron/terrain/local_affine.hpp>
#include <diachron/terrain/transfer.hpp>

using Catch::Matchers::Contains;
using diachron::DescriptorDistance;
using diachron::Features;
using diachron::GuidedMatch;
using diachron::GuidedMatchOptions;
using diachron::GuidedMatchResult;
using diachron::Keypoint;
using diachron::kPi;

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();
constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();

double deg(double d) { return d * kPi / 180.0; }

Keypoint keypoint(double x, double y, double scale, double angle) {
  Keypoint k;
  k.position = Eigen::Vector2d(x, y);
  k.scale = scale;
  k.angle = angle;
  return k;
}

Features features(std::vector<Keypoint> kps, std::vector<std::vector<float>> rows) {
  Features f;
  f.keypoints = std::move(kps);
  f.descriptors.resize(static_cast<Eigen::Index>(rows.size()),
                       rows.empty() ? 4 : static_cast<Eigen::Index>(rows[0].size()));
  for (std::size_t r = 0; r < rows.size(); ++r)
    for (std::size_t c = 0; c < rows[r].size(); ++c)
      f.descriptors(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(c)) = rows[r][c];
  return f;
}

// ---- Brute-force oracle: every pair, the same gates and rules, written the plain way. ----------

struct OracleOutcome {
  std::vector<GuidedMatch> pairs;
  std::size_t no_prediction = 0, no_candidate = 0, failed_ratio = 0, failed_mutual = 0;
};

struct Prediction {
  bool valid = false;
  Eigen::Vector2d at;
  double scale = 0, rotation = 0;
};

template <class T>
Prediction oracle_predict(const T& transfer, const Eigen::Vector2d& px) {
  Prediction p;
  const auto to = transfer(px);
  const auto a = diachron::local_affine(transfer, px, 1.0);
  if (!to || !a) return p;
  p.scale = std::sqrt(std::abs(a->determinant()));
  p.rotation = diachron::affine_rotation(*a);
  p.at = *to;
  p.valid = p.scale > 0;
  return p;
}

// The pair is always gated as (master, secondary) with the master -> secondary scale and rotation.
bool oracle_gates(const Keypoint& mk, const Keypoint& sk, double scale, double rotation, const GuidedMatchOptions& o) {
  if (o.check_scale && mk.scale > 0 && sk.scale > 0) {
    const double r = sk.scale / mk.scale;
    if (r < (1 - o.scale_ratio_tolerance) * scale || r > (1 + o.scale_ratio_tolerance) * scale) return false;
  }
  if (o.check_angle && mk.angle >= 0 && sk.angle >= 0) {
    double d = std::fmod(sk.angle - mk.angle - rotation, 2 * kPi);
    if (d > kPi) d -= 2 * kPi;
    if (d < -kPi) d += 2 * kPi;
    if (std::abs(d) > deg(o.angle_tolerance_deg)) return false;
  }
  return true;
}

double oracle_distance(const Features& a, std::size_t i, const Features& b, std::size_t j, DescriptorDistance m) {
  double s = 0, na = 0, nb = 0;
  for (Eigen::Index c = 0; c < a.descriptors.cols(); ++c) {
    const double x = a.descriptors(static_cast<Eigen::Index>(i), c), y = b.descriptors(static_cast<Eigen::Index>(j), c);
    s += m == DescriptorDistance::L2 ? (x - y) * (x - y) : x * y;
    na += x * x;
    nb += y * y;
  }
  if (m == DescriptorDistance::L2) return std::sqrt(s);
  if (na == 0 || nb == 0) return kInfinity;
  return std::sqrt(std::max(0.0, 2 - 2 * (s / (std::sqrt(na) * std::sqrt(nb)))));
}

struct Two {
  std::size_t best = kNone;
  double d1 = kInfinity, d2 = kInfinity;
};

// Best, then best among the others: no "second best" bookkeeping to get wrong. Ties: lower index.
template <class T>
Two oracle_two(const Features& from, std::size_t i, const Features& to, const T& transfer, bool reverse,
               const GuidedMatchOptions& o, bool* predicted = nullptr) {
  Two t;
  const Prediction p = oracle_predict(transfer, from.keypoints[i].position);
  if (predicted) *predicted = p.valid;
  if (!p.valid) return t;
  const double r = o.search_radius_px * (!reverse && o.scale_search_radius ? p.scale : 1.0);
  const double scale = reverse ? 1 / p.scale : p.scale, rotation = reverse ? -p.rotation : p.rotation;
  std::vector<double> d(to.size(), kInfinity);
  for (std::size_t j = 0; j < to.size(); ++j)
    if ((to.keypoints[j].position - p.at).squaredNorm() <= r * r &&
        oracle_gates(reverse ? to.keypoints[j] : from.keypoints[i], reverse ? from.keypoints[i] : to.keypoints[j],
                     scale, rotation, o))
      d[j] = oracle_distance(from, i, to, j, o.metric);
  for (std::size_t j = 0; j < to.size(); ++j)
    if (d[j] < t.d1) t.d1 = d[j], t.best = j;
  for (std::size_t j = 0; j < to.size(); ++j)
    if (j != t.best && d[j] < t.d2) t.d2 = d[j];
  return t;
}

template <class F, class G>
OracleOutcome oracle(const Features& m, const Features& s, const F& forward, const G& inverse,
                     const GuidedMatchOptions& o) {
  OracleOutcome out;
  for (std::size_t i = 0; i < m.size(); ++i) {
    bool predicted = false;
    const Two t = oracle_two(m, i, s, forward, false, o, &predicted);
    if (!predicted) {
      ++out.no_prediction;
      continue;
    }
    if (t.best == kNone) {
      ++out.no_candidate;
      continue;
    }
    if (o.ratio_test && !(t.d1 < o.ratio * t.d2)) {
      ++out.failed_ratio;
      continue;
    }
    if (o.mutual && oracle_two(s, t.best, m, inverse, true, o).best != i) {
      ++out.failed_mutual;
      continue;
    }
    out.pairs.push_back(GuidedMatch{i, t.best, t.d1, t.d2, 0.0});
  }
  return out;
}

// ---- A random scene: master keypoints, their noisy images through a map, and distractors. ------

template <class Map>
void make_scene(const Map& secondary_from_master, std::size_t n, std::size_t distractors, Eigen::Index dim,
                std::uint64_t seed, Features& master, Features& secondary) {
  diachron::RandomStream rng(seed);
  master = Features();
  secondary = Features();
  master.descriptors.resize(static_cast<Eigen::Index>(n), dim);
  secondary.descriptors.resize(static_cast<Eigen::Index>(n + distractors), dim);
  const auto transfer = diachron::make_map_transfer(secondary_from_master);
  // One draw per statement, y before x: the order of a call's arguments is unspecified
  // (core/random.hpp, "Order of draws").
  for (std::size_t i = 0; i < n; ++i) {
    const double py = rng.uniform(0, 600);
    const Eigen::Vector2d x(rng.uniform(0, 800), py);
    // A few keypoints without orientation or scale exercise the gate skips.
    const double scale = i % 17 == 0 ? 0.0 : rng.uniform(2, 30);
    const double angle = i % 13 == 0 ? -1.0 : rng.uniform(0, 2 * kPi);
    master.keypoints.push_back(keypoint(x.x(), x.y(), scale, angle));
    for (Eigen::Index c = 0; c < dim; ++c)
      master.descriptors(static_cast<Eigen::Index>(i), c) = static_cast<float>(rng.uniform(0, 1));
  }
  for (std::size_t j = 0; j < n + distractors; ++j) {
    Keypoint k;
    const std::size_t src = j < n ? j : rng.uniform_index(n);
    const Prediction p = oracle_predict(transfer, master.keypoints[src].position);
    Eigen::Vector2d at;
    if (p.valid) {
      at = p.at;
    } else {
      const double ay = rng.uniform(0, 600);
      at = Eigen::Vector2d(rng.uniform(0, 800), ay);
    }
    // Images of the master keypoints within a few px and within the gates most of the time; the
    // distractors sit near a random master keypoint's image with a random look.
    const double spread = j < n ? 2.0 : 60.0;
    const double dy = rng.normal(0, spread);
    k.position = at + Eigen::Vector2d(rng.normal(0, spread), dy);
    const Keypoint& mk = master.keypoints[src];
    k.scale =
        j % 19 == 0 ? 0.0 : (j < n && mk.scale > 0 ? mk.scale * p.scale * rng.uniform(0.75, 1.25) : rng.uniform(2, 30));
    k.angle = j % 23 == 0 ? -1.0
                          : (j < n && mk.angle >= 0
                                 ? std::fmod(mk.angle + p.rotation + deg(rng.uniform(-40, 40)) + 4 * kPi, 2 * kPi)
                                 : rng.uniform(0, 2 * kPi));
    secondary.keypoints.push_back(k);
    for (Eigen::Index c = 0; c < dim; ++c)
      secondary.descriptors(static_cast<Eigen::Index>(j), c) =
          j < n ? master.descriptors(static_cast<Eigen::Index>(src), c) + static_cast<float>(rng.normal(0, 0.15))
                : static_cast<float>(rng.uniform(0, 1));
  }
}

void require_same(const GuidedMatchResult& r, const OracleOutcome& o, std::size_t n) {
  REQUIRE(r.pairs.size() == o.pairs.size());
  for (std::size_t k = 0; k < o.pairs.size(); ++k) {
    INFO("match " << k);
    REQUIRE(r.pairs[k].master == o.pairs[k].master);
    REQUIRE(r.pairs[k].secondary == o.pairs[k].secondary);
    REQUIRE(r.pairs[k].distance == Approx(o.pairs[k].distance).epsilon(1e-12));
    if (std::isfinite(o.pairs[k].second_distance))
      REQUIRE(r.pairs[k].second_distance == Approx(o.pairs[k].second_distance).epsilon(1e-12));
    else
      REQUIRE(std::isinf(r.pairs[k].second_distance));
  }
  CHECK(r.no_prediction == o.no_prediction);
  CHECK(r.no_candidate == o.no_candidate);
  CHECK(r.failed_ratio == o.failed_ratio);
  CHECK(r.failed_mutual == o.failed_mutual);
  CHECK(r.predicted + r.no_prediction == n);
  CHECK(r.no_candidate + r.failed_ratio + r.failed_mutual + r.pairs.size() == r.predicted);
  REQUIRE(r.matches.size() == r.pairs.size());
  CHECK(r.success == !r.pairs.empty());
}

// A transfer with a hole: no prediction left of x = 60 (a DSM border, say).
template <class T>
struct Holed {
  T inner;
  std::optional<Eigen::Vector2d> operator()(const Eigen::Vector2d& p) const {
    if (p.x() < 60.0) return std::nullopt;
    return inner(p);
  }
};

}  // namespace

TEST_CASE("guided_match: equals a brute-force oracle (similarity, homography, cosine, options)", "[matching]") {
  const diachron::Similarity2 sim{0.8, deg(35.0), Eigen::Vector2d(120.0, -40.0)};
  const auto fwd_sim = diachron::make_map_transfer(sim);
  const auto inv_sim = diachron::make_map_transfer(sim.inverse());

  diachron::Homography2 h;
  h.matrix << 1.1, 0.15, 30.0, -0.1, 0.95, 20.0, 2e-4, -1e-4, 1.0;
  const auto fwd_h = diachron::make_map_transfer(h);
  const auto inv_h = diachron::make_map_transfer(*h.inverse());

  Features m, s;
  SECTION("similarity, defaults") {
    make_scene(sim, 400, 400, 32, 1, m, s);
    const GuidedMatchOptions o;
    const GuidedMatchResult r = diachron::guided_match(m, s, fwd_sim, inv_sim, o);
    const OracleOutcome want = oracle(m, s, fwd_sim, inv_sim, o);
    require_same(r, want, m.size());
    // The scene exercises every branch, so agreeing is not agreeing on nothing.
    CHECK(r.pairs.size() > 100);
    CHECK(r.no_candidate > 0);
    CHECK(r.failed_ratio > 0);
    CHECK(r.failed_mutual > 0);
    for (std::size_t k = 0; k < r.pairs.size(); ++k) {
      CHECK(r.matches[k].a == m.keypoints[r.pairs[k].master].position);
      CHECK(r.matches[k].b == s.keypoints[r.pairs[k].secondary].position);
      CHECK(r.matches[k].score == -r.pairs[k].distance);
    }
  }
  SECTION("homography with a hole, unscaled radius, tight gates") {
    make_scene(h, 400, 400, 32, 2, m, s);
    GuidedMatchOptions o;
    o.search_radius_px = 40.0;
    o.scale_search_radius = false;
    o.angle_tolerance_deg = 20.0;
    o.scale_ratio_tolerance = 0.1;
    const Holed<decltype(fwd_h)> holed{fwd_h};
    const GuidedMatchResult r = diachron::guided_match(m, s, holed, inv_h, o);
    require_same(r, oracle(m, s, holed, inv_h, o), m.size());
    CHECK(r.no_prediction > 0);
    CHECK(r.pairs.size() > 50);
  }
  SECTION("homography, cosine, no mutual, no gates") {
    make_scene(h, 300, 600, 24, 3, m, s);
    GuidedMatchOptions o;
    o.metric = DescriptorDistance::Cosine;
    o.mutual = false;
    o.check_angle = false;
    o.check_scale = false;
    o.ratio = 0.9;
    const GuidedMatchResult r = diachron::guided_match(m, s, fwd_h, inv_h, o);
    require_same(r, oracle(m, s, fwd_h, inv_h, o), m.size());
    CHECK(r.pairs.size() > 50);
    CHECK(r.failed_mutual == 0);
    for (std::size_t k = 0; k < r.pairs.size(); ++k)
      CHECK(r.pairs[k].score == Approx(1.0 - 0.5 * r.pairs[k].distance * r.pairs[k].distance));
  }
  SECTION("similarity, no ratio test") {
    make_scene(sim, 300, 300, 16, 4, m, s);
    GuidedMatchOptions o;
    o.ratio_test = false;
    const GuidedMatchResult r = diachron::guided_match(m, s, fwd_sim, inv_sim, o);
    require_same(r, oracle(m, s, fwd_sim, inv_sim, o), m.size());
    CHECK(r.failed_ratio == 0);
  }
}

TEST_CASE("guided_match: the orientation gate wraps around 0 / 2 pi", "[matching]") {
  const auto identity = diachron::make_map_transfer(diachron::Similarity2::identity());
  const std::vector<float> d{1, 0, 0, 0};
  SECTION("359 and 1 degrees are 2 degrees apart, both ways") {
    for (const auto& [a, b] : {std::pair<double, double>{1.0, 359.0}, {359.0, 1.0}}) {
      const Features m = features({keypoint(100, 100, 10, deg(a))}, {d});
      const Features s = features({keypoint(101, 100, 10, deg(b))}, {d});
      // A gate on the raw difference (MicMac's) sees 358 degrees and rejects the pair.
      REQUIRE(std::abs(deg(b) - deg(a)) > deg(30.0));
      const GuidedMatchResult r = diachron::guided_match(m, s, identity, identity);
      INFO(a << " vs " << b);
      REQUIRE(r.pairs.size() == 1);
    }
  }
  SECTION("predicted rotation carried across 2 pi, and the tolerance is kept") {
    const diachron::Similarity2 turn{1.0, deg(10.0), Eigen::Vector2d::Zero()};
    const auto fwd = diachron::make_map_transfer(turn);
    const auto inv = diachron::make_map_transfer(turn.inverse());
    const Eigen::Vector2d at = turn(Eigen::Vector2d(100, 100));
    const Features m = features({keypoint(100, 100, 10, deg(355.0))}, {d});
    // 355 + 10 = 5 degrees: 4 matches (1 off); 336 is 29 off, 334 is 31 off.
    for (const auto& [angle, matches] :
         {std::pair<double, bool>{4.0, true}, {336.0, true}, {334.0, false}, {40.0, false}}) {
      const Features s = features({keypoint(at.x(), at.y(), 10, deg(angle))}, {d});
      const GuidedMatchResult r = diachron::guided_match(m, s, fwd, inv);
      INFO("secondary angle " << angle);
      CHECK(r.pairs.size() == (matches ? 1u : 0u));
      CHECK(r.no_candidate == (matches ? 0u : 1u));
    }
  }
  SECTION("a keypoint without orientation skips the gate") {
    const Features m = features({keypoint(100, 100, 10, -1.0)}, {d});
    const Features s = features({keypoint(100, 100, 10, deg(180.0))}, {d});
    CHECK(diachron::guided_match(m, s, identity, identity).pairs.size() == 1);
  }
}

TEST_CASE("guided_match: the scale gate follows the predicted scale; the radius scales too", "[matching]") {
  const diachron::Similarity2 zoom{2.0, 0.0, Eigen::Vector2d::Zero()};
  const auto fwd = diachron::make_map_transfer(zoom);
  const auto inv = diachron::make_map_transfer(zoom.inverse());
  const std::vector<float> d{0, 1, 0, 0};
  const Features m = features({keypoint(100, 100, 10, 0.5)}, {d});
  // Predicted secondary scale 20: [16, 24] passes.
  for (const auto& [scale, matches] : {std::pair<double, bool>{20.0, true},
                                       {16.5, true},
                                       {23.5, true},
                                       {15.5, false},
                                       {24.5, false},
                                       {10.0, false},
                                       {0.0, true}}) {
    const Features s = features({keypoint(200, 200, scale, 0.5)}, {d});
    const GuidedMatchResult r = diachron::guided_match(m, s, fwd, inv);
    INFO("secondary scale " << scale);
    CHECK(r.pairs.size() == (matches ? 1u : 0u));
  }
  GuidedMatchOptions off;
  off.check_scale = false;
  CHECK(diachron::guided_match(m, features({keypoint(200, 200, 10.0, 0.5)}, {d}), fwd, inv, off).pairs.size() == 1);

  // 150 px from the prediction: inside 100 x 2 (scaled radius), outside 100 (unscaled).
  const Features far = features({keypoint(350, 200, 20, 0.5)}, {d});
  GuidedMatchOptions no_mutual;
  no_mutual.mutual = false;  // the reverse search uses 100 master px = 200 secondary px anyway
  CHECK(diachron::guided_match(m, far, fwd, inv, no_mutual).pairs.size() == 1);
  no_mutual.scale_search_radius = false;
  CHECK(diachron::guided_match(m, far, fwd, inv, no_mutual).no_candidate == 1);
}

TEST_CASE("guided_match: the ratio test demotes the old best to second", "[matching]") {
  const auto identity = diachron::make_map_transfer(diachron::Similarity2::identity());
  const Features m = features({keypoint(100, 100, 10, 1.0)}, {{0, 0, 0, 0}});
  // The spatially nearest candidate is seen first and is the worse one, so the best changes late:
  // a tracker that forgets the demoted best (MicMac's) compares 0.9 to +inf and keeps the match.
  SECTION("0.9 against 1.0 fails") {
    const Features s =
        features({keypoint(100, 101, 10, 1.0), keypoint(100, 110, 10, 1.0)}, {{1, 0, 0, 0}, {0.9f, 0, 0, 0}});
    const GuidedMatchResult r = diachron::guided_match(m, s, identity, identity);
    CHECK(r.pairs.empty());
    CHECK(r.failed_ratio == 1);
    CHECK_FALSE(r.success);
  }
  SECTION("0.7 against 1.0 passes, with the right second distance") {
    const Features s =
        features({keypoint(100, 101, 10, 1.0), keypoint(100, 110, 10, 1.0)}, {{1, 0, 0, 0}, {0.7f, 0, 0, 0}});
    const GuidedMatchResult r = diachron::guided_match(m, s, identity, identity);
    REQUIRE(r.pairs.size() == 1);
    CHECK(r.pairs[0].secondary == 1);
    CHECK(r.pairs[0].distance == Approx(0.7));
    CHECK(r.pairs[0].second_distance == Approx(1.0));
    CHECK(r.success);
  }
  SECTION("a gated-out candidate is no second best") {
    const Features s =
        features({keypoint(100, 101, 10, 1.0 + kPi), keypoint(100, 110, 10, 1.0)}, {{1, 0, 0, 0}, {0.9f, 0, 0, 0}});
    const GuidedMatchResult r = diachron::guided_match(m, s, identity, identity);
    REQUIRE(r.pairs.size() == 1);
    CHECK(std::isinf(r.pairs[0].second_distance));
  }
}

TEST_CASE("guided_match: the mutual check searches back through the inverse transfer", "[matching]") {
  const diachron::Similarity2 shift{1.0, 0.0, Eigen::Vector2d(50, 0)};
  const auto fwd = diachron::make_map_transfer(shift);
  const auto inv = diachron::make_map_transfer(shift.inverse());
  // Master 0's only candidate is secondary 0, whose nearest master keypoint is 1.
  const Features m = features({keypoint(100, 100, 10, 1.0), keypoint(120, 100, 10, 1.0)}, {{0, 0, 0, 0}, {1, 1, 0, 0}});
  const Features s = features({keypoint(160, 100, 10, 1.0)}, {{1, 1, 0.1f, 0}});
  GuidedMatchResult r = diachron::guided_match(m, s, fwd, inv);
  REQUIRE(r.pairs.size() == 1);
  CHECK(r.pairs[0].master == 1);
  CHECK(r.failed_mutual == 1);

  GuidedMatchOptions o;
  o.mutual = false;
  r = diachron::guided_match(m, s, fwd, inv, o);
  CHECK(r.pairs.size() == 2);

  // A wrong inverse sends the reverse search elsewhere: nothing is mutual any more.
  const diachron::Similarity2 wrong{1.0, 0.0, Eigen::Vector2d(500, 0)};
  r = diachron::guided_match(m, s, fwd, diachron::make_map_transfer(wrong));
  CHECK(r.pairs.empty());
  CHECK(r.failed_mutual == 2);
}

TEST_CASE("guided_match: the same result for 1 and 4 threads", "[matching]") {
  const diachron::Similarity2 sim{1.2, deg(-100.0), Eigen::Vector2d(300.0, 500.0)};
  const auto fwd = diachron::make_map_transfer(sim);
  const auto inv = diachron::make_map_transfer(sim.inverse());
  Features m, s;
  make_scene(sim, 600, 600, 32, 7, m, s);
  GuidedMatchOptions one, four;
  one.threads = 1;
  four.threads = 4;
  const GuidedMatchResult a = diachron::guided_match(m, s, fwd, inv, one);
  const GuidedMatchResult b = diachron::guided_match(m, s, fwd, inv, four);
  REQUIRE(a.pairs.size() > 100);
  REQUIRE(a.pairs.size() == b.pairs.size());
  for (std::size_t k = 0; k < a.pairs.size(); ++k) {
    CHECK(a.pairs[k].master == b.pairs[k].master);
    CHECK(a.pairs[k].secondary == b.pairs[k].secondary);
    CHECK(a.pairs[k].distance == b.pairs[k].distance);
  }
  CHECK(a.candidates == b.candidates);
  CHECK(a.failed_mutual == b.failed_mutual);
}

TEST_CASE("guided_match: empty inputs and bad input", "[matching]") {
  const auto identity = diachron::make_map_transfer(diachron::Similarity2::identity());
  const Features m = features({keypoint(10, 10, 5, 1.0), keypoint(20, 10, 5, 1.0)}, {{1, 0, 0, 0}, {0, 1, 0, 0}});
  GuidedMatchResult r = diachron::guided_match(Features(), m, identity, identity);
  CHECK_FALSE(r.success);
  CHECK(r.predicted == 0);
  r = diachron::guided_match(m, Features(), identity, identity);
  CHECK(r.no_candidate == 2);
  CHECK(r.pairs.empty());

  const Features wide = features({keypoint(10, 10, 5, 1.0)}, {{1, 0, 0, 0, 0}});
  CHECK_THROWS_WITH(diachron::guided_match(m, wide, identity, identity), Contains("widths differ"));
  Features rows = m;
  rows.keypoints.pop_back();
  CHECK_THROWS_WITH(diachron::guided_match(rows, m, identity, identity), Contains("descriptor rows"));
  Features nan = m;
  nan.descriptors(1, 2) = std::numeric_limits<float>::quiet_NaN();
  CHECK_THROWS_WITH(diachron::guided_match(m, nan, identity, identity), Contains("secondary descriptor row 1"));
  Features bad_kp = m;
  bad_kp.keypoints[1].position.x() = kInfinity;
  CHECK_THROWS_WITH(diachron::guided_match(bad_kp, m, identity, identity), Contains("master keypoint 1"));
  bad_kp = m;
  bad_kp.keypoints[0].scale = -2.0;
  CHECK_THROWS_AS(diachron::guided_match(m, bad_kp, identity, identity), diachron::Error);

  const auto bad_option = [&](auto set, const char* field) {
    GuidedMatchOptions o;
    set(o);
    CHECK_THROWS_WITH(diachron::guided_match(m, m, identity, identity, o), Contains(field));
  };
  bad_option([](GuidedMatchOptions& o) { o.search_radius_px = 0; }, "search_radius_px");
  bad_option([](GuidedMatchOptions& o) { o.affine_step_px = -1; }, "affine_step_px");
  bad_option([](GuidedMatchOptions& o) { o.scale_ratio_tolerance = 1; }, "scale_ratio_tolerance");
  bad_option([](GuidedMatchOptions& o) { o.angle_tolerance_deg = 181; }, "angle_tolerance_deg");
  bad_option([](GuidedMatchOptions& o) { o.ratio = 0; }, "ratio");
}
