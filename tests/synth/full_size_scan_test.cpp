// Tests of the full-size scans (synth/full_size_scan.hpp): exact scaling of cameras and truth,
// where the rebuilt images put the ground, agreement of two epochs on the same ground, and
// determinism over threads and bands.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <vector>

#include <catch2/catch.hpp>

#include <diachron/synth/full_size_scan.hpp>

using namespace diachron;

namespace {

// One flight line of two 200 x 150 px images per epoch (the default field of view).
SceneOptions scan_test_options() {
  SceneOptions o;
  o.seed = 5;
  for (EpochOptions& e : o.epochs) {
    e.rows = 1;
    e.columns = 2;
    e.image_width_px /= 2;
    e.image_height_px /= 2;
    e.focal_px /= 2.0;
    e.tie_points = 100;
  }
  o.check_points = 30;
  return o;
}

const SceneOptions& options() {
  static const SceneOptions o = scan_test_options();
  return o;
}

const Scene& coarse_scene() {
  static const Scene scene = generate_scene(options());
  return scene;
}

// The coarse scene delivered 3 times larger.
const Scene& scaled_scene() {
  static const Scene scene = [] {
    Scene s = coarse_scene();
    scale_scene_images(s, 3.0);
    return s;
  }();
  return scene;
}

// Pearson correlation of two equally long samples.
double correlation(const std::vector<double>& a, const std::vector<double>& b) {
  double ma = 0.0, mb = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    ma += a[i];
    mb += b[i];
  }
  ma /= static_cast<double>(a.size());
  mb /= static_cast<double>(b.size());
  double sab = 0.0, saa = 0.0, sbb = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    sab += (a[i] - ma) * (b[i] - mb);
    saa += (a[i] - ma) * (a[i] - ma);
    sbb += (b[i] - mb) * (b[i] - mb);
  }
  return sab / std::sqrt(std::max(saa * sbb, 1e-30));
}

}  // namespace

TEST_CASE("FullSizeScan: scale_camera maps every projection to the finer pixel grid") {
  const Camera<FraserAffine> coarse(265.0, 101.5, 72.0, 200, 150, {-0.025, 0.004, 0.001, 2e-4, -1.5e-4, 0.4, -0.2});
  const Camera<FraserAffine> fine = scale_camera(coarse, 7.5);
  CHECK(fine.width() == 1500);
  CHECK(fine.height() == 1125);
  for (const Vec3& p : {Vec3(0.1, -0.2, 1.0), Vec3(-0.3, 0.25, 1.0), Vec3(0.0, 0.0, 2.0), Vec3(0.35, 0.3, 1.2)}) {
    const std::optional<Vec2> a = coarse.project(p), b = fine.project(p);
    REQUIRE(a);
    REQUIRE(b);
    CHECK((*b - (7.5 * (*a + Vec2(0.5, 0.5)) - Vec2(0.5, 0.5))).norm() < 1e-9);
  }
  // Back to the coarse camera.
  const Camera<FraserAffine> back = scale_camera(fine, 1.0 / 7.5);
  CHECK(back.width() == 200);
  CHECK(std::abs(back.cx() - coarse.cx()) < 1e-9);
  CHECK_THROWS_AS(scale_camera(coarse, 1.01), Error);  // 202 x 151.5 px
  CHECK_THROWS_AS(scale_camera(coarse, 0.0), Error);
}

