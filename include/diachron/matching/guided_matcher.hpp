#pragma once
/// @file
/// Guided descriptor matching: each master keypoint is predicted into the secondary image through a
/// Transfer, and only the secondary keypoints near the prediction whose scale and orientation agree
/// with the local affine of the transfer compete for it (MicMac TiePHistorical's guided SIFT, with
/// a KD-tree radius search instead of its brute-force loop). docs/guided-matching.md.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/core/parallel.hpp>
#include <diachron/core/types.hpp>
#include <diachron/matching/descriptor_matching.hpp>
#include <diachron/matching/features.hpp>
#include <diachron/matching/point_index_2d.hpp>
#include <diachron/matching/point_match.hpp>
#include <diachron/terrain/local_affine.hpp>
#include <diachron/terrain/transfer.hpp>

namespace diachron {

/// Options of guided_match. Defaults are MicMac TiePHistorical's guided SIFT (SearchSpace 100,
/// ScaleTh 0.2, AngleTh 30 degrees, ratio 0.8, MutualNN, RootSIFT compared with L2).
struct GuidedMatchOptions {
  /// Search radius around each prediction, in MASTER pixels (> 0). In the secondary image it is
  /// multiplied by the local scale of the transfer at the keypoint (secondary px per master px)
  /// unless `scale_search_radius` is false, in which case it is used as secondary pixels as is.
  /// The reverse search of the mutual check uses it in master pixels.
  double search_radius_px = 100.0;
  bool scale_search_radius = true;
  /// Central-difference step of local_affine, master (forward) or secondary (inverse) pixels, > 0.
  double affine_step_px = 1.0;
  /// Scale gate: a candidate passes when secondary.scale / master.scale lies in
  /// [1 - tol, 1 + tol] x the predicted scale. Skipped for a pair where a keypoint has scale 0.
  bool check_scale = true;
  double scale_ratio_tolerance = 0.2;  ///< in [0, 1)
  /// Orientation gate: a candidate passes when its angle differs from master.angle + predicted
  /// rotation by at most this, measured around the circle (359 and 1 degrees are 2 apart).
  /// Skipped for a pair where a keypoint has no orientation (negative angle).
  bool check_angle = true;
  double angle_tolerance_deg = 30.0;  ///< degrees, in [0, 180]
  /// Descriptor comparison: L2 on the rows as given (RootSIFT rows from RootSiftExtractor), or
  /// cosine (distance = chordal sqrt(2 - 2 s), as in DescriptorMatch).
  DescriptorDistance metric = DescriptorDistance::L2;
  /// Lowe's test among the gated candidates: keep when best < ratio * second best (strict; a lone
  /// candidate passes). The second best is tracked correctly (a demoted best becomes second).
  bool ratio_test = true;
  double ratio = 0.8;  ///< in (0, 1]
  /// Keep (i, j) only when, predicted back through the inverse transfer, secondary keypoint j has
  /// master keypoint i as its nearest among the gated master candidates within search_radius_px
  /// (master px) of that prediction. The reverse gates use the inverse transfer's own local affine,
  /// inverted, on the pair in the master -> secondary sense, so an exact inverse gates alike.
  bool mutual = true;
  /// Worker threads over master keypoints; 0 = all cores. The result does not depend on it.
  std::size_t threads = 0;

