#pragma once
/// @file
/// Brute-force nearest-neighbour matching of descriptor rows (L2 or cosine), with Lowe's ratio test,
/// mutual nearest neighbours and distance / similarity thresholds, plus the RootSIFT transform.
///
/// The ratio test tracks the two nearest neighbours correctly: when a new best is found the old best
/// becomes the second best. MicMac's MatchOneWay keeps the old second best instead, which makes its
/// 0.8 test weaker than Lowe's (reference/micmac-tiephistorical.md section 3); this one does not.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <mutex>
#include <vector>

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/core/parallel.hpp>
#include <diachron/matching/features.hpp>
#include <diachron/matching/point_match.hpp>

namespace diachron {

/// How two descriptor rows are compared.
enum class DescriptorDistance {
  L2,      ///< Euclidean distance (SIFT, RootSIFT)
  Cosine,  ///< cosine similarity s = a.b / (|a| |b|); the inner product for unit descriptors (XFeat)
};

/// Options of match_descriptors. Defaults follow MicMac's guided matching: ratio 0.8, mutual NN.
struct DescriptorMatchOptions {
  DescriptorDistance metric = DescriptorDistance::L2;
  /// Lowe's ratio test on distances: keep a match when best < ratio * second best (strict, so a
  /// query with two equally near neighbours is ambiguous and dropped). MicMac hard-codes 0.8.
  bool ratio_test = true;
  double ratio = 0.8;  ///< in (0, 1]
  /// Also apply the ratio test from the train side (the matched train row's two nearest query rows),
  /// as MicMac does when it runs MatchOneWay in both directions. Off: the test is one-way (Lowe).
  bool ratio_test_both_ways = false;
  /// Keep (q, t) only when q is also the nearest query row of t (MicMac's MutualNN = 1).
  bool mutual = true;
  /// Drop matches whose distance exceeds this (distance units: see DescriptorMatch::distance).
  double max_distance = std::numeric_limits<double>::infinity();
  /// Cosine metric only: drop matches whose cosine similarity is below this. -1 keeps all; XFeat's
  /// own matcher uses 0.82.
  double min_similarity = -1.0;
  /// Worker threads over blocks of query rows; 0 = all cores. The output does not depend on it.
  std::size_t threads = 0;

  void check() const {
    DIACHRON_CHECK(ratio > 0.0 && ratio <= 1.0, "ratio must be in (0, 1], got " << ratio);
    DIACHRON_CHECK(!(max_distance < 0.0) && !std::isnan(max_distance),
                   "max_distance must be >= 0, got " << max_distance);
    DIACHRON_CHECK(min_similarity >= -1.0 && min_similarity <= 1.0,
                   "min_similarity must be in [-1, 1], got " << min_similarity);
  }
};

/// One match between query row `query` and train row `train`.
struct DescriptorMatch {
  std::size_t query = 0;
  std::size_t train = 0;
  /// L2: Euclidean distance. Cosine: the chordal distance sqrt(2 - 2 s) between the normalised
  /// rows, so the ratio test and max_distance mean the same thing for both metrics.
  double distance = 0.0;
  /// Distance from the query row to its second-nearest train row (+inf when there is none).
  double second_distance = std::numeric_limits<double>::infinity();
  /// Higher is better, as PointMatch::score: the cosine similarity (Cosine) or -distance (L2).
  double score = 0.0;
};

namespace detail {

inline constexpr std::size_t kNoNeighbour = std::numeric_limits<std::size_t>::max();

// The two nearest candidates seen so far, under the total order (distance, index): ties go to the
// lower index, which makes the result independent of the order candidates arrive in.
struct NearestTwo {
  double d1 = std::numeric_limits<double>::infinity();
  std::size_t i1 = kNoNeighbour;
  double d2 = std::numeric_limits<double>::infinity();
  std::size_t i2 = kNoNeighbour;

