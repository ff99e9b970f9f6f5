// Correlation matching of two images through a 2D transfer (pipeline/correlation_pair.hpp): a textured
// image and its warp by a known similarity, matched from a transfer several px off; every stage judged
// against the truth; masks, invalid options, thread counts, too few matches; the generic two passes
// against correlation_match called directly; the example of docs/two-image-matching.md.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <iostream>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include <diachron/geometry/homography.hpp>
#include <diachron/geometry/similarity2.hpp>
#include <diachron/matching/correlation_matcher.hpp>
#include <diachron/matching/image_mask.hpp>
#include <diachron/pipeline/correlation_pair.hpp>
#include <diachron/terrain/transfer.hpp>
#include <diachron/vision/image.hpp>

#include "support/textures.hpp"

using namespace diachron;

namespace {

// The truth of the pair: secondary px = cp_truth()(master px), scale 1.08, 6 degrees, a shift.
Similarity2 cp_truth() { return Similarity2{1.08, 6.0 * kPi / 180.0, Eigen::Vector2d(-12.0, 25.0)}; }

// The rough transfer a user has: the truth after a similarity about the master centre (240, 180)
// of 1.5 % scale and 0.015 rad, and a shift of (5, -3) px: 6 px off at the centre, up to about 11
// at the corners, inside the default +-12 master px search.
Similarity2 cp_rough() {
  const Eigen::Vector2d c(240.0, 180.0);
  const Similarity2 about_centre{1.015, 0.015, Eigen::Vector2d::Zero()};
  const Eigen::Vector2d shift = c - about_centre(c) + Eigen::Vector2d(5.0, -3.0);
  const Similarity2 off{about_centre.scale, about_centre.angle, shift};
  const Similarity2 t = cp_truth();
  // t(off(p)) = t.scale R(t.angle) (off(p)) + t.translation
  return Similarity2{t.scale * off.scale, t.angle + off.angle, t.scale * t.rotation() * off.translation + t.translation};
}

cv::Matx23d cp_matx(const Similarity2& s) {
  const Eigen::Matrix2d l = s.linear();
  return cv::Matx23d(l(0, 0), l(0, 1), s.translation.x(), l(1, 0), l(1, 1), s.translation.y());
}

struct CpPair {
  Raster<std::uint8_t> master, secondary;
};

// A 480 x 360 textured master and its warp by the truth (same size).
const CpPair& cp_pair() {
  static const CpPair pair = [] {
    CpPair p;
    p.master = test::textured(480, 360, 11);
    p.secondary = test::warp(p.master, cp_matx(cp_truth()));
    return p;
  }();
  return pair;
}

Homography2 cp_as_homography(const Similarity2& s) { return Homography2{s.matrix()}; }

// The distance of a match's secondary point from the truth's image of its master point, px.
double cp_error(const PointMatch& m, const Homography2& truth) { return (*truth(m.a) - m.b).norm(); }

double cp_median_error(const PointMatches& matches, const Homography2& truth = cp_as_homography(cp_truth())) {
  std::vector<double> e;
  for (const PointMatch& m : matches) e.push_back(cp_error(m, truth));
  if (e.empty()) return std::numeric_limits<double>::infinity();
  std::nth_element(e.begin(), e.begin() + static_cast<std::ptrdiff_t>(e.size() / 2), e.end());
  return e[e.size() / 2];
}

std::size_t cp_within(const PointMatches& matches, double tol,
                      const Homography2& truth = cp_as_homography(cp_truth())) {
  return static_cast<std::size_t>(std::count_if(matches.begin(), matches.end(),
                                                [&](const PointMatch& m) { return cp_error(m, truth) <= tol; }));
}

// A pair related by a homography: secondary px = cp_homography()(master px), with a perspective
// part that moves the corners 2 to 5 px from any similarity.
Homography2 cp_homography() {
  Eigen::Matrix3d h;
  h << 1.05, 0.04, -10.0, -0.03, 1.02, 15.0, 4e-5, -3e-5, 1.0;
  return Homography2{h};
}

struct CpHomographyPair {
  Raster<std::uint8_t> master, secondary;
  Homography2 rough;  // the truth after cp_rough's error about the master centre
};

const CpHomographyPair& cp_homography_pair() {
  static const CpHomographyPair pair = [] {
    CpHomographyPair p;
    p.master = test::textured(480, 360, 12);
    cv::Mat warped;
    cv::Matx33d m;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) m(r, c) = cp_homography().matrix(r, c);
    // warpPerspective maps source pixel centres to destination pixel centres, as diachron does.
    cv::warpPerspective(as_mat(p.master), warped, m, cv::Size(480, 360), cv::INTER_CUBIC, cv::BORDER_REFLECT_101);
    p.secondary = to_raster<std::uint8_t>(warped);
    // cp_rough() = truth o off: off = inverse(truth) o cp_rough().
    const Similarity2 t = cp_truth();
    const Similarity2 off = t.inverse() * cp_rough();
    p.rough = cp_homography() * cp_as_homography(off);
    return p;
  }();
  return pair;
}