TEST_CASE("FullSizeScan: the scaled truth is exact, tie noise stays in written pixels") {
  const Scene& coarse = coarse_scene();
  const Scene& scene = scaled_scene();
  REQUIRE(!scene.check_points.empty());
  for (std::size_t e = 0; e < scene.epochs.size(); ++e) {
    const SyntheticEpoch& epoch = scene.epochs[e];
    CHECK(epoch.camera.width() == 3 * coarse.epochs[e].camera.width());
    CHECK(epoch.estimated_camera.height() == 3 * coarse.epochs[e].camera.height());
    CHECK(std::abs(epoch.gsd_m - coarse.epochs[e].gsd_m / 3.0) < 1e-12);
    // Estimated poses untouched: they still fit the scaled estimated camera as well as before.
    double coarse_rms = 0.0, fine_rms = 0.0, noise = 0.0;
    int n = 0;
    for (std::size_t t = 0; t < epoch.tie_points.size(); ++t) {
      const TiePoint& tie = epoch.tie_points[t];
      for (std::size_t o = 0; o < tie.observations.size(); ++o) {
        const auto i = static_cast<std::size_t>(tie.observations[o].image);
        const std::optional<Vec2> truth = epoch.world_frame(i).project(tie.world);
        const std::optional<Vec2> fine = epoch.estimated_frame(i).project(tie.epoch);
        const std::optional<Vec2> rough = coarse.epochs[e].estimated_frame(i).project(tie.epoch);
        REQUIRE(truth);
        REQUIRE(fine);
        REQUIRE(rough);
        // The noise drawn at the coarse size is the noise at the written size.
        const Vec2 coarse_noise = coarse.epochs[e].tie_points[t].observations[o].pixel -
                                  *coarse.epochs[e].world_frame(i).project(tie.world);
        CHECK((tie.observations[o].pixel - *truth - coarse_noise).norm() < 1e-9);
        noise += (tie.observations[o].pixel - *truth).squaredNorm();
        const Vec2 true_coarse = *coarse.epochs[e].epoch_frame(i).project(tie.epoch);
        coarse_rms += (*rough - true_coarse).squaredNorm();
        fine_rms += (*fine - *epoch.epoch_frame(i).project(tie.epoch)).squaredNorm();
        ++n;
      }
    }
    REQUIRE(n > 50);
    CHECK(std::sqrt(noise / (2.0 * n)) == Approx(0.3).epsilon(0.2));
    // The SfM's error grows with the pixels: exactly 3 times.
    CHECK(std::sqrt(fine_rms / coarse_rms) == Approx(3.0).epsilon(1e-6));
  }
  for (const CheckPoint& cp : scene.check_points)
    for (const CheckPoint::Observation& ob : cp.observations) {
      const std::optional<Vec2> px =
          scene.epochs[static_cast<std::size_t>(ob.epoch)].world_frame(static_cast<std::size_t>(ob.image)).project(cp.world);
      REQUIRE(px);
      CHECK((*px - ob.pixel).norm() < 1e-6);
    }
}

TEST_CASE("FullSizeScan: the written pixels of the check points show their ground") {
  const Scene& scene = scaled_scene();
  FullSizeScanOptions scan;
  scan.scale = 3.0;
  std::vector<double> errors;
  for (std::size_t e = 0; e < scene.epochs.size(); ++e) {
    const FullSizeEpochRenderer renderer(scene, e, options().epochs[e].look, scan);
    for (std::size_t i = 0; i < scene.epochs[e].images.size(); ++i) {
      std::vector<Vec2> pixels;
      std::vector<Vec3> points;
      for (const CheckPoint& cp : scene.check_points)
        for (const CheckPoint::Observation& ob : cp.observations)
          if (ob.epoch == static_cast<int>(e) && ob.image == static_cast<int>(i)) {
            pixels.push_back(ob.pixel);
            points.push_back(cp.world);
          }
      const std::vector<std::optional<Vec2>> ground = renderer.ground_positions(i, pixels);
      for (std::size_t k = 0; k < pixels.size(); ++k) {
        REQUIRE(ground[k]);
        // In written pixels: the interpolation error next to the ray-cast position.
        errors.push_back((*ground[k] - points[k].head<2>()).norm() / scene.epochs[e].gsd_m);
      }
    }
  }
  REQUIRE(errors.size() >= 40);
  std::sort(errors.begin(), errors.end());
  const double median = errors[errors.size() / 2], worst = errors.back();
  INFO("ground position error, written px: median " << median << ", worst " << worst);
  // Interpolated on open ground: far below a written pixel (the relief is smooth over a coarse
  // pixel). A point next to a depth edge takes the nearest coarse hit, up to half a coarse
  // pixel's diagonal (0.71 * 3 written pixels) away.
  CHECK(median < 0.05);
  CHECK(worst < 0.75 * 3.0);
}

