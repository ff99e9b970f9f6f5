// bundle_adjust on a two-epoch block built from geometry: the reference epoch fixed, the other
// epoch's poses, camera and affine recovered; staging, rejection, gauge, GCPs, covariance, the
// report, and every bad-input path.

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <diachron/adjustment/bundle_adjustment.hpp>
#include <diachron/adjustment/tracks.hpp>
#include <diachron/core/error.hpp>
#include <diachron/eval/distortion_difference.hpp>
#include <diachron/eval/distortion_precision.hpp>

#include "adjustment/block_fixture.hpp"

#include "adjustment/catch_ceres.hpp"  // last: gives CHECK back to Catch after glog

using namespace diachron;

namespace {

BundleInput block_input(const test::Block& b) {
  BundleInput in;
  in.frames = b.estimated;
  in.image_epoch = b.epoch;
  in.tracks = build_tracks(b.tie_points, b.matches, static_cast<int>(b.truth.size())).tracks;
  return in;
}

BundleOptions reference_fixed() {
  BundleOptions o;
  o.epochs = {EpochFreedom::all_free(), EpochFreedom::all_fixed()};
  return o;
}

// RMS error (world units) of the true ground points triangulated from their true pixels in the
// images [first, first + count) of the block, with `frames` standing for those images.
double ground_rms(const std::vector<Frame<FraserAffine>>& frames, const test::Block& b, int first, int count) {
  double sum = 0.0;
  int n = 0;
  for (const Vec3& p : b.ground) {
    Track t;
    for (int i = 0; i < count; ++i) {
      const auto px = b.truth[static_cast<std::size_t>(first + i)].project(p);
      if (px && b.truth[static_cast<std::size_t>(first + i)].in_image(*px)) t.observations.push_back({i, *px, ObservationKind::intra_epoch});
    }
    if (t.observations.size() < 2) continue;
    const TriangulationResult r = triangulate_track(frames, t);
    if (!r.success) continue;
    sum += (r.point - p).squaredNorm();
    ++n;
  }
  return n > 0 ? std::sqrt(sum / n) : std::numeric_limits<double>::infinity();
}

double epoch0_ground_rms(const std::vector<Frame<FraserAffine>>& frames, const test::Block& b) {
  return ground_rms(frames, b, 0, b.epoch0_images);
}

}  // namespace