  static bool before(double da, std::size_t ia, double db, std::size_t ib) {
    return da < db || (da == db && ia < ib);
  }
  void push(double d, std::size_t i) {
    if (i == kNoNeighbour || !(d < std::numeric_limits<double>::infinity())) return;
    if (before(d, i, d1, i1)) {
      d2 = d1;  // the old best is now the second best (MicMac forgets this)
      i2 = i1;
      d1 = d;
      i1 = i;
    } else if (before(d, i, d2, i2)) {
      d2 = d;
      i2 = i;
    }
  }
  void merge(const NearestTwo& other) {
    push(other.d1, other.i1);
    push(other.d2, other.i2);
  }
};

using DescriptorMatrixD = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

inline void check_descriptors_finite(const DescriptorMatrix& m, const char* which) {
  for (Eigen::Index r = 0; r < m.rows(); ++r)
    for (Eigen::Index c = 0; c < m.cols(); ++c)
      DIACHRON_CHECK(std::isfinite(m(r, c)),
                     which << " descriptor row " << r << " column " << c << " is not finite");
}

}  // namespace detail

/// Matches every row of `query` to its nearest row of `train` (brute force) and filters the pairs
/// with the ratio test, mutual check and thresholds of `options`.
/// @return matches sorted by query row; at most one per query row, and with `mutual` at most one per
///         train row. Empty when either matrix has no row.
/// Throws diachron::Error when the column counts differ or a value is not finite.
/// Cost: O(rows_q * rows_t * cols) as a blocked matrix product in double precision; parallel over
/// blocks of query rows, deterministic whatever the thread count (ties go to the lower index).
inline std::vector<DescriptorMatch> match_descriptors(const DescriptorMatrix& query,
                                                      const DescriptorMatrix& train,
                                                      const DescriptorMatchOptions& options = {}) {
  options.check();
  if (query.rows() == 0 || train.rows() == 0) return {};
  DIACHRON_CHECK(query.cols() == train.cols(), "descriptor lengths differ: query "
                                                   << query.cols() << ", train " << train.cols());
  DIACHRON_CHECK(query.cols() > 0, "descriptors have no column");
  detail::check_descriptors_finite(query, "query");
  detail::check_descriptors_finite(train, "train");

  const std::size_t nq = static_cast<std::size_t>(query.rows());
  const std::size_t nt = static_cast<std::size_t>(train.rows());
  const bool cosine = options.metric == DescriptorDistance::Cosine;
  const bool need_backward = options.mutual || options.ratio_test_both_ways;

  // Double precision keeps |q|^2 + |t|^2 - 2 q.t accurate enough that near ties are decided the
  // same way as by a direct sum of squared differences.
  const detail::DescriptorMatrixD q = query.cast<double>();
  const detail::DescriptorMatrixD t = train.cast<double>();
  const Eigen::VectorXd qn = q.rowwise().squaredNorm();
  const Eigen::VectorXd tn = t.rowwise().squaredNorm();
  // Cosine: a zero row has no direction, so it is nobody's neighbour (infinite distance).
  const Eigen::VectorXd q_inv = qn.unaryExpr([](double v) { return v > 0.0 ? 1.0 / std::sqrt(v) : 0.0; });
  const Eigen::VectorXd t_inv = tn.unaryExpr([](double v) { return v > 0.0 ? 1.0 / std::sqrt(v) : 0.0; });

  constexpr std::size_t kQueryBlock = 128;
  constexpr std::size_t kTrainBlock = 1024;
  const std::size_t blocks = (nq + kQueryBlock - 1) / kQueryBlock;

  std::vector<detail::NearestTwo> forward(nq);
  std::vector<detail::NearestTwo> backward(need_backward ? nt : 0);
  std::mutex backward_mutex;

  parallel_for(blocks, options.threads, [&](std::size_t b) {
    const std::size_t q0 = b * kQueryBlock;
    const std::size_t qcount = std::min(kQueryBlock, nq - q0);
    std::vector<detail::NearestTwo> local_backward(need_backward ? nt : 0);
    Eigen::MatrixXd dots;
    for (std::size_t t0 = 0; t0 < nt; t0 += kTrainBlock) {
      const std::size_t tcount = std::min(kTrainBlock, nt - t0);
      dots.noalias() = q.middleRows(static_cast<Eigen::Index>(q0), static_cast<Eigen::Index>(qcount)) *
                       t.middleRows(static_cast<Eigen::Index>(t0), static_cast<Eigen::Index>(tcount))
                           .transpose();
      for (std::size_t j = 0; j < tcount; ++j) {
        const std::size_t tj = t0 + j;
        for (std::size_t i = 0; i < qcount; ++i) {
          const std::size_t qi = q0 + i;
          const double dot = dots(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j));
          const double qq = qn[static_cast<Eigen::Index>(qi)], tt = tn[static_cast<Eigen::Index>(tj)];
          // Squared distances order the same as distances: the square roots wait for the winners.
          double d;
          if (cosine)
            d = (qq > 0.0 && tt > 0.0)
                    ? std::max(0.0, 2.0 - 2.0 * dot * q_inv[static_cast<Eigen::Index>(qi)] *
                                               t_inv[static_cast<Eigen::Index>(tj)])
                    : std::numeric_limits<double>::infinity();
          else
            d = std::max(0.0, qq + tt - 2.0 * dot);
          forward[qi].push(d, tj);
          if (need_backward) local_backward[tj].push(d, qi);
        }
      }
    }
    if (need_backward) {
      // Merging keeps the two smallest under a total order, so the merge order does not matter.
      std::lock_guard<std::mutex> lock(backward_mutex);
      for (std::size_t j = 0; j < nt; ++j) backward[j].merge(local_backward[j]);
    }
  });

