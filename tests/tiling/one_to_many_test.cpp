#include <catch2/catch.hpp>

#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <set>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include <diachron/core/random.hpp>
#include <diachron/tiling/one_to_many.hpp>

using diachron::GridTiler;
using diachron::GridTilerOptions;
using diachron::OneToManyOptions;
using diachron::PointMatch;
using diachron::Raster;

namespace {

using Image = Raster<std::uint8_t>;
constexpr int kRadius = 2;  // 5 x 5 patterns

Image noise_image(int w, int h, std::uint64_t seed) {
  diachron::RandomStream rng(seed);
  Image img(w, h);
  for (auto& v : img) v = static_cast<std::uint8_t>(rng.uniform_index(256));
  return img;
}

std::string pattern(const Image& img, int x, int y) {
  std::string key;
  for (int dy = -kRadius; dy <= kRadius; ++dy)
    for (int dx = -kRadius; dx <= kRadius; ++dx) key.push_back(static_cast<char>(img(x + dx, y + dy)));
  return key;
}

// Exact template matcher: every pixel of `a` whose 5x5 pattern occurs exactly once in `b`.
// Random noise makes 25-byte patterns unique, so it finds every true correspondence and nothing else.
struct PatternMatcher {
  std::vector<PointMatch> match(const Image& a, const Image& b) const {
    std::unordered_map<std::string, std::pair<int, int>> where;
    std::set<std::string> repeated;
    for (int y = kRadius; y < b.height() - kRadius; ++y)
      for (int x = kRadius; x < b.width() - kRadius; ++x) {
        const auto key = pattern(b, x, y);
        if (!where.emplace(key, std::make_pair(x, y)).second) repeated.insert(key);
      }
    std::vector<PointMatch> out;
    for (int y = kRadius; y < a.height() - kRadius; ++y)
      for (int x = kRadius; x < a.width() - kRadius; ++x) {
        const auto key = pattern(a, x, y);
        const auto it = where.find(key);
        if (it == where.end() || repeated.count(key)) continue;
        out.push_back(PointMatch{{x, y}, {it->second.first, it->second.second}, 1.0});
      }
    return out;
  }
};

bool inside_with_margin(const diachron::PixelRect& r, int x, int y) {
  return x - kRadius >= r.x && y - kRadius >= r.y && x + kRadius < r.right() && y + kRadius < r.bottom();
}

struct Scene {
  Image master, secondary;
  int ox = 0, oy = 0;  // secondary(x, y) = master(x + ox, y + oy)
};

Scene make_scene() {
  Scene s;
  s.master = noise_image(70, 55, 1);
  s.ox = 7;
  s.oy = 4;
  s.secondary = Image(60, 50);
  for (int y = 0; y < 50; ++y)
    for (int x = 0; x < 60; ++x) s.secondary(x, y) = s.master(x + s.ox, y + s.oy);
  return s;
}

}  // namespace

TEST_CASE("crop_raster: copies the rectangle and rejects rectangles outside", "[tiling]") {
  const Image img = noise_image(9, 7, 3);
  const Image c = diachron::crop_raster(img, diachron::PixelRect{2, 3, 4, 3});
  REQUIRE(c.width() == 4);
  REQUIRE(c.height() == 3);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 4; ++x) REQUIRE(c(x, y) == img(x + 2, y + 3));
  REQUIRE_THROWS_AS(diachron::crop_raster(img, diachron::PixelRect{6, 0, 4, 3}), diachron::Error);
  REQUIRE_THROWS_AS(diachron::crop_raster(img, diachron::PixelRect{-1, 0, 4, 3}), diachron::Error);
}