TEST_CASE("bundle_adjust: Nominal, the reference epoch fixed recovers the other epoch and its camera", "[adjustment]") {
  const test::Block b = test::make_block(/*seed=*/1, /*points=*/1000);
  const BundleInput input = block_input(b);
  const BundleResult r = bundle_adjust(input, reference_fixed());
  INFO(r.report.message);
  REQUIRE(r.report.success);
  const BundleReport& rep = r.report;
  CHECK(rep.before.all.rms_px > 1.5);
  CHECK(rep.after.all.rms_px < 0.5);
  CHECK(rep.after.by_epoch.size() == 2);
  CHECK(rep.after.inter_epoch.observations > 0);
  CHECK(rep.after.intra_epoch.observations > 0);
  CHECK(rep.tracks_used > 100);
  CHECK(rep.inter_epoch_tracks > 50);
  CHECK(rep.solves.size() >= 1);
  CHECK(rep.solves.front().usable);
  CHECK(rep.solves.front().final_cost < rep.solves.front().initial_cost);
  CHECK(std::abs(rep.sigma0 - 0.3) < 0.1);  // observations at 0.3 px with 1 px sigmas

  // Ground points seen by the adjusted epoch: 12.7 m -> 0.31 m RMS (GSD 2 m, 0.3 px noise).
  const double before = epoch0_ground_rms(input.frames, b), after = epoch0_ground_rms(r.frames, b);
  INFO("ground RMS " << before << " -> " << after << " m");
  CHECK(before > 5.0);
  CHECK(after < 0.5);
  const Camera<FraserAffine>& adjusted = r.frames[0].camera();
  const Camera<FraserAffine>& truth = b.truth[0].camera();
  // Focal and principal point within 3 of their reported standard deviations (honest sigmas),
  // the distortion within 0.5 px over the image (0.35 px here; it was 2.4 px off).
  const auto& values = rep.cameras[0].values;
  CHECK(std::abs(adjusted.focal() - truth.focal()) < 3.0 * values[0].sigma);
  CHECK(std::abs(adjusted.cx() - truth.cx()) < 3.0 * values[1].sigma);
  CHECK(std::abs(adjusted.cy() - truth.cy()) < 3.0 * values[2].sigma);
  // Over the whole image, corners included (beyond the outermost tie points, where the error of
  // the recovered distortion is largest: 0.55 px there, against 0.09 px RMS over the image).
  const DistortionDifference recovered = distortion_difference(adjusted, truth);
  INFO("distortion error: RMS " << recovered.rms_px << " px, worst " << recovered.max_px << " px");
  CHECK(recovered.rms_px < 0.2);
  CHECK(recovered.max_px < 0.7);
  CHECK(distortion_difference(input.frames[0].camera(), truth).max_px > 1.0);

  // Report of the intrinsics: camera 0 free with standard deviations, camera 1 fixed.
  REQUIRE(rep.cameras.size() == 2);
  CHECK(rep.covariance_available);
  CHECK(rep.cameras[0].free);
  CHECK_FALSE(rep.cameras[1].free);
  REQUIRE(rep.cameras[0].values.size() == 8);
  CHECK(rep.cameras[0].values[0].name == "f");
  CHECK(rep.cameras[0].values[0].after == adjusted.focal());
  CHECK(rep.cameras[0].values[0].before == input.frames[0].camera().focal());
  for (const ParameterChange& p : rep.cameras[0].values) CHECK((std::isfinite(p.sigma) && p.sigma > 0.0));
  for (const ParameterChange& p : rep.cameras[1].values) CHECK(std::isnan(p.sigma));
  CHECK(rep.cameras[0].values[0].sigma < 3.0);
  // The full covariance of the free camera: its diagonal gives the sigmas; none for the fixed one.
  REQUIRE(rep.cameras[0].covariance.size() == 64);
  for (std::size_t k = 0; k < 8; ++k)
    CHECK(std::sqrt(rep.cameras[0].covariance[k * 8 + k]) == Approx(rep.cameras[0].values[k].sigma).epsilon(1e-12));
  CHECK(rep.cameras[0].covariance[0 * 8 + 3] == Approx(rep.cameras[0].covariance[3 * 8 + 0]).epsilon(1e-9));
  CHECK(rep.cameras[1].covariance.empty());
  // Propagated to the distortion over the image (eval/distortion_precision.hpp): the recovered
  // distortion's RMS error is of the order of its predicted 1-sigma (honest, neither hidden nor
  // inflated: the affine part, not in the camera's covariance, adds a little).
  const DistortionPrecision precision = distortion_precision(adjusted, rep.cameras[0].covariance);
  INFO("distortion 1-sigma: RMS " << precision.rms_sigma_px << " px, worst " << precision.max_sigma_px << " px");
  REQUIRE(precision.valid);
  CHECK(recovered.rms_px < 3.0 * precision.rms_sigma_px);
  CHECK(recovered.rms_px > 0.2 * precision.rms_sigma_px);
  REQUIRE(rep.affine.size() == b.truth.size());
  CHECK(std::isfinite(rep.affine[0].values[0].sigma));

  // Fixed blocks are unchanged; the input is not modified.
  for (std::size_t i = static_cast<std::size_t>(b.epoch0_images); i < b.truth.size(); ++i) {
    CHECK((r.frames[i].pose().centre() - input.frames[i].pose().centre()).norm() < 1e-9);
    CHECK(r.frames[i].camera().intrinsics() == input.frames[i].camera().intrinsics());
  }
  CHECK(input.frames[0].camera().intrinsics() == b.estimated[0].camera().intrinsics());
  // The adjusted points sit on the true ground.
  std::size_t close = 0, counted = 0;
  for (std::size_t t = 0; t < r.points.size(); ++t) {
    if (!r.track_used[t]) continue;
    ++counted;
    const Vec3& p = r.points[t];
    close += std::abs(p.z() - test::terrain(p.x(), p.y())) < 3.0 ? 1 : 0;
  }
  CHECK(close > 0.9 * static_cast<double>(counted));
}

