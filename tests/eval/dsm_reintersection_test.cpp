// reintersect_dsm on an analytic terrain seen by two nadir images: a rigid move of the orientation
// is recovered exactly (no bend, the DSM unchanged); a changed camera bends the DSM and every
// corrected height matches the brute force (project, triangulate, bring back); the dome a wrong
// radial distortion puts into a DSM is taken out when the true camera is given; bad input.

#include <algorithm>
#include <cmath>
#include <vector>

#include <catch2/catch.hpp>

#include <diachron/adjustment/triangulation.hpp>
#include <diachron/core/error.hpp>
#include <diachron/eval/dsm_reintersection.hpp>
#include <diachron/geometry/rotation.hpp>

using namespace diachron;

namespace {

// 200 x 200 cells of 1 m, gentle hills of a few metres.
Dsm hills() {
  Raster<float> z(200, 200);
  for (int y = 0; y < 200; ++y)
    for (int x = 0; x < 200; ++x) z(x, y) = static_cast<float>(10.0 * std::sin(x / 30.0) + 5.0 * std::cos(y / 20.0));
  return Dsm(z, GeoTransform::north_up(0.0, 200.0, 1.0));
}

// Two nadir images 500 m up, 100 m apart, each seeing the whole DSM (400 x 300 px, f 300 px:
// 667 x 500 m on the ground); `k1` the radial distortion of their camera.
std::vector<Frame<FraserAffine>> block(double k1 = 0.0) {
  Camera<FraserAffine> camera(300.0, 199.5, 149.5, 400, 300);
  Camera<FraserAffine>::Params params{};
  params[0] = k1;
  camera.set_params(params);
  const Mat3 down = (Mat3() << 1, 0, 0, 0, -1, 0, 0, 0, -1).finished();  // camera z to world -z
  return {Frame<FraserAffine>(camera, Pose(down, Vec3(50.0, 100.0, 500.0))),
          Frame<FraserAffine>(camera, Pose(down, Vec3(150.0, 100.0, 500.0)))};
}

}  // namespace

TEST_CASE("reintersect_dsm: a rigid move of the orientation is the Helmert, with no bend", "[eval]") {
  const Dsm dsm = hills();
  const Helmert3 move{1.02, rotation_from_axis_angle<double>(Vec3(0.1, -0.2, 0.9).normalized() * 0.3), Vec3(40.0, -25.0, 7.0)};
  const std::vector<Frame<FraserAffine>> before = block();
  const std::vector<Frame<FraserAffine>> after = transformed_frames(before, move);
  const DsmReintersection r = reintersect_dsm(dsm, before, after);
  INFO(r.reason);
  REQUIRE(r.success);
  CHECK(r.cells == 200u * 200u);
  CHECK(r.reintersected == r.cells);
  CHECK(std::abs(r.reference_from_epoch.scale - move.scale) < 1e-9);
  CHECK((r.reference_from_epoch.rotation - move.rotation).norm() < 1e-9);
  CHECK((r.reference_from_epoch.translation - move.translation).norm() < 1e-6);
  CHECK(r.rms_nonrigid < 1e-6);
  CHECK(r.max_height_correction < 1e-5);
  for (int y = 0; y < 200; y += 17)
    for (int x = 0; x < 200; x += 13) CHECK(std::abs(r.dsm.heights()(x, y) - dsm.heights()(x, y)) < 1e-4);
}