  void check() const {
    DIACHRON_CHECK(search_radius_px > 0.0 && std::isfinite(search_radius_px),
                   "GuidedMatchOptions::search_radius_px must be positive and finite, got " << search_radius_px);
    DIACHRON_CHECK(affine_step_px > 0.0 && std::isfinite(affine_step_px),
                   "GuidedMatchOptions::affine_step_px must be positive and finite, got " << affine_step_px);
    DIACHRON_CHECK(scale_ratio_tolerance >= 0.0 && scale_ratio_tolerance < 1.0,
                   "GuidedMatchOptions::scale_ratio_tolerance must be in [0, 1), got " << scale_ratio_tolerance);
    DIACHRON_CHECK(angle_tolerance_deg >= 0.0 && angle_tolerance_deg <= 180.0,
                   "GuidedMatchOptions::angle_tolerance_deg must be in [0, 180], got " << angle_tolerance_deg);
    DIACHRON_CHECK(ratio > 0.0 && ratio <= 1.0, "GuidedMatchOptions::ratio must be in (0, 1], got " << ratio);
  }
};

/// One kept match: keypoint indices, descriptor distances (units of DescriptorMatch::distance)
/// and the score (higher is better: -distance for L2, cosine similarity for Cosine).
struct GuidedMatch {
  std::size_t master = 0;
  std::size_t secondary = 0;
  double distance = 0.0;
  /// Distance to the second-nearest gated candidate, +inf when there was a single one.
  double second_distance = std::numeric_limits<double>::infinity();
  double score = 0.0;
};

/// What guided_match returns. `matches[k]` (a = master px, b = secondary px) is `pairs[k]`, sorted
/// by master index. Every master keypoint lands in exactly one of: no_prediction, no_candidate,
/// failed_ratio, failed_mutual, or the matches (so predicted = size - no_prediction).
struct GuidedMatchResult {
  bool success = false;  ///< at least one match kept
  PointMatches matches;
  std::vector<GuidedMatch> pairs;
  std::size_t predicted = 0;      ///< master keypoints with a prediction and a local affine
  std::size_t no_prediction = 0;  ///< the forward transfer (or its local affine) gave nothing
  std::size_t no_candidate = 0;   ///< no secondary keypoint in the radius passed the gates
  std::size_t failed_ratio = 0;   ///< best not clearly better than the second best
  std::size_t failed_mutual = 0;  ///< the reverse search chose another master keypoint (or none)
  std::size_t candidates = 0;     ///< descriptor comparisons of the forward search (gated pairs)
};

/// Where a keypoint goes and how the image turns and scales around it.
struct GuidedPrediction {
  bool valid = false;
  Eigen::Vector2d position = Eigen::Vector2d::Zero();  ///< px in the other image
  double scale = 1.0;                                  ///< affine_scale of the local affine: other px per own px
  double rotation = 0.0;                               ///< affine_rotation of the local affine, radians in (-pi, pi]
};

/// The prediction of `px` through `transfer`: invalid when the transfer or its local affine gives
/// nothing, or the scale is not positive and finite.
template <class Transfer>
GuidedPrediction predict_keypoint(const Transfer& transfer, const Eigen::Vector2d& px, double affine_step_px) {
  static_assert(check_transfer<Transfer>());
  GuidedPrediction p;
  const std::optional<Eigen::Vector2d> to = transfer(px);
  if (!to || !to->allFinite()) return p;
  const std::optional<Eigen::Matrix2d> a = local_affine(transfer, px, affine_step_px);
  if (!a) return p;
  p.scale = affine_scale(*a);
  p.rotation = affine_rotation(*a);
  if (!(p.scale > 0.0) || !std::isfinite(p.scale) || !std::isfinite(p.rotation)) return p;
  p.position = *to;
  p.valid = true;
  return p;
}

/// Guided matching of `master` against `secondary` (see the file comment and
/// docs/guided-matching.md for the rules).
/// @param forward Transfer master px -> secondary px; @param inverse Transfer secondary px ->
///        master px (used by the mutual check only; both must be safe to call concurrently).
/// Throws diachron::Error when descriptor rows and keypoints disagree in number, the descriptor
/// widths differ, a descriptor value, keypoint position, scale or angle is not finite, a scale is
/// negative, or an option is out of range.
/// Cost: 5 transfer calls per master keypoint (and per matched secondary keypoint with `mutual`),
/// then one radius query and a descriptor distance per candidate in the radius. Deterministic
/// whatever the thread count: ties go to the lower index.
template <class Transfer, class InverseTransfer>
GuidedMatchResult guided_match(const Features& master, const Features& secondary, const Transfer& forward,
                               const InverseTransfer& inverse, const GuidedMatchOptions& options = {});

// Implementation ----------------------------------------------------------------------------------

namespace detail {

// a - b wrapped into [-pi, pi]: orientations live on a circle (MicMac's gate does not wrap).
inline double angle_difference(double a, double b) { return std::remainder(a - b, 2.0 * kPi); }

// The gates on a (master, secondary) keypoint pair, given the predicted scale (secondary px per
// master px) and rotation (master -> secondary). The reverse search of the mutual check calls it
// with the pair in the same order and the inverse of its own prediction, so that an exact inverse
// transfer accepts exactly the pairs the forward search accepts.
inline bool guided_gates_pass(const Keypoint& master, const Keypoint& secondary, double scale, double rotation,
                              const GuidedMatchOptions& o, double angle_tolerance_rad) {
  if (o.check_scale && master.scale > 0.0 && secondary.scale > 0.0) {
    const double ratio = secondary.scale / master.scale;
    if (ratio < (1.0 - o.scale_ratio_tolerance) * scale || ratio > (1.0 + o.scale_ratio_tolerance) * scale)
      return false;
  }
  if (o.check_angle && master.angle >= 0.0 && secondary.angle >= 0.0 &&
      std::abs(angle_difference(secondary.angle, master.angle + rotation)) > angle_tolerance_rad)
    return false;
  return true;
}

// Squared distance (L2) or squared chordal distance (cosine) between two rows, summed in double in
// column order so that an oracle written the plain way finds the same numbers bit for bit.
// `na`, `nb` are the rows' L2 norms (cosine only); a zero row is nobody's neighbour.
inline double squared_descriptor_distance(const DescriptorMatrix& a, std::size_t ra, const DescriptorMatrix& b,
                                          std::size_t rb, bool cosine, double na, double nb) {
  const float* pa = a.data() + static_cast<Eigen::Index>(ra) * a.cols();
  const float* pb = b.data() + static_cast<Eigen::Index>(rb) * b.cols();
  const Eigen::Index n = a.cols();
  double sum = 0.0;
  if (!cosine) {
    for (Eigen::Index c = 0; c < n; ++c) {
      const double d = static_cast<double>(pa[c]) - static_cast<double>(pb[c]);
      sum += d * d;
    }
    return sum;
  }
  if (!(na > 0.0) || !(nb > 0.0)) return std::numeric_limits<double>::infinity();
  for (Eigen::Index c = 0; c < n; ++c) sum += static_cast<double>(pa[c]) * static_cast<double>(pb[c]);
  return std::max(0.0, 2.0 - 2.0 * (sum / (na * nb)));
}

inline std::vector<double> descriptor_row_norms(const DescriptorMatrix& m) {
  std::vector<double> out(static_cast<std::size_t>(m.rows()), 0.0);
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    double s = 0.0;
    for (Eigen::Index c = 0; c < m.cols(); ++c) s += static_cast<double>(m(r, c)) * static_cast<double>(m(r, c));
    out[static_cast<std::size_t>(r)] = std::sqrt(s);
  }
  return out;
}

inline void check_guided_features(const Features& f, const char* which) {
  DIACHRON_CHECK(f.descriptors.rows() == static_cast<Eigen::Index>(f.keypoints.size()),
                 "guided_match: " << which << " has " << f.keypoints.size() << " keypoints but " << f.descriptors.rows()
                                  << " descriptor rows");
  for (std::size_t i = 0; i < f.keypoints.size(); ++i) {
    const Keypoint& k = f.keypoints[i];
    DIACHRON_CHECK(k.position.allFinite() && std::isfinite(k.scale) && k.scale >= 0.0 && std::isfinite(k.angle),
                   "guided_match: " << which << " keypoint " << i << " has position (" << k.position.x() << ", "
                                    << k.position.y() << "), scale " << k.scale << ", angle " << k.angle
                                    << " (finite values and a scale >= 0 are required)");
  }
  check_descriptors_finite(f.descriptors, which);
}

// The two nearest gated candidates of keypoint `from` (of image `from_f`) among the points of
// `to_index` (keypoints of `to_f`) within `radius` of prediction `p`. `reverse`: `from` is a
// secondary keypoint and `p` its prediction into the master image.
inline NearestTwo guided_nearest_two(const Features& from_f, std::size_t from, const std::vector<double>& from_norms,
                                     const Features& to_f, const PointIndex2D& to_index,
                                     const std::vector<double>& to_norms, const GuidedPrediction& p, double radius,
                                     bool reverse, const GuidedMatchOptions& o, double angle_tolerance_rad,
                                     std::size_t* compared = nullptr) {
  NearestTwo best;
  const bool cosine = o.metric == DescriptorDistance::Cosine;
  const Keypoint& kf = from_f.keypoints[from];
  const double scale = reverse ? 1.0 / p.scale : p.scale;
  const double rotation = reverse ? -p.rotation : p.rotation;
  for (const IndexedNeighbor& n : to_index.radius_search(p.position, radius)) {
    const Keypoint& kt = to_f.keypoints[n.index];
    if (!guided_gates_pass(reverse ? kt : kf, reverse ? kf : kt, scale, rotation, o, angle_tolerance_rad)) continue;
    if (compared) ++*compared;
    best.push(squared_descriptor_distance(from_f.descriptors, from, to_f.descriptors, n.index, cosine,
                                          cosine ? from_norms[from] : 0.0, cosine ? to_norms[n.index] : 0.0),
              n.index);
  }
  return best;
}

}  // namespace detail