TEST_CASE("bundle_adjust: staged intrinsics reach the same solution", "[adjustment]") {
  const test::Block b = test::make_block(/*seed=*/2);
  BundleOptions o = reference_fixed();
  const BundleResult plain = bundle_adjust(block_input(b), o);
  o.staged_intrinsics = true;
  const BundleResult staged = bundle_adjust(block_input(b), o);
  REQUIRE(plain.report.success);
  REQUIRE(staged.report.success);
  CHECK(staged.report.solves.size() >= 3);
  CHECK(staged.report.solves[0].stage == "focal+pp");
  CHECK(std::abs(staged.report.after.all.rms_px - plain.report.after.all.rms_px) < 0.01);
  CHECK(distortion_difference(staged.frames[0].camera(), plain.frames[0].camera()).max_px < 0.1);
}

TEST_CASE("bundle_adjust: AffineScope::per_camera shares B1, B2 over a camera's images", "[adjustment]") {
  // The fixture's epoch-0 images share one true camera (B1 0.4, B2 -0.2 px) and start at B1 = B2 = 0.
  const test::Block b = test::make_block(/*seed=*/1, /*points=*/1000);
  BundleOptions o = reference_fixed();
  const BundleResult per_image = bundle_adjust(block_input(b), o);
  o.affine_scope = AffineScope::per_camera;
  const BundleResult shared = bundle_adjust(block_input(b), o);
  INFO(shared.report.message);
  REQUIRE(per_image.report.success);
  REQUIRE(shared.report.success);
  const auto n0 = static_cast<std::size_t>(b.epoch0_images);
  const Camera<FraserAffine>& truth = b.truth[0].camera();
  const auto b1 = [](const Frame<FraserAffine>& f) { return f.camera().params()[5]; };
  // Per image, each scan gets its own values; per camera, one pair for all of them.
  bool differ = false;
  for (std::size_t i = 1; i < n0; ++i) {
    differ = differ || b1(per_image.frames[i]) != b1(per_image.frames[0]);
    CHECK(shared.frames[i].camera().intrinsics() == shared.frames[0].camera().intrinsics());
  }
  CHECK(differ);
  // The shared pair is the true one within 3 of its reported standard deviations, and each image's
  // report entry shows it.
  REQUIRE(shared.report.affine.size() == b.truth.size());
  const ParameterChange& reported_b1 = shared.report.affine[0].values[0];
  const ParameterChange& reported_b2 = shared.report.affine[0].values[1];
  INFO("B1 " << reported_b1.after << " +- " << reported_b1.sigma << ", B2 " << reported_b2.after << " +- " << reported_b2.sigma);
  CHECK(reported_b1.after == b1(shared.frames[0]));
  CHECK(reported_b1.before == 0.0);
  CHECK(std::abs(reported_b1.after - truth.params()[5]) < 3.0 * reported_b1.sigma);
  CHECK(std::abs(reported_b2.after - truth.params()[6]) < 3.0 * reported_b2.sigma);
  CHECK(reported_b1.sigma < 0.2);
  for (std::size_t i = 0; i < n0; ++i) {
    CHECK(shared.report.affine[i].free);
    CHECK(shared.report.affine[i].values[0].sigma == reported_b1.sigma);
  }
  // The fixed epoch's shared pair stays as it was.
  for (std::size_t i = n0; i < b.truth.size(); ++i) {
    CHECK_FALSE(shared.report.affine[i].free);
    CHECK(shared.frames[i].camera().intrinsics() == b.estimated[i].camera().intrinsics());
  }
  // Two parameters instead of two per image: the block is recovered as well as per image.
  const double shared_error = distortion_difference(shared.frames[0].camera(), truth).max_px;
  INFO("worst distortion error: per image " << distortion_difference(per_image.frames[0].camera(), truth).max_px
                                            << " px, per camera " << shared_error << " px");
  CHECK(shared_error < 0.7);
  CHECK(epoch0_ground_rms(shared.frames, b) < 0.5);
}

