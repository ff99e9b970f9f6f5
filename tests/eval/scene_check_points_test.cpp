// The check points of a synthetic scene, triangulated from epoch 1's true pixels with epoch 1's
// orientation moved into epoch 2's frame: the true orientation gives the truth back, the "as
// estimated" one (wrong focal, principal point and distortion) gives errors of metres.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstddef>
#include <optional>
#include <vector>

#include <Eigen/Dense>

#include <diachron/camera/frame.hpp>
#include <diachron/eval/check_points.hpp>
#include <diachron/eval/scene_check_points.hpp>
#include <diachron/synth/scene.hpp>

#include "support/scenes.hpp"

using namespace diachron;

namespace {

// The small test scene with images of half the size (and half the focal length: the same ground
// sampling distance): check points need geometry, not pixels, and rendering dominates the time.
const Scene& check_point_scene() {
  static const Scene s = [] {
    SceneOptions o = diachron::test::small_scene_options(5, 0, 30);
    for (EpochOptions& e : o.epochs) {
      e.image_width_px /= 2;
      e.image_height_px /= 2;
      e.focal_px /= 2.0;
    }
    return generate_scene(o);
  }();
  return s;
}

// Least-squares intersection of the rays of the observations (the point nearest to all of them).
struct RayTriangulator {
  std::vector<Frame<FraserAffine>> frames;
  std::optional<Vec3> operator()(const std::vector<CheckPointObservation>& observations) const {
    if (observations.size() < 2) return std::nullopt;
    Mat3 a = Mat3::Zero();
    Vec3 b = Vec3::Zero();
    for (const CheckPointObservation& o : observations) {
      const std::optional<Ray3> ray = frames.at(o.image).ray(o.pixel);
      if (!ray) return std::nullopt;
      const Mat3 p = Mat3::Identity() - ray->direction * ray->direction.transpose();
      a += p;
      b += p * ray->origin;
    }
    return Vec3(a.ldlt().solve(b));
  }
};

RayTriangulator epoch1_in_epoch2(const Scene& s, bool estimated) {
  RayTriangulator t;
  const SyntheticEpoch& e1 = s.epochs[0];
  const Helmert3 h = s.epoch2_from_epoch1();
  for (std::size_t i = 0; i < e1.images.size(); ++i)
    t.frames.push_back((estimated ? e1.estimated_frame(i) : e1.epoch_frame(i)).transformed(h));
  return t;
}

}  // namespace

TEST_CASE("scene_check_points: truth in the reference frame, true pixels of the observed epoch", "[eval]") {
  const Scene& s = check_point_scene();
  const std::vector<ObservedCheckPoint> points = scene_check_points(s, 0, 1);
  REQUIRE(points.size() == s.check_points.size());
  REQUIRE(!points.empty());
  const Helmert3 epoch2_from_world = s.epochs[1].epoch_from_world();
  for (std::size_t k = 0; k < points.size(); ++k) {
    CHECK((points[k].truth - epoch2_from_world(s.check_points[k].world)).norm() < 1e-9);
    for (const CheckPointObservation& o : points[k].observations) {
      // Each observation is the true projection in epoch 1's true world frame of that image.
      const std::optional<Vec2> px = s.epochs[0].world_frame(o.image).project(s.check_points[k].world);
      REQUIRE(px);
      CHECK((*px - o.pixel).norm() < 1e-6);
    }
  }
  CHECK_THROWS_AS(scene_check_points(s, 0, 2), Error);
}

TEST_CASE("evaluate_check_points on a scene: true orientation exact, estimated orientation metres off", "[eval]") {
  const Scene& s = check_point_scene();
  const std::vector<ObservedCheckPoint> points = scene_check_points(s, 0, 1);
  const double gsd = s.epochs[0].gsd_m;
  const CheckPointReport truth = evaluate_check_points(points, epoch1_in_epoch2(s, false), gsd);
  REQUIRE(truth.success);
  CHECK(truth.num_used + truth.num_failed == points.size());
  CHECK(truth.num_used >= 5);
  CHECK(truth.rms_3d_m < 1e-4);
  // Failed are exactly the points epoch 1 sees in fewer than two images.
  for (std::size_t i : truth.failed) CHECK(points[i].observations.size() < 2);

  const CheckPointReport rough = evaluate_check_points(points, epoch1_in_epoch2(s, true), gsd);
  REQUIRE(rough.success);
  CHECK(rough.num_used == truth.num_used);
  CHECK(rough.rms_3d_m > 0.5);
  CHECK(rough.rms_3d_gsd == Approx(rough.rms_3d_m / gsd));
  CAPTURE(rough.axes_m[0].mean, rough.axes_m[1].mean, rough.axes_m[2].mean, rough.rms_3d_m, gsd);
}

TEST_CASE("evaluate_scene_check_points: errors in world metres whatever the frame's scale", "[eval]") {
  const Scene& s = check_point_scene();
  const double scale = s.epochs[1].world_from_epoch.scale;
  REQUIRE(std::abs(scale - 1.0) > 0.05);  // a frame whose units are not metres, else the test proves nothing
  const RayTriangulator exact = epoch1_in_epoch2(s, false);
  const CheckPointReport truth = evaluate_scene_check_points(s, 0, 1, exact);
  REQUIRE(truth.success);
  CHECK(truth.rms_3d_m < 1e-4);
  // One unit of epoch 2's frame off along X is `scale` metres in the world.
  const auto shifted = [&exact](const std::vector<CheckPointObservation>& o) -> std::optional<Vec3> {
    const std::optional<Vec3> p = exact(o);
    return p ? std::optional<Vec3>(*p + Vec3(1.0, 0.0, 0.0)) : std::nullopt;
  };
  const CheckPointReport off = evaluate_scene_check_points(s, 0, 1, shifted);
  REQUIRE(off.success);
  CHECK(off.num_used == truth.num_used);
  CHECK(off.rms_3d_m == Approx(scale).epsilon(1e-6));
  CHECK(off.rms_3d_gsd == Approx(scale / s.epochs[0].gsd_m).epsilon(1e-6));
  CHECK_THROWS_AS(evaluate_scene_check_points(s, 0, 2, exact), Error);
}
