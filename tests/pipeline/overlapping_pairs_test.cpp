// Tests of overlapping_pairs.hpp: polygon intersection against a brute-force rasterisation, image
// footprints of pinhole frames over a flat and a tilted DSM against analytic ray-plane points, an
// image with no DSM under it, overlap areas of shifted footprints, ranking, filters and a Helmert.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

#include <Eigen/Geometry>

#include <diachron/core/random.hpp>
#include <diachron/pipeline/overlapping_pairs.hpp>

#include "terrain/pinhole_test_frame.hpp"

using diachron::Dsm;
using diachron::FootprintImage;
using diachron::GeoTransform;
using diachron::Polygon2;
using diachron::Raster;
using diachron::test::make_frame;
using diachron::test::PinholeFrame;
using Eigen::Vector2d;
using Eigen::Vector3d;

namespace {

constexpr int kWidth = 1000, kHeight = 800;

// Z = z0 + gx X + gy Y sampled on odd-metre pixel centres with dyadic coefficients, so the float
// samples are exact and the bilinear DSM is the plane itself.
struct Plane {
  double z0 = 10.0, gx = 0.0, gy = 0.0;
  double operator()(double X, double Y) const { return z0 + gx * X + gy * Y; }
};

Dsm plane_dsm(const Plane& p, double x0 = -1000.0, double y0 = 2000.0, int size = 1500) {
  const GeoTransform gt = GeoTransform::north_up(x0, y0, 2.0);
  Raster<float> z(size, size);
  for (int y = 0; y < z.height(); ++y)
    for (int x = 0; x < z.width(); ++x) {
      const Vector2d w = gt.pixel_to_world({x, y});
      z(x, y) = static_cast<float>(p(w.x(), w.y()));
    }
  return Dsm(std::move(z), gt);
}

FootprintImage<PinholeFrame> image_at(const Vector3d& centre, double roll = 0.0, double tilt = 0.0) {
  PinholeFrame f = make_frame(centre, 1000.0, roll, tilt);
  f.cx = 500.0;
  f.cy = 400.0;
  return {f, kWidth, kHeight};
}

// Where the ray of `px` meets the plane, analytically.
Vector3d on_plane(const PinholeFrame& frame, const Plane& p, const Vector2d& px) {
  const auto ray = frame.ray(px);
  const Vector3d n(-p.gx, -p.gy, 1.0);
  const double t = -(ray->origin.z() - p(ray->origin.x(), ray->origin.y())) / n.dot(ray->direction);
  return ray->at(t);
}

bool inside(const Polygon2& poly, const Vector2d& q) {
  bool in = false;
  for (std::size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const Vector2d& a = poly[i];
    const Vector2d& b = poly[j];
    if ((a.y() > q.y()) != (b.y() > q.y()) && q.x() < (b.x() - a.x()) * (q.y() - a.y()) / (b.y() - a.y()) + a.x())
      in = !in;
  }
  return in;
}

// Brute force: the share of an n x n grid of cell centres inside both polygons.
double raster_intersection_area(const Polygon2& a, const Polygon2& b, double lo, double hi, int n) {
  const double cell = (hi - lo) / n;
  int count = 0;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const Vector2d q(lo + (x + 0.5) * cell, lo + (y + 0.5) * cell);
      if (inside(a, q) && inside(b, q)) ++count;
    }
  return count * cell * cell;
}

// A star-shaped (generally non-convex) polygon: random radii at increasing angles.
Polygon2 star(diachron::RandomStream& rng, const Vector2d& centre, int n) {
  Polygon2 p;
  for (int k = 0; k < n; ++k) {
    const double angle = 2.0 * M_PI * (k + 0.8 * rng.uniform01()) / n;
    const double r = 2.0 + 6.0 * rng.uniform01();
    p.push_back(centre + r * Vector2d(std::cos(angle), std::sin(angle)));
  }
  return p;
}

double min_distance(const Polygon2& poly, const Vector2d& q) {
  double d = std::numeric_limits<double>::infinity();
  for (const Vector2d& v : poly) d = std::min(d, (v - q).norm());
  return d;
}

}  // namespace