TEST_CASE("BundleProblem: a camera shared by a fixed and a free epoch keeps its shared affine fixed", "[adjustment]") {
  const test::Block b = test::make_block(/*seed=*/4);
  BundleInput input = block_input(b);
  input.image_camera.assign(b.truth.size(), 0);  // one camera for both epochs
  input.points.assign(input.tracks.size(), Vec3::Constant(std::numeric_limits<double>::quiet_NaN()));
  BundleOptions o = reference_fixed();
  o.affine_scope = AffineScope::per_camera;
  const BundleProblem problem(input, o);
  CHECK(problem.camera_count() == 1);
  CHECK_FALSE(problem.affine_free(0));
  CHECK_FALSE(problem.affine_free(b.truth.size() - 1));
  o.affine_scope = AffineScope::per_image;
  const BundleProblem per_image(input, o);
  CHECK(per_image.affine_free(0));
  CHECK_FALSE(per_image.affine_free(b.truth.size() - 1));
}

TEST_CASE("bundle_adjust: EstimateRobust, gross outliers are rejected and the solve repeated", "[adjustment]") {
  test::Block b = test::make_block(/*seed=*/3);
  // Spoil 5 % of the epoch-1 observations that inter-epoch matches reach by 40 px, everywhere they
  // appear (matches and epoch 1's own tie points): each track then holds one wrong pixel for that image,
  // a gross error the adjustment must reject. Spoiling single matches instead makes most tracks hold
  // two pixels of one image, and build_tracks drops those as conflicts before the solve.
  std::vector<ImagePixel> seen;
  const auto same = [](const ImagePixel& p, const ImagePixel& q) { return p.image == q.image && p.pixel == q.pixel; };
  for (const ImageMatch& m : b.matches)
    if (std::none_of(seen.begin(), seen.end(), [&](const ImagePixel& p) { return same(p, m.b); })) seen.push_back(m.b);
  std::vector<ImagePixel> spoiled;
  for (std::size_t k = 0; k < seen.size(); k += 20) spoiled.push_back(seen[k]);
  const auto spoil = [&](ImagePixel& o) {
    if (std::any_of(spoiled.begin(), spoiled.end(), [&](const ImagePixel& p) { return same(p, o); }))
      o.pixel += Vec2(40.0, -25.0);
  };
  for (ImageMatch& m : b.matches) spoil(m.b);
  for (auto& tie : b.tie_points)
    for (ImagePixel& o : tie) spoil(o);
  const BundleResult r = bundle_adjust(block_input(b), reference_fixed());
  INFO(r.report.message << "; " << spoiled.size() << " of " << seen.size() << " observations spoiled");
  REQUIRE(r.report.success);
  CHECK(r.report.observations_rejected >= spoiled.size() * 9 / 10);  // nearly every spoiled one
  CHECK(r.report.solves.size() >= 2);
  CHECK(r.report.after.all.rms_px < 0.6);
  CHECK(epoch0_ground_rms(r.frames, b) < 1.0);
}