template <class Transfer, class InverseTransfer>
GuidedMatchResult guided_match(const Features& master, const Features& secondary, const Transfer& forward,
                               const InverseTransfer& inverse, const GuidedMatchOptions& options) {
  static_assert(check_transfer<Transfer>());
  static_assert(check_transfer<InverseTransfer>());
  options.check();
  detail::check_guided_features(master, "master");
  detail::check_guided_features(secondary, "secondary");
  if (!master.empty() && !secondary.empty())
    DIACHRON_CHECK(master.descriptors.cols() == secondary.descriptors.cols() && master.descriptors.cols() > 0,
                   "guided_match: descriptor widths differ or are zero: master "
                       << master.descriptors.cols() << ", secondary " << secondary.descriptors.cols());

  GuidedMatchResult result;
  const std::size_t nm = master.size(), ns = secondary.size();
  const double angle_tol = deg_to_rad(options.angle_tolerance_deg);
  const bool cosine = options.metric == DescriptorDistance::Cosine;
  const std::vector<double> master_norms =
      cosine ? detail::descriptor_row_norms(master.descriptors) : std::vector<double>();
  const std::vector<double> secondary_norms =
      cosine ? detail::descriptor_row_norms(secondary.descriptors) : std::vector<double>();

  std::vector<Eigen::Vector2d> secondary_points(ns);
  for (std::size_t j = 0; j < ns; ++j) secondary_points[j] = secondary.keypoints[j].position;
  const PointIndex2D secondary_index(std::move(secondary_points));

  // Forward pass: slot i belongs to master keypoint i, so the thread count cannot change anything.
  enum class Outcome : unsigned char { no_prediction, no_candidate, failed_ratio, chosen };
  struct Forward {
    Outcome outcome = Outcome::no_prediction;
    detail::NearestTwo nearest;
    std::size_t compared = 0;
  };
  std::vector<Forward> fwd(nm);
  constexpr std::size_t kBlock = 64;
  parallel_for((nm + kBlock - 1) / kBlock, options.threads, [&](std::size_t b) {
    for (std::size_t i = b * kBlock; i < std::min(nm, (b + 1) * kBlock); ++i) {
      Forward& f = fwd[i];
      const GuidedPrediction p = predict_keypoint(forward, master.keypoints[i].position, options.affine_step_px);
      if (!p.valid) continue;
      const double radius = options.search_radius_px * (options.scale_search_radius ? p.scale : 1.0);
      f.nearest = detail::guided_nearest_two(master, i, master_norms, secondary, secondary_index, secondary_norms, p,
                                             radius, false, options, angle_tol, &f.compared);
      if (f.nearest.i1 == detail::kNoNeighbour)
        f.outcome = Outcome::no_candidate;
      else if (options.ratio_test && !(std::sqrt(f.nearest.d1) < options.ratio * std::sqrt(f.nearest.d2)))
        f.outcome = Outcome::failed_ratio;
      else
        f.outcome = Outcome::chosen;
    }
  });

  // Reverse pass, once per distinct chosen secondary keypoint.
  std::vector<std::size_t> reverse_best;
  if (options.mutual) {
    std::vector<char> chosen(ns, 0);
    for (const Forward& f : fwd)
      if (f.outcome == Outcome::chosen) chosen[f.nearest.i1] = 1;
    std::vector<std::size_t> targets;
    for (std::size_t j = 0; j < ns; ++j)
      if (chosen[j]) targets.push_back(j);
    std::vector<Eigen::Vector2d> master_points(nm);
    for (std::size_t i = 0; i < nm; ++i) master_points[i] = master.keypoints[i].position;
    const PointIndex2D master_index(std::move(master_points));
    reverse_best.assign(ns, detail::kNoNeighbour);
    parallel_for(targets.size(), options.threads, [&](std::size_t t) {
      const std::size_t j = targets[t];
      const GuidedPrediction p = predict_keypoint(inverse, secondary.keypoints[j].position, options.affine_step_px);
      if (!p.valid) return;
      reverse_best[j] = detail::guided_nearest_two(secondary, j, secondary_norms, master, master_index, master_norms, p,
                                                   options.search_radius_px, true, options, angle_tol)
                            .i1;
    });
  }

  for (std::size_t i = 0; i < nm; ++i) {
    const Forward& f = fwd[i];
    result.candidates += f.compared;
    switch (f.outcome) {
      case Outcome::no_prediction: ++result.no_prediction; continue;
      case Outcome::no_candidate: ++result.no_candidate; continue;
      case Outcome::failed_ratio: ++result.failed_ratio; continue;
      case Outcome::chosen: break;
    }
    if (options.mutual && reverse_best[f.nearest.i1] != i) {
      ++result.failed_mutual;
      continue;
    }
    GuidedMatch m;
    m.master = i;
    m.secondary = f.nearest.i1;
    m.distance = std::sqrt(f.nearest.d1);
    m.second_distance = std::sqrt(f.nearest.d2);
    m.score = cosine ? 1.0 - 0.5 * f.nearest.d1 : -m.distance;
    result.pairs.push_back(m);
    result.matches.push_back(
        PointMatch{master.keypoints[i].position, secondary.keypoints[m.secondary].position, m.score});
  }
  result.predicted = nm - result.no_prediction;
  result.success = !result.pairs.empty();
  return result;
}

}  // namespace diachron