TEST_CASE("match_one_to_many: maps matches back exactly and keeps exactly the in-core ones",
          "[tiling]") {
  const Scene s = make_scene();
  const GridTiler mt(GridTilerOptions{24, 20, 3, 2});  // core 18 x 16 -> 4 x 4 tiles
  const GridTiler st(GridTilerOptions{20, 18, 4, 3});  // core 12 x 12 -> 5 x 5 tiles
  OneToManyOptions o;
  o.threads = 1;
  const auto r = diachron::match_one_to_many(s.master, s.secondary, mt, st, PatternMatcher{}, o);
  REQUIRE(r.master_tiles.size() == 16);
  REQUIRE(r.secondary_tiles.size() == 25);
  REQUIRE(r.pair_count == 400);
  REQUIRE(r.pair_counts.size() == 400);
  REQUIRE(r.matches.size() == r.match_pair.size());

  // Oracle: master pixel p matches iff its true partner q = p - o is in the secondary, p's pattern
  // fits in its master tile's buffered crop and q's in its secondary tile's crop.
  std::set<std::pair<int, int>> expected;
  for (int y = 0; y < s.master.height(); ++y)
    for (int x = 0; x < s.master.width(); ++x) {
      const int qx = x - s.ox, qy = y - s.oy;
      if (!s.secondary.contains(qx, qy)) continue;
      const auto im = mt.tile_index_at({x, y}, s.master.width(), s.master.height());
      const auto is = st.tile_index_at({qx, qy}, s.secondary.width(), s.secondary.height());
      if (inside_with_margin(r.master_tiles[*im].buffered, x, y) &&
          inside_with_margin(r.secondary_tiles[*is].buffered, qx, qy))
        expected.insert({x, y});
    }
  REQUIRE(expected.size() > 1500);

  std::set<std::pair<int, int>> got;
  std::size_t previous_pair = 0, sum = 0;
  for (std::size_t k = 0; k < r.matches.size(); ++k) {
    const PointMatch& m = r.matches[k];
    // Exact back-mapping: the secondary point is the master point shifted by the known offset.
    REQUIRE(m.b.x() == m.a.x() - s.ox);
    REQUIRE(m.b.y() == m.a.y() - s.oy);
    const std::size_t pair = r.match_pair[k];
    REQUIRE(pair >= previous_pair);
    previous_pair = pair;
    REQUIRE(r.master_tiles[r.pair_master(pair)].core.contains(m.a));
    REQUIRE(r.secondary_tiles[r.pair_secondary(pair)].core.contains(m.b));
    REQUIRE(got.insert({static_cast<int>(m.a.x()), static_cast<int>(m.a.y())}).second);  // no duplicate
  }
  for (std::size_t c : r.pair_counts) sum += c;
  REQUIRE(sum == r.matches.size());
  REQUIRE(got == expected);

  // Without the core filters the buffers give duplicates and the raw counts are all kept.
  o.master_core_only = false;
  o.secondary_core_only = false;
  const auto loose = diachron::match_one_to_many(s.master, s.secondary, mt, st, PatternMatcher{}, o);
  std::size_t raw = 0;
  for (std::size_t c : loose.pair_raw_counts) raw += c;
  REQUIRE(loose.matches.size() == raw);
  REQUIRE(loose.matches.size() > r.matches.size());
  for (const auto& m : loose.matches) REQUIRE(m.b == m.a - Eigen::Vector2d(s.ox, s.oy));
}

TEST_CASE("match_one_to_many: identical output for 1, 2 and all threads", "[tiling]") {
  const Scene s = make_scene();
  const GridTiler mt(GridTilerOptions{22, 19, 2, 3});
  const GridTiler st(GridTilerOptions{17, 21, 1, 0});
  OneToManyOptions o;
  o.threads = 1;
  const auto one = diachron::match_one_to_many(s.master, s.secondary, mt, st, PatternMatcher{}, o);
  REQUIRE(!one.matches.empty());
  for (std::size_t threads : {2u, 0u}) {
    o.threads = threads;
    const auto other = diachron::match_one_to_many(s.master, s.secondary, mt, st, PatternMatcher{}, o);
    REQUIRE(other.matches.size() == one.matches.size());
    REQUIRE(other.match_pair == one.match_pair);
    REQUIRE(other.pair_counts == one.pair_counts);
    for (std::size_t k = 0; k < one.matches.size(); ++k) {
      REQUIRE(other.matches[k].a == one.matches[k].a);
      REQUIRE(other.matches[k].b == one.matches[k].b);
    }
  }
}