TEST_CASE("bundle_adjust: gauge without fixed poses, and GCPs", "[adjustment]") {
  const test::Block b = test::make_block(/*seed=*/4, /*points=*/300);
  // Epoch 1 alone with its true orientation as the start; nothing fixed.
  BundleInput one;
  for (std::size_t i = static_cast<std::size_t>(b.epoch0_images); i < b.truth.size(); ++i) one.frames.push_back(b.truth[i]);
  std::vector<std::vector<ImagePixel>> ties;
  for (const auto& t : b.tie_points)
    if (t.front().image >= b.epoch0_images) {
      ties.push_back(t);
      for (auto& o : ties.back()) o.image -= b.epoch0_images;
    }
  one.tracks = build_tracks(ties, {}, static_cast<int>(one.frames.size())).tracks;
  BundleOptions o;
  o.epochs = {EpochFreedom{true, false, false}};  // poses free, camera known
  SECTION("the gauge is fixed internally: the solve succeeds and poses stay put") {
    const BundleResult r = bundle_adjust(one, o);
    INFO(r.report.message);
    REQUIRE(r.report.success);
    CHECK(r.report.after.all.rms_px < 0.5);
    // Image 0 is held (the gauge); the rest fits the observations to their noise. (Ground
    // accuracy is not asked: without control the block is free to bend along its weak modes.)
    CHECK((r.frames[0].pose().centre() - one.frames[0].pose().centre()).norm() < 1e-9);
    CHECK((r.frames[0].pose().cam_from_world_rotation() - one.frames[0].pose().cam_from_world_rotation()).norm() < 1e-9);
    CHECK(r.report.covariance_message == "no free intrinsics");
  }
  SECTION("GCPs pull a shifted block back") {
    for (auto& f : one.frames) f = f.transformed(1.0, Mat3::Identity(), Vec3(30.0, -20.0, 10.0));
    // Eight GCPs: the ground of eight tracks (triangulated before the shift), 0.1 m.
    const auto points_before = [&] {
      std::vector<Vec3> p;
      for (const Track& t : one.tracks) p.push_back(triangulate_track(one.frames, t).point);
      return p;
    }();
    for (std::size_t t = 0; t < one.tracks.size() && one.control_points.size() < 8; t += 17)
      one.control_points.push_back({t, points_before[t] - Vec3(30.0, -20.0, 10.0), 0.1});
    const BundleResult r = bundle_adjust(one, o);
    INFO(r.report.message);
    REQUIRE(r.report.success);
    CHECK(r.report.control_points == one.control_points.size());
    const int count = static_cast<int>(one.frames.size());
    CHECK(ground_rms(one.frames, b, b.epoch0_images, count) > 30.0);
    CHECK(ground_rms(r.frames, b, b.epoch0_images, count) < 1.0);
  }
}

TEST_CASE("bundle_adjust: bad input gives success == false or throws", "[adjustment]") {
  const test::Block b = test::make_block(/*seed=*/5, /*points=*/200);
  SECTION("too few inter-epoch tracks") {
    BundleInput in;
    in.frames = b.estimated;
    in.image_epoch = b.epoch;
    in.tracks = build_tracks(b.tie_points, {}, static_cast<int>(b.truth.size())).tracks;
    const BundleResult r = bundle_adjust(in, reference_fixed());
    CHECK_FALSE(r.report.success);
    CHECK(r.report.message.find("too few inter-epoch tracks") != std::string::npos);
    CHECK(r.frames.size() == in.frames.size());
  }
  SECTION("a camera with no observations") {
    BundleInput in = block_input(b);
    in.frames.push_back(b.truth.back());
    in.image_epoch.push_back(1);
    in.image_camera = in.image_epoch;
    in.image_camera.back() = 2;
    const BundleResult r = bundle_adjust(in, reference_fixed());
    CHECK_FALSE(r.report.success);
    CHECK(r.report.message.find("camera 2 has no observations") != std::string::npos);
  }
  SECTION("non-finite initial point") {
    BundleInput in = block_input(b);
    for (const Track& t : in.tracks) in.points.push_back(triangulate_track(in.frames, t).point);
    in.points[3] = Vec3(std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0);
    const BundleResult r = bundle_adjust(in, reference_fixed());
    CHECK_FALSE(r.report.success);
    CHECK(r.report.message.find("non-finite") != std::string::npos);
  }
  SECTION("a failing solve (a point above the cameras cannot be evaluated)") {
    BundleInput in = block_input(b);
    for (const Track& t : in.tracks) in.points.push_back(triangulate_track(in.frames, t).point);
    in.points[0] = Vec3(0.0, 0.0, 5000.0);
    const BundleResult r = bundle_adjust(in, reference_fixed());
    CHECK_FALSE(r.report.success);
    CHECK(r.report.message.find("solve failed") != std::string::npos);
    REQUIRE(r.report.solves.size() == 1);
    CHECK_FALSE(r.report.solves[0].usable);
  }
  SECTION("malformed input throws") {
    BundleInput in = block_input(b);
    in.image_epoch.pop_back();
    CHECK_THROWS_AS(bundle_adjust(in), Error);
    BundleInput in2 = block_input(b);
    in2.tracks[0].observations[0].image = 99;
    CHECK_THROWS_AS(bundle_adjust(in2), Error);
    BundleOptions o;
    o.loss_scale_px = 0.0;
    CHECK_THROWS_AS(bundle_adjust(block_input(b), o), Error);
  }
}

