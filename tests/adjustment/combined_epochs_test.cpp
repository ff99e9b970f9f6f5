// combined_epochs_adjustment on a small generated three-epoch scene (two film-like epochs, a
// recent reference), judged with the truth: inter-epoch matches from the true geometry (0.3 px
// noise) between any two epochs, rough Helmerts a few metres and half a degree off; each free
// epoch's check points triangulated in its own images after the adjustment. Also a free epoch
// tied only through another free one, an epoch tied to nothing, the epochs' order, and malformed
// input.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include <diachron/adjustment/triangulation.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/random.hpp>
#include <diachron/geometry/rotation.hpp>
#include <diachron/pipeline/combined_epochs.hpp>
#include <diachron/synth/scene.hpp>

#include "support/scenes.hpp"

#include "adjustment/catch_ceres.hpp"  // last: gives CHECK back to Catch after glog

using namespace diachron;

namespace {

constexpr std::size_t kReference = 2;

const Scene& three_epochs() {
  static const Scene s = [] {
    SceneOptions o = test::small_scene_options(/*seed=*/5, /*tie_points=*/800, /*check_points=*/60);
    o.epochs = {EpochOptions::historical("e1"), EpochOptions::historical("e2"), EpochOptions::recent("e3")};
    o.epochs[1].heading_deg = -25.0;
    for (EpochOptions& e : o.epochs) {
      e.rows = 2;
      e.columns = 3;
      e.tie_points = 800;
    }
    return generate_scene(o);
  }();
  return s;
}

CombinedEpoch combined_epoch_of(const SyntheticEpoch& e) { return {e.estimated_frames(), e.tie_point_observations()}; }

// Matches from the truth between epochs a (master) and b: each tie observation of a paired with
// the true pixel (plus 0.3 px noise) of its point in every image of b that sees it.
EpochLinkMatches true_link(const Scene& s, std::size_t a, std::size_t b, std::uint64_t seed) {
  RandomStream random(seed);
  const auto noise = [&random] { return random.normal(0.0, 0.3); };
  const SyntheticEpoch& ea = s.epochs[a];
  const SyntheticEpoch& eb = s.epochs[b];
  EpochLinkMatches link{a, b, {}};
  for (std::size_t m = 0; m < ea.images.size(); ++m)
    for (std::size_t q = 0; q < eb.images.size(); ++q) link.pairs.push_back({m, q, {}});
  for (const TiePoint& t : ea.tie_points)
    for (std::size_t q = 0; q < eb.images.size(); ++q) {
      const auto px = eb.world_frame(q).project(t.world);
      if (!px || !eb.world_frame(q).in_image(*px)) continue;
      const double ny = noise();  // y before x (core/random.hpp, "Order of draws")
      const Vec2 secondary = *px + Vec2(noise(), ny);
      for (const ImageObservation& o : t.observations)
        link.pairs[static_cast<std::size_t>(o.image) * eb.images.size() + q].matches.push_back({o.pixel, secondary, 1.0});
    }
  return link;
}

// Epoch e's true transform into the reference frame, turned by 0.5 degree about a tilted axis
// through the reference block and shifted by about 4 m.
Helmert3 rough_into_reference(const Scene& s, std::size_t e) {
  const Helmert3 truth = s.transform(kReference, e);
  Vec3 centre = Vec3::Zero();
  for (const auto& image : s.epochs[kReference].images) centre += image.pose_epoch.centre();
  centre /= static_cast<double>(s.epochs[kReference].images.size());
  const double sign = e == 0 ? 1.0 : -1.0;  // the two free epochs off in different directions
  const Mat3 turn = rotation_from_axis_angle<double>(Vec3(0.3, -0.5, 0.8).normalized() * (sign * 0.5 * kPi / 180.0));
  const Vec3 shift = s.epochs[kReference].epoch_from_world().scale * Vec3(3.0, -2.0, 2.0) * sign;
  return Helmert3{1.0, turn, Vec3(centre - turn * centre + shift)} * truth;
}

std::vector<Helmert3> rough_helmerts(const Scene& s) {
  return {rough_into_reference(s, 0), rough_into_reference(s, 1), Helmert3::identity()};
}

// RMS distance (reference units) between epoch e's check points triangulated from their true
// pixels in its images with `frames` (reference frame) and their true positions.
double epoch_check_point_rms(const Scene& s, std::size_t e, const std::vector<Frame<FraserAffine>>& frames, int* used = nullptr) {
  const Helmert3 ref_from_world = s.epochs[kReference].epoch_from_world();
  double sum = 0.0;
  int n = 0;
  for (const CheckPoint& cp : s.check_points) {
    Track t;
    for (const auto& o : cp.observations)
      if (o.epoch == static_cast<int>(e)) t.observations.push_back({o.image, o.pixel, ObservationKind::intra_epoch});
    if (t.observations.size() < 2) continue;
    const TriangulationResult r = triangulate_track(frames, t);
    if (!r.success) continue;
    sum += (r.point - ref_from_world(cp.world)).squaredNorm();
    ++n;
  }
  if (used) *used = n;
  return n > 0 ? std::sqrt(sum / n) : std::numeric_limits<double>::infinity();
}

std::vector<CombinedEpoch> combined_epochs(const Scene& s) {
  return {combined_epoch_of(s.epochs[0]), combined_epoch_of(s.epochs[1]), combined_epoch_of(s.epochs[2])};
}

// Matches as precise as the tie points are weighted as they are (the default's 6 px is for
// matches across decades).
CombinedAdjustmentOptions precise_matches() {
  CombinedAdjustmentOptions o;
  o.bundle.inter_epoch_sigma_px = 1.0;
  return o;
}

// Each free epoch's check points at least 3 times closer than with its rough Helmert alone, and
// within 1.5 of its GSD.
void check_free_epochs(const Scene& s, const CombinedEpochsResult& r, const std::vector<Helmert3>& rough) {
  const std::vector<CombinedEpoch> epochs = combined_epochs(s);
  for (std::size_t e = 0; e < 2; ++e) {
    int used = 0;
    const double before = epoch_check_point_rms(s, e, transformed_frames(epochs[e].frames, rough[e]));
    const double after = epoch_check_point_rms(s, e, r.epochs[e], &used);
    const double gsd = s.epochs[e].gsd_m * s.epochs[kReference].epoch_from_world().scale;
    INFO("epoch " << e << " check points (" << used << "): " << before << " -> " << after << "; GSD " << gsd);
    CHECK(used >= 10);
    CHECK(after * 3.0 < before);
    CHECK(after < 1.5 * gsd);
  }
}

}  // namespace

