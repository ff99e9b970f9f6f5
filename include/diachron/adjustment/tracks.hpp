#pragma once
/// @file
/// Tracks for the bundle adjustment: intra-epoch tie points and inter-epoch matches merged by
/// union-find into one list of observations per 3D point. A track that sees one image at two
/// different pixels (a wrong match chained through others) is dropped and counted.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <map>
#include <numeric>
#include <tuple>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/core/types.hpp>

namespace diachron {

/// Where an observation comes from: an intra-epoch tie point (the epoch's own SfM) or an
/// inter-epoch match. An observation named by both counts as inter-epoch (it carries the link).
enum class ObservationKind { intra_epoch, inter_epoch };

/// An inter-epoch match: the same ground point in two images (usually of different epochs).
struct ImageMatch {
  ImagePixel a;  ///< e.g. the master image of epoch 1
  ImagePixel b;  ///< e.g. the secondary image of epoch 2
  /// The square root of b's information relative to the inter-epoch sigma (TrackObservation::weight):
  /// a matcher that knows its match is less precise along one direction says so here.
  Eigen::Matrix2d weight_b = Eigen::Matrix2d::Identity();
};

/// One observation of a track.
struct TrackObservation {
  int image = 0;
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();  ///< px
  ObservationKind kind = ObservationKind::intra_epoch;
  /// The square root of the observation's information relative to its kind's sigma: the
  /// adjustment's whitened residual is weight (projected - pixel) / sigma. Identity by default.
  Eigen::Matrix2d weight = Eigen::Matrix2d::Identity();
};

/// The observations of one 3D point, sorted by image index (one per image).
struct Track {
  std::vector<TrackObservation> observations;
  /// True when at least one observation is inter-epoch.
  bool has_inter_epoch() const {
    return std::any_of(observations.begin(), observations.end(),
                       [](const TrackObservation& o) { return o.kind == ObservationKind::inter_epoch; });
  }
};

/// Options of build_tracks.
struct TrackOptions {
  /// Two observations of one image are the same one when their pixels agree within this distance
  /// (per axis, they are binned on a grid of this size), px. > 0. Matchers give the same keypoint
  /// the same coordinates, so the default only absorbs rounding.
  double same_pixel_px = 1e-3;
  /// Fewest observations of a kept track. >= 2.
  int min_observations = 2;
};

/// What build_tracks made. Default: nothing built.
struct TrackReport {
  std::size_t tracks = 0;                      ///< tracks kept
  std::size_t observations = 0;                ///< observations in kept tracks
  std::size_t inter_epoch_tracks = 0;          ///< kept tracks with an inter-epoch observation
  std::size_t dropped_conflicting = 0;         ///< tracks dropped: one image seen at two pixels
  std::size_t dropped_short = 0;               ///< tracks dropped: fewer than min_observations
  std::size_t dropped_observations = 0;        ///< observations in dropped tracks
};

/// Tracks and their report.
struct TrackSet {
  std::vector<Track> tracks;
  TrackReport report;
};

namespace detail {

// Union-find with path halving and union by size: near-constant time per operation.
class DisjointSets {
 public:
  explicit DisjointSets(std::size_t n) : parent_(n), size_(n, 1) { std::iota(parent_.begin(), parent_.end(), 0); }
  std::size_t find(std::size_t x) {
    while (parent_[x] != x) {
      parent_[x] = parent_[parent_[x]];
      x = parent_[x];
    }
    return x;
  }
  void unite(std::size_t a, std::size_t b) {
    a = find(a);
    b = find(b);
    if (a == b) return;
    if (size_[a] < size_[b]) std::swap(a, b);
    parent_[b] = a;
    size_[a] += size_[b];
  }

