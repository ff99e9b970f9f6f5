// Tests of patch_warp.hpp and one_to_one.hpp: the three warps against a known homography (the
// resampled patch equals the directly warped image) and a nonlinear transfer (piecewise affine <
// grid homography < corner homography in max error); one-to-one tiling with stub matchers: matches
// back in image coordinates, the core and displacement rules, masks, skipped tiles with reasons,
// determinism over thread counts.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <vector>

#include <diachron/core/random.hpp>
#include <diachron/geometry/homography.hpp>
#include <diachron/tiling/one_to_one.hpp>

using diachron::PatchWarpKind;
using diachron::PixelRect;
using diachron::PointMatch;
using diachron::Raster;
using Eigen::Vector2d;

namespace {

using Image = Raster<std::uint8_t>;
constexpr PatchWarpKind kKinds[3] = {PatchWarpKind::homography_corners, PatchWarpKind::homography_grid,
                                     PatchWarpKind::piecewise_affine};

// Smooth texture: bilinear interpolation of it is close to the underlying function.
Image smooth_image(int w, int h) {
  Image img(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      img(x, y) = static_cast<std::uint8_t>(std::lround(128.0 + 60.0 * std::sin(x / 11.0) * std::cos(y / 13.0) +
                                                        40.0 * std::sin((x + 2.0 * y) / 29.0)));
  return img;
}

Image tile_noise_image(int w, int h, std::uint64_t seed) {
  diachron::RandomStream rng(seed);
  Image img(w, h);
  for (auto& v : img) v = static_cast<std::uint8_t>(rng.uniform_index(256));
  return img;
}

double bilinear(const Image& img, const Vector2d& q) {
  const int x0 = static_cast<int>(std::floor(q.x())), y0 = static_cast<int>(std::floor(q.y()));
  const double fx = q.x() - x0, fy = q.y() - y0;
  return (1 - fy) * ((1 - fx) * img(x0, y0) + fx * img(x0 + 1, y0)) + fy * ((1 - fx) * img(x0, y0 + 1) + fx * img(x0 + 1, y0 + 1));
}

diachron::Homography2 test_homography() {
  Eigen::Matrix3d m;
  const double s = 1.2, a = 0.3;
  m << s * std::cos(a), -s * std::sin(a), 160.0,  //
      s * std::sin(a), s * std::cos(a), 30.0,     //
      2e-5, -1e-5, 1.0;
  return diachron::Homography2{m};
}

// A similarity: every warp kind reproduces it exactly.
struct Similarity {
  Vector2d operator()(const Vector2d& p) const {
    const double c = 1.5 * std::cos(0.2), s = 1.5 * std::sin(0.2);
    return {c * p.x() - s * p.y() + 150.0, s * p.x() + c * p.y() + 20.0};
  }
};

diachron::OneToOneOptions small_tiles(PatchWarpKind kind = PatchWarpKind::piecewise_affine) {
  diachron::OneToOneOptions o;
  o.tiles = diachron::GridTilerOptions{200, 150, 20, 15};  // core 160 x 120
  o.warp.kind = kind;
  o.threads = 1;
  return o;
}

}  // namespace

TEST_CASE("PatchWarp: every kind reproduces a homography and resamples like the direct warp", "[tiling]") {
  const Image secondary = smooth_image(700, 600);
  const diachron::Homography2 h = test_homography();
  const auto transfer = diachron::make_map_transfer(h);
  const PixelRect rect{50, 40, 200, 160};
  for (const PatchWarpKind kind : kKinds) {
    INFO(diachron::to_string(kind));
    diachron::PatchWarpOptions options;
    options.kind = kind;
    const diachron::PatchWarpFit fit = diachron::fit_patch_warp(transfer, rect, options);
    REQUIRE(fit.success);
    CHECK(fit.failure == diachron::PatchWarpFailure::none);
    CHECK(fit.points == (kind == PatchWarpKind::homography_corners ? 4u : 81u));
    CHECK(fit.transferred == fit.points);
    CHECK(fit.homography_rms_px < 1e-6);
    double max_error = 0.0;
    for (int y = rect.y; y < rect.bottom(); y += 3)
      for (int x = rect.x; x < rect.right(); x += 3)
        max_error = std::max(max_error, (*fit.warp(Vector2d(x, y)) - *h(Vector2d(x, y))).norm());
    // The homography kinds are the homography; piecewise affine is a chord of it (cells of 25 x 20 px).
    CHECK(max_error < (kind == PatchWarpKind::piecewise_affine ? 0.02 : 1e-6));
    const diachron::ResampledPatch<std::uint8_t> patch = diachron::resample_patch(secondary, fit.warp);
    REQUIRE(patch.pixels.width() == rect.width);
    REQUIRE(patch.pixels.height() == rect.height);
    CHECK(patch.valid_pixels == rect.area());  // the homography keeps the rectangle on the image
    int worst = 0;
    std::size_t masked = 0;
    for (int v = 0; v < rect.height; ++v)
      for (int u = 0; u < rect.width; ++u) {
        const double direct = bilinear(secondary, *h(Vector2d(rect.x + u, rect.y + v)));
        worst = std::max(worst, static_cast<int>(std::abs(patch.pixels(u, v) - direct) + 0.5));
        masked += patch.mask(u, v) == 255 ? 0 : 1;
      }
    CHECK(masked == 0u);
    CHECK(worst <= 1);  // rounding, and for piecewise affine its < 0.02 px offset
  }
}

TEST_CASE("PatchWarp: on a nonlinear transfer the grid fit beats the corners and piecewise affine beats both",
          "[tiling]") {
  const diachron::Homography2 h = test_homography();
  const auto bent = [h](const Vector2d& p) -> std::optional<Vector2d> {
    std::optional<Vector2d> q = h(p);
    if (!q) return q;
    const double dx = p.x() - 200.0, dy = p.y() - 150.0;
    return Vector2d(q->x() + 2e-4 * dx * dx, q->y() + 1.5e-4 * dx * dy);
  };
  const auto transfer = diachron::make_map_transfer(bent);
  const PixelRect rect{0, 0, 400, 300};
  double error[3] = {0.0, 0.0, 0.0};
  for (int k = 0; k < 3; ++k) {
    diachron::PatchWarpOptions options;
    options.kind = kKinds[k];
    const diachron::PatchWarpFit fit = diachron::fit_patch_warp(transfer, rect, options);
    REQUIRE(fit.success);
    for (int y = 0; y < rect.height; y += 2)
      for (int x = 0; x < rect.width; x += 2)
        error[k] = std::max(error[k], (*fit.warp(Vector2d(x, y)) - *bent(Vector2d(x, y))).norm());
  }
  INFO("max error corners " << error[0] << ", grid " << error[1] << ", piecewise affine " << error[2]);
  CHECK(error[0] > 2.0);  // the quadratic bends the middle by 8 px
  CHECK(error[1] < 0.8 * error[0]);
  CHECK(error[2] < 0.2);  // h^2 / 4 times the curvature on 50 px cells
  CHECK(error[2] < 0.1 * error[1]);
  // A denser grid follows it closer still.
  diachron::PatchWarpOptions dense;
  dense.grid_points = 17;
  const diachron::PatchWarpFit fine = diachron::fit_patch_warp(transfer, rect, dense);
  double fine_error = 0.0;
  for (int y = 0; y < rect.height; y += 2)
    for (int x = 0; x < rect.width; x += 2)
      fine_error = std::max(fine_error, (*fine.warp(Vector2d(x, y)) - *bent(Vector2d(x, y))).norm());
  CHECK(fine_error < 0.5 * error[2]);
}

TEST_CASE("PatchWarp: nodes that do not transfer are skipped or fail the fit with the reason", "[tiling]") {
  const diachron::Homography2 h = test_homography();
  // No transfer left of x = 100.
  const auto holed = diachron::make_map_transfer([h](const Vector2d& p) -> std::optional<Vector2d> {
    if (p.x() < 100.0) return std::nullopt;
    return h(p);
  });
  const PixelRect rect{0, 0, 401, 301};  // nodes every 50 x 37.5 px
  diachron::PatchWarpOptions options;
  const diachron::PatchWarpFit piecewise = diachron::fit_patch_warp(holed, rect, options);
  REQUIRE(piecewise.success);
  CHECK(piecewise.transferred == 81u - 2u * 9u);  // columns x = 0 and x = 50 are missing
  // The missing nodes take the grid homography's value, which is the homography here.
  CHECK((piecewise.warp.node_secondary(0, 0) - *h(Vector2d(0.0, 0.0))).norm() < 1e-6);
  CHECK((piecewise.warp.node_secondary(1, 4) - *h(piecewise.warp.node_master(1, 4))).norm() < 1e-6);
  CHECK((*piecewise.warp(Vector2d(10.0, 10.0)) - *h(Vector2d(10.0, 10.0))).norm() < 0.05);
  options.kind = PatchWarpKind::homography_corners;
  const diachron::PatchWarpFit corners = diachron::fit_patch_warp(holed, rect, options);
  CHECK_FALSE(corners.success);
  CHECK(corners.failure == diachron::PatchWarpFailure::corner_not_transferred);
  CHECK(corners.message.find("2 of 4 transferred") != std::string::npos);
  options.kind = PatchWarpKind::homography_grid;
  const diachron::PatchWarpFit none = diachron::fit_patch_warp(holed, PixelRect{0, 0, 90, 90}, options);
  CHECK_FALSE(none.success);
  CHECK(none.failure == diachron::PatchWarpFailure::too_few_points);
  CHECK_FALSE(none.warp(Vector2d(1.0, 1.0)));  // an empty warp maps nothing
  CHECK_THROWS_AS(diachron::resample_patch(smooth_image(10, 10), none.warp), diachron::Error);
  options.grid_points = 1;
  CHECK_THROWS_WITH(diachron::fit_patch_warp(holed, rect, options), Catch::Contains("grid_points"));
}

TEST_CASE("match_one_to_one: matches come back in image coordinates; core, displacement and patch rules",
          "[tiling]") {
  const Image master = tile_noise_image(600, 450, 1);
  const Image secondary = smooth_image(1100, 900);
  const Similarity similarity;
  const auto transfer = diachron::make_map_transfer(similarity);
  // The same four matches in every tile, in tile (= aligned patch) pixels.
  const std::vector<PointMatch> fixed = {
      {Vector2d(50.0, 40.0), Vector2d(50.5, 40.25), 1.0},    // kept (the tile core starts <= 20 px in)
      {Vector2d(5.0, 5.0), Vector2d(5.0, 5.0), 2.0},         // outside the core unless at the image's top left
      {Vector2d(100.0, 80.0), Vector2d(220.0, 80.0), 3.0},   // displaced by 120 px > 100
      {Vector2d(60.0, 60.0), Vector2d(-30.0, 60.0), 4.0}};   // patch point off the patch
  const auto stub = diachron::make_pair_matcher([&](const Image&, const Image&) { return fixed; });
  for (const PatchWarpKind kind : kKinds) {
    INFO(diachron::to_string(kind));
    const diachron::OneToOneResult r = diachron::match_one_to_one(master, secondary, transfer, stub, small_tiles(kind));
    REQUIRE(r.tiles.size() == 16u);
    CHECK(r.tiles_matched == 16u);
    CHECK(r.tiles_skipped == 0u);
    std::size_t expected_kept = 0;
    for (const diachron::OneToOneTileReport& t : r.tiles) {
      CHECK(t.matched());
      CHECK(t.reason.empty());
      CHECK(t.raw == 4u);
      const Vector2d origin(t.tile.buffered.x, t.tile.buffered.y);
      const bool second_in_core = t.tile.core.contains(Vector2d(fixed[1].a + origin));
      CHECK(t.outside_core == (second_in_core ? 0u : 1u));
      CHECK(t.displaced == 1u);
      CHECK(t.off_patch == 1u);
      CHECK(t.kept == (second_in_core ? 2u : 1u));
      CHECK(t.raw == t.outside_core + t.displaced + t.off_patch + t.kept);
      expected_kept += t.kept;
    }
    REQUIRE(r.matches.size() == expected_kept);
    REQUIRE(r.match_tile.size() == r.matches.size());
    CHECK(r.kept == expected_kept);
    CHECK(r.success);
    for (std::size_t k = 0; k < r.matches.size(); ++k) {
      const diachron::Tile& tile = r.tiles[r.match_tile[k]].tile;
      const Vector2d origin(tile.buffered.x, tile.buffered.y);
      const PointMatch& m = r.matches[k];
      const PointMatch& source = m.score == 1.0 ? fixed[0] : fixed[1];
      CHECK((m.a - (source.a + origin)).norm() == 0.0);
      CHECK((m.b - similarity(source.b + origin)).norm() < 1e-6);
      CHECK(tile.core.contains(m.a));
    }
    // Tile order: match_tile never decreases.
    CHECK(std::is_sorted(r.match_tile.begin(), r.match_tile.end()));
  }
  // A looser displacement bound keeps the displaced match.
  diachron::OneToOneOptions loose = small_tiles();
  loose.max_displacement_px = 150.0;
  const auto r = diachron::match_one_to_one(master, secondary, transfer, stub, loose);
  CHECK(r.displaced == 0u);
  loose.max_displacement_px = 0.0;
  CHECK_THROWS_WITH(diachron::match_one_to_one(master, secondary, transfer, stub, loose),
                    Catch::Contains("max_displacement_px"));
}

TEST_CASE("match_one_to_one: a content matcher gives the same output on 1 and 4 threads, with progress",
          "[tiling]") {
  const Image master = tile_noise_image(600, 450, 2);
  const Image secondary = tile_noise_image(1100, 900, 3);
  const auto transfer = diachron::make_map_transfer(Similarity{});
  // Matches the brightest pixel of each 20 x 20 block of a with the brightest of the same block of b.
  const auto matcher = diachron::make_pair_matcher([](const Image& a, const Image& b) {
    std::vector<PointMatch> out;
    for (int by = 0; by + 20 <= a.height(); by += 20)
      for (int bx = 0; bx + 20 <= a.width(); bx += 20) {
        Vector2d pa(bx, by), pb(bx, by);
        int va = -1, vb = -1;
        for (int y = by; y < by + 20; ++y)
          for (int x = bx; x < bx + 20; ++x) {
            if (a(x, y) > va) va = a(x, y), pa = Vector2d(x, y);
            if (b(x, y) > vb) vb = b(x, y), pb = Vector2d(x, y);
          }
        out.push_back({pa, pb, static_cast<double>(va)});
      }
    return out;
  });
  diachron::OneToOneOptions options = small_tiles();
  std::size_t events = 0, last_done = 0;
  options.progress = [&](const diachron::ProgressEvent& e) {
    ++events;
    last_done = e.done;
  };
  const auto one = diachron::match_one_to_one(master, secondary, transfer, matcher, options);
  CHECK(events == 17u);  // the start, then one per tile
  CHECK(last_done == 16u);
  options.threads = 4;
  options.progress = nullptr;
  const auto four = diachron::match_one_to_one(master, secondary, transfer, matcher, options);
  REQUIRE(one.kept > 100u);
  REQUIRE(one.matches.size() == four.matches.size());
  for (std::size_t k = 0; k < one.matches.size(); ++k) {
    CHECK(one.matches[k].a == four.matches[k].a);
    CHECK(one.matches[k].b == four.matches[k].b);
    CHECK(one.match_tile[k] == four.match_tile[k]);
  }
}

TEST_CASE("match_one_to_one: tiles without transfer or off the secondary image are skipped with their reason",
          "[tiling]") {
  const Image master = tile_noise_image(600, 450, 4);
  const Image secondary = smooth_image(400, 400);
  const Similarity similarity;
  // No transfer right of x = 300; the similarity leaves the small secondary image lower down.
  const auto transfer = diachron::make_map_transfer([&](const Vector2d& p) -> std::optional<Vector2d> {
    if (p.x() > 300.0) return std::nullopt;
    return similarity(p);
  });
  std::size_t masked_calls = 0;
  std::vector<std::size_t> invalid_pixels;
  const auto matcher = diachron::make_pair_matcher(
      [&](const Image&, const Image&, const Image& mask_a, const Image& mask_b) {
        CHECK(std::all_of(mask_a.begin(), mask_a.end(), [](std::uint8_t v) { return v == 255; }));
        ++masked_calls;
        invalid_pixels.push_back(static_cast<std::size_t>(std::count(mask_b.begin(), mask_b.end(), 0)));
        return std::vector<PointMatch>{};
      });
  for (const PatchWarpKind kind : kKinds) {
    INFO(diachron::to_string(kind));
    masked_calls = 0;
    invalid_pixels.clear();
    const auto r = diachron::match_one_to_one(master, secondary, transfer, matcher, small_tiles(kind));
    REQUIRE(r.tiles.size() == 16u);
    CHECK_FALSE(r.success);
    CHECK(r.kept == 0u);
    std::size_t no_transfer = 0, off = 0;
    for (const diachron::OneToOneTileReport& t : r.tiles) {
      if (t.tile.buffered.x > 300) {
        // Every node lies right of x = 300.
        CHECK(t.skip == diachron::OneToOneSkip::warp_failed);
        CHECK(t.transferred == 0u);
        CHECK(t.reason.find(kind == PatchWarpKind::homography_corners ? "corner" : "too few grid points") !=
              std::string::npos);
        ++no_transfer;
      }
      if (t.skip == diachron::OneToOneSkip::off_secondary) {
        CHECK(t.reason.find("pixels resampled") != std::string::npos);
        ++off;
      }
    }
    CHECK(no_transfer == 4u);  // the last column (buffered x from 460)
    CHECK(off > 0u);           // the bottom rows map below the 400 px secondary image
    CHECK(r.tiles_skipped >= no_transfer + off);
    CHECK(masked_calls == r.tiles_matched);
    CHECK(masked_calls > 0u);
    // Partly covered patches arrive with their invalid pixels masked.
    CHECK(*std::max_element(invalid_pixels.begin(), invalid_pixels.end()) > 0u);
  }
}
