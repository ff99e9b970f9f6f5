// Tests for validation/ncc_validator.hpp: NCC through the local affine of a Transfer, and the
// sub-pixel refinement. Images are drawn from a continuous texture, so the truth of every match is
// known to rounding (no OpenCV needed).

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include <catch2/catch.hpp>
#include <Eigen/Geometry>

#include <diachron/core/random.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/core/types.hpp>
#include <diachron/terrain/transfer.hpp>
#include <diachron/validation/ncc_validator.hpp>

using diachron::NccOptions;
using diachron::NccOutcome;
using diachron::NccRefineStatus;
using diachron::NccResult;
using diachron::PointMatch;
using diachron::PointMatches;
using diachron::Raster;

namespace {

// A smooth random texture: sinusoids with wavelengths of 7 to 40 px in random directions, plus
// Gaussian blobs, so every 32 px window has structure and none repeats.
struct Texture {
  struct Wave {
    Eigen::Vector2d k;
    double phase, amplitude;
  };
  struct Blob {
    Eigen::Vector2d centre;
    double sigma, amplitude;
  };
  std::vector<Wave> waves;
  std::vector<Blob> blobs;

  explicit Texture(std::uint64_t seed) {
    diachron::RandomStream rng(seed);
    for (int i = 0; i < 24; ++i) {
      const double wavelength = rng.uniform(7.0, 40.0), angle = rng.uniform(0.0, 2.0 * diachron::kPi);
      waves.push_back({2.0 * diachron::kPi / wavelength * Eigen::Vector2d(std::cos(angle), std::sin(angle)),
                       rng.uniform(0.0, 2.0 * diachron::kPi), rng.uniform(0.5, 1.0)});
    }
    // One draw per statement where a call has several, y before x: the order of a call's arguments
    // is unspecified (core/random.hpp, "Order of draws"). A braced list draws left to right.
    for (int i = 0; i < 150; ++i) {
      const double cy = rng.uniform(-100.0, 500.0);
      blobs.push_back({Eigen::Vector2d(rng.uniform(-100.0, 500.0), cy), rng.uniform(2.0, 6.0), rng.uniform(-3.0, 3.0)});
    }
  }
  double operator()(const Eigen::Vector2d& p) const {
    double v = 0.0;
    for (const Wave& w : waves) v += w.amplitude * std::sin(w.k.dot(p) + w.phase);
    for (const Blob& b : blobs) {
      const double d2 = (p - b.centre).squaredNorm();
      if (d2 < 50.0 * b.sigma * b.sigma) v += b.amplitude * std::exp(-0.5 * d2 / (b.sigma * b.sigma));
    }
    return 128.0 + 14.0 * v;
  }
};

// The image of `texture` seen through `from_pixel` (image pixel -> texture point), 8-bit.
template <class F>
Raster<std::uint8_t> render(const Texture& texture, int w, int h, const F& from_pixel) {
  Raster<std::uint8_t> img(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double v = texture(from_pixel(Eigen::Vector2d(x, y)));
      img(x, y) = static_cast<std::uint8_t>(std::clamp(std::lround(v), 0L, 255L));
    }
  return img;
}

// secondary = L master + t: scale 1.15, rotation 0.35 rad, a little shear.
struct Affine {
  Eigen::Matrix2d linear;
  Eigen::Vector2d translation{31.3, -12.6};
  Affine() {
    Eigen::Matrix2d shear;
    shear << 1.0, 0.06, 0.0, 0.97;
    linear = 1.15 * Eigen::Rotation2Dd(0.35).toRotationMatrix() * shear;
  }
  Eigen::Vector2d operator()(const Eigen::Vector2d& p) const { return linear * p + translation; }
  Eigen::Vector2d inverse(const Eigen::Vector2d& q) const { return linear.inverse() * (q - translation); }
};

// Straightforward oracle: bilinear with explicit corner weights, sums in long double.
double oracle_ncc(const Raster<std::uint8_t>& m, const Eigen::Vector2d& a, const Raster<std::uint8_t>& s,
                  const Eigen::Vector2d& b, const Eigen::Matrix2d& affine, int window) {
  const auto bilinear = [](const Raster<std::uint8_t>& img, const Eigen::Vector2d& p) {
    const int x0 = std::min(static_cast<int>(std::floor(p.x())), img.width() - 2);
    const int y0 = std::min(static_cast<int>(std::floor(p.y())), img.height() - 2);
    const double fx = p.x() - x0, fy = p.y() - y0;
    return (1 - fx) * (1 - fy) * img(x0, y0) + fx * (1 - fy) * img(x0 + 1, y0) + (1 - fx) * fy * img(x0, y0 + 1) +
           fx * fy * img(x0 + 1, y0 + 1);
  };
  long double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
  const int n = window * window;
  for (int j = -window / 2; j < window - window / 2; ++j)
    for (int i = -window / 2; i < window - window / 2; ++i) {
      const Eigen::Vector2d o(i, j);
      const long double va = bilinear(m, a + o), vb = bilinear(s, b + affine * o);
      sa += va;
      sb += vb;
      saa += va * va;
      sbb += vb * vb;
      sab += va * vb;
    }
  const long double cab = sab - sa * sb / n, caa = saa - sa * sa / n, cbb = sbb - sb * sb / n;
  return static_cast<double>(cab / std::sqrt(caa * cbb));
}

struct Pair {
  Texture texture{42};
  Affine truth;
  Raster<std::uint8_t> master, secondary;
  Pair() {
    master = render(texture, 260, 260, [](const Eigen::Vector2d& p) { return p; });
    secondary = render(texture, 380, 380, [&](const Eigen::Vector2d& q) { return truth.inverse(q); });
  }
  // Master points on a grid whose windows and transferred windows fit both images.
  std::vector<Eigen::Vector2d> points(std::uint64_t seed, double jitter = 0.5) const {
    diachron::RandomStream rng(seed);
    std::vector<Eigen::Vector2d> out;
    for (double y = 30.0; y <= 230.0; y += 20.0)
      for (double x = 30.0; x <= 230.0; x += 20.0) {
        const double dy = rng.uniform(-jitter, jitter);  // y before x, see Texture
        const Eigen::Vector2d a(x + rng.uniform(-jitter, jitter), y + dy);
        const Eigen::Vector2d b = truth(a);
        if (b.minCoeff() > 40.0 && b.x() < 340.0 && b.y() < 340.0) out.push_back(a);
      }
    return out;
  }
};

const auto identity_map = [](const Eigen::Vector2d& p) { return p; };

}  // namespace

