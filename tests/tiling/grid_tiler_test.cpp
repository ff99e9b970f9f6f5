#include <catch2/catch.hpp>

#include <algorithm>
#include <limits>
#include <vector>

#include <diachron/core/random.hpp>
#include <diachron/tiling/grid_tiler.hpp>

using diachron::GridTiler;
using diachron::GridTilerOptions;
using diachron::PixelRect;
using diachron::Tile;

namespace {

// Checks every invariant of a tiling of a w x h image; returns the number of tiles.
std::size_t check_tiling(const GridTiler& tiler, int w, int h) {
  const auto& o = tiler.options();
  const std::vector<Tile> tiles = tiler.tiles(w, h);
  const PixelRect image{0, 0, w, h};
  REQUIRE(tiles.size() == static_cast<std::size_t>(tiler.columns(w)) * tiler.rows(h));
  std::vector<int> owner_count(static_cast<std::size_t>(w) * h, 0);
  for (std::size_t i = 0; i < tiles.size(); ++i) {
    const Tile& t = tiles[i];
    REQUIRE(t.index == i);
    REQUIRE(t.index == static_cast<std::size_t>(t.row) * tiler.columns(w) + t.column);
    // No empty tile, everything inside the image, core inside the buffered rectangle.
    REQUIRE(!t.core.empty());
    REQUIRE(t.core.intersect(image) == t.core);
    REQUIRE(t.buffered.intersect(image) == t.buffered);
    REQUIRE(t.buffered.intersect(t.core) == t.core);
    REQUIRE(t.core.width <= o.core_width());
    REQUIRE(t.core.height <= o.core_height());
    REQUIRE(t.buffered.width <= o.tile_width);
    REQUIRE(t.buffered.height <= o.tile_height);
    // MicMac's origin m * core - buffer, clipped: the buffer reaches as far as the image allows.
    REQUIRE(t.core.x == t.column * o.core_width());
    REQUIRE(t.core.y == t.row * o.core_height());
    REQUIRE(t.buffered.x == std::max(0, t.core.x - o.buffer_x));
    REQUIRE(t.buffered.y == std::max(0, t.core.y - o.buffer_y));
    REQUIRE(t.buffered.right() == std::min(w, t.core.x - o.buffer_x + o.tile_width));
    REQUIRE(t.buffered.bottom() == std::min(h, t.core.y - o.buffer_y + o.tile_height));
    for (int y = t.core.y; y < t.core.bottom(); ++y)
      for (int x = t.core.x; x < t.core.right(); ++x) ++owner_count[static_cast<std::size_t>(y) * w + x];
  }
  for (int c : owner_count) REQUIRE(c == 1);
  return tiles.size();
}

}  // namespace

TEST_CASE("GridTiler: every pixel of random image sizes is in exactly one tile core", "[tiling]") {
  diachron::RandomStream rng(7);
  for (int trial = 0; trial < 200; ++trial) {
    GridTilerOptions o;
    o.buffer_x = static_cast<int>(rng.uniform_index(6));
    o.buffer_y = static_cast<int>(rng.uniform_index(6));
    o.tile_width = 2 * o.buffer_x + 1 + static_cast<int>(rng.uniform_index(20));
    o.tile_height = 2 * o.buffer_y + 1 + static_cast<int>(rng.uniform_index(20));
    const GridTiler tiler(o);
    const int w = 1 + static_cast<int>(rng.uniform_index(90));
    const int h = 1 + static_cast<int>(rng.uniform_index(90));
    INFO("tile " << o.tile_width << "x" << o.tile_height << " buffer " << o.buffer_x << "x"
                 << o.buffer_y << " image " << w << "x" << h);
    const std::size_t n = check_tiling(tiler, w, h);
    // ceil(Img / Core) per axis (MicMac's Guided count).
    const std::size_t nx = static_cast<std::size_t>((w + o.core_width() - 1) / o.core_width());
    const std::size_t ny = static_cast<std::size_t>((h + o.core_height() - 1) / o.core_height());
    REQUIRE(n == nx * ny);
  }
}

TEST_CASE("GridTiler: buffers are clipped at the image borders", "[tiling]") {
  const GridTiler tiler(GridTilerOptions{20, 16, 4, 3});  // core 12 x 10
  const auto tiles = tiler.tiles(30, 25);                  // 3 x 3 tiles
  REQUIRE(tiler.columns(30) == 3);
  REQUIRE(tiler.rows(25) == 3);
  REQUIRE(tiles.size() == 9);
  // Top-left: origin (-4, -3) clipped to (0, 0); size 20 x 16 becomes 16 x 13.
  REQUIRE(tiles[0].core == PixelRect{0, 0, 12, 10});
  REQUIRE(tiles[0].buffered == PixelRect{0, 0, 16, 13});
  // Centre: a full tile.
  REQUIRE(tiles[4].core == PixelRect{12, 10, 12, 10});
  REQUIRE(tiles[4].buffered == PixelRect{8, 7, 20, 16});
  // Bottom-right: the 6 x 5 leftover strip is its own core, buffer clipped at the far borders.
  REQUIRE(tiles[8].core == PixelRect{24, 20, 6, 5});
  REQUIRE(tiles[8].buffered == PixelRect{20, 17, 10, 8});
  check_tiling(tiler, 30, 25);
}

