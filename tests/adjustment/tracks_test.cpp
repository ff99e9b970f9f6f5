// build_tracks: union-find merging of tie points and matches against a brute-force oracle
// (label propagation to a fixed point), the conflict and length rules, determinism, bad input.

#include <algorithm>
#include <cstdint>
#include <set>
#include <tuple>
#include <vector>

#include <catch2/catch.hpp>

#include <diachron/adjustment/tracks.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/random.hpp>

using namespace diachron;

namespace {

using Obs = std::tuple<int, double, double, int>;  // image, x, y, kind

std::vector<Obs> as_tuples(const Track& t) {
  std::vector<Obs> out;
  for (const auto& o : t.observations)
    out.emplace_back(o.image, o.pixel.x(), o.pixel.y(), o.kind == ObservationKind::inter_epoch ? 1 : 0);
  std::sort(out.begin(), out.end());
  return out;
}

// The oracle: every distinct (image, x, y) is a vertex; each tie point connects all its
// observations, each match its two; labels propagate (min over neighbours) until nothing changes.
std::multiset<std::vector<Obs>> oracle(const std::vector<std::vector<ImagePixel>>& ties,
                                       const std::vector<ImageMatch>& matches, std::size_t* conflicting,
                                       std::size_t* short_tracks) {
  std::vector<std::tuple<int, double, double>> vertices;
  std::vector<int> inter;
  const auto id = [&](const ImagePixel& p, int is_inter) {
    const auto key = std::make_tuple(p.image, p.pixel.x(), p.pixel.y());
    for (std::size_t i = 0; i < vertices.size(); ++i)
      if (vertices[i] == key) {
        inter[i] = std::max(inter[i], is_inter);
        return i;
      }
    vertices.push_back(key);
    inter.push_back(is_inter);
    return vertices.size() - 1;
  };
  std::vector<std::pair<std::size_t, std::size_t>> edges;
  for (const auto& t : ties)
    for (std::size_t a = 0; a < t.size(); ++a)
      for (std::size_t b = 0; b < t.size(); ++b) edges.emplace_back(id(t[a], 0), id(t[b], 0));
  for (const auto& m : matches) edges.emplace_back(id(m.a, 1), id(m.b, 1));
  std::vector<std::size_t> label(vertices.size());
  for (std::size_t i = 0; i < label.size(); ++i) label[i] = i;
  for (bool changed = true; changed;) {
    changed = false;
    for (const auto& [a, b] : edges) {
      const std::size_t m = std::min(label[a], label[b]);
      if (label[a] != m || label[b] != m) changed = true;
      label[a] = label[b] = m;
    }
  }
  std::multiset<std::vector<Obs>> out;
  *conflicting = *short_tracks = 0;
  for (std::size_t root = 0; root < vertices.size(); ++root) {
    std::vector<Obs> track;
    std::set<int> images;
    bool conflict = false;
    for (std::size_t i = 0; i < vertices.size(); ++i)
      if (label[i] == root) {
        const auto& [image, x, y] = vertices[i];
        conflict = conflict || !images.insert(image).second;
        track.emplace_back(image, x, y, inter[i]);
      }
    if (track.empty()) continue;
    if (conflict) {
      ++*conflicting;
      continue;
    }
    if (track.size() < 2) {
      ++*short_tracks;
      continue;
    }
    std::sort(track.begin(), track.end());
    out.insert(track);
  }
  return out;
}

}  // namespace