TEST_CASE("NccValidator: identical windows give 1, an inverted one -1", "[validation]") {
  const Texture texture(3);
  const Raster<std::uint8_t> img = render(texture, 120, 120, identity_map);
  Raster<std::uint8_t> inverted(120, 120);
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 120; ++x) inverted(x, y) = static_cast<std::uint8_t>(255 - img(x, y));
  const auto transfer = diachron::make_map_transfer(identity_map);
  const PointMatches matches{{{60.0, 60.0}, {60.0, 60.0}, 0.0}, {{50.3, 61.7}, {50.3, 61.7}, 0.0}};

  const NccResult same = diachron::ncc_validate(img, img, matches, transfer);
  REQUIRE(same.size() == 2);
  for (std::size_t i = 0; i < 2; ++i) {
    CHECK(same.score[i] == Approx(1.0).margin(1e-12));
    CHECK(same.keep[i] == 1);
    CHECK(same.outcome[i] == NccOutcome::kept);
  }
  const NccResult inv = diachron::ncc_validate(img, inverted, matches, transfer);
  for (std::size_t i = 0; i < 2; ++i) {
    CHECK(inv.score[i] == Approx(-1.0).margin(1e-12));
    CHECK(inv.keep[i] == 0);
    CHECK(inv.outcome[i] == NccOutcome::below_threshold);
  }
  CHECK(inv.below_threshold == 2);
  CHECK(inv.kept() == 0);
}