// The defaults with 9 px cells (1900 points instead of 4300 at 6 px: the same checks at half the
// time; the docs example below keeps the defaults).
CorrelationPairOptions cp_options(std::size_t threads = 1) {
  CorrelationPairOptions o;
  o.threads = threads;
  o.interest.cell_px = 9;
  return o;
}

// The example of docs/two-image-matching.md, as it is there (between the braces).
struct CpDocResult {
  diachron::CorrelationPairReport report;
  std::vector<diachron::PointPair2> ties;
  diachron::Similarity2 refined;
};
CpDocResult cp_doc_example(const Raster<std::uint8_t>& master, const Raster<std::uint8_t>& secondary,
                           const Similarity2& rough) {
  diachron::CorrelationPairOptions options;  // the defaults below
  const auto transfer = diachron::make_map_transfer(rough);
  const diachron::CorrelationPairReport report =
      diachron::correlation_match_pair(master, secondary, transfer, options);
  if (!report.success) std::cerr << report.message << '\n';
  std::vector<diachron::PointPair2> ties;  // master px -> secondary px
  for (const diachron::PointMatch& m : report.matches) ties.push_back({m.a, m.b});
  const diachron::Similarity2 refined = report.final_fit.similarity;  // the pair's map, re-estimated
  return {report, ties, refined};
}

void cp_require_same(const PointMatches& x, const PointMatches& y) {
  REQUIRE(x.size() == y.size());
  for (std::size_t i = 0; i < x.size(); ++i) {
    REQUIRE(x[i].a == y[i].a);
    REQUIRE(x[i].b == y[i].b);
    REQUIRE(x[i].score == y[i].score);
  }
}

}  // namespace

TEST_CASE("CorrelationPair: a similarity pair is matched to a fraction of a px from a transfer px off",
          "[pipeline]") {
  const CpPair& p = cp_pair();
  const auto rough = make_map_transfer(cp_rough());
  // The rough transfer is really several px off.
  REQUIRE((cp_rough()(Eigen::Vector2d(240, 180)) - cp_truth()(Eigen::Vector2d(240, 180))).norm() > 5.0);

  const CorrelationPairReport r = correlation_match_pair(p.master, p.secondary, rough, cp_options());
  INFO(r.message);
  REQUIRE(r.success);
  REQUIRE(r.cell_px == 9);
  REQUIRE(r.threshold_px == 3.0);
  REQUIRE(r.second_ran);
  REQUIRE(r.refit.success);
  REQUIRE(r.final_fit.success);
  REQUIRE(r.first_counts.matched == r.first_pass.size());
  REQUIRE(r.second_counts.matched == r.second_pass.size());

  // The final matches: hundreds, all within a fraction of a px of the truth.
  REQUIRE(r.matches.size() >= 800);
  REQUIRE(r.matches.size() == r.final_fit.inliers.size());
  REQUIRE(cp_median_error(r.matches) < 0.05);
  REQUIRE(cp_within(r.matches, 0.5) == r.matches.size());

  // The second pass improves on the first: more matches, and more of them within 0.1 px.
  REQUIRE(r.second_pass.size() > r.first_pass.size());
  REQUIRE(cp_within(r.second_pass, 0.1) > cp_within(r.first_pass, 0.1));
  REQUIRE(cp_median_error(r.second_pass) <= cp_median_error(r.first_pass));

  // The refit recovers the true map, and the final fit too.
  const Similarity2 t = cp_truth();
  for (const PairMapFit* fit : {&r.refit, &r.final_fit}) {
    REQUIRE(std::abs(fit->similarity.scale - t.scale) < 1e-3);
    REQUIRE(std::abs(fit->similarity.angle - t.angle) < 1e-3);
    for (const Eigen::Vector2d& corner : {Eigen::Vector2d(0, 0), Eigen::Vector2d(479, 0), Eigen::Vector2d(0, 359),
                                         Eigen::Vector2d(479, 359)}) {
      REQUIRE((fit->similarity(corner) - t(corner)).norm() < 0.1);
      // The homography is the same map.
      REQUIRE((*fit->homography(corner) - fit->similarity(corner)).norm() < 1e-9);
    }
  }
}

