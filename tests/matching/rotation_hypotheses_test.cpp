#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <set>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include <diachron/core/random.hpp>
#include <diachron/matching/rotation_hypotheses.hpp>
#include <diachron/tiling/one_to_many.hpp>

using diachron::PointMatch;
using diachron::Raster;
using Eigen::Vector2d;

namespace {

using Image = Raster<std::uint8_t>;

Image noise_image(int w, int h, std::uint64_t seed) {
  diachron::RandomStream rng(seed);
  Image img(w, h);
  for (auto& v : img) v = static_cast<std::uint8_t>(rng.uniform_index(256));
  return img;
}

// Exact 5x5 template matcher (unique patterns in noise): matches only when the two images are
// related by a pure translation, so it fails under the wrong rotation hypotheses.
struct PatternMatcher {
  static std::string pattern(const Image& img, int x, int y) {
    std::string key;
    for (int dy = -2; dy <= 2; ++dy)
      for (int dx = -2; dx <= 2; ++dx) key.push_back(static_cast<char>(img(x + dx, y + dy)));
    return key;
  }
  std::vector<PointMatch> match(const Image& a, const Image& b) const {
    std::unordered_map<std::string, Vector2d> where;
    std::set<std::string> repeated;
    for (int y = 2; y < b.height() - 2; ++y)
      for (int x = 2; x < b.width() - 2; ++x)
        if (!where.emplace(pattern(b, x, y), Vector2d(x, y)).second) repeated.insert(pattern(b, x, y));
    std::vector<PointMatch> out;
    for (int y = 2; y < a.height() - 2; ++y)
      for (int x = 2; x < a.width() - 2; ++x) {
        const auto key = pattern(a, x, y);
        const auto it = where.find(key);
        if (it != where.end() && !repeated.count(key)) out.push_back(PointMatch{Vector2d(x, y), it->second, 1.0});
      }
    return out;
  }
};

template <class T>
bool same(const Raster<T>& a, const Raster<T>& b) {
  if (a.width() != b.width() || a.height() != b.height()) return false;
  for (int y = 0; y < a.height(); ++y)
    for (int x = 0; x < a.width(); ++x)
      if (a(x, y) != b(x, y)) return false;
  return true;
}

}  // namespace

TEST_CASE("rotate_quarter_turns: pixels land where the point maps say, non-square rasters", "[matching]") {
  Raster<int> r(5, 3);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 5; ++x) r(x, y) = 10 * y + x;
  // 90 degrees clockwise: the left column becomes the top row, read bottom to top.
  const Raster<int> r90 = diachron::rotate_quarter_turns(r, 1);
  REQUIRE(r90.width() == 3);
  REQUIRE(r90.height() == 5);
  REQUIRE(r90(0, 0) == 20);
  REQUIRE(r90(1, 0) == 10);
  REQUIRE(r90(2, 0) == 0);
  REQUIRE(r90(2, 4) == 4);
  for (int k = -1; k <= 4; ++k) {
    const Raster<int> rk = diachron::rotate_quarter_turns(r, k);
    const bool odd = ((k % 4) + 4) % 2 == 1;
    REQUIRE(rk.width() == (odd ? 3 : 5));
    REQUIRE(rk.height() == (odd ? 5 : 3));
    const diachron::Similarity2 s = diachron::quarter_turn_similarity(k, 5, 3);
    for (int y = 0; y < 3; ++y)
      for (int x = 0; x < 5; ++x) {
        const Vector2d p(x, y);
        const Vector2d q = diachron::rotate_point_quarter_turns(p, k, 5, 3);
        INFO("k " << k << " p " << x << "," << y << " q " << q.transpose());
        REQUIRE(rk.at(static_cast<int>(q.x()), static_cast<int>(q.y())) == r(x, y));
        REQUIRE(diachron::unrotate_point_quarter_turns(q, k, 5, 3) == p);
        REQUIRE((s(p) - q).norm() < 1e-12);
      }
  }
  // Continuous points: the far corner of the pixel area maps to the far corner.
  REQUIRE(diachron::rotate_point_quarter_turns(Vector2d(-0.5, -0.5), 1, 5, 3) == Vector2d(2.5, -0.5));
}

TEST_CASE("rotate_quarter_turns: round trips and composition", "[matching]") {
  const Image img = noise_image(37, 22, 4);
  for (int k = 0; k < 4; ++k) {
    REQUIRE(same(diachron::rotate_quarter_turns(diachron::rotate_quarter_turns(img, k), 4 - k), img));
    REQUIRE(same(diachron::rotate_quarter_turns(diachron::rotate_quarter_turns(img, k), -k), img));
  }
  Image four = img;
  for (int i = 0; i < 4; ++i) four = diachron::rotate_quarter_turns(four, 1);
  REQUIRE(same(four, img));
  REQUIRE(same(diachron::rotate_quarter_turns(diachron::rotate_quarter_turns(img, 1), 1),
               diachron::rotate_quarter_turns(img, 2)));
  REQUIRE(same(diachron::rotate_quarter_turns(img, 3), diachron::rotate_quarter_turns(img, -1)));
}

