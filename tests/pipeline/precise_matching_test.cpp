// Precise matching composed over a small synthetic two-epoch scene: overlapping pairs through the
// DSMs, guided and patch matching, the ground filter and NCC, every final match judged with the
// scene's truth; determinism across thread counts; no pair is an answer, not an error.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <catch2/catch.hpp>

#include <diachron/core/progress.hpp>
#include <diachron/eval/match_truth.hpp>
#include <diachron/pipeline/overlapping_pairs.hpp>
#include <diachron/pipeline/precise_matching.hpp>
#include <diachron/synth/scene.hpp>
#include <diachron/vision/extractor_pair_matcher.hpp>
#include <diachron/vision/sift.hpp>

#include "support/scenes.hpp"

using namespace diachron;

namespace {

struct Fixture {
  Scene scene;
  std::vector<Frame<FraserAffine>> frames1, frames2;
  std::vector<ImagePairOverlap> pairs;
};

// Generated once: two epochs of 1 x 2 images of 400 x 300 px, 40 years apart in the generator's
// default change model; the SfM's estimated cameras and the epoch DSMs, as a user has them.
const Fixture& fixture() {
  static const Fixture f = [] {
    Fixture out;
    out.scene = generate_scene(diachron::test::small_scene_options(5, 20, 5));
    const SyntheticEpoch& e1 = out.scene.epochs[0];
    const SyntheticEpoch& e2 = out.scene.epochs[1];
    out.frames1 = e1.estimated_frames();
    out.frames2 = e2.estimated_frames();
    OverlappingPairsOptions po;
    po.min_overlap_fraction = 0.2;
    out.pairs = overlapping_pairs(make_footprint_images(out.frames1), e1.dsm, make_footprint_images(out.frames2),
                                  e2.dsm, out.scene.epoch2_from_epoch1(), po)
                    .pairs;
    return out;
  }();
  return f;
}

PreciseEpoch<Frame<FraserAffine>> epoch_view(const Fixture& f, int e) {
  const SyntheticEpoch& epoch = f.scene.epochs[static_cast<std::size_t>(e)];
  return {e == 0 ? f.frames1 : f.frames2, [&epoch](std::size_t i) { return epoch.images[i].pixels; }, &epoch.dsm};
}

struct Judged {
  std::size_t matches = 0, decidable = 0, within3 = 0;
};

// Every final match against the truth; changed surfaces are undecidable and left out.
Judged judge(const Fixture& f, const PreciseMatchingReport& report) {
  const MatchTruthScorer truth(f.scene);
  Judged j;
  for (const PrecisePairReport& p : report.pairs)
    for (const PointMatch& m : p.matches) {
      ++j.matches;
      const MatchTruth t =
          truth.score({0, static_cast<int>(p.master)}, {1, static_cast<int>(p.secondary)}, m.a, m.b);
      if (t.status == MatchTruthStatus::changed_surface || t.status == MatchTruthStatus::no_surface) continue;
      ++j.decidable;
      if (t.scored() && t.error_px < 3.0) ++j.within3;
    }
  return j;
}

bool same_matches(const PreciseMatchingReport& a, const PreciseMatchingReport& b) {
  if (a.pairs.size() != b.pairs.size()) return false;
  for (std::size_t k = 0; k < a.pairs.size(); ++k) {
    const PointMatches& x = a.pairs[k].matches;
    const PointMatches& y = b.pairs[k].matches;
    if (x.size() != y.size()) return false;
    for (std::size_t i = 0; i < x.size(); ++i)
      if (x[i].a != y[i].a || x[i].b != y[i].b) return false;
  }
  return true;
}

}  // namespace