TEST_CASE("CorrelationPair: a homography pair is matched and its homography recovered", "[pipeline]") {
  const CpHomographyPair& p = cp_homography_pair();
  const Homography2 truth = cp_homography();
  const Eigen::Vector2d centre(240, 180);
  REQUIRE((*p.rough(centre) - *truth(centre)).norm() > 5.0);
  CorrelationPairOptions o = cp_options();
  o.model = PairRefitModel::homography;
  const CorrelationPairReport r = correlation_match_pair(p.master, p.secondary, make_map_transfer(p.rough), o);
  INFO(r.message);
  REQUIRE(r.success);
  REQUIRE(r.refit.success);
  REQUIRE(r.second_ran);
  REQUIRE(r.matches.size() >= 800);
  REQUIRE(cp_median_error(r.matches, truth) < 0.05);
  REQUIRE(cp_within(r.matches, 0.5, truth) == r.matches.size());
  REQUIRE(r.second_pass.size() > r.first_pass.size());
  REQUIRE(cp_within(r.second_pass, 0.1, truth) > cp_within(r.first_pass, 0.1, truth));
  for (const PairMapFit* fit : {&r.refit, &r.final_fit})
    for (const Eigen::Vector2d& corner : {Eigen::Vector2d(0, 0), Eigen::Vector2d(479, 0), Eigen::Vector2d(0, 359),
                                          Eigen::Vector2d(479, 359), centre})
      REQUIRE((*fit->homography(corner) - *truth(corner)).norm() < 0.1);

  // A similarity cannot follow the perspective: at 3 px it keeps fewer of the same pair's matches.
  o.model = PairRefitModel::similarity;
  const CorrelationPairReport s = correlation_match_pair(p.master, p.secondary, make_map_transfer(p.rough), o);
  INFO(s.message);
  REQUIRE(s.matches.size() < r.matches.size());
}

TEST_CASE("CorrelationPair: masks are honoured on both images", "[pipeline]") {
  const CpPair& p = cp_pair();
  // The master without its left third, the secondary without its bottom quarter (0 = ignore).
  Raster<std::uint8_t> m1(480, 360, 255), m2(480, 360, 255);
  for (int y = 0; y < 360; ++y)
    for (int x = 0; x < 480; ++x) {
      if (x < 160) m1(x, y) = 0;
      if (y >= 270) m2(x, y) = 0;
    }
  const ImageMask mask1(m1), mask2(m2);
  const auto rough = make_map_transfer(cp_rough());
  const CorrelationPairReport r = correlation_match_pair(p.master, p.secondary, rough, cp_options(), &mask1, &mask2);
  INFO(r.message);
  REQUIRE(r.success);
  REQUIRE(r.matches.size() >= 150);
  REQUIRE(cp_within(r.matches, 0.5) == r.matches.size());
  // Every master window (21 px) and every secondary window (about 21 x 1.08 px) lies on usable pixels.
  for (const PointMatches* list : {&r.first_pass, &r.second_pass, &r.matches})
    for (const PointMatch& m : *list) {
      REQUIRE(mask1.box_usable(m.a, 10));
      REQUIRE(mask2.box_usable(m.b, 11));
    }
  REQUIRE(r.second_counts.masked > 0);  // the secondary mask had something to drop
  // Without the masks there are matches where they were.
  const CorrelationPairReport all = correlation_match_pair(p.master, p.secondary, rough, cp_options());
  REQUIRE(std::any_of(all.matches.begin(), all.matches.end(), [](const PointMatch& m) { return m.a.x() < 160; }));
  REQUIRE(std::any_of(all.matches.begin(), all.matches.end(), [](const PointMatch& m) { return m.b.y() >= 270; }));
}

TEST_CASE("CorrelationPair: the same report whatever the thread count", "[pipeline]") {
  const CpPair& p = cp_pair();
  const auto rough = make_map_transfer(cp_rough());
  const CorrelationPairReport one = correlation_match_pair(p.master, p.secondary, rough, cp_options(1));
  for (const std::size_t threads : {std::size_t{2}, std::size_t{0}}) {
    const CorrelationPairReport other = correlation_match_pair(p.master, p.secondary, rough, cp_options(threads));
    REQUIRE(other.message == one.message);
    cp_require_same(other.first_pass, one.first_pass);
    cp_require_same(other.second_pass, one.second_pass);
    cp_require_same(other.matches, one.matches);
    REQUIRE(other.refit.inliers == one.refit.inliers);
    REQUIRE(other.final_fit.similarity.translation == one.final_fit.similarity.translation);
  }
}