TEST_CASE("FullSizeScan: the same ground shows the same fine texture in both epochs") {
  const Scene& scene = scaled_scene();
  FullSizeScanOptions scan;
  scan.scale = 3.0;
  scan.detail_amplitude = 0.5;
  const FullSizeEpochRenderer r1(scene, 0, options().epochs[0].look, scan);
  const FullSizeEpochRenderer r2(scene, 1, options().epochs[1].look, scan);
  // The check point with the most room around it in epoch 1's first image and one epoch 2 image.
  const std::size_t a_image = 0;
  std::optional<Vec2> a_px, b_px;
  std::size_t b_image = 0;
  for (const CheckPoint& cp : scene.check_points) {
    std::optional<Vec2> a, b;
    std::size_t bi = 0;
    for (const CheckPoint::Observation& ob : cp.observations) {
      if (ob.epoch == 0 && ob.image == static_cast<int>(a_image)) a = ob.pixel;
      if (ob.epoch == 1) {
        b = ob.pixel;
        bi = static_cast<std::size_t>(ob.image);
      }
    }
    const auto inside = [](const Vec2& p, int w, int h) { return p.x() > 40 && p.y() > 40 && p.x() < w - 41 && p.y() < h - 41; };
    if (a && b && inside(*a, r1.width(), r1.height()) && inside(*b, r2.width(), r2.height())) {
      a_px = a;
      b_px = b;
      b_image = bi;
      break;
    }
  }
  REQUIRE(a_px);
  const Raster<std::uint8_t> image1 = r1.render(a_image), image2 = r2.render(b_image);
  // A 31 x 31 window of epoch 1 and the epoch 2 pixels that see the same ground (through the
  // truth: the surface under each epoch 1 pixel projected into epoch 2), sampled bilinearly.
  const SyntheticEpoch& e1 = scene.epochs[0];
  const SyntheticEpoch& e2 = scene.epochs[1];
  const detail::SurfaceTracer tracer(e1.true_surface);
  std::vector<double> va, vb;
  for (int dy = -15; dy <= 15; ++dy)
    for (int dx = -15; dx <= 15; ++dx) {
      const Vec2 p = *a_px + Vec2(dx, dy);
      const std::optional<Ray3> ray = e1.world_frame(a_image).ray(p);
      const std::optional<Vec3> hit = ray ? tracer.intersect(*ray) : std::nullopt;
      if (!hit) continue;
      const std::optional<Vec2> q = e2.world_frame(b_image).project(*hit);
      if (!q || !(q->x() >= 0 && q->y() >= 0 && q->x() < image2.width() - 1 && q->y() < image2.height() - 1)) continue;
      const int qx = static_cast<int>(q->x()), qy = static_cast<int>(q->y());
      const double fx = q->x() - qx, fy = q->y() - qy;
      const double top = image2(qx, qy) + fx * (image2(qx + 1, qy) - image2(qx, qy));
      const double bottom = image2(qx, qy + 1) + fx * (image2(qx + 1, qy + 1) - image2(qx, qy + 1));
      va.push_back(image1(static_cast<int>(std::lround(p.x())), static_cast<int>(std::lround(p.y()))));
      vb.push_back(top + fy * (bottom - top));
    }
  REQUIRE(va.size() > 500);
  const double same_ground = correlation(va, vb);
  // The same window of epoch 2 moved by 6 written pixels: other ground.
  std::vector<double> vc;
  for (std::size_t k = 0; k < va.size(); ++k) vc.push_back(vb[(k + 6) % vb.size()]);
  INFO("correlation on the same ground " << same_ground << ", shifted " << correlation(va, vc));
  CHECK(same_ground > 0.5);
  CHECK(same_ground > correlation(va, vc) + 0.2);
}

TEST_CASE("FullSizeScan: determinism over threads and bands") {
  const Scene& scene = scaled_scene();
  FullSizeScanOptions one;
  one.scale = 3.0;
  one.threads = 1;
  one.band_rows = 8;
  FullSizeScanOptions two = one;
  two.threads = 2;
  two.band_rows = 256;
  // Epoch 1 has scratches and dust; epoch 2 another look. Both epochs, first image.
  for (std::size_t e = 0; e < scene.epochs.size(); ++e) {
    const Raster<std::uint8_t> a = FullSizeEpochRenderer(scene, e, options().epochs[e].look, one).render(0);
    const Raster<std::uint8_t> b = FullSizeEpochRenderer(scene, e, options().epochs[e].look, two).render(0);
    REQUIRE(a.width() == 3 * coarse_scene().epochs[e].camera.width());
    CHECK(std::equal(a.begin(), a.end(), b.begin()));
  }
  // A decades-like film look: clumped grain, S curve, uneven exposure, scanner, JPEG.
  LookOptions film = options().epochs[0].look;
  film.grain_size_px = 1.2;
  film.tone_curve = 6.0;
  film.exposure_unevenness = 0.25;
  film.scan_line_sigma = 0.008;
  film.scan_stripes = 4;
  film.jpeg_quality = 75;
  const Raster<std::uint8_t> a = FullSizeEpochRenderer(scene, 0, film, one).render(1);
  const Raster<std::uint8_t> b = FullSizeEpochRenderer(scene, 0, film, two).render(1);
  CHECK(std::equal(a.begin(), a.end(), b.begin()));
}

TEST_CASE("FullSizeScan: options are checked") {
  FullSizeScanOptions o;
  CHECK_NOTHROW(o.check());
  o.band_rows = 12;
  CHECK_THROWS_AS(o.check(), Error);
  o = FullSizeScanOptions();
  o.scale = 0.5;
  CHECK_THROWS_AS(o.check(), Error);
  o = FullSizeScanOptions();
  o.detail_amplitude = 1.5;
  CHECK_THROWS_AS(o.check(), Error);
  Scene scene = coarse_scene();
  CHECK_THROWS_AS(scale_scene_images(scene, 0.5), Error);
  CHECK_THROWS_AS(FullSizeEpochRenderer(scene, 7, LookOptions(), FullSizeScanOptions()), Error);
}