TEST_CASE("combined_epochs_adjustment: three epochs jointly, every free epoch 3x closer, the reference held",
          "[adjustment][pipeline]") {
  const Scene& s = three_epochs();
  const std::vector<Helmert3> rough = rough_helmerts(s);
  const CombinedEpochsResult r = combined_epochs_adjustment(
      combined_epochs(s), rough, kReference, {true_link(s, 0, 2, 1), true_link(s, 1, 2, 2), true_link(s, 0, 1, 3)},
      precise_matches());
  INFO(r.report.message);
  REQUIRE(r.report.success);
  REQUIRE(r.epochs.size() == 3);
  CHECK(r.first_image == std::vector<std::size_t>{0, 6, 12});
  check_free_epochs(s, r, rough);
  // Every pair of epochs is tied, symmetrically.
  for (Eigen::Index a = 0; a < 3; ++a)
    for (Eigen::Index b = 0; b < 3; ++b) {
      CHECK(r.epoch_links(a, b) == r.epoch_links(b, a));
      if (a != b) CHECK(r.epoch_links(a, b) >= 100);
    }
  // Tracks that span all three epochs exist: a film point seen in the other film and the reference.
  std::size_t spanning = 0;
  for (std::size_t t = 0; t < r.track_list.size(); ++t) {
    bool in[3] = {false, false, false};
    for (const TrackObservation& o : r.track_list[t].observations)
      in[o.image < 6 ? 0 : o.image < 12 ? 1 : 2] = true;
    spanning += in[0] && in[1] && in[2] && r.track_used[t] ? 1 : 0;
  }
  CHECK(spanning >= 50);
  // The reference is held, bit for bit; each free epoch has its own camera (3 in all).
  const CombinedEpoch reference = combined_epoch_of(s.epochs[kReference]);
  for (std::size_t i = 0; i < reference.frames.size(); ++i)
    CHECK((r.epochs[kReference][i].pose().centre() - reference.frames[i].pose().centre()).norm() == 0.0);
  CHECK(*std::max_element(r.image_camera.begin(), r.image_camera.end()) == 2);
}

TEST_CASE("combined_epochs_adjustment: an epoch tied to the reference only through another free epoch",
          "[adjustment][pipeline]") {
  const Scene& s = three_epochs();
  const std::vector<Helmert3> rough = rough_helmerts(s);
  // Epoch 0 has no direct match with the reference: its datum comes through epoch 1.
  const CombinedEpochsResult r = combined_epochs_adjustment(combined_epochs(s), rough, kReference,
                                                            {true_link(s, 1, 2, 2), true_link(s, 0, 1, 3)},
                                                            precise_matches());
  INFO(r.report.message);
  REQUIRE(r.report.success);
  CHECK(r.epoch_links(0, 1) >= 100);
  check_free_epochs(s, r, rough);
}