TEST_CASE("CorrelationPair: too few first-pass matches is an honest failure", "[pipeline]") {
  const CpPair& p = cp_pair();
  // The secondary shows the master's ground only in a 70 x 70 px block; elsewhere it is flat grey.
  Raster<std::uint8_t> secondary(480, 360, 128);
  for (int y = 150; y < 220; ++y)
    for (int x = 200; x < 270; ++x) secondary(x, y) = p.secondary(x, y);
  const auto rough = make_map_transfer(cp_rough());
  CorrelationPairOptions o = cp_options();
  o.min_matches = 200;  // more than the block can give
  const CorrelationPairReport r = correlation_match_pair(p.master, secondary, rough, o);
  INFO(r.message);
  REQUIRE(!r.first_pass.empty());
  REQUIRE(r.first_pass.size() < o.min_matches);
  REQUIRE_FALSE(r.success);
  REQUIRE_FALSE(r.refit.success);
  REQUIRE_FALSE(r.second_ran);
  REQUIRE(r.second_pass.empty());
  REQUIRE_FALSE(r.final_fit.success);
  REQUIRE(r.matches.empty());
  REQUIRE(r.message.find("refit:") != std::string::npos);
  REQUIRE(r.message.find("no final match") != std::string::npos);

  // A flat secondary: nothing at all, and still a report, not an error.
  const CorrelationPairReport none =
      correlation_match_pair(p.master, Raster<std::uint8_t>(480, 360, 128), rough, cp_options());
  REQUIRE_FALSE(none.success);
  REQUIRE(none.first_pass.empty());
  REQUIRE(none.matches.empty());

  // A default report means failure.
  REQUIRE_FALSE(CorrelationPairReport{}.success);
  REQUIRE_FALSE(PairMapFit{}.success);
}

TEST_CASE("CorrelationPair: without a second pass the filter judges the first", "[pipeline]") {
  const CpPair& p = cp_pair();
  CorrelationPairOptions o = cp_options();
  o.second_pass_radius_px = 0;
  const CorrelationPairReport r = correlation_match_pair(p.master, p.secondary, make_map_transfer(cp_rough()), o);
  REQUIRE(r.success);
  REQUIRE_FALSE(r.second_ran);
  REQUIRE(r.refit.message == "not run");
  REQUIRE(&r.tentative() == &r.first_pass);
  REQUIRE(r.matches.size() == r.final_fit.inliers.size());
  for (std::size_t k = 0; k < r.matches.size(); ++k) REQUIRE(r.matches[k].a == r.first_pass[r.final_fit.inliers[k]].a);
}

TEST_CASE("CorrelationPair: the threshold never goes below min_threshold_master_px master px", "[pipeline]") {
  const CpPair& p = cp_pair();
  // A secondary 2.5 times finer than the master: 1.5 master px is 3.75 secondary px.
  const auto fine = make_map_transfer(Similarity2{2.5, 0.0, Eigen::Vector2d::Zero()});
  CorrelationPairOptions o = cp_options();
  o.second_pass_radius_px = 0;
  const CorrelationPairReport r = correlation_match_pair(p.master, p.secondary, fine, o);
  REQUIRE(r.threshold_px == Approx(3.75).epsilon(1e-9));
  o.min_threshold_master_px = 0.0;
  REQUIRE(correlation_match_pair(p.master, p.secondary, fine, o).threshold_px == 3.0);
}

TEST_CASE("CorrelationPair: invalid options and inputs throw diachron::Error naming the field", "[pipeline]") {
  const CpPair& p = cp_pair();
  const auto rough = make_map_transfer(cp_rough());
  const auto fails = [&](const CorrelationPairOptions& o, const char* field) {
    REQUIRE_THROWS_AS(o.check(), Error);
    REQUIRE_THROWS_WITH(correlation_match_pair(p.master, p.secondary, rough, o), Catch::Contains(field));
  };
  CorrelationPairOptions o;
  o.threshold_px = 0.0;
  fails(o, "threshold_px");
  o = {};
  o.threshold_px = std::numeric_limits<double>::quiet_NaN();
  fails(o, "threshold_px");
  o = {};
  o.min_threshold_master_px = -1.0;
  fails(o, "min_threshold_master_px");
  o = {};
  o.second_pass_radius_px = -1;
  fails(o, "second_pass_radius_px");
  o = {};
  o.second_pass_radius_px = 129;
  fails(o, "second_pass_radius_px");
  o = {};
  o.min_matches = 3;
  fails(o, "min_matches");
  o = {};
  o.match.window_px = 4;
  fails(o, "window_px");
  o = {};
  o.interest.cell_px = 1;
  fails(o, "cell_px");
  o = {};
  o.ransac.max_iterations = 0;
  fails(o, "max_iterations");
  REQUIRE_NOTHROW(CorrelationPairOptions{}.check());

  // Images and masks.
  REQUIRE_THROWS_AS(correlation_match_pair(Raster<std::uint8_t>{}, p.secondary, rough), Error);
  const ImageMask small(Raster<std::uint8_t>(100, 100, 255));
  REQUIRE_THROWS_WITH(correlation_match_pair(p.master, p.secondary, rough, cp_options(), &small),
                      Catch::Contains("master"));
  REQUIRE_THROWS_WITH(correlation_match_pair(p.master, p.secondary, rough, cp_options(), nullptr, &small),
                      Catch::Contains("secondary"));
}