TEST_CASE("bundle_adjust: deterministic", "[adjustment]") {
  const test::Block b = test::make_block(/*seed=*/6, /*points=*/200);
  const BundleResult a = bundle_adjust(block_input(b), reference_fixed());
  const BundleResult c = bundle_adjust(block_input(b), reference_fixed());
  REQUIRE(a.report.success);
  for (std::size_t i = 0; i < a.frames.size(); ++i) {
    CHECK(a.frames[i].camera().intrinsics() == c.frames[i].camera().intrinsics());
    CHECK(a.frames[i].pose().centre() == c.frames[i].pose().centre());
  }
}

TEST_CASE("BundleOptions: Options, defaults and checks", "[adjustment]") {
  const BundleOptions o;
  CHECK(o.epochs.empty());
  CHECK(o.intra_epoch_sigma_px == 1.0);
  CHECK(o.inter_epoch_sigma_px == 1.0);
  CHECK(o.loss == RobustLoss::huber);
  CHECK(o.loss_scale_px == 1.0);
  CHECK_FALSE(o.staged_intrinsics);
  CHECK(o.reject_residual_px == 3.0);
  CHECK(o.rejection_rounds == 1);
  CHECK(o.min_inter_epoch_tracks == 10);
  CHECK(o.num_threads == 1);
  CHECK(o.compute_covariance);
  CHECK_NOTHROW(o.check());
  BundleOptions bad;
  bad.inter_epoch_sigma_px = -1.0;
  CHECK_THROWS_AS(bad.check(), Error);
  bad = BundleOptions{};
  bad.max_iterations = 0;
  CHECK_THROWS_AS(bad.check(), Error);
  bad = BundleOptions{};
  bad.triangulation.min_views = 1;
  CHECK_THROWS_AS(bad.check(), Error);
}

TEST_CASE("BundleReport: Report, defaults mean failure", "[adjustment]") {
  const BundleReport r;
  CHECK_FALSE(r.success);
  CHECK(r.solves.empty());
  CHECK(std::isnan(r.after.all.rms_px));
  CHECK(std::isnan(r.sigma0));
  CHECK_FALSE(r.covariance_available);
  const SolveSummary s;
  CHECK_FALSE(s.usable);
  const BundleResult result;
  CHECK_FALSE(result.report.success);
  CHECK(result.frames.empty());
}

TEST_CASE("bundle_adjust: Cauchy loss and unequal sigmas also recover the block", "[adjustment]") {
  const test::Block b = test::make_block(/*seed=*/7, /*points=*/400);
  BundleOptions o = reference_fixed();
  o.loss = RobustLoss::cauchy;
  o.inter_epoch_sigma_px = 2.0;
  const BundleResult r = bundle_adjust(block_input(b), o);
  INFO(r.report.message);
  REQUIRE(r.report.success);
  CHECK(epoch0_ground_rms(r.frames, b) < 1.0);
  CHECK(epoch0_ground_rms(b.estimated, b) > 5.0);
}

