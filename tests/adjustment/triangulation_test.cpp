// triangulate_point / triangulate_track: exact on noise-free views with distortion, close under
// pixel noise, and failures (few views, small angle, behind a camera) reported, not returned.

#include <cmath>
#include <optional>
#include <vector>

#include <diachron/adjustment/triangulation.hpp>
#include <diachron/camera/frame.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/random.hpp>

#include "adjustment/catch_ceres.hpp"  // last: gives CHECK back to Catch after glog

using namespace diachron;

namespace {

std::vector<Frame<FraserAffine>> strip(int n) {
  const Camera<FraserAffine> camera(265.0, 201.0, 147.5, 400, 300, {-0.025, 0.004, 0.0, 2e-4, -1.5e-4, 0.4, -0.2});
  std::vector<Frame<FraserAffine>> out;
  // A far-off epoch frame (shift ~ 1e5, as SfM frames can be) to exercise the conditioning.
  const Vec3 origin(1.0e5, -2.0e5, 300.0);
  for (int k = 0; k < n; ++k)
    out.emplace_back(camera, Pose::from_yaw_pitch_roll(origin + Vec3(160.0 * k, 5.0 * k, 520.0 + 3.0 * k), 0.05 * k,
                                                       0.01, -0.01 * k));
  return out;
}

}  // namespace

TEST_CASE("triangulate_point: noise-free views give the point back", "[adjustment]") {
  const auto frames = strip(3);
  const Vec3 truth = frames[1].pose().centre() + Vec3(20.0, -35.0, -510.0);
  std::vector<const Frame<FraserAffine>*> views;
  std::vector<Vec2> pixels;
  for (const auto& f : frames) {
    views.push_back(&f);
    pixels.push_back(*f.project(truth));
  }
  const TriangulationResult r = triangulate_point(views, pixels);
  REQUIRE(r.success);
  CHECK((r.point - truth).norm() < 1e-6);
  CHECK(r.rms_px < 1e-6);
  CHECK(r.views == 3);
  CHECK(r.angle_deg > 10.0);
}

TEST_CASE("triangulate_track: pixel noise of 0.3 px moves the point by about a GSD", "[adjustment]") {
  const auto frames = strip(3);
  RandomStream random(3);
  const auto noise = [&random] { return random.normal(0.0, 0.3); };
  double sum_squared = 0.0;
  const int n = 50;
  for (int i = 0; i < n; ++i) {
    const Vec3 truth = frames[1].pose().centre() + Vec3(-60.0 + 2.5 * i, 20.0 - i, -500.0 - 0.4 * i);
    Track track;
    for (int k = 0; k < 3; ++k) {
      const double ny = noise();  // y before x (core/random.hpp, "Order of draws")
      track.observations.push_back({k, *frames[static_cast<std::size_t>(k)].project(truth) + Vec2(noise(), ny),
                                    ObservationKind::intra_epoch});
    }
    const TriangulationResult r = triangulate_track(frames, track);
    REQUIRE(r.success);
    CHECK(r.rms_px < 1.0);
    sum_squared += (r.point - truth).squaredNorm();
  }
  // GSD ~ 2 m; depth error ~ GSD * height / base ~ 2 * 520 / 320 * 0.3 px ~ 2 m at most.
  CHECK(std::sqrt(sum_squared / n) < 3.0);
}

TEST_CASE("triangulate_point: failures are reported", "[adjustment]") {
  const auto frames = strip(2);
  const Vec3 truth = frames[0].pose().centre() + Vec3(80.0, 0.0, -500.0);
  const Vec2 p0 = *frames[0].project(truth), p1 = *frames[1].project(truth);
  SECTION("one view") {
    const auto r = triangulate_point<FraserAffine>({&frames[0]}, {p0});
    CHECK_FALSE(r.success);
    CHECK(r.message.find("too few") != std::string::npos);
  }
  SECTION("the same camera twice: no angle") {
    const auto r = triangulate_point<FraserAffine>({&frames[0], &frames[0]}, {p0, p0 + Vec2(0.01, 0)});
    CHECK_FALSE(r.success);
    CHECK(r.message.find("angle") != std::string::npos);
  }
  SECTION("diverging rays meet behind the cameras") {
    // Camera 0 looks towards its left edge, camera 1 (to the east) towards its right edge.
    const auto r = triangulate_point<FraserAffine>({&frames[0], &frames[1]}, {Vec2(5.0, 150.0), Vec2(395.0, 150.0)});
    CHECK_FALSE(r.success);
    CHECK(r.message.find("behind") != std::string::npos);
  }
  SECTION("the good pair succeeds") {
    CHECK(triangulate_point<FraserAffine>({&frames[0], &frames[1]}, {p0, p1}).success);
  }
  CHECK_THROWS_AS(triangulate_point<FraserAffine>({&frames[0]}, {p0, p1}), Error);
  Track bad;
  bad.observations = {{0, p0, ObservationKind::intra_epoch}, {7, p1, ObservationKind::intra_epoch}};
  CHECK_THROWS_AS(triangulate_track(frames, bad), Error);
}

TEST_CASE("FrameTriangulator: observation lists by image index, nullopt below two views, bad index throws",
          "[adjustment]") {
  const auto frames = strip(3);
  const Vec3 truth = frames[1].pose().centre() + Vec3(-15.0, 25.0, -505.0);
  struct Observation {
    int image;
    Vec2 pixel;
  };
  const FrameTriangulator<FraserAffine> triangulate(frames);
  const std::vector<Observation> two{{0, *frames[0].project(truth)}, {2, *frames[2].project(truth)}};
  const std::optional<Vec3> p = triangulate(two);
  REQUIRE(p);
  CHECK((*p - truth).norm() < 1e-6);
  CHECK_FALSE(triangulate(std::vector<Observation>{two[0]}));
  CHECK_THROWS_AS(triangulate(std::vector<Observation>{two[0], {3, two[1].pixel}}), Error);
}