TEST_CASE("polygon_intersection_area: non-convex polygons agree with a brute-force rasterisation", "[pipeline]") {
  diachron::RandomStream rng(7);
  for (int trial = 0; trial < 6; ++trial) {
    const Polygon2 a = star(rng, Vector2d(10.0, 10.0), 9 + trial);
    // One draw per statement, y before x (star draws after both): the order of a call's arguments is
    // unspecified (core/random.hpp, "Order of draws").
    const double y = 10.0 - 3.0 * rng.uniform01();
    Polygon2 b = star(rng, Vector2d(10.0 + 3.0 * rng.uniform01(), y), 7 + trial);
    if (trial % 2) std::reverse(b.begin(), b.end());  // either orientation
    const std::optional<double> exact = diachron::polygon_intersection_area(a, b);
    REQUIRE(exact);
    const double brute = raster_intersection_area(a, b, 0.0, 20.0, 500);
    CHECK(*exact == Approx(brute).margin(0.25));
    // The triangulation partitions the polygon.
    double sum = 0.0;
    const auto triangles = diachron::triangulate_polygon(a);
    REQUIRE(triangles);
    for (const auto& t : *triangles) sum += diachron::polygon_signed_area(Polygon2(t.begin(), t.end()));
    CHECK(sum == Approx(std::abs(diachron::polygon_signed_area(a))).epsilon(1e-12));
    // With itself: its own area.
    CHECK(*diachron::polygon_intersection_area(a, a) == Approx(std::abs(diachron::polygon_signed_area(a))).epsilon(1e-9));
  }
}

TEST_CASE("polygon_intersection_area: exact cases, collinear vertices, and non-simple polygons", "[pipeline]") {
  // An L (area 3) against a square over its notch and one arm: the overlap is 1 of the arm plus 0.
  const Polygon2 l = {{0, 0}, {2, 0}, {2, 1}, {1, 1}, {1, 2}, {0, 2}};
  const Polygon2 notch = {{1, 0}, {2, 0}, {2, 2}, {1, 2}};
  CHECK(*diachron::polygon_intersection_area(l, notch) == Approx(1.0).epsilon(1e-12));
  // Collinear samples along the edges (as from a footprint over flat ground).
  const Polygon2 square = {{0, 0}, {1, 0}, {2, 0}, {3, 0}, {3, 3}, {1.5, 3}, {0, 3}};
  const Polygon2 shifted = {{1, 1}, {4, 1}, {4, 4}, {1, 4}};
  CHECK(*diachron::polygon_intersection_area(square, shifted) == Approx(4.0).epsilon(1e-12));
  // Disjoint, and touching along an edge: no area.
  CHECK(*diachron::polygon_intersection_area(notch, Polygon2{{5, 5}, {6, 5}, {6, 6}}) == 0.0);
  CHECK(*diachron::polygon_intersection_area(notch, Polygon2{{2, 0}, {3, 0}, {3, 2}, {2, 2}}) ==
        Approx(0.0).margin(1e-12));
  // A bow tie is not simple.
  const Polygon2 bow = {{0, 0}, {2, 2}, {2, 0}, {0, 2}};
  CHECK_FALSE(diachron::polygon_is_simple(bow));
  CHECK_FALSE(diachron::polygon_intersection_area(bow, notch));
  CHECK(diachron::polygon_is_simple(l));
}

TEST_CASE("image_footprint: nadir frame over flat ground gives the analytic rectangle", "[pipeline]") {
  const Plane plane;
  const Dsm dsm = plane_dsm(plane);
  const auto image = image_at(Vector3d(101.0, 203.0, 1010.0));
  diachron::FootprintOptions options;
  options.samples_per_edge = 5;
  const diachron::Footprint f = diachron::image_footprint(image, dsm, options);
  REQUIRE(f.valid);
  CHECK(f.reason.empty());
  CHECK(f.rays == 24u);
  CHECK(f.hits == 24u);
  CHECK(f.misses == 0u);
  // Height 1000 above the ground, f = 1000: one pixel is one metre.
  const double x0 = 101.0 - 500.5, x1 = 101.0 + 499.5, y_top = 203.0 + 400.5, y_bottom = 203.0 - 399.5;
  for (const Vector2d& c : {Vector2d(x0, y_top), Vector2d(x1, y_top), Vector2d(x1, y_bottom), Vector2d(x0, y_bottom)})
    CHECK(min_distance(f.polygon, c) < 1e-6);
  CHECK(f.area == Approx(1000.0 * 800.0).epsilon(1e-9));
  CHECK(diachron::polygon_signed_area(f.polygon) > 0.0);  // counter-clockwise
}

TEST_CASE("image_footprint: rolled, tilted frame over a sloping DSM follows the analytic ray-plane points",
          "[pipeline]") {
  const Plane plane{5.0, 0.125, -0.0625};
  const Dsm dsm = plane_dsm(plane);
  const auto image = image_at(Vector3d(150.0, 300.0, 1200.0), 0.4, 0.15);
  diachron::FootprintOptions options;
  options.samples_per_edge = 3;
  const diachron::Footprint f = diachron::image_footprint(image, dsm, options);
  REQUIRE(f.valid);
  Polygon2 expected;
  const Vector2d corners[4] = {{-0.5, -0.5}, {kWidth - 0.5, -0.5}, {kWidth - 0.5, kHeight - 0.5}, {-0.5, kHeight - 0.5}};
  for (int e = 0; e < 4; ++e)
    for (int k = 0; k < 4; ++k) {
      const Vector2d px = corners[e] + (corners[(e + 1) % 4] - corners[e]) * (k / 4.0);
      const Vector3d g = on_plane(image.frame, plane, px);
      expected.push_back(g.head<2>());
      CHECK(min_distance(f.polygon, g.head<2>()) < 1e-5);
    }
  CHECK(f.area == Approx(std::abs(diachron::polygon_signed_area(expected))).epsilon(1e-9));
  // A plane at the DSM's mean height (MicMac) would put the corners elsewhere on this slope.
  CHECK(f.polygon.size() == expected.size());
}