TEST_CASE("match_one_to_many: drops points outside the tiles and non-finite points", "[tiling]") {
  const Image master(30, 20, 1), secondary(20, 20, 2);
  const GridTiler tiler(GridTilerOptions{10, 10, 0, 0});
  const double nan = std::numeric_limits<double>::quiet_NaN();
  auto matcher = diachron::make_pair_matcher([nan](const Image& a, const Image& b) {
    REQUIRE(a(0, 0) == 1);
    REQUIRE(b(0, 0) == 2);
    return std::vector<PointMatch>{
        PointMatch{{0.0, 0.0}, {0.0, 0.0}, 1.0},    // kept
        PointMatch{{-0.5, 9.4}, {9.49, -0.5}, 2.0},  // kept: still inside the pixel areas
        PointMatch{{-0.51, 3.0}, {3.0, 3.0}, 3.0},  // master point outside the tile
        PointMatch{{3.0, 3.0}, {9.5, 3.0}, 4.0},    // secondary point outside the tile
        PointMatch{{nan, 3.0}, {3.0, 3.0}, 5.0},    // non-finite
    };
  });
  const auto r = diachron::match_one_to_many(master, secondary, tiler, tiler, matcher);
  REQUIRE(r.pair_count == 6 * 4);
  REQUIRE(r.matches.size() == 2 * r.pair_count);
  for (std::size_t pair = 0; pair < r.pair_count; ++pair) {
    REQUIRE(r.pair_raw_counts[pair] == 5);
    REQUIRE(r.pair_counts[pair] == 2);
    const auto& tm = r.master_tiles[r.pair_master(pair)];
    const auto& ts = r.secondary_tiles[r.pair_secondary(pair)];
    const PointMatch& first = r.matches[2 * pair];
    REQUIRE(first.a == Eigen::Vector2d(tm.core.x, tm.core.y));
    REQUIRE(first.b == Eigen::Vector2d(ts.core.x, ts.core.y));
    REQUIRE(r.matches[2 * pair + 1].score == 2.0);
  }
}

TEST_CASE("match_one_to_many: progress, exceptions and bad input", "[tiling]") {
  const Image master(40, 20), secondary(20, 20);
  const GridTiler tiler(GridTilerOptions{10, 10, 0, 0});
  auto empty_matcher = diachron::make_pair_matcher([](const Image&, const Image&) { return std::vector<PointMatch>{}; });
  std::vector<std::size_t> done;
  std::size_t total = 0;
  OneToManyOptions o;
  o.threads = 2;
  o.progress_stage = "stage x";
  o.progress = [&](const diachron::ProgressEvent& e) {
    REQUIRE(e.stage == "stage x");
    done.push_back(e.done);
    total = e.total;
  };
  const auto r = diachron::match_one_to_many(master, secondary, tiler, tiler, empty_matcher, o);
  REQUIRE(r.pair_count == 8 * 4);
  REQUIRE(total == r.pair_count);
  REQUIRE(done.size() == r.pair_count + 1);
  REQUIRE(done.back() == r.pair_count);
  REQUIRE(r.matches.empty());

  auto throwing = diachron::make_pair_matcher([](const Image&, const Image&) -> std::vector<PointMatch> {
    throw std::runtime_error("matcher failed");
  });
  REQUIRE_THROWS_AS(diachron::match_one_to_many(master, secondary, tiler, tiler, throwing, o), std::runtime_error);
  REQUIRE_THROWS_AS(diachron::match_one_to_many(Image(), secondary, tiler, tiler, empty_matcher, o),
                    diachron::Error);
}