TEST_CASE("NccValidator: agrees with a brute-force oracle through the local affine", "[validation]") {
  const Pair pair;
  const auto transfer = diachron::make_map_transfer(pair.truth);
  diachron::RandomStream rng(8);
  PointMatches matches;
  for (const Eigen::Vector2d& a : pair.points(2)) {
    // Off by up to 3 px: the NCC must be the one at b, whatever the transfer predicts.
    const double dy = rng.uniform(-3, 3);  // y before x, see Texture
    matches.push_back({a, pair.truth(a) + Eigen::Vector2d(rng.uniform(-3, 3), dy), 0.0});
  }
  REQUIRE(matches.size() > 50);
  NccOptions options;
  options.min_ncc = 0.5;
  const NccResult r = diachron::ncc_validate(pair.master, pair.secondary, matches, transfer, options);
  std::size_t low = 0;
  for (std::size_t i = 0; i < matches.size(); ++i) {
    INFO("match " << i);
    const double expected =
        oracle_ncc(pair.master, matches[i].a, pair.secondary, matches[i].b, pair.truth.linear, 32);
    CHECK(r.score[i] == Approx(expected).margin(1e-9));
    CHECK(static_cast<bool>(r.keep[i]) == (r.score[i] >= 0.5));
    low += r.score[i] < 0.5;
    // The validator's affine comes from central differences, equal to the linear part up to rounding.
    CHECK(diachron::ncc_window(pair.master, matches[i].a, pair.secondary, matches[i].b, pair.truth.linear).ncc ==
          Approx(r.score[i]).margin(1e-12));
  }
  CHECK(low > 0);  // 3 px off at wavelengths from 7 px: some fall below
  CHECK(low < matches.size());
  CHECK(r.below_threshold == low);
}

TEST_CASE("NccValidator: windows outside an image, flat windows, no affine", "[validation]") {
  const Texture texture(5);
  const Raster<std::uint8_t> img = render(texture, 100, 80, identity_map);
  const Raster<std::uint8_t> flat(100, 80, 77);
  // No transfer west of x = 30.
  const auto transfer = diachron::make_map_transfer([](const Eigen::Vector2d& p) -> std::optional<Eigen::Vector2d> {
    if (p.x() < 30.0) return std::nullopt;
    return p;
  });
  const PointMatches matches{
      {{16.0, 40.0}, {50.0, 40.0}, 0.0},  // window [0, 31]: inside, but no transfer at x = 16
      {{50.0, 16.0}, {50.0, 16.0}, 0.0},  // [0, 31] x [0, 31]: just inside both
      {{50.0, 15.9}, {50.0, 40.0}, 0.0},  // master window starts at y = -0.1
      {{50.0, 40.0}, {84.0, 40.0}, 0.0},  // secondary window ends at x = 99: just inside
      {{50.0, 40.0}, {84.1, 40.0}, 0.0},  // ends at x = 99.1
      {{50.0, 40.0}, {50.0, 64.5}, 0.0},  // bottom row at y = 79.5
  };
  const NccResult r = diachron::ncc_validate(img, img, matches, transfer);
  REQUIRE(r.size() == matches.size());
  CHECK(r.outcome[0] == NccOutcome::no_affine);
  CHECK(r.outcome[1] == NccOutcome::kept);
  CHECK(r.score[1] == Approx(1.0).margin(1e-12));
  CHECK(r.outcome[2] == NccOutcome::outside_master);
  CHECK(std::isfinite(r.score[3]));
  CHECK(r.outcome[4] == NccOutcome::outside_secondary);
  CHECK(r.outcome[5] == NccOutcome::outside_secondary);
  for (std::size_t i : {0, 2, 4, 5}) {
    CHECK(std::isnan(r.score[i]));
    CHECK(r.keep[i] == 0);
  }
  CHECK(r.no_affine == 1);
  CHECK(r.outside_master == 1);
  CHECK(r.outside_secondary == 2);

  const NccResult f = diachron::ncc_validate(img, flat, PointMatches{{{50.0, 40.0}, {50.3, 40.2}, 0.0}}, transfer);
  CHECK(f.outcome[0] == NccOutcome::flat);
  CHECK(std::isnan(f.score[0]));
  CHECK(f.keep[0] == 0);
  CHECK(f.flat == 1);

  Raster<float> holes(100, 80, 1.0f), textured_f(100, 80);
  for (int y = 0; y < 80; ++y)
    for (int x = 0; x < 100; ++x) textured_f(x, y) = static_cast<float>(img(x, y));
  holes(50, 40) = std::nanf("");
  const NccResult h = diachron::ncc_validate(textured_f, holes, PointMatches{{{50.0, 40.0}, {50.0, 40.0}, 0.0}}, transfer);
  CHECK(h.outcome[0] == NccOutcome::not_finite);
  CHECK(h.not_finite == 1);
}