TEST_CASE("build_tracks: equals the brute-force oracle on random tie points and matches", "[adjustment]") {
  RandomStream random(7);
  for (int round = 0; round < 30; ++round) {
    const int images = 6;
    // Few distinct pixels per image so observations collide and tracks chain.
    const auto in = [&random](int lo, int hi) { return lo + static_cast<int>(random.uniform_index(static_cast<std::size_t>(hi - lo + 1))); };
    const auto image = [&] { return in(0, images - 1); };
    const auto coordinate = [&] { return in(0, 6); };
    const auto length = [&] { return in(1, 4); };
    const auto count = [&] { return in(0, 25); };
    // One draw per statement, y before x: the order of a call's arguments is unspecified
    // (core/random.hpp, "Order of draws").
    const auto draw = [&] {
      const int i = image(), y = coordinate();
      return ImagePixel{i, Eigen::Vector2d(coordinate(), y)};
    };
    std::vector<std::vector<ImagePixel>> ties(static_cast<std::size_t>(count()));
    for (auto& t : ties) {
      const int n = length();
      for (int k = 0; k < n; ++k) t.push_back(draw());
    }
    std::vector<ImageMatch> matches(static_cast<std::size_t>(count()));
    for (auto& m : matches) m = ImageMatch{draw(), draw()};

    const TrackSet built = build_tracks(ties, matches, images);
    std::size_t conflicting = 0, short_tracks = 0;
    const auto expected = oracle(ties, matches, &conflicting, &short_tracks);
    std::multiset<std::vector<Obs>> got;
    std::size_t observations = 0, inter = 0;
    for (const Track& t : built.tracks) {
      got.insert(as_tuples(t));
      observations += t.observations.size();
      inter += t.has_inter_epoch() ? 1 : 0;
      for (std::size_t k = 1; k < t.observations.size(); ++k) CHECK(t.observations[k - 1].image < t.observations[k].image);
    }
    INFO("round " << round);
    CHECK(got == expected);
    CHECK(built.report.tracks == built.tracks.size());
    CHECK(built.report.dropped_conflicting == conflicting);
    CHECK(built.report.dropped_short == short_tracks);
    CHECK(built.report.observations == observations);
    CHECK(built.report.inter_epoch_tracks == inter);
  }
}

TEST_CASE("build_tracks: chains a tie point through matches and drops a track seeing one image twice", "[adjustment]") {
  const Eigen::Vector2d p(10, 20), q(30, 40), r(50, 60);
  // Epoch 1: images 0, 1; epoch 2: images 2, 3.
  const std::vector<std::vector<ImagePixel>> ties = {{{0, p}, {1, q}}, {{2, r}, {3, p}}};
  SECTION("one match links the two epochs' tie points into a 4-view track") {
    const TrackSet t = build_tracks(ties, {ImageMatch{{0, p}, {2, r}}}, 4);
    REQUIRE(t.tracks.size() == 1);
    CHECK(t.tracks[0].observations.size() == 4);
    CHECK(t.tracks[0].observations[0].kind == ObservationKind::inter_epoch);
    CHECK(t.tracks[0].observations[1].kind == ObservationKind::intra_epoch);
    CHECK(t.report.inter_epoch_tracks == 1);
  }
  SECTION("a second match to another pixel of image 2 makes a conflict: dropped, counted") {
    const TrackSet t = build_tracks(ties, {ImageMatch{{0, p}, {2, r}}, ImageMatch{{1, q}, {2, q}}}, 4);
    CHECK(t.tracks.empty());
    CHECK(t.report.dropped_conflicting == 1);
    CHECK(t.report.dropped_observations == 5);
  }
  SECTION("a match's weight goes to its secondary observation, the master's stays the identity") {
    Eigen::Matrix2d w;
    w << 2.0, 0.1, 0.1, 0.5;
    const TrackSet t = build_tracks({}, {ImageMatch{{0, p}, {2, r}, w}}, 4);
    REQUIRE(t.tracks.size() == 1);
    REQUIRE(t.tracks[0].observations.size() == 2);
    CHECK(t.tracks[0].observations[0].weight.isIdentity(0.0));
    CHECK(t.tracks[0].observations[1].weight == w);
  }
  SECTION("pixels within same_pixel_px are one observation") {
    const TrackSet t = build_tracks(ties, {ImageMatch{{0, p + Eigen::Vector2d(1e-5, 0)}, {2, r}}}, 4);
    REQUIRE(t.tracks.size() == 1);
    CHECK(t.tracks[0].observations.size() == 4);
  }
}

TEST_CASE("build_tracks: bad input throws", "[adjustment]") {
  CHECK_THROWS_AS(build_tracks({{{0, {0, 0}}, {5, {1, 1}}}}, {}, 4), Error);
  CHECK_THROWS_AS(build_tracks({}, {ImageMatch{{0, {NAN, 0}}, {1, {1, 1}}}}, 4), Error);
  CHECK_THROWS_AS(build_tracks({}, {ImageMatch{{0, {0, 0}}, {1, {1, 1}}, Eigen::Matrix2d::Zero()}}, 4), Error);
  TrackOptions o;
  o.min_observations = 1;
  CHECK_THROWS_AS(build_tracks({}, {}, 4, o), Error);
  CHECK(build_tracks({}, {}, 0).tracks.empty());
}