TEST_CASE("bundle_adjust: intrinsics held by EpochFreedom::fixed_intrinsics keep their values, the others adjust",
          "[adjustment]") {
  const test::Block b = test::make_block(/*seed=*/1, /*points=*/1000);
  const BundleInput input = block_input(b);
  BundleOptions options = reference_fixed();
  options.epochs[0].fixed_intrinsics = {Intrinsic::k3, Intrinsic::p2, Intrinsic::p1, Intrinsic::k3};  // any order, repeats
  const BundleResult held = bundle_adjust(input, options);
  INFO(held.report.message);
  REQUIRE(held.report.success);
  const auto before = input.frames[0].camera().params(), after = held.frames[0].camera().params();
  CHECK(after[2] == before[2]);  // K3
  CHECK(after[3] == before[3]);  // P1
  CHECK(after[4] == before[4]);  // P2
  CHECK(after[0] != before[0]);  // K1 adjusted
  CHECK(held.frames[0].camera().focal() != input.frames[0].camera().focal());
  const CameraReport& camera = held.report.cameras[0];
  CHECK(camera.held == std::vector<std::string>{"K3", "P1", "P2"});
  CHECK(held.report.cameras[1].held.empty());  // the fixed camera holds everything, none "held"
  REQUIRE(camera.values.size() == 8);
  REQUIRE(camera.covariance.size() == 64);
  for (std::size_t k = 0; k < 8; ++k) {
    const bool fixed = k == 5 || k == 6 || k == 7;
    INFO(camera.values[k].name);
    CHECK(std::isnan(camera.values[k].sigma) == fixed);
    if (fixed)
      for (std::size_t j = 0; j < 8; ++j) CHECK(camera.covariance[k * 8 + j] == 0.0);
  }
  // A held value is really held: the radial terms kept at the SfM's (half the truth's K1, K2) leave
  // the distortion as wrong as the SfM had it, where the free camera recovers it. (The fit hardly
  // tells: with K1 alone held, f, K2 and K3 absorb it to within 0.1 % of the free RMS.)
  const BundleResult free = bundle_adjust(input, reference_fixed());
  REQUIRE(free.report.success);
  options.epochs[0].fixed_intrinsics = {Intrinsic::k1, Intrinsic::k2, Intrinsic::k3};
  const BundleResult radial = bundle_adjust(input, options);
  REQUIRE(radial.report.success);
  const Camera<FraserAffine>& truth = b.truth[0].camera();
  const double d_free = distortion_difference(free.frames[0].camera(), truth).max_px;
  const double d_radial = distortion_difference(radial.frames[0].camera(), truth).max_px;
  INFO("distortion error: free " << d_free << " px, K1-K3 held " << d_radial << " px");
  CHECK(d_free < 0.7);
  CHECK(d_radial > 1.0);
  // The truth has K3 = 0 and so has the SfM's camera: holding K3 there costs nothing.
  options.epochs[0].fixed_intrinsics = {Intrinsic::k3};
  const BundleResult k3 = bundle_adjust(input, options);
  REQUIRE(k3.report.success);
  CHECK(k3.frames[0].camera().params()[2] == 0.0);
  CHECK(k3.report.after.all.rms_px == Approx(free.report.after.all.rms_px).epsilon(0.02));
  CHECK(epoch0_ground_rms(k3.frames, b) < 0.5);

  // Staged self-calibration keeps them too.
  options.staged_intrinsics = true;
  options.epochs[0].fixed_intrinsics = {Intrinsic::p1, Intrinsic::p2};
  const BundleResult staged = bundle_adjust(input, options);
  REQUIRE(staged.report.success);
  CHECK(staged.frames[0].camera().params()[3] == before[3]);
  CHECK(staged.frames[0].camera().params()[4] == before[4]);

  // Every intrinsic held: the camera stays as it was, the poses still adjust.
  options.staged_intrinsics = false;
  options.epochs[0].fixed_intrinsics = {Intrinsic::f,  Intrinsic::cx, Intrinsic::cy, Intrinsic::k1,
                                        Intrinsic::k2, Intrinsic::k3, Intrinsic::p1, Intrinsic::p2};
  const BundleResult all = bundle_adjust(input, options);
  REQUIRE(all.report.success);
  CHECK(all.frames[0].camera().intrinsics()[0] == input.frames[0].camera().intrinsics()[0]);
  CHECK(all.frames[0].camera().params()[0] == before[0]);
  CHECK((all.frames[0].pose().centre() - input.frames[0].pose().centre()).norm() > 0.1);

  options.epochs[0].fixed_intrinsics = {static_cast<Intrinsic>(8)};
  CHECK_THROWS_WITH(bundle_adjust(input, options), Catch::Contains("not an intrinsic"));
}