TEST_CASE("NccValidator: refinement brings sub-pixel errors below 0.05 px", "[validation]") {
  const Pair pair;
  const auto transfer = diachron::make_map_transfer(pair.truth);
  diachron::RandomStream rng(21);
  PointMatches matches;
  for (const Eigen::Vector2d& a : pair.points(4)) {
    const double angle = rng.uniform(0.0, 2.0 * diachron::kPi), r = rng.uniform(0.3, 0.7);
    matches.push_back({a, pair.truth(a) + r * Eigen::Vector2d(std::cos(angle), std::sin(angle)), 0.0});
  }
  REQUIRE(matches.size() > 50);

  for (const auto method : {diachron::NccRefineMethod::lsm, diachron::NccRefineMethod::ncc_peak}) {
    NccOptions options;
    options.refine = true;
    options.refinement.method = method;
    options.refinement.fallback_to_ncc_peak = false;
    const NccResult r = diachron::ncc_validate(pair.master, pair.secondary, matches, transfer, options);
    REQUIRE(r.refinement.size() == matches.size());
    REQUIRE(r.kept() == matches.size());
    double worst_before = 0.0, worst_after = 0.0, sum_after = 0.0;
    for (std::size_t i = 0; i < matches.size(); ++i) {
      INFO("match " << i);
      const auto& ref = r.refinement[i];
      REQUIRE(ref.applied());
      const Eigen::Vector2d truth = pair.truth(matches[i].a);
      const double before = (matches[i].b - truth).norm(), after = (ref.b - truth).norm();
      worst_before = std::max(worst_before, before);
      worst_after = std::max(worst_after, after);
      sum_after += after;
      CHECK(ref.moved_px == Approx((ref.b - matches[i].b).norm()));
      CHECK(ref.ncc > r.score[i]);
    }
    const double mean_after = sum_after / static_cast<double>(matches.size());
    INFO("method " << static_cast<int>(method) << ": worst " << worst_before << " -> " << worst_after << " px, mean "
                   << mean_after);
    CHECK(worst_before > 0.6);
    if (method == diachron::NccRefineMethod::lsm) {
      CHECK(r.refined_lsm == matches.size());
      CHECK(worst_after < 0.05);
      CHECK(mean_after < 0.02);
    } else {
      CHECK(r.refined_ncc_peak == matches.size());
      CHECK(worst_after < 0.1);  // the NCC peak is the coarser fallback
    }
  }
}

TEST_CASE("NccValidator: a refinement moving too far is rejected and the input kept", "[validation]") {
  const Pair pair;
  const auto transfer = diachron::make_map_transfer(pair.truth);
  const std::vector<Eigen::Vector2d> points = pair.points(6);
  PointMatches matches;
  for (std::size_t i = 0; i < 10; ++i) matches.push_back({points[i], pair.truth(points[i]) + Eigen::Vector2d(0.5, 0.0), 0.0});
  NccOptions options;
  options.refine = true;
  options.refinement.max_move_px = 0.2;
  const NccResult r = diachron::ncc_validate(pair.master, pair.secondary, matches, transfer, options);
  REQUIRE(r.kept() == 10);
  CHECK(r.refine_rejected_move == 10);
  for (std::size_t i = 0; i < 10; ++i) {
    const auto& ref = r.refinement[i];
    CHECK(ref.status == NccRefineStatus::rejected_move);
    CHECK_FALSE(ref.applied());
    CHECK(ref.b == matches[i].b);
    CHECK(ref.moved_px == Approx(0.5).margin(0.05));
    CHECK(ref.converged);
  }
  // Not kept, not refined.
  options.min_ncc = 1.0;
  const NccResult none = diachron::ncc_validate(pair.master, pair.secondary, matches, transfer, options);
  CHECK(none.kept() == 0);
  for (std::size_t i = 0; i < 10; ++i) {
    CHECK(none.refinement[i].status == NccRefineStatus::not_run);
    CHECK(none.refinement[i].b == matches[i].b);
  }
}