TEST_CASE("guided precise matching: correct matches on every overlapping pair, whatever the threads",
          "[pipeline][precise]") {
  const Fixture& f = fixture();
  REQUIRE(f.pairs.size() >= 2);
  PreciseMatchingOptions options;
  options.threads = 2;
  std::vector<ProgressEvent> events;  // the library serialises the calls
  options.progress = [&events](const ProgressEvent& e) { events.push_back(e); };
  const PreciseMatchingReport report = precise_matching_guided(epoch_view(f, 0), epoch_view(f, 1),
                                                               f.scene.epoch2_from_epoch1(), f.pairs,
                                                               RootSiftExtractor{}, options);
  INFO(report.message);
  REQUIRE(report.success);
  // Progress: every stage starts at 0, counts up by one unit per call, and ends at its total; the
  // pair stage counts the pairs.
  std::map<std::string, std::vector<ProgressEvent>> stages;
  for (const ProgressEvent& e : events) stages[e.stage].push_back(e);
  REQUIRE(stages.count("precise matching (pairs)") == 1);
  CHECK(stages["precise matching (pairs)"].back().total == f.pairs.size());
  for (const auto& [stage, list] : stages) {
    INFO(stage);
    CHECK(list.front().done == 0);
    for (std::size_t i = 1; i < list.size(); ++i) CHECK(list[i].done == list[i - 1].done + 1);
    CHECK(list.back().done == list.back().total);
  }
  REQUIRE(report.pairs.size() == f.pairs.size());
  for (std::size_t k = 0; k < report.pairs.size(); ++k) {
    const PrecisePairReport& p = report.pairs[k];
    CHECK(p.master == f.pairs[k].master);
    CHECK(p.secondary == f.pairs[k].secondary);
    // Each stage only removes: the filters judge exactly the list before them.
    CHECK(p.ground.size() == p.tentative.size());
    CHECK(p.grounded.size() == p.ground.kept());
    CHECK(p.ncc.size() == p.grounded.size());
    CHECK(p.matches.size() == p.ncc.kept());
  }
  const Judged j = judge(f, report);
  CHECK(report.final_matches == j.matches);
  INFO(j.within3 << " of " << j.decidable << " decidable final matches within 3 px");
  CHECK(j.matches >= 40);
  CHECK(j.within3 >= 0.95 * static_cast<double>(j.decidable));

  options.threads = 1;
  const PreciseMatchingReport serial = precise_matching_guided(epoch_view(f, 0), epoch_view(f, 1),
                                                               f.scene.epoch2_from_epoch1(), f.pairs,
                                                               RootSiftExtractor{}, options);
  CHECK(same_matches(report, serial));
}

TEST_CASE("patch precise matching: transfer-guided tiles with SIFT, then the filters", "[pipeline][precise]") {
  const Fixture& f = fixture();
  REQUIRE(!f.pairs.empty());
  const std::vector<ImagePairOverlap> first(f.pairs.begin(), f.pairs.begin() + 1);
  PreciseMatchingOptions options;
  options.threads = 2;
  const PreciseMatchingReport report =
      precise_matching_patch(epoch_view(f, 0), epoch_view(f, 1), f.scene.epoch2_from_epoch1(), first,
                             ExtractorPairMatcher<SiftExtractor>(SiftExtractor{}), options);
  INFO(report.message);
  REQUIRE(report.success);
  const Judged j = judge(f, report);
  INFO(j.within3 << " of " << j.decidable << " decidable final matches within 3 px");
  CHECK(j.matches >= 20);
  CHECK(j.within3 >= 0.95 * static_cast<double>(j.decidable));
}