 private:
  std::vector<std::size_t> parent_;
  std::vector<std::size_t> size_;
};

}  // namespace detail

/// Merges tie points (each a list of observations of one point, typically of one epoch) and
/// matches into tracks by union-find over the distinct (image, pixel) observations.
/// Deterministic: tracks come in the order of their first observation in the input (tie points
/// first, then matches), observations sorted by image.
/// @param image_count number of images; every image index must be in [0, image_count).
/// Precondition: valid indices and finite pixels, options in range (throws diachron::Error).
inline TrackSet build_tracks(const std::vector<std::vector<ImagePixel>>& tie_points,
                             const std::vector<ImageMatch>& matches, int image_count,
                             const TrackOptions& options = {}) {
  DIACHRON_CHECK(options.same_pixel_px > 0.0 && std::isfinite(options.same_pixel_px),
                 "TrackOptions::same_pixel_px must be > 0, got " << options.same_pixel_px);
  DIACHRON_CHECK(options.min_observations >= 2,
                 "TrackOptions::min_observations must be >= 2, got " << options.min_observations);
  DIACHRON_CHECK(image_count >= 0, "build_tracks: image_count must be >= 0");

  using Key = std::tuple<int, long long, long long>;
  std::map<Key, std::size_t> ids;  // ordered map: deterministic, no hashing of doubles
  std::vector<TrackObservation> nodes;
  const auto node = [&](const ImagePixel& o, ObservationKind kind) {
    DIACHRON_CHECK(o.image >= 0 && o.image < image_count,
                   "build_tracks: image index " << o.image << " outside [0, " << image_count << ")");
    DIACHRON_CHECK(o.pixel.allFinite(), "build_tracks: non-finite pixel in image " << o.image);
    const Key key{o.image, std::llround(o.pixel.x() / options.same_pixel_px),
                  std::llround(o.pixel.y() / options.same_pixel_px)};
    const auto [it, inserted] = ids.emplace(key, nodes.size());
    if (inserted) nodes.push_back(TrackObservation{o.image, o.pixel, kind});
    if (kind == ObservationKind::inter_epoch) nodes[it->second].kind = kind;
    return it->second;
  };
  std::vector<std::pair<std::size_t, std::size_t>> links;
  for (const auto& tie : tie_points) {
    if (tie.empty()) continue;
    const std::size_t first = node(tie.front(), ObservationKind::intra_epoch);
    for (std::size_t k = 1; k < tie.size(); ++k) links.emplace_back(first, node(tie[k], ObservationKind::intra_epoch));
  }
  for (const ImageMatch& m : matches) {
    DIACHRON_CHECK(m.weight_b.allFinite() && std::abs(m.weight_b.determinant()) > 1e-12,
                   "build_tracks: a match's weight must be finite and invertible");
    const std::size_t a = node(m.a, ObservationKind::inter_epoch);
    const std::size_t b = node(m.b, ObservationKind::inter_epoch);
    // A pixel named by several matches keeps the first weight that is not the identity.
    if (nodes[b].weight.isIdentity(0.0)) nodes[b].weight = m.weight_b;
    links.emplace_back(a, b);
  }

  detail::DisjointSets sets(nodes.size());
  for (const auto& [a, b] : links) sets.unite(a, b);

  // Group nodes by root in node order (= order of first appearance).
  std::vector<std::size_t> track_of_root(nodes.size(), nodes.size());
  std::vector<std::vector<std::size_t>> groups;
  for (std::size_t n = 0; n < nodes.size(); ++n) {
    const std::size_t root = sets.find(n);
    if (track_of_root[root] == nodes.size()) {
      track_of_root[root] = groups.size();
      groups.emplace_back();
    }
    groups[track_of_root[root]].push_back(n);
  }

  TrackSet out;
  for (const auto& group : groups) {
    Track track;
    for (std::size_t n : group) track.observations.push_back(nodes[n]);
    std::stable_sort(track.observations.begin(), track.observations.end(),
                     [](const TrackObservation& a, const TrackObservation& b) { return a.image < b.image; });
    bool conflict = false;
    for (std::size_t k = 1; k < track.observations.size(); ++k)
      conflict = conflict || track.observations[k].image == track.observations[k - 1].image;
    if (conflict) {
      ++out.report.dropped_conflicting;
      out.report.dropped_observations += track.observations.size();
      continue;
    }
    if (static_cast<int>(track.observations.size()) < options.min_observations) {
      ++out.report.dropped_short;
      out.report.dropped_observations += track.observations.size();
      continue;
    }
    out.report.observations += track.observations.size();
    if (track.has_inter_epoch()) ++out.report.inter_epoch_tracks;
    out.tracks.push_back(std::move(track));
  }
  out.report.tracks = out.tracks.size();
  return out;
}

}  // namespace diachron