TEST_CASE("NccValidator: deterministic whatever the threads", "[validation]") {
  const Pair pair;
  const auto transfer = diachron::make_map_transfer(pair.truth);
  diachron::RandomStream rng(13);
  PointMatches matches;
  for (int rep = 0; rep < 2; ++rep)
    for (const Eigen::Vector2d& a : pair.points(7 + rep)) {
      const double dy = rng.uniform(-6, 6);  // y before x, see Texture
      matches.push_back({a, pair.truth(a) + Eigen::Vector2d(rng.uniform(-6, 6), dy), 0.0});
    }
  NccOptions options;
  options.refine = true;
  options.threads = 1;
  const NccResult one = diachron::ncc_validate(pair.master, pair.secondary, matches, transfer, options);
  options.threads = 4;
  const NccResult four = diachron::ncc_validate(pair.master, pair.secondary, matches, transfer, options);
  REQUIRE(matches.size() > 64);  // more than one chunk
  CHECK(one.keep == four.keep);
  CHECK(one.outcome == four.outcome);
  for (std::size_t i = 0; i < matches.size(); ++i) {
    CHECK((one.score[i] == four.score[i] || (std::isnan(one.score[i]) && std::isnan(four.score[i]))));
    CHECK(one.refinement[i].status == four.refinement[i].status);
    CHECK(one.refinement[i].b == four.refinement[i].b);
  }
  CHECK(one.kept() > 0);
  CHECK(one.below_threshold > 0);
}

TEST_CASE("NccValidator: Options and invalid input", "[validation]") {
  const NccOptions defaults;
  CHECK(defaults.window_px == 32);
  CHECK(defaults.min_ncc == 0.6);
  CHECK_FALSE(defaults.refine);
  CHECK(defaults.refinement.max_move_px == 2.0);
  CHECK_NOTHROW(defaults.check());

  NccOptions o;
  o.window_px = 2;
  CHECK_THROWS_WITH(o.check(), Catch::Contains("window_px"));
  o = {};
  o.min_ncc = 1.5;
  CHECK_THROWS_WITH(o.check(), Catch::Contains("min_ncc"));
  o = {};
  o.affine_step_px = 0.0;
  CHECK_THROWS_WITH(o.check(), Catch::Contains("affine_step_px"));
  o = {};
  o.refinement.max_move_px = -1.0;
  CHECK_THROWS_WITH(o.check(), Catch::Contains("max_move_px"));
  o = {};
  o.refinement.max_iterations = 0;
  CHECK_THROWS_WITH(o.check(), Catch::Contains("max_iterations"));

  const Raster<std::uint8_t> img(50, 50, 1), tiny(1, 50, 1);
  const auto transfer = diachron::make_map_transfer(identity_map);
  PointMatches matches{{{25.0, 25.0}, {25.0, 25.0}, 0.0}};
  CHECK_THROWS_WITH(diachron::ncc_validate(tiny, img, matches, transfer), Catch::Contains("master"));
  CHECK_THROWS_WITH(diachron::ncc_validate(img, tiny, matches, transfer), Catch::Contains("secondary"));
  matches[0].a.y() = std::nan("");
  CHECK_THROWS_WITH(diachron::ncc_validate(img, img, matches, transfer), Catch::Contains("match 0"));
  CHECK(diachron::ncc_validate(img, img, PointMatches{}, transfer).size() == 0);
  const NccResult fresh;
  CHECK(fresh.size() == 0);
  CHECK(fresh.refinement.empty());
}