TEST_CASE("image_footprint: an image with no DSM under it is invalid, with the reason", "[pipeline]") {
  // The DSM lies 10 km east of the image.
  const Dsm far_dsm = plane_dsm(Plane{}, 10000.0, 2000.0, 200);
  const auto image = image_at(Vector3d(101.0, 203.0, 1010.0));
  const diachron::Footprint f = diachron::image_footprint(image, far_dsm);
  CHECK_FALSE(f.valid);
  CHECK(f.hits == 0u);
  CHECK(f.misses == f.rays);
  CHECK(f.reason.find("no valid cell under the image") != std::string::npos);
  diachron::FootprintOptions strict;
  strict.plane_fallback = false;
  const diachron::Footprint f_strict = diachron::image_footprint(image, far_dsm, strict);
  CHECK_FALSE(f_strict.valid);
  CHECK(f_strict.reason.find("0 of 36 boundary rays hit the DSM") != std::string::npos);
  // A DSM under the western third only: without the fallback fewer than half the rays hit and the
  // footprint is invalid; with it, the missing rays land on the plane at the hits' mean height and
  // the footprint is the whole image's.
  const Dsm partial = plane_dsm(Plane{}, -1000.0, 2000.0, 400);  // X in [-1000, -200]
  const auto west = image_at(Vector3d(-100.0, 1500.0, 1010.0));
  const diachron::Footprint g = diachron::image_footprint(west, partial, strict);
  CHECK_FALSE(g.valid);
  CHECK(g.hits > 0u);
  CHECK(g.hits < g.rays / 2);
  const diachron::Footprint h = diachron::image_footprint(west, partial);
  CHECK(h.valid);
  CHECK(h.hits == g.hits);
  CHECK(h.plane_hits == h.rays - h.hits);
  CHECK(h.polygon.size() == h.rays);
  // Invalid options name the field.
  diachron::FootprintOptions bad;
  bad.samples_per_edge = -1;
  CHECK_THROWS_WITH(diachron::image_footprint(image, far_dsm, bad), Catch::Contains("samples_per_edge"));
  CHECK_THROWS_AS(diachron::image_footprint(FootprintImage<PinholeFrame>{image.frame, 0, 10}, far_dsm),
                  diachron::Error);
}