TEST_CASE("CorrelationPair: the two passes are correlation_match through the first and the refitted transfer",
          "[pipeline]") {
  const CpPair& p = cp_pair();
  const auto rough = make_map_transfer(cp_rough());
  GridInterestOptions interest;
  interest.cell_px = 12;
  const std::vector<Eigen::Vector2d> points = correlation_points(p.master, interest, 21);
  REQUIRE(points.size() > 300);
  for (const Eigen::Vector2d& q : points) {  // a whole window (and 2 px more) inside the image
    REQUIRE(q.x() >= 12);
    REQUIRE(q.y() >= 12);
    REQUIRE(q.x() <= 479 - 12);
    REQUIRE(q.y() <= 359 - 12);
  }
  CorrelationMatchOptions match;
  match.threads = 1;
  // The refit policy may return another Transfer type: here the truth as a homography.
  std::size_t seen = 0;
  const auto refit = [&](const PointMatches& first) {
    seen = first.size();
    CorrelationRefit<Homography2> out;
    out.transfer = Homography2{cp_truth().matrix()};
    return out;
  };
  const CorrelationPasses passes = correlation_two_passes(p.master, p.secondary, points, rough, match, 4, refit);
  REQUIRE(passes.second_ran);
  REQUIRE(seen == passes.first.size());
  cp_require_same(passes.first, correlation_match(p.master, p.secondary, points, rough, match).matches);
  cp_require_same(passes.second,
                  correlation_match(p.master, p.secondary, points, Homography2{cp_truth().matrix()},
                                    narrow_correlation_options(match, 4))
                      .matches);
  REQUIRE(narrow_correlation_options(match, 4).search_radius_px == 4);
  REQUIRE(narrow_correlation_options(match, 4).exclusion_px == 3);
  REQUIRE(narrow_correlation_options(match, 2).exclusion_px == 1);
  REQUIRE(passes.message.find("; second pass: ") != std::string::npos);

  // A policy that declines: the first pass alone, with its note.
  const auto decline = [](const PointMatches&) { return CorrelationRefit<Homography2>{std::nullopt, "no model"}; };
  const CorrelationPasses one = correlation_two_passes(p.master, p.secondary, points, rough, match, 4, decline);
  REQUIRE_FALSE(one.second_ran);
  REQUIRE(&one.tentative() == &one.first);
  REQUIRE(one.message.size() > 20);
  REQUIRE(one.message.substr(one.message.size() - 27) == "; no second pass (no model)");
}

TEST_CASE("CorrelationPair: the example of docs/two-image-matching.md runs", "[pipeline]") {
  const CpPair& p = cp_pair();
  const CpDocResult r = cp_doc_example(p.master, p.secondary, cp_rough());
  REQUIRE(r.report.success);
  REQUIRE(r.ties.size() == r.report.matches.size());
  REQUIRE(std::abs(r.refined.scale - cp_truth().scale) < 1e-3);
  cp_require_same(r.report.matches,
                  correlation_match_pair(p.master, p.secondary, make_map_transfer(cp_rough()),
                                         CorrelationPairOptions{}).matches);
}

TEST_CASE("CorrelationPair: effective_cell_px bounds the points of a large image", "[pipeline]") {
  REQUIRE(effective_cell_px(6, 60000, 1600, 1200) == 6);    // 53333 cells of 6 px: within the bound
  REQUIRE(effective_cell_px(6, 60000, 3200, 2400) == 12);   // ceil(sqrt(128)) = 12
  REQUIRE(effective_cell_px(6, 0, 12000, 12000) == 6);      // no bound
  REQUIRE(effective_cell_px(6, 10000, 1000, 1000) == 10);   // an exact square does not round up
  REQUIRE_THROWS_AS(effective_cell_px(6, 100, 0, 10), Error);
}