TEST_CASE("reintersect_dsm: a changed camera bends the DSM, each height as the brute force gives it",
          "[eval]") {
  const Dsm dsm = hills();
  const std::vector<Frame<FraserAffine>> before = block(0.0), after = block(-0.08);
  const DsmReintersection r = reintersect_dsm(dsm, before, after);
  REQUIRE(r.success);
  CHECK(r.rms_nonrigid > 0.1);  // a bend no similarity takes out
  CHECK(r.max_height_correction > 0.5);
  // Brute force at a few cells: project with `before`, triangulate with `after`, bring back by the
  // fitted similarity's inverse, and the rise there applied at the cell.
  const Helmert3 back = r.reference_from_epoch.inverse();
  int checked = 0;
  for (int y = 20; y < 180; y += 31)
    for (int x = 20; x < 180; x += 29) {
      const Eigen::Vector2d xy = dsm.pixel_to_world({x, y});
      const Vec3 point(xy.x(), xy.y(), dsm.heights()(x, y));
      Track track;
      for (int i = 0; i < 2; ++i)
        track.observations.push_back({i, *before[static_cast<std::size_t>(i)].project(point), ObservationKind::intra_epoch});
      const TriangulationResult t = triangulate_track(after, track);
      REQUIRE(t.success);
      const Vec3 moved = back(t.point);
      const double expected = point.z() + moved.z() - dsm.height_at(moved.x(), moved.y());
      CHECK(std::abs(r.dsm.heights()(x, y) - expected) < 1e-3);
      ++checked;
    }
  CHECK(checked >= 25);
}

TEST_CASE("reintersect_dsm: the dome of a wrong radial distortion is taken out by the true camera",
          "[eval]") {
  // A DSM as an SfM with a wrong K1 measures it: each true point intersected from its true pixels
  // with the wrong camera lands bent; its height, kept at the true cell, makes a dome.
  const Dsm truth = hills();
  const std::vector<Frame<FraserAffine>> true_block = block(0.0), wrong = block(0.05);
  Raster<float> bent(200, 200);
  for (int y = 0; y < 200; ++y)
    for (int x = 0; x < 200; ++x) {
      const Eigen::Vector2d xy = truth.pixel_to_world({x, y});
      const Vec3 point(xy.x(), xy.y(), truth.heights()(x, y));
      Track track;
      for (int i = 0; i < 2; ++i)
        track.observations.push_back({i, *true_block[static_cast<std::size_t>(i)].project(point), ObservationKind::intra_epoch});
      const TriangulationResult t = triangulate_track(wrong, track);
      REQUIRE(t.success);
      bent(x, y) = static_cast<float>(t.point.z());
    }
  const Dsm dsm(bent, truth.transform());
  double before = 0.0;
  for (int y = 0; y < 200; ++y)
    for (int x = 0; x < 200; ++x) before = std::max(before, std::abs(static_cast<double>(dsm.heights()(x, y)) - truth.heights()(x, y)));
  // The wrong camera's own orientation made the DSM; the true one carries it back.
  const DsmReintersection r = reintersect_dsm(dsm, wrong, true_block);
  REQUIRE(r.success);
  // Each corrected cell placed by the fitted similarity lies on the true surface.
  double after = 0.0;
  for (int y = 10; y < 190; ++y)
    for (int x = 10; x < 190; ++x) {
      const Eigen::Vector2d xy = r.dsm.pixel_to_world({x, y});
      const Vec3 placed = r.reference_from_epoch(Vec3(xy.x(), xy.y(), r.dsm.heights()(x, y)));
      after = std::max(after, std::abs(placed.z() - truth.height_at(placed.x(), placed.y())));
    }
  INFO("largest height error " << before << " m bent, " << after << " m reintersected");
  CHECK(before > 1.0);
  CHECK(after < 0.1 * before);
}

TEST_CASE("reintersect_dsm: no overlap is a failure with the reason; bad input throws", "[eval]") {
  const Dsm far(Raster<float>(20, 20, 0.0f), GeoTransform::north_up(5000.0, 5000.0, 1.0));
  const DsmReintersection r = reintersect_dsm(far, block(), block());
  CHECK_FALSE(r.success);
  CHECK(r.reason.find("too few cells reintersected (0 of 400)") != std::string::npos);
  CHECK_FALSE(reintersect_dsm(Dsm{}, block(), block()).success);
  std::vector<Frame<FraserAffine>> one = block();
  one.pop_back();
  CHECK_THROWS_AS(reintersect_dsm(hills(), block(), one), Error);
  DsmReintersectionOptions bad;
  bad.min_images = 1;
  CHECK_THROWS_AS(reintersect_dsm(hills(), block(), block(), bad), Error);
}