TEST_CASE("combined_epochs_adjustment: a free epoch tied to nothing fixed is a failure, not a floating answer",
          "[adjustment][pipeline]") {
  const Scene& s = three_epochs();
  const std::vector<Helmert3> rough = rough_helmerts(s);
  const CombinedEpochsResult r =
      combined_epochs_adjustment(combined_epochs(s), rough, kReference, {true_link(s, 1, 2, 2)}, precise_matches());
  CHECK_FALSE(r.report.success);
  CHECK(r.report.message.find("epoch 0 is tied to no fixed epoch") != std::string::npos);
  CHECK(r.report.message.find("at most 0 tracks") != std::string::npos);
  // On failure every epoch is where its rough Helmert put it.
  const std::vector<CombinedEpoch> epochs = combined_epochs(s);
  for (std::size_t e = 0; e < 2; ++e)
    for (std::size_t i = 0; i < epochs[e].frames.size(); ++i)
      CHECK((r.epochs[e][i].pose().centre() - rough[e](epochs[e].frames[i].pose().centre())).norm() < 1e-9);
}

TEST_CASE("combined_epochs_adjustment: the order in which the epochs are given does not change the answer",
          "[adjustment][pipeline]") {
  const Scene& s = three_epochs();
  const std::vector<Helmert3> rough = rough_helmerts(s);
  const std::vector<CombinedEpoch> epochs = combined_epochs(s);
  const std::vector<EpochLinkMatches> links = {true_link(s, 0, 2, 1), true_link(s, 1, 2, 2), true_link(s, 0, 1, 3)};
  const CombinedEpochsResult a = combined_epochs_adjustment(epochs, rough, kReference, links, precise_matches());
  // The reference first, then epoch 1, then epoch 0: indices renamed 2 -> 0, 1 -> 1, 0 -> 2.
  const std::size_t renamed[3] = {2, 1, 0};
  std::vector<EpochLinkMatches> swapped = links;
  for (EpochLinkMatches& l : swapped) {
    l.master_epoch = renamed[l.master_epoch];
    l.secondary_epoch = renamed[l.secondary_epoch];
  }
  const CombinedEpochsResult b = combined_epochs_adjustment({epochs[2], epochs[1], epochs[0]},
                                                            {rough[2], rough[1], rough[0]}, 0, swapped,
                                                            precise_matches());
  REQUIRE(a.report.success);
  REQUIRE(b.report.success);
  for (std::size_t e = 0; e < 3; ++e)
    for (std::size_t i = 0; i < epochs[e].frames.size(); ++i) {
      const Frame<FraserAffine>& fa = a.epochs[e][i];
      const Frame<FraserAffine>& fb = b.epochs[renamed[e]][i];
      CHECK((fa.pose().centre() - fb.pose().centre()).norm() < 1e-3);
      CHECK(std::abs(fa.camera().focal() - fb.camera().focal()) < 1e-2);
    }
}

TEST_CASE("combined_epochs_adjustment: malformed input throws", "[adjustment][pipeline]") {
  const Scene& s = three_epochs();
  const std::vector<CombinedEpoch> epochs = combined_epochs(s);
  const std::vector<Helmert3> rough = rough_helmerts(s);
  // The reference's own Helmert must be the identity: the frame the adjustment works in.
  CHECK_THROWS_AS(combined_epochs_adjustment(epochs, {rough[0], rough[1], rough[0]}, kReference, {}), Error);
  CHECK_THROWS_AS(combined_epochs_adjustment(epochs, {rough[0], rough[1]}, kReference, {}), Error);
  CHECK_THROWS_AS(combined_epochs_adjustment(epochs, rough, 3, {}), Error);
  CHECK_THROWS_AS(combined_epochs_adjustment(epochs, rough, kReference, {{1, 1, {}}}), Error);
  CHECK_THROWS_AS(combined_epochs_adjustment(epochs, rough, kReference, {{0, 5, {}}}), Error);
  CHECK_THROWS_AS(combined_epochs_adjustment(epochs, rough, kReference, {{0, 2, {{6, 0, {}}}}}), Error);
  CombinedAdjustmentOptions two;
  two.bundle.epochs = {EpochFreedom::all_free(), EpochFreedom::all_fixed()};
  CHECK_THROWS_AS(combined_epochs_adjustment(epochs, rough, kReference, {}, two), Error);
  EpochsControlPoint g{Vec3::Zero(), 1.0, {{}, {}, {}, {{0, Vec2::Zero()}}}};  // a fourth epoch
  CHECK_THROWS_AS(combined_epochs_adjustment(epochs, rough, kReference, {}, {}, {g}), Error);
}