TEST_CASE("correlation precise matching: correct matches on every pair, whatever the threads",
          "[pipeline][precise]") {
  const Fixture& f = fixture();
  REQUIRE(f.pairs.size() >= 2);
  PreciseMatchingOptions options;
  options.threads = 2;
  // Coarser cells than the default 6 px keep the test quick; accuracy does not depend on density.
  options.correlation.interest.cell_px = 10;
  const PreciseMatchingReport report = precise_matching_correlation(epoch_view(f, 0), epoch_view(f, 1),
                                                                    f.scene.epoch2_from_epoch1(), f.pairs, options);
  INFO(report.message);
  REQUIRE(report.success);
  REQUIRE(report.pairs.size() == f.pairs.size());
  for (const PrecisePairReport& p : report.pairs) {
    INFO(p.message);
    CHECK(p.ground.size() == p.tentative.size());
    CHECK(p.grounded.size() == p.ground.kept());
    // The correlation score is the validation: no intensity NCC by default.
    CHECK(p.ncc.size() == 0);
    CHECK(p.matches.size() == p.grounded.size());
  }
  const Judged j = judge(f, report);
  INFO(j.within3 << " of " << j.decidable << " decidable final matches within 3 px");
  CHECK(j.matches >= 40);
  CHECK(j.within3 >= 0.95 * static_cast<double>(j.decidable));

  options.threads = 1;
  const PreciseMatchingReport serial = precise_matching_correlation(epoch_view(f, 0), epoch_view(f, 1),
                                                                    f.scene.epoch2_from_epoch1(), f.pairs, options);
  CHECK(same_matches(report, serial));

  {
    // A bound on the points per image coarsens the cell of a large master image: a bound of a
    // hundredth of its pixels gives 10 px cells from the default 6, and the same matches as 10 px
    // cells asked for directly.
    const Raster<std::uint8_t>& image1 = f.scene.epochs[0].images[0].pixels;
    PreciseMatchingOptions bounded = options;
    bounded.correlation.interest.cell_px = 6;
    bounded.correlation.max_points_per_image =
        static_cast<std::size_t>(image1.width()) * static_cast<std::size_t>(image1.height()) / 100;
    REQUIRE(effective_cell_px(bounded.correlation, image1.width(), image1.height()) == 10);
    const PreciseMatchingReport coarse = precise_matching_correlation(epoch_view(f, 0), epoch_view(f, 1),
                                                                      f.scene.epoch2_from_epoch1(), f.pairs, bounded);
    CHECK(same_matches(report, coarse));
    for (const PrecisePairReport& p : coarse.pairs) {
      INFO(p.message);
      CHECK(p.message.find("(10 px cells)") != std::string::npos);
    }
  }
  {
    // The ground filter's threshold: ground_threshold_gsd GSD of the secondary image, but at least
    // ground_floor_master_gsd GSD of the master (in secondary units), re-computed here from the
    // definition. A floor of 6 master GSD binds on these images of equal size and keeps at least as
    // many matches as the default; no floor gives 3 secondary GSD.
    const SyntheticEpoch& e1 = f.scene.epochs[0];
    const SyntheticEpoch& e2 = f.scene.epochs[1];
    const auto gsd_of = [](const Frame<FraserAffine>& frame, const Dsm& dsm, const Raster<std::uint8_t>& image) {
      return *gsd_on_dsm(frame, dsm, 0.5 * Eigen::Vector2d(image.width() - 1, image.height() - 1));
    };
    for (const double floor : {0.0, 1.5, 6.0}) {
      PreciseMatchingOptions floored = options;
      floored.correlation.ground_floor_master_gsd = floor;
      const PreciseMatchingReport r = precise_matching_correlation(epoch_view(f, 0), epoch_view(f, 1),
                                                                   f.scene.epoch2_from_epoch1(), f.pairs, floored);
      REQUIRE(r.pairs.size() == report.pairs.size());
      for (std::size_t k = 0; k < r.pairs.size(); ++k) {
        const PrecisePairReport& p = r.pairs[k];
        const double gsd1 = gsd_of(f.frames1[p.master], e1.dsm, e1.images[p.master].pixels) *
                            f.scene.epoch2_from_epoch1().scale;
        const double gsd2 = gsd_of(f.frames2[p.secondary], e2.dsm, e2.images[p.secondary].pixels);
        INFO("floor " << floor << ", pair " << k << ": master GSD " << gsd1 << ", secondary GSD " << gsd2);
        CHECK(p.ground.threshold == Approx(std::max(3.0 * gsd2, floor * gsd1)).epsilon(1e-12));
        if (floor == 6.0) {
          CHECK(p.ground.threshold > 3.0 * gsd2);
          CHECK(p.grounded.size() >= report.pairs[k].grounded.size());
        }
      }
    }
  }
  PreciseMatchingOptions bad;
  bad.correlation.ground_floor_master_gsd = -1.0;
  CHECK_THROWS_WITH(precise_matching_correlation(epoch_view(f, 0), epoch_view(f, 1), f.scene.epoch2_from_epoch1(),
                                                 f.pairs, bad),
                    Catch::Contains("ground_floor_master_gsd must be finite and >= 0"));
  bad = PreciseMatchingOptions{};
  bad.correlation.master_sharpen.amount = -0.5;
  CHECK_THROWS_WITH(precise_matching_correlation(epoch_view(f, 0), epoch_view(f, 1), f.scene.epoch2_from_epoch1(),
                                                 f.pairs, bad),
                    Catch::Contains("UnsharpMaskOptions::amount"));
  bad = PreciseMatchingOptions{};
  bad.correlation.ground_threshold_gsd = 0.0;
  CHECK_THROWS_AS(precise_matching_correlation(epoch_view(f, 0), epoch_view(f, 1), f.scene.epoch2_from_epoch1(),
                                               f.pairs, bad),
                  Error);

  {
    // Only on plane ground.
    PreciseMatchingOptions plane = options;
    plane.correlation.max_relief_gsd = 0.5;
    const PreciseMatchingReport flat = precise_matching_correlation(epoch_view(f, 0), epoch_view(f, 1),
                                                                    f.scene.epoch2_from_epoch1(), f.pairs, plane);
    INFO(flat.message);
    REQUIRE(flat.success);
    const Judged jf = judge(f, flat);
    CHECK(jf.matches >= 10);
    CHECK(jf.matches < j.matches);
    CHECK(jf.within3 >= 0.95 * static_cast<double>(jf.decidable));
    // Every final master point has plane ground in both DSMs, re-checked here from the definition.
    const SyntheticEpoch& e1 = f.scene.epochs[0];
    const SyntheticEpoch& e2 = f.scene.epochs[1];
    const Helmert3 helmert = f.scene.epoch2_from_epoch1();
    for (const PrecisePairReport& p : flat.pairs) {
      INFO(p.message);
      CHECK(p.message.find("skipped on relief") != std::string::npos);
      const auto& m1 = f.frames1[p.master];
      const auto& m2 = f.frames2[p.secondary];
      const auto transfer = make_dsm_transfer(m1, e1.dsm, m2, helmert);
      const Raster<std::uint8_t>& image1 = e1.images[p.master].pixels;
      const Raster<std::uint8_t>& image2 = e2.images[p.secondary].pixels;
      const double gsd1 = *gsd_on_dsm(m1, e1.dsm, 0.5 * Eigen::Vector2d(image1.width() - 1, image1.height() - 1));
      const double gsd2 = *gsd_on_dsm(m2, e2.dsm, 0.5 * Eigen::Vector2d(image2.width() - 1, image2.height() - 1));
      for (const PointMatch& m : p.matches) {
        const LocalRelief r1 = local_relief(e1.dsm, transfer.master_point(m.a)->head<2>(), 21.0 * gsd1);
        const LocalRelief r2 = local_relief(e2.dsm, transfer.secondary_point(m.a)->head<2>(), 21.0 * gsd1 * helmert.scale);
        CHECK(r1.rms * helmert.scale <= 0.5 * gsd2);
        CHECK(r2.rms <= 0.5 * gsd2);
      }
    }
    PreciseMatchingOptions wrong = options;
    wrong.correlation.max_relief_gsd = -1.0;
    CHECK_THROWS_WITH(precise_matching_correlation(epoch_view(f, 0), epoch_view(f, 1), helmert, f.pairs, wrong),
                      Catch::Contains("max_relief_gsd must be finite and >= 0"));
    wrong = options;
    wrong.correlation.relief_radius_px = 0.0;
    CHECK_THROWS_WITH(precise_matching_correlation(epoch_view(f, 0), epoch_view(f, 1), helmert, f.pairs, wrong),
                      Catch::Contains("relief_radius_px must be finite and > 0"));
  }
}