TEST_CASE("overlapping_pairs: analytic overlap areas, ranking, filters and counts", "[pipeline]") {
  const Dsm dsm = plane_dsm(Plane{});
  // Footprints 1000 x 800 m; shifts give overlaps of 700 x 700, 900 x 800, 400 x 600 and none.
  const std::vector<FootprintImage<PinholeFrame>> master = {image_at(Vector3d(101.0, 203.0, 1010.0))};
  const std::vector<FootprintImage<PinholeFrame>> secondary = {
      image_at(Vector3d(401.0, 303.0, 1010.0)), image_at(Vector3d(201.0, 203.0, 1010.0)),
      image_at(Vector3d(-499.0, 403.0, 1010.0)), image_at(Vector3d(1501.0, 203.0, 1010.0)),
      image_at(Vector3d(50000.0, 0.0, 1010.0))};  // off the DSM: invalid footprint
  diachron::OverlappingPairsOptions options;
  options.threads = 1;
  const diachron::OverlappingPairsResult r = diachron::overlapping_pairs(master, dsm, secondary, dsm, diachron::IdentityPointTransform{}, options);
  REQUIRE(r.success);
  CHECK(r.invalid_master_footprints == 0u);
  CHECK(r.invalid_secondary_footprints == 1u);
  CHECK(r.candidate_pairs == 4u);
  CHECK(r.overlapping_pairs == 3u);
  CHECK(r.filtered_pairs == 0u);
  REQUIRE(r.pairs.size() == 3u);
  CHECK(r.pairs[0].secondary == 1u);
  CHECK(r.pairs[0].area == Approx(900.0 * 800.0).epsilon(1e-9));
  CHECK(r.pairs[1].secondary == 0u);
  CHECK(r.pairs[1].area == Approx(700.0 * 700.0).epsilon(1e-9));
  CHECK(r.pairs[1].fraction_of_smaller == Approx(490000.0 / 800000.0).epsilon(1e-9));
  CHECK(r.pairs[1].fraction_of_master == Approx(490000.0 / 800000.0).epsilon(1e-9));
  CHECK(r.pairs[2].secondary == 2u);
  CHECK(r.pairs[2].area == Approx(400.0 * 600.0).epsilon(1e-9));

  // Filters: fraction of the smaller footprint, then area.
  options.min_overlap_fraction = 0.5;
  const auto by_fraction = diachron::overlapping_pairs(master, dsm, secondary, dsm, diachron::IdentityPointTransform{}, options);
  CHECK(by_fraction.pairs.size() == 2u);
  CHECK(by_fraction.filtered_pairs == 1u);
  options.min_overlap_fraction = 0.0;
  options.min_overlap_area = 600000.0;
  const auto by_area = diachron::overlapping_pairs(master, dsm, secondary, dsm, diachron::IdentityPointTransform{}, options);
  REQUIRE(by_area.pairs.size() == 1u);
  CHECK(by_area.pairs[0].secondary == 1u);

  // Same answer with threads.
  options.min_overlap_area = 0.0;
  options.threads = 4;
  const auto threaded = diachron::overlapping_pairs(master, dsm, secondary, dsm, diachron::IdentityPointTransform{}, options);
  REQUIRE(threaded.pairs.size() == r.pairs.size());
  for (std::size_t k = 0; k < r.pairs.size(); ++k) {
    CHECK(threaded.pairs[k].secondary == r.pairs[k].secondary);
    CHECK(threaded.pairs[k].area == r.pairs[k].area);
  }

  // No overlap at all: not a success, and it says so.
  const auto none = diachron::overlapping_pairs(master, dsm, std::vector<FootprintImage<PinholeFrame>>{secondary[3]}, dsm);
  CHECK_FALSE(none.success);
  CHECK(none.message.find("0 pair(s) kept") != std::string::npos);
  options.min_overlap_fraction = 1.5;
  CHECK_THROWS_WITH(diachron::overlapping_pairs(master, dsm, secondary, dsm, diachron::IdentityPointTransform{}, options),
                    Catch::Contains("min_overlap_fraction"));
}

TEST_CASE("overlapping_pairs: the Helmert moves the master footprints into the secondary frame", "[pipeline]") {
  const Dsm dsm = plane_dsm(Plane{});
  const auto image = image_at(Vector3d(101.0, 203.0, 1010.0));
  struct Helmert {
    double s = 1.25;
    Eigen::Matrix3d R = Eigen::AngleAxisd(0.3, Vector3d::UnitZ()).toRotationMatrix();
    Vector3d T = Vector3d(5000.0, -3000.0, 7.0);
    Vector3d operator()(const Vector3d& p) const { return s * R * p + T; }
  } helmert;
  const diachron::Footprint plain = diachron::image_footprint(image, dsm);
  const diachron::Footprint moved = diachron::image_footprint(image, dsm, diachron::FootprintOptions{}, helmert);
  REQUIRE(plain.valid);
  REQUIRE(moved.valid);
  REQUIRE(moved.polygon.size() == plain.polygon.size());
  for (std::size_t k = 0; k < plain.polygon.size(); ++k) {
    const Vector3d p(plain.polygon[k].x(), plain.polygon[k].y(), 10.0);
    CHECK((moved.polygon[k] - helmert(p).head<2>()).norm() < 1e-6);
  }
  CHECK(moved.area == Approx(1.25 * 1.25 * plain.area).epsilon(1e-9));
  // A secondary image where the moved master footprint lies overlaps it; one at the old place does not.
  const Vector2d c = helmert(Vector3d(101.0, 203.0, 10.0)).head<2>();
  const std::vector<FootprintImage<PinholeFrame>> master = {image};
  const std::vector<FootprintImage<PinholeFrame>> secondary = {image_at(Vector3d(101.0, 203.0, 1010.0)),
                                                               image_at(Vector3d(c.x(), c.y(), 1010.0))};
  const Dsm dsm2 = plane_dsm(Plane{}, 3500.0, -1000.0, 1500);  // covers the moved ground
  const auto r = diachron::overlapping_pairs(master, dsm, secondary, dsm2, helmert);
  CHECK(r.invalid_secondary_footprints == 1u);  // the first secondary image is off dsm2
  REQUIRE(r.pairs.size() == 1u);
  CHECK(r.pairs[0].secondary == 1u);
  CHECK(r.pairs[0].fraction_of_smaller > 0.5);
  // diachron::Frame gives its size itself.
  static_assert(!diachron::detail::has_camera_size<PinholeFrame>::value);
}
