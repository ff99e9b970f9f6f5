// The true error of matches between images of a synthetic scene, checked against constructions
// that do not use the scorer: check points (true pixels in every epoch), buildings that exist in
// one epoch only, segments sampled against the true surface, the exact ray-DSM intersection.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <optional>
#include <type_traits>
#include <vector>

#include <diachron/core/parallel.hpp>
#include <diachron/eval/match_truth.hpp>
#include <diachron/synth/scene.hpp>
#include <diachron/terrain/ray_dsm_intersection.hpp>

#include "support/scenes.hpp"

using namespace diachron;

namespace {

const Scene& scene() {
  static const Scene s = generate_scene(diachron::test::small_scene_options(4, 0, 40));
  return s;
}

// The first epoch-e observation of a check point, or null.
const CheckPoint::Observation* observation_in(const CheckPoint& cp, int epoch) {
  for (const auto& o : cp.observations)
    if (o.epoch == epoch) return &o;
  return nullptr;
}

// The ground point of a pixel by the exact (unaccelerated) ray-DSM intersection.
std::optional<Vec3> exact_ground(const Scene& s, ImageRef r, const Vec2& pixel) {
  const SyntheticEpoch& e = s.epochs[static_cast<std::size_t>(r.epoch)];
  const std::optional<Ray3> ray = e.world_frame(static_cast<std::size_t>(r.image)).ray(pixel);
  if (!ray) return std::nullopt;
  const RayDsmResult hit = intersect_ray_dsm(e.true_surface, *ray);
  if (!hit.success) return std::nullopt;
  return hit.point;
}

// Lowest height of the segment from the camera of image b to `point` above epoch b's true surface,
// sampled every 5 cm where the segment is below the surface's highest point, leaving out the last
// `skip_m` metres before the point.
double clearance(const Scene& s, ImageRef b, const Vec3& point, double skip_m) {
  const SyntheticEpoch& e = s.epochs[static_cast<std::size_t>(b.epoch)];
  const Vec3 c = e.images[static_cast<std::size_t>(b.image)].pose_world.centre();
  const double length = (point - c).norm();
  const double top = e.true_surface.statistics().max + 1.0;
  const double start = c.z() > top ? length * (c.z() - top) / (c.z() - point.z()) : 0.0;
  double lowest = std::numeric_limits<double>::infinity();
  for (double d = start; d < length - skip_m; d += 0.05) {
    const Vec3 p = c + (point - c) * (d / length);
    const double z = e.true_surface.height_at(p.head<2>());
    if (!std::isnan(z)) lowest = std::min(lowest, p.z() - z);
  }
  return lowest;
}

}  // namespace

TEST_CASE("MatchTruthScorer: check points transfer to their recorded true pixel in the other epoch", "[eval]") {
  const Scene& s = scene();
  const MatchTruthScorer scorer(s);
  int tested = 0;
  double worst = 0.0;
  for (const CheckPoint& cp : s.check_points) {
    const auto* a = observation_in(cp, 0);
    const auto* b = observation_in(cp, 1);
    if (!a || !b) continue;
    const ImageRef ra{0, a->image}, rb{1, b->image};
    for (const auto& [from, to, px_from, px_to] :
         {std::make_tuple(ra, rb, a->pixel, b->pixel), std::make_tuple(rb, ra, b->pixel, a->pixel)}) {
      const MatchTruth t = scorer.transfer(from, to, px_from);
      REQUIRE(t.status == MatchTruthStatus::scored);
      CHECK(std::isnan(t.error_px));
      worst = std::max(worst, (t.true_pixel - px_to).norm());
      // The exact match, and the same match displaced by (3, 4) px.
      const MatchTruth exact = scorer.score(from, to, px_from, px_to);
      REQUIRE(exact.scored());
      CHECK(exact.error_px < 1e-9);
      const MatchTruth off = scorer.score(from, to, px_from, px_to + Vec2(3.0, -4.0));
      REQUIRE(off.scored());
      CHECK(off.error_px == Approx(5.0).margin(1e-9));
    }
    ++tested;
  }
  CHECK(tested >= 20);
  // Measured: 1.5e-13 px (tracer tolerance 1e-8 cells, unprojection 1e-10 px).
  CHECK(worst < 1e-9);
}