TEST_CASE("effective_cell_px: the smallest cell that keeps an image within the point bound", "[pipeline][precise]") {
  // Oracle: the smallest integer side c >= cell_px with width * height / c^2 <= the bound.
  const auto oracle = [](int cell, std::size_t bound, int w, int h) {
    if (bound == 0) return cell;
    int c = cell;
    while (static_cast<double>(w) * h / (static_cast<double>(c) * c) > static_cast<double>(bound)) ++c;
    return c;
  };
  PreciseCorrelationOptions o;
  CHECK(o.interest.cell_px == 6);
  CHECK(effective_cell_px(o, 1600, 1200) == 6);   // the scenes the defaults were measured on
  CHECK(effective_cell_px(o, 3200, 2400) == 12);
  CHECK(effective_cell_px(o, 12000, 12000) == 49);
  for (const std::size_t bound : {std::size_t{0}, std::size_t{1}, std::size_t{100}, std::size_t{6000}, std::size_t{60000},
                                  std::size_t{250000}})
    for (const int cell : {2, 6, 17})
      for (const auto& [w, h] : {std::pair{1, 1}, std::pair{400, 300}, std::pair{600, 600}, std::pair{1600, 1200},
                                 std::pair{4801, 3599}, std::pair{20000, 15000}}) {
        o.interest.cell_px = cell;
        o.max_points_per_image = bound;
        INFO(w << " x " << h << ", cell " << cell << ", bound " << bound);
        CHECK(effective_cell_px(o, w, h) == oracle(cell, bound, w, h));
      }
  // An exact square: 600 x 600 px over 10000 points is 6 px exactly, not 7.
  o.interest.cell_px = 2;
  o.max_points_per_image = 10000;
  CHECK(effective_cell_px(o, 600, 600) == 6);
  CHECK_THROWS_AS(effective_cell_px(o, 0, 10), Error);
  // A cell asked for is kept whatever the size, finer than the bound's too.
  PreciseCorrelationOptions fixed;
  fixed.use_fixed_cell(4);
  CHECK(effective_cell_px(fixed, 1600, 1200) == 4);
  CHECK(effective_cell_px(fixed, 12000, 12000) == 4);
}