TEST_CASE("bundle_adjust: EpochFreedom::intrinsic_priors lie between holding and freeing an intrinsic",
          "[adjustment]") {
  const test::Block b = test::make_block(/*seed=*/1, /*points=*/1000);
  const BundleInput input = block_input(b);
  const Camera<FraserAffine>& truth = b.truth[0].camera();
  const auto k_before = input.frames[0].camera().params();
  const double f_before = input.frames[0].camera().focal();
  const BundleResult free = bundle_adjust(input, reference_fixed());
  REQUIRE(free.report.success);
  const double f_free = free.frames[0].camera().focal();
  REQUIRE(std::abs(f_free - f_before) > 0.5);

  // A prior far tighter than anything the images say is a hold: the radial terms stay at the
  // SfM's (half the truth's), and the distortion stays as wrong as when they are held.
  BundleOptions options = reference_fixed();
  options.epochs[0].intrinsic_priors = {{Intrinsic::k1, 1e-9}, {Intrinsic::k2, 1e-9}, {Intrinsic::k3, 1e-9}};
  const BundleResult tight = bundle_adjust(input, options);
  INFO(tight.report.message);
  REQUIRE(tight.report.success);
  for (int k = 0; k < 3; ++k) CHECK(std::abs(tight.frames[0].camera().params()[k] - k_before[k]) < 1e-7);
  CHECK(distortion_difference(tight.frames[0].camera(), truth).max_px > 1.0);
  const CameraReport& camera = tight.report.cameras[0];
  CHECK(camera.priors == std::vector<std::string>{"K1", "K2", "K3"});
  CHECK(camera.prior_sigmas == std::vector<double>{1e-9, 1e-9, 1e-9});
  CHECK(camera.held.empty());
  CHECK(tight.report.cameras[1].priors.empty());  // the reference camera is fixed

  // A prior far looser than the images' evidence changes nothing that matters.
  options.epochs[0].intrinsic_priors = {{Intrinsic::f, 1e6}, {Intrinsic::k1, 1e3}, {Intrinsic::cx, 1e6}};
  const BundleResult loose = bundle_adjust(input, options);
  REQUIRE(loose.report.success);
  CHECK(loose.frames[0].camera().focal() == Approx(f_free).margin(1e-3));
  CHECK(loose.frames[0].camera().params()[0] == Approx(free.frames[0].camera().params()[0]).margin(1e-7));

  // In between, the oracle is the linear-Gaussian update: a prior of sigma p on f, centred at the
  // SfM's f0, moves the free solution's f by var / (var + p^2) of the way back to f0, where var is
  // the free solution's variance of f with the observations' own sigmas (the report's, divided by
  // sigma0^2). The same prior as the images' own sigma goes half way.
  const double var = std::pow(free.report.cameras[0].values[0].sigma / free.report.sigma0, 2);
  for (const double p : {0.5 * std::sqrt(var), std::sqrt(var), 2.0 * std::sqrt(var)}) {
    options.epochs[0].intrinsic_priors = {{Intrinsic::f, p}};
    const BundleResult mid = bundle_adjust(input, options);
    REQUIRE(mid.report.success);
    const double expected = f_free + var / (var + p * p) * (f_before - f_free);
    INFO("focal: SfM " << f_before << ", free " << f_free << " (sigma " << std::sqrt(var) << "), prior sigma " << p
                       << ": " << mid.frames[0].camera().focal() << ", expected " << expected);
    CHECK(std::abs(mid.frames[0].camera().focal() - expected) < 0.02 * std::abs(f_free - f_before));
    CHECK(mid.report.cameras[0].values[0].sigma < free.report.cameras[0].values[0].sigma);
  }

  // A held intrinsic's prior does nothing and is not reported.
  options.epochs[0].fixed_intrinsics = {Intrinsic::f};
  const BundleResult held = bundle_adjust(input, options);
  REQUIRE(held.report.success);
  CHECK(held.frames[0].camera().focal() == f_before);
  CHECK(held.report.cameras[0].priors.empty());

  options.epochs[0].fixed_intrinsics.clear();
  options.epochs[0].intrinsic_priors = {{Intrinsic::f, 0.0}};
  CHECK_THROWS_WITH(bundle_adjust(input, options), Catch::Contains("sigma > 0"));
  options.epochs[0].intrinsic_priors = {{Intrinsic::k1, std::numeric_limits<double>::quiet_NaN()}};
  CHECK_THROWS_WITH(bundle_adjust(input, options), Catch::Contains("sigma > 0"));
  options.epochs[0].intrinsic_priors = {{static_cast<Intrinsic>(9), 1.0}};
  CHECK_THROWS_WITH(bundle_adjust(input, options), Catch::Contains("not an intrinsic"));
}