TEST_CASE("match_with_rotation_hypotheses: recovers a known quarter turn through one-to-many tiling",
          "[matching]") {
  const Image master = noise_image(64, 48, 21);
  const int ox = 9, oy = 6, cw = 50, ch = 38;  // the secondary sees master[ox, ox + cw) x [oy, oy + ch)
  Image crop(cw, ch);
  for (int y = 0; y < ch; ++y)
    for (int x = 0; x < cw; ++x) crop(x, y) = master(x + ox, y + oy);
  const diachron::GridTiler tiler(diachron::GridTilerOptions{24, 20, 0, 0});

  for (int k = 0; k < 4; ++k) {
    INFO("secondary rotated by " << 90 * k << " deg");
    const Image secondary = diachron::rotate_quarter_turns(crop, k);
    std::vector<int> seen_rotations;
    diachron::RandomStream junk(static_cast<std::uint64_t>(k));
    auto match_fn = [&](const Image& m, const Image& s, int rotation_deg) {
      seen_rotations.push_back(rotation_deg);
      diachron::OneToManyOptions o;
      o.threads = 2;
      auto matches = diachron::match_one_to_many(m, s, tiler, tiler, PatternMatcher{}, o).matches;
      // Outliers under every hypothesis: random pairs.
      // One draw per statement, each y before its x: the order of a call's arguments is
      // unspecified (core/random.hpp, "Order of draws").
      for (int i = 0; i < 40; ++i) {
        const double ay = junk.uniform(0, m.height()), ax = junk.uniform(0, m.width());
        const double by = junk.uniform(0, s.height()), bx = junk.uniform(0, s.width());
        matches.push_back(PointMatch{Vector2d(ax, ay), Vector2d(bx, by), 0.0});
      }
      return matches;
    };
    diachron::RotationHypothesesOptions options;
    options.ransac.threshold = 2.0;
    const auto report = diachron::match_with_rotation_hypotheses(master, secondary, match_fn, options);
    REQUIRE(seen_rotations == std::vector<int>{0, 90, 180, 270});
    REQUIRE(report.success);
    // Undoing a k quarter-turn clockwise rotation takes (4 - k) more.
    const int expected_deg = (360 - 90 * k) % 360;
    REQUIRE(report.best_rotation_deg == expected_deg);
    REQUIRE(report.hypotheses.size() == 4);
    const auto inliers = report.inlier_counts();
    const auto counts = report.match_counts();
    for (int q = 0; q < 4; ++q) {
      REQUIRE(counts[static_cast<std::size_t>(q)] >= 40);
      if (90 * q == expected_deg)
        REQUIRE(inliers[static_cast<std::size_t>(q)] > 500);
      else
        REQUIRE(inliers[static_cast<std::size_t>(q)] < 40);
    }
    // The similarity maps master px to the unrotated secondary: s = R_k(m - offset).
    const diachron::Similarity2 truth =
        diachron::quarter_turn_similarity(k, cw, ch) *
        diachron::Similarity2{1.0, 0.0, Vector2d(-ox, -oy)};
    // The refit may take in a random pair that happens to fall within the threshold, hence the
    // tolerances; the pattern matches themselves must map exactly.
    REQUIRE(report.similarity.scale == Approx(1.0).margin(1e-3));
    REQUIRE(std::abs(std::remainder(report.similarity.angle - truth.angle, 2 * diachron::kPi)) < 1e-3);
    REQUIRE((report.similarity.translation - truth.translation).norm() < 0.1);
    REQUIRE(report.best_matches == report.matches.size());
    REQUIRE(report.inlier_matches.size() == report.inliers.size());
    std::size_t junk_inliers = 0;
    for (const PointMatch& m : report.inlier_matches) {
      if (m.score == 0.0) {
        ++junk_inliers;
        continue;
      }
      // Exact back-mapping to the unrotated secondary: the pixel values agree.
      REQUIRE(secondary.at(static_cast<int>(m.b.x()), static_cast<int>(m.b.y())) ==
              master.at(static_cast<int>(m.a.x()), static_cast<int>(m.a.y())));
      REQUIRE((truth(m.a) - m.b).norm() < 1e-9);
    }
    REQUIRE(junk_inliers <= 3);
  }
}

TEST_CASE("match_with_rotation_hypotheses: subset of rotations, two-argument match function, failure",
          "[matching]") {
  const Image master = noise_image(30, 30, 2), secondary = noise_image(30, 30, 3);
  // Ground-truth matches with a 180 degree rotation, returned only under that hypothesis.
  auto truth_fn = [](const Image& m, const Image& s) {
    std::vector<PointMatch> out;
    if (s.width() != 30) return out;
    for (int i = 0; i < 20; ++i) {
      const Vector2d a(i, (7 * i) % 30);
      // master a is at secondary 29 - a; after the 180 rotation of the secondary, back at a.
      out.push_back(PointMatch{a, a, 1.0});
    }
    (void)m;
    return out;
  };
  const auto only = diachron::match_with_rotation_hypotheses(master, secondary, truth_fn,
                                                              diachron::RansacOptions{}, {180});
  REQUIRE(only.success);
  REQUIRE(only.hypotheses.size() == 1);
  REQUIRE(only.best_rotation_deg == 180);
  REQUIRE(only.inlier_counts()[0] == -1);
  REQUIRE(only.inlier_counts()[2] == 20);
  for (const auto& m : only.inlier_matches) REQUIRE(m.b == Vector2d(29, 29) - m.a);

  auto nothing = [](const Image&, const Image&) { return std::vector<PointMatch>{}; };
  const auto none = diachron::match_with_rotation_hypotheses(master, secondary, nothing);
  REQUIRE_FALSE(none.success);
  REQUIRE(none.best_rotation_deg == -1);
  REQUIRE(none.hypotheses.size() == 4);
  REQUIRE(!none.message.empty());

  diachron::RotationHypothesesOptions bad;
  bad.rotations_deg = {0, 45};
  REQUIRE_THROWS_AS(diachron::match_with_rotation_hypotheses(master, secondary, nothing, bad), diachron::Error);
  bad.rotations_deg = {90, 90};
  REQUIRE_THROWS_AS(diachron::match_with_rotation_hypotheses(master, secondary, nothing, bad), diachron::Error);
  REQUIRE_THROWS_AS(diachron::match_with_rotation_hypotheses(Image(), secondary, nothing), diachron::Error);
}