TEST_CASE("MatchTruthScorer: occluded and seen points agree with the sampled line of sight", "[eval]") {
  const Scene& s = scene();
  const MatchTruthScorer scorer(s);
  int occluded = 0, scored = 0;
  for (const ImageRef a : {ImageRef{0, 0}, ImageRef{1, 1}})
    for (const ImageRef b : {ImageRef{1, 0}, ImageRef{0, 1}})
      for (int y = 4; y < 300; y += 12)
        for (int x = 4; x < 400; x += 12) {
          const MatchTruth t = scorer.transfer(a, b, Vec2(x, y));
          if (t.status != MatchTruthStatus::occluded && t.status != MatchTruthStatus::scored) continue;
          const std::optional<Vec3> ground = exact_ground(s, a, Vec2(x, y));
          REQUIRE(ground);
          if (t.status == MatchTruthStatus::occluded) {
            // Something of epoch b's surface lies between its camera and the point.
            CHECK(clearance(s, b, *ground, scorer.options().occlusion_tolerance_m) < 0.0);
            ++occluded;
          } else {
            CHECK(clearance(s, b, *ground, scorer.options().occlusion_tolerance_m + 0.1) > -1e-3);
            ++scored;
          }
        }
  CHECK(occluded >= 5);
  CHECK(scored >= 1000);
}

TEST_CASE("MatchTruthScorer: a building of one epoch only is a changed surface", "[eval]") {
  const Scene& s = scene();
  const MatchTruthScorer scorer(s);
  int removed = 0, built = 0;
  for (const Building& building : s.landscape.buildings) {
    const bool only_first = building.exists_in(0) && !building.exists_in(1);
    const bool only_second = !building.exists_in(0) && building.exists_in(1);
    if (!only_first && !only_second) continue;
    // The roof centre where it stands in epoch 0, the bare ground where it will stand.
    const double z = s.epochs[0].true_surface.height_at(building.centre);
    const Vec3 point(building.centre.x(), building.centre.y(), z);
    if (only_first && std::abs(z - building.roof_z(building.centre)) > 1e-3) continue;  // roof off the grid
    for (std::size_t i = 0; i < s.epochs[0].images.size(); ++i) {
      const Frame<FraserAffine> frame = s.epochs[0].world_frame(i);
      const std::optional<Vec2> px = frame.project(point);
      if (!px || !frame.in_image(*px)) continue;
      const std::optional<Vec3> ground = exact_ground(s, {0, static_cast<int>(i)}, *px);
      if (!ground || (*ground - point).norm() > 0.05) continue;  // hidden from this image
      for (std::size_t j = 0; j < s.epochs[1].images.size(); ++j) {
        const Frame<FraserAffine> other = s.epochs[1].world_frame(j);
        const std::optional<Vec2> px_b = other.project(point);
        if (!px_b || !other.in_image(*px_b)) continue;
        const MatchTruth t = scorer.score({0, static_cast<int>(i)}, {1, static_cast<int>(j)}, *px, *px_b);
        CHECK(t.status == MatchTruthStatus::changed_surface);
        CHECK_FALSE(t.scored());
        CHECK(std::isnan(t.error_px));
        (only_first ? removed : built) += 1;
      }
    }
  }
  CHECK(removed >= 1);
  CHECK(built >= 1);
}

TEST_CASE("MatchTruthScorer: a ground point outside image b is off_image, a ray that misses is no_surface",
          "[eval]") {
  const Scene& s = scene();
  const MatchTruthScorer scorer(s);
  const ImageRef a{0, 0}, b{1, 1};
  const Frame<FraserAffine> frame_b = s.epochs[1].world_frame(1);
  int outside = 0, inside = 0;
  for (int y = 5; y < 300; y += 40)
    for (int x = 5; x < 400; x += 40) {
      const std::optional<Vec3> ground = exact_ground(s, a, Vec2(x, y));
      REQUIRE(ground);
      const std::optional<Vec2> px = frame_b.project(*ground);
      const MatchTruth t = scorer.transfer(a, b, Vec2(x, y));
      if (!px || !frame_b.in_image(*px)) {
        CHECK(t.status == MatchTruthStatus::off_image);
        // Where it would be, outside the image, so that benches can say how far such a match is off.
        if (px) CHECK((t.true_pixel - *px).norm() < 1e-6);
        ++outside;
      } else {
        CHECK(t.status != MatchTruthStatus::off_image);
        CHECK(t.status != MatchTruthStatus::no_surface);
        ++inside;
      }
    }
  CHECK(outside >= 3);
  CHECK(inside >= 3);
  // A pixel far left of image a: its ray leaves the scene without meeting the surface.
  const Vec2 far(-3000.0, 150.0);
  REQUIRE_FALSE(exact_ground(s, a, far));
  CHECK(scorer.transfer(a, b, far).status == MatchTruthStatus::no_surface);
}