TEST_CASE("precise matching: no pair is an answer, bad input an error", "[pipeline][precise]") {
  const Fixture& f = fixture();
  const PreciseMatchingReport none = precise_matching_guided(epoch_view(f, 0), epoch_view(f, 1),
                                                             f.scene.epoch2_from_epoch1(), {}, RootSiftExtractor{});
  CHECK_FALSE(none.success);
  CHECK(none.message == "no overlapping pair");
  CHECK(none.pairs.empty());

  // A pair naming an image the epoch does not have.
  std::vector<ImagePairOverlap> wrong(1);
  wrong[0].master = 7;
  CHECK_THROWS_WITH(precise_matching_patch(epoch_view(f, 0), epoch_view(f, 1), f.scene.epoch2_from_epoch1(), wrong,
                                           ExtractorPairMatcher<SiftExtractor>(SiftExtractor{})),
                    Catch::Contains("refers to images 7 and 0"));
  PreciseEpoch<Frame<FraserAffine>> no_dsm = epoch_view(f, 1);
  no_dsm.dsm = nullptr;
  CHECK_THROWS_WITH(precise_matching_guided(epoch_view(f, 0), no_dsm, f.scene.epoch2_from_epoch1(), f.pairs,
                                            RootSiftExtractor{}),
                    Catch::Contains("epoch 2 has no DSM"));
}

namespace {

// Masks as a scan's frame and a cloud would make them: epoch 1 without its left third and a block
// in its middle, epoch 2 without its bottom quarter (0 = ignore).
Raster<std::uint8_t> test_mask(const Raster<std::uint8_t>& image, int epoch) {
  const int w = image.width(), h = image.height();
  Raster<std::uint8_t> mask(w, h, 255);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const bool off = epoch == 0 ? (x < w / 3 || (std::abs(x - 2 * w / 3) < 20 && std::abs(y - h / 2) < 20))
                                  : y >= 3 * h / 4;
      if (off) mask(x, y) = 0;
    }
  return mask;
}

PreciseEpoch<Frame<FraserAffine>> masked_view(const Fixture& f, int e) {
  PreciseEpoch<Frame<FraserAffine>> view = epoch_view(f, e);
  const SyntheticEpoch& epoch = f.scene.epochs[static_cast<std::size_t>(e)];
  view.load_mask = [&epoch, e](std::size_t i) { return test_mask(epoch.images[i].pixels, e); };
  return view;
}

// Masked pixels in the square of half side `half` around the pixel containing p (outside counts).
int masked_in_box(const Raster<std::uint8_t>& mask, const Eigen::Vector2d& p, int half) {
  const int cx = static_cast<int>(std::lround(p.x())), cy = static_cast<int>(std::lround(p.y()));
  int n = 0;
  for (int y = cy - half; y <= cy + half; ++y)
    for (int x = cx - half; x <= cx + half; ++x) n += !mask.contains(x, y) || mask(x, y) == 0;
  return n;
}

}  // namespace