TEST_CASE("GridTiler: image sizes that are multiples of the core make no empty tile", "[tiling]") {
  // MicMac's BruteForce count int(Img / Core) + 1 would give 4 x 3 here, the last row/column empty.
  const GridTiler tiler(GridTilerOptions{10, 10, 0, 0});
  REQUIRE(tiler.columns(30) == 3);
  REQUIRE(tiler.rows(20) == 2);
  REQUIRE(check_tiling(tiler, 30, 20) == 6);
  // One pixel more: a one-pixel-wide last column of tiles.
  const auto tiles = tiler.tiles(31, 20);
  REQUIRE(tiles.size() == 8);
  REQUIRE(tiles[3].core == PixelRect{30, 0, 1, 10});
}

TEST_CASE("GridTiler: image smaller than one tile gives one tile covering it", "[tiling]") {
  const GridTiler tiler(GridTilerOptions{64, 48, 8, 6});
  const auto tiles = tiler.tiles(17, 9);
  REQUIRE(tiles.size() == 1);
  REQUIRE(tiles[0].core == PixelRect{0, 0, 17, 9});
  REQUIRE(tiles[0].buffered == PixelRect{0, 0, 17, 9});
  check_tiling(tiler, 17, 9);
  // Exactly one core: still one tile; the buffered rectangle is the whole image.
  REQUIRE(tiler.tiles(48, 36).size() == 1);
  REQUIRE(tiler.tiles(49, 36).size() == 2);
}

TEST_CASE("GridTiler: default options are MicMac's rough co-registration layout", "[tiling]") {
  const GridTiler tiler;
  REQUIRE(tiler.options().tile_width == 1920);
  REQUIRE(tiler.options().tile_height == 1440);
  REQUIRE(tiler.options().buffer_x == 0);
  const auto tiles = tiler.tiles(4000, 3000);  // ceil(4000/1920) = 3, ceil(3000/1440) = 3
  REQUIRE(tiles.size() == 9);
  for (const auto& t : tiles) REQUIRE(t.core == t.buffered);
  const GridTilerOptions precise = GridTilerOptions::micmac_precise();
  REQUIRE(precise.core_width() == 1536);
  REQUIRE(precise.core_height() == 1152);
}

TEST_CASE("GridTiler: tile_index_at agrees with the core rectangles", "[tiling]") {
  const GridTiler tiler(GridTilerOptions{9, 7, 2, 1});  // core 5 x 5
  const int w = 23, h = 12;
  const auto tiles = tiler.tiles(w, h);
  diachron::RandomStream rng(3);
  for (int i = 0; i < 2000; ++i) {
    // One draw per statement, y before x (core/random.hpp, "Order of draws").
    const double y = rng.uniform(-1.0, h);
    const Eigen::Vector2d p(rng.uniform(-1.0, w), y);
    const auto idx = tiler.tile_index_at(p, w, h);
    std::size_t containing = 0, which = 0;
    for (const auto& t : tiles)
      if (t.core.contains(p)) {
        ++containing;
        which = t.index;
      }
    const bool inside = p.x() >= -0.5 && p.x() < w - 0.5 && p.y() >= -0.5 && p.y() < h - 0.5;
    REQUIRE(containing == (inside ? 1u : 0u));
    REQUIRE(idx.has_value() == inside);
    if (idx) REQUIRE(*idx == which);
  }
  // Half-open pixel areas: x = 4.5 is pixel 5, the second core; x = 4.499 is still the first.
  REQUIRE(*tiler.tile_index_at({4.5, 0.0}, w, h) == 1);
  REQUIRE(*tiler.tile_index_at({4.499, 0.0}, w, h) == 0);
}

TEST_CASE("GridTiler: empty images and invalid options", "[tiling]") {
  const GridTiler tiler(GridTilerOptions{8, 8, 1, 1});
  REQUIRE(tiler.tiles(0, 10).empty());
  REQUIRE(tiler.tiles(10, 0).empty());
  REQUIRE_THROWS_AS(tiler.tiles(-1, 5), diachron::Error);
  REQUIRE_THROWS_AS(GridTiler(GridTilerOptions{8, 8, 4, 1}), diachron::Error);  // core width 0
  REQUIRE_THROWS_AS(GridTiler(GridTilerOptions{0, 8, 0, 0}), diachron::Error);
  REQUIRE_THROWS_AS(GridTiler(GridTilerOptions{8, 8, -1, 0}), diachron::Error);
  REQUIRE_THROWS_AS(tiler.tile(5, 0, 10, 10), diachron::Error);
  REQUIRE(tiler.tile(1, 1, 10, 10).core == PixelRect{6, 6, 4, 4});
}

TEST_CASE("PixelRect: integer and continuous containment", "[tiling]") {
  const PixelRect r{2, 3, 4, 5};
  REQUIRE(r.contains(2, 3));
  REQUIRE(r.contains(5, 7));
  REQUIRE_FALSE(r.contains(6, 7));
  REQUIRE_FALSE(r.contains(5, 8));
  REQUIRE(r.contains(Eigen::Vector2d(1.5, 2.5)));
  REQUIRE_FALSE(r.contains(Eigen::Vector2d(1.49, 3.0)));
  REQUIRE_FALSE(r.contains(Eigen::Vector2d(5.5, 3.0)));
  REQUIRE(r.contains(Eigen::Vector2d(5.49, 7.49)));
  REQUIRE_FALSE(r.contains(Eigen::Vector2d(std::numeric_limits<double>::quiet_NaN(), 4.0)));
  REQUIRE(r.area() == 20);
  REQUIRE(r.intersect(PixelRect{10, 10, 3, 3}).empty());
}
