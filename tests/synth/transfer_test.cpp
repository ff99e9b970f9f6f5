// Transfers between two synthetic epochs (terrain/transfer.hpp on synth/ scenes): the geometry the
// precise matching relies on, checked against the generator's truth.
#include <catch2/catch.hpp>

#include <chrono>
#include <cmath>

#include <diachron/geometry/rotation.hpp>
#include <diachron/synth/scene.hpp>
#include <diachron/terrain/local_affine.hpp>
#include <diachron/terrain/transfer.hpp>

using namespace diachron;

namespace {

const Scene& scene() {
  static const Scene s = [] {
    SceneOptions o;
    o.seed = 11;
    for (EpochOptions& e : o.epochs) e.columns = 2;
    o.check_points = 60;
    o.threads = 1;
    const auto t0 = std::chrono::steady_clock::now();
    Scene generated = generate_scene(o);
    WARN("2 x 2 images per epoch generated on one thread in "
         << std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() << " s");
    return generated;
  }();
  return s;
}

// Epoch-0 and epoch-1 observations of a check point, or nulls.
std::pair<const CheckPoint::Observation*, const CheckPoint::Observation*> pair_of(const CheckPoint& cp) {
  const CheckPoint::Observation* a = nullptr;
  const CheckPoint::Observation* b = nullptr;
  for (const auto& o : cp.observations) {
    if (o.epoch == 0 && !a) a = &o;
    if (o.epoch == 1 && !b) b = &o;
  }
  return {a, b};
}

}  // namespace

TEST_CASE("DsmTransfer: check points go from an epoch-1 image to an epoch-2 image within 0.1 px", "[synth]") {
  const Scene& s = scene();
  const SyntheticEpoch& e1 = s.epochs[0];
  const SyntheticEpoch& e2 = s.epochs[1];
  int tested = 0;
  for (const CheckPoint& cp : s.check_points) {
    const auto [a, b] = pair_of(cp);
    if (!a || !b) continue;
    // Master in the world with its true surface; secondary in epoch 2's own frame, reached through
    // the true Helmert: exercises the ray, the intersection, the point transform and the projection.
    const auto transfer =
        make_dsm_transfer(e1.world_frame(a->image), e1.true_surface, e2.epoch_frame(b->image), e2.epoch_from_world());
    const auto predicted = transfer(a->pixel);
    REQUIRE(predicted);
    REQUIRE((*predicted - b->pixel).norm() < 0.1);
    ++tested;
  }
  REQUIRE(tested >= 20);
}

TEST_CASE("local_affine: the transfer's scale ratio and rotation match the projected ground", "[synth]") {
  const Scene& s = scene();
  const SyntheticEpoch& e1 = s.epochs[0];
  const SyntheticEpoch& e2 = s.epochs[1];
  int tested = 0, agree = 0;
  for (const CheckPoint& cp : s.check_points) {
    const auto [a, b] = pair_of(cp);
    if (!a || !b) continue;
    const auto m = e1.world_frame(a->image);
    const auto inside = [](const Vec2& p, const Raster<std::uint8_t>& image) {
      return p.x() > 10 && p.y() > 10 && p.x() < image.width() - 10 && p.y() < image.height() - 10;
    };
    if (!inside(a->pixel, e1.images[a->image].pixels) || !inside(b->pixel, e2.images[b->image].pixels)) continue;
    const auto q = e2.world_frame(b->image);
    // Independent truth: ground points around the check point, on the surface, projected into both
    // images (no ray, no intersection). Only where the surface is locally planar (no building edge).
    const double h = 0.5;
    const Dsm& ground = e1.true_surface;
    auto on_ground = [&](double dx, double dy) {
      return Vec3(cp.world.x() + dx, cp.world.y() + dy, ground.height_at(cp.world.x() + dx, cp.world.y() + dy));
    };
    const double z = ground.height_at(cp.world.x(), cp.world.y());
    const double curvature_x = on_ground(2, 0).z() + on_ground(-2, 0).z() - 2 * z;
    const double curvature_y = on_ground(0, 2).z() + on_ground(0, -2).z() - 2 * z;
    if (!(std::abs(curvature_x) < 0.02 && std::abs(curvature_y) < 0.02)) continue;
    const Vec3 g0 = on_ground(0, 0), g1 = on_ground(h, 0), g2 = on_ground(0, h);
    const auto p0 = m.project(g0), p1 = m.project(g1), p2 = m.project(g2);
    const auto r0 = q.project(g0), r1 = q.project(g1), r2 = q.project(g2);
    Mat2 dm, dq;
    dm.col(0) = *p1 - *p0;
    dm.col(1) = *p2 - *p0;
    dq.col(0) = *r1 - *r0;
    dq.col(1) = *r2 - *r0;
    const AffineDecomposition truth = decompose_affine(dq * dm.inverse());

    const auto transfer = make_dsm_transfer(m, e1.true_surface, q);
    const auto affine = local_affine(transfer, a->pixel, 0.25);
    REQUIRE(affine);
    const AffineDecomposition got = decompose_affine(*affine);
    // A wall or roof edge within the difference step is a true discontinuity of the map: such points
    // disagree legitimately, so most, not all, must agree.
    ++tested;
    agree += std::abs(got.scale / truth.scale - 1.0) < 0.01 &&
             std::abs(wrap_angle(got.rotation - truth.rotation)) < deg_to_rad(0.5);
  }
  REQUIRE(tested >= 5);
  REQUIRE(agree >= 0.9 * tested);
}