TEST_CASE("precise matching keeps masked pixels out of its matches", "[pipeline][precise]") {
  const Fixture& f = fixture();
  REQUIRE(f.pairs.size() >= 2);
  PreciseMatchingOptions options;
  options.threads = 2;
  options.correlation.interest.cell_px = 10;
  const int half = options.correlation.match.window_px / 2;
  const auto on_masks = [&f](const PrecisePairReport& p, int master_half) {
    const Raster<std::uint8_t> m1 = test_mask(f.scene.epochs[0].images[p.master].pixels, 0);
    const Raster<std::uint8_t> m2 = test_mask(f.scene.epochs[1].images[p.secondary].pixels, 1);
    std::size_t n = 0;
    for (const PointMatch& m : p.tentative)
      n += masked_in_box(m1, m.a, master_half) > 0 || masked_in_box(m2, m.b, 0) > 0;
    return n;
  };

  SECTION("correlation: whole windows on the master side, points and windows on the secondary") {
    const PreciseMatchingReport plain = precise_matching_correlation(epoch_view(f, 0), epoch_view(f, 1),
                                                                     f.scene.epoch2_from_epoch1(), f.pairs, options);
    const PreciseMatchingReport masked = precise_matching_correlation(
        masked_view(f, 0), masked_view(f, 1), f.scene.epoch2_from_epoch1(), f.pairs, options);
    INFO(masked.message);
    REQUIRE(masked.success);
    std::size_t plain_on = 0, masked_on = 0, dropped = 0;
    for (const PrecisePairReport& p : plain.pairs) plain_on += on_masks(p, half);
    for (const PrecisePairReport& p : masked.pairs) {
      INFO(p.message);
      masked_on += on_masks(p, half);
      dropped += p.masked;
      // The final matches are a subset of the tentative ones.
      CHECK(p.matches.size() <= p.tentative.size());
    }
    // Without masks many matches lie there, so the check below can fail.
    CHECK(plain_on >= 20);
    CHECK(masked_on == 0);
    // The master side is kept out before correlating; what the secondary's mask drops is counted.
    CHECK(dropped > 0);
    const Judged j = judge(f, masked);
    INFO(j.within3 << " of " << j.decidable << " decidable final matches within 3 px");
    CHECK(j.matches >= 20);
    CHECK(j.within3 >= 0.95 * static_cast<double>(j.decidable));
  }

  // The descriptor methods keep the NCC validator's windows (32 px, on by default) off the masks too.
  const int ncc_half = options.ncc.window_px / 2;

  SECTION("patch: no keypoint, and no NCC window on the master side, on a masked pixel") {
    const std::vector<ImagePairOverlap> first(f.pairs.begin(), f.pairs.begin() + 1);
    const PreciseMatchingReport plain =
        precise_matching_patch(epoch_view(f, 0), epoch_view(f, 1), f.scene.epoch2_from_epoch1(), first,
                               ExtractorPairMatcher<SiftExtractor>(SiftExtractor{}), options);
    const PreciseMatchingReport masked =
        precise_matching_patch(masked_view(f, 0), masked_view(f, 1), f.scene.epoch2_from_epoch1(), first,
                               ExtractorPairMatcher<SiftExtractor>(SiftExtractor{}), options);
    REQUIRE(masked.success);
    CHECK(on_masks(plain.pairs[0], 0) > 0);
    CHECK(on_masks(masked.pairs[0], ncc_half) == 0);
    // The same tentative matches, those near a mask dropped and counted.
    CHECK(masked.pairs[0].masked >= on_masks(plain.pairs[0], ncc_half));
    CHECK(masked.pairs[0].tentative.size() + masked.pairs[0].masked == plain.pairs[0].tentative.size());
  }

  SECTION("guided: masked keypoints are left out before matching") {
    const PreciseMatchingReport plain = precise_matching_guided(epoch_view(f, 0), epoch_view(f, 1),
                                                                f.scene.epoch2_from_epoch1(), f.pairs,
                                                                RootSiftExtractor{}, options);
    const PreciseMatchingReport masked = precise_matching_guided(masked_view(f, 0), masked_view(f, 1),
                                                                 f.scene.epoch2_from_epoch1(), f.pairs,
                                                                 RootSiftExtractor{}, options);
    REQUIRE(masked.success);
    std::size_t plain_on = 0, masked_on = 0;
    for (const PrecisePairReport& p : plain.pairs) plain_on += on_masks(p, 0);
    for (const PrecisePairReport& p : masked.pairs) masked_on += on_masks(p, ncc_half);
    CHECK(plain_on > 0);
    CHECK(masked_on == 0);
    const Judged j = judge(f, masked);
    CHECK(j.within3 >= 0.95 * static_cast<double>(j.decidable));
    PreciseEpoch<Frame<FraserAffine>> wrong = epoch_view(f, 0);
    wrong.load_mask = [](std::size_t) { return Raster<std::uint8_t>(3, 3, 255); };
    CHECK_THROWS_WITH(precise_matching_guided(wrong, epoch_view(f, 1), f.scene.epoch2_from_epoch1(), f.pairs,
                                              RootSiftExtractor{}, options),
                      Catch::Contains("of epoch 1 is 3 x 3 px"));
  }

  SECTION("a mask of another size than its image is an error naming the image") {
    PreciseEpoch<Frame<FraserAffine>> wrong = epoch_view(f, 1);
    wrong.load_mask = [](std::size_t) { return Raster<std::uint8_t>(10, 10, 255); };
    CHECK_THROWS_WITH(precise_matching_correlation(epoch_view(f, 0), wrong, f.scene.epoch2_from_epoch1(), f.pairs,
                                                   options),
                      Catch::Contains("the mask of image") && Catch::Contains("of epoch 2 is 10 x 10 px"));
  }
}