TEST_CASE("match_one_to_many: a masked matcher receives each tile's crop of the masks", "[tiling]") {
  // Masks with a recognisable value per pixel: master mask = 1 + x % 200, secondary = 1 + y % 200,
  // with a hole (0) in a block of each. The matcher checks every crop pixel against the image.
  Image master(40, 30, 0), secondary(35, 25, 0);
  Image master_mask(40, 30), secondary_mask(35, 25);
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 40; ++x) {
      master(x, y) = static_cast<std::uint8_t>(x);
      master_mask(x, y) = (x >= 5 && x < 9 && y < 4) ? 0 : static_cast<std::uint8_t>(1 + x);
    }
  for (int y = 0; y < 25; ++y)
    for (int x = 0; x < 35; ++x) {
      secondary(x, y) = static_cast<std::uint8_t>(y);
      secondary_mask(x, y) = (y >= 20) ? 0 : static_cast<std::uint8_t>(1 + y);
    }
  // Counted, not asserted, inside the matcher: Catch2 assertions are not thread-safe.
  std::atomic<int> calls{0}, zero_master{0}, zero_secondary{0}, wrong{0};
  auto matcher = diachron::make_pair_matcher([&](const Image& a, const Image& b, const Image& ma, const Image& mb) {
    calls.fetch_add(1);
    if (ma.width() != a.width() || ma.height() != a.height() || mb.width() != b.width() ||
        mb.height() != b.height()) {
      wrong.fetch_add(1);
      return std::vector<PointMatch>{};
    }
    for (int y = 0; y < a.height(); ++y)
      for (int x = 0; x < a.width(); ++x) {
        if (ma(x, y) == 0) zero_master.fetch_add(1);
        else if (ma(x, y) != a(x, y) + 1) wrong.fetch_add(1);  // not the same pixel of the full image
      }
    for (int y = 0; y < b.height(); ++y)
      for (int x = 0; x < b.width(); ++x) {
        if (mb(x, y) == 0) zero_secondary.fetch_add(1);
        else if (mb(x, y) != b(x, y) + 1) wrong.fetch_add(1);
      }
    return std::vector<PointMatch>{};
  });
  const GridTiler mt(GridTilerOptions{16, 12, 2, 1});
  const GridTiler st(GridTilerOptions{20, 10, 0, 0});
  for (std::size_t threads : {1u, 2u}) {
    calls = 0;
    zero_master = 0;
    zero_secondary = 0;
    OneToManyOptions o;
    o.threads = threads;
    const auto r = diachron::match_one_to_many(master, master_mask, secondary, secondary_mask, mt, st, matcher, o);
    REQUIRE(calls.load() == static_cast<int>(r.pair_count));
    REQUIRE(wrong.load() == 0);
    REQUIRE(zero_master.load() > 0);
    REQUIRE(zero_secondary.load() > 0);
  }
  // Empty masks mean all valid: the matcher then sees no 0.
  zero_master = 0;
  zero_secondary = 0;
  diachron::match_one_to_many(master, Image(), secondary, Image(), mt, st, matcher);
  REQUIRE(zero_master.load() == 0);
  REQUIRE(zero_secondary.load() == 0);
  // A mask of the wrong size is an error.
  REQUIRE_THROWS_AS(diachron::match_one_to_many(master, Image(3, 3, 1), secondary, secondary_mask, mt, st, matcher),
                    diachron::Error);
}

TEST_CASE("match_one_to_many: an unmasked matcher still runs when masks are given", "[tiling]") {
  const Scene s = make_scene();
  const GridTiler mt(GridTilerOptions{22, 19, 2, 3});
  const GridTiler st(GridTilerOptions{17, 21, 1, 0});
  const auto plain = diachron::match_one_to_many(s.master, s.secondary, mt, st, PatternMatcher{});
  const Image mask_m(s.master.width(), s.master.height(), 0), mask_s(s.secondary.width(), s.secondary.height(), 0);
  const auto with_masks = diachron::match_one_to_many(s.master, mask_m, s.secondary, mask_s, mt, st, PatternMatcher{});
  REQUIRE(with_masks.matches.size() == plain.matches.size());
}