TEST_CASE("MatchTruthScorer: the same answers on any number of threads; bad input throws", "[eval]") {
  const Scene& s = scene();
  const MatchTruthScorer scorer(s);
  std::vector<Vec2> pixels;
  for (int y = 0; y < 300; y += 25)
    for (int x = 0; x < 400; x += 25) pixels.emplace_back(x + 0.3, y + 0.7);
  const auto run = [&](std::size_t threads) {
    std::vector<MatchTruth> out(pixels.size());
    parallel_for(pixels.size(), threads, [&](std::size_t k) {
      out[k] = scorer.score({0, 1}, {1, 0}, pixels[k], pixels[k]);
    });
    return out;
  };
  const std::vector<MatchTruth> one = run(1), four = run(4);
  for (std::size_t k = 0; k < pixels.size(); ++k) {
    CHECK(one[k].status == four[k].status);
    if (one[k].scored()) {
      CHECK(one[k].true_pixel == four[k].true_pixel);
      CHECK(one[k].error_px == four[k].error_px);
    }
  }

  static_assert(!std::is_constructible_v<MatchTruthScorer, Scene&&>, "a temporary scene would dangle");
  CHECK_THROWS_WITH(scorer.transfer({2, 0}, {1, 0}, Vec2(1, 1)), Catch::Contains("epoch 2"));
  CHECK_THROWS_WITH(scorer.transfer({0, 0}, {1, 5}, Vec2(1, 1)), Catch::Contains("image 5"));
  CHECK_THROWS_AS(scorer.transfer({0, 0}, {1, 0}, Vec2(std::nan(""), 1)), Error);
  CHECK_THROWS_AS(scorer.score({0, 0}, {1, 0}, Vec2(1, 1), Vec2(std::nan(""), 1)), Error);
  MatchTruthOptions bad;
  bad.occlusion_tolerance_m = 0.0;
  CHECK_THROWS_AS(MatchTruthScorer(s, bad), Error);
  Scene without_truth;
  without_truth.epochs.resize(1);
  without_truth.epochs[0].name = "e1";
  CHECK_THROWS_WITH(MatchTruthScorer(without_truth), Catch::Contains("true surface"));
}

TEST_CASE("accuracy_curve: shares of scored matches within 0..max_px px", "[eval]") {
  std::vector<MatchTruth> truths;
  for (double e : {0.0, 0.5, 1.0, 1.0, 2.5, 9.99, 10.0, 11.0}) {
    MatchTruth t;
    t.status = MatchTruthStatus::scored;
    t.error_px = e;
    truths.push_back(t);
  }
  MatchTruth occluded;
  occluded.status = MatchTruthStatus::occluded;
  truths.push_back(occluded);
  truths.push_back(MatchTruth{});  // default: not scored
  MatchTruth transferred;           // scored by transfer(): a true pixel but no error
  transferred.status = MatchTruthStatus::scored;
  truths.push_back(transferred);

  const AccuracyCurve curve = accuracy_curve(truths);
  CHECK(curve.scored == 8);
  CHECK(curve.unscored == 3);
  REQUIRE(curve.thresholds_px.size() == 11);
  REQUIRE(curve.share.size() == 11);
  CHECK(curve.thresholds_px.front() == 0.0);
  CHECK(curve.thresholds_px.back() == 10.0);
  const std::vector<double> expected = {1, 4, 4, 5, 5, 5, 5, 5, 5, 5, 7};
  for (std::size_t t = 0; t < expected.size(); ++t) CHECK(curve.share[t] == Approx(expected[t] / 8.0));
  CHECK(curve.share_within(10.5) == Approx(7.0 / 8.0));
  CHECK(curve.share_within(100.0) == 1.0);
  CHECK(curve.share_within(-1.0) == 0.0);

  const AccuracyCurve three = accuracy_curve(truths, 3);
  CHECK(three.thresholds_px.size() == 4);
  const AccuracyCurve empty = accuracy_curve({});
  CHECK(empty.scored == 0);
  CHECK(std::isnan(empty.share[0]));
  CHECK(std::isnan(empty.share_within(1.0)));
  CHECK_THROWS_AS(accuracy_curve(truths, -1), Error);
}