  // From squared to plain distances (sqrt is monotonic, so the neighbours do not change).
  auto to_distance = [](detail::NearestTwo& n) {
    n.d1 = std::sqrt(n.d1);
    n.d2 = std::sqrt(n.d2);
  };
  for (auto& n : forward) to_distance(n);
  for (auto& n : backward) to_distance(n);

  std::vector<DescriptorMatch> out;
  for (std::size_t i = 0; i < nq; ++i) {
    const detail::NearestTwo& f = forward[i];
    if (f.i1 == detail::kNoNeighbour) continue;
    if (f.d1 > options.max_distance) continue;
    const double similarity = 1.0 - 0.5 * f.d1 * f.d1;
    if (cosine && similarity < options.min_similarity) continue;
    if (options.ratio_test && !(f.d1 < options.ratio * f.d2)) continue;
    if (need_backward) {
      const detail::NearestTwo& g = backward[f.i1];
      if (options.mutual && g.i1 != i) continue;
      if (options.ratio_test_both_ways && (g.i1 != i || !(g.d1 < options.ratio * g.d2))) continue;
    }
    DescriptorMatch m;
    m.query = i;
    m.train = f.i1;
    m.distance = f.d1;
    m.second_distance = f.d2;
    m.score = cosine ? similarity : -f.d1;
    out.push_back(m);
  }
  return out;
}

/// Turns descriptor matches into point matches: a = query keypoint position, b = train keypoint
/// position, score = DescriptorMatch::score. Throws diachron::Error when an index is out of range.
inline std::vector<PointMatch> to_point_matches(const std::vector<DescriptorMatch>& matches,
                                                const Features& query, const Features& train) {
  std::vector<PointMatch> out;
  out.reserve(matches.size());
  for (const DescriptorMatch& m : matches) {
    DIACHRON_CHECK(m.query < query.keypoints.size() && m.train < train.keypoints.size(),
                   "match (" << m.query << ", " << m.train << ") outside " << query.keypoints.size()
                             << " query and " << train.keypoints.size() << " train keypoints");
    out.push_back(PointMatch{query.keypoints[m.query].position, train.keypoints[m.train].position,
                             m.score});
  }
  return out;
}

/// RootSIFT (Arandjelovic and Zisserman, 2012), in place: each row is divided by its L1 norm, then
/// every element replaced by its square root, so the L2 distance of the results is the Hellinger
/// distance of the originals and every non-zero row has unit L2 norm. Zero rows stay zero.
/// Throws diachron::Error for negative or non-finite entries (SIFT descriptors are histograms).
inline void root_sift_in_place(DescriptorMatrix& descriptors) {
  for (Eigen::Index r = 0; r < descriptors.rows(); ++r) {
    double l1 = 0.0;
    for (Eigen::Index c = 0; c < descriptors.cols(); ++c) {
      const float v = descriptors(r, c);
      DIACHRON_CHECK(std::isfinite(v) && v >= 0.0f,
                     "RootSIFT needs non-negative finite entries, row " << r << " column " << c
                                                                         << " is " << v);
      l1 += v;
    }
    if (l1 <= 0.0) continue;
    for (Eigen::Index c = 0; c < descriptors.cols(); ++c)
      descriptors(r, c) = static_cast<float>(std::sqrt(descriptors(r, c) / l1));
  }
}

/// RootSIFT of a copy of `descriptors` (see root_sift_in_place).
inline DescriptorMatrix root_sift(DescriptorMatrix descriptors) {
  root_sift_in_place(descriptors);
  return descriptors;
}

}  // namespace diachron
