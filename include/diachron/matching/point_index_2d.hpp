#pragma once
/// @file
/// PointIndex2D: a KD-tree over 2D points (nanoflann) with radius, k-nearest and box queries that
/// take and return plain (not squared) distances, and that compiles against nanoflann 1.4.x
/// (Debian 12) and >= 1.5 alike.
///
/// Why a wrapper: nanoflann's L2 adaptor takes and returns SQUARED radii and distances (a classic
/// trap, nanoflann #128/#145/#239), and 1.5 renamed SearchParams to SearchParameters and replaced
/// the std::pair results by ResultItem. Here the result sets are our own, so only the search
/// parameter type depends on the version; distances are recomputed exactly from the stored points,
/// so the radius boundary (inclusive) and the order of the results do not depend on nanoflann.
///
/// Threading: building is single-threaded; after construction every query is const and may run
/// concurrently from many threads (nanoflann #54: queries are reentrant).
/// Lifetime: the index owns a copy of the points and keeps them at a stable address, so it may be
/// moved freely (a moved-from index may only be destroyed or assigned to); it is not copyable.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <memory>
#include <vector>

#include <Eigen/Core>

#include <nanoflann.hpp>

#include <diachron/core/error.hpp>

namespace diachron {

/// One query result: the index of a point (in the order given to the constructor) and its
/// Euclidean distance to the query, in the points' units (pixels for image points).
struct IndexedNeighbor {
  std::size_t index = 0;
  double distance = 0.0;
};

namespace detail {

#if NANOFLANN_VERSION >= 0x150
using NanoflannSearchParams = nanoflann::SearchParameters;
#else
using NanoflannSearchParams = nanoflann::SearchParams;
#endif

struct PointCloud2D {
  std::vector<Eigen::Vector2d> points;

  std::size_t kdtree_get_point_count() const { return points.size(); }
  double kdtree_get_pt(std::size_t i, std::size_t dim) const { return points[i][static_cast<Eigen::Index>(dim)]; }
  template <class BBox>
  bool kdtree_get_bbox(BBox&) const {
    return false;
  }
};

// Collects every candidate the tree reports within `radius_sq`; the caller re-checks exactly.
class CollectWithinResultSet {
 public:
  using DistanceType = double;
  using IndexType = std::size_t;

  CollectWithinResultSet(double radius_sq, std::vector<std::size_t>& out) : radius_sq_(radius_sq), out_(out) {}
  void init() {}
  void clear() { out_.clear(); }
  std::size_t size() const { return out_.size(); }
  bool empty() const { return out_.empty(); }
  bool full() const { return true; }
  bool addPoint(double dist, std::size_t index) {
    if (dist <= radius_sq_) out_.push_back(index);
    return true;
  }
  double worstDist() const { return radius_sq_; }
  void sort() {}

 private:
  double radius_sq_;
  std::vector<std::size_t>& out_;
};

// Keeps the k smallest (distance, index), sorted; ties go to the lower index.
class KNearestResultSet {
 public:
  using DistanceType = double;
  using IndexType = std::size_t;

  explicit KNearestResultSet(std::size_t k) : k_(k) { items_.reserve(k + 1); }
  void init() {}
  void clear() { items_.clear(); }
  std::size_t size() const { return items_.size(); }
  bool empty() const { return items_.empty(); }
  bool full() const { return items_.size() == k_; }
  bool addPoint(double dist, std::size_t index) {
    const Item item{dist, index};
    if (full() && !(item < items_.back())) return true;
    items_.insert(std::upper_bound(items_.begin(), items_.end(), item), item);
    if (items_.size() > k_) items_.pop_back();
    return true;
  }
  // Pruning bound: unbounded until k are found, then just above the k-th distance, because
  // nanoflann only offers points strictly closer than the bound and an equally distant point with
  // a lower index must still replace the k-th.
  double worstDist() const {
    return full() ? std::nextafter(items_.back().dist, std::numeric_limits<double>::infinity())
                  : std::numeric_limits<double>::max();
  }
  void sort() {}

  struct Item {
    double dist;
    std::size_t index;
    bool operator<(const Item& o) const { return dist < o.dist || (dist == o.dist && index < o.index); }
  };
  const std::vector<Item>& items() const { return items_; }

 private:
  std::size_t k_;
  std::vector<Item> items_;
};

}  // namespace detail

/// KD-tree over 2D points (see the file comment for threading, lifetime and nanoflann versions).
class PointIndex2D {
 public:
  /// Builds the tree. `leaf_size` is nanoflann's leaf_max_size (10 is its default; larger builds
  /// faster, queries slower). Throws diachron::Error for a non-finite point or leaf_size 0.
  explicit PointIndex2D(std::vector<Eigen::Vector2d> points, std::size_t leaf_size = 10)
      : data_(std::make_unique<detail::PointCloud2D>()) {
    DIACHRON_CHECK(leaf_size > 0, "leaf_size must be positive");
    for (std::size_t i = 0; i < points.size(); ++i)
      DIACHRON_CHECK(points[i].allFinite(), "point " << i << " is not finite: (" << points[i].x() << ", "
                                                     << points[i].y() << ")");
    data_->points = std::move(points);
    // nanoflann's tree keeps a reference to data_, which lives on the heap and so survives moves.
    if (!data_->points.empty())
      tree_ = std::make_unique<Tree>(2, *data_, nanoflann::KDTreeSingleIndexAdaptorParams(leaf_size));
  }

  PointIndex2D(PointIndex2D&&) noexcept = default;
  PointIndex2D& operator=(PointIndex2D&&) noexcept = default;
  PointIndex2D(const PointIndex2D&) = delete;
  PointIndex2D& operator=(const PointIndex2D&) = delete;

  std::size_t size() const { return data_ ? data_->points.size() : 0; }
  bool empty() const { return size() == 0; }
  /// The indexed points, in constructor order.
  const std::vector<Eigen::Vector2d>& points() const { return data_->points; }

  /// All points p with |p - centre| <= radius. `radius` is a plain distance in the points' units
  /// (pixels), NOT squared. Sorted by distance, ties by index. A negative or NaN radius finds nothing.
  std::vector<IndexedNeighbor> radius_search(const Eigen::Vector2d& centre, double radius) const {
    std::vector<IndexedNeighbor> out;
    if (!tree_ || !(radius >= 0.0) || !centre.allFinite()) return out;
    const double r2 = radius * radius;
    std::vector<std::size_t> candidates;
    // A slightly larger squared radius for the tree, because nanoflann's own sum may round
    // differently from ours; the exact test below decides.
    detail::CollectWithinResultSet set(r2 * (1.0 + 1e-9) + 1e-300, candidates);
    tree_->findNeighbors(set, centre.data(), search_params());
    out.reserve(candidates.size());
    for (std::size_t i : candidates) {
      const double d2 = (data_->points[i] - centre).squaredNorm();
      if (d2 <= r2) out.push_back(IndexedNeighbor{i, std::sqrt(d2)});
    }
    sort_neighbors(out);
    return out;
  }

  /// The k nearest points to `query` (fewer when the index has fewer), sorted by distance, ties by
  /// index. Distances are plain, not squared.
  std::vector<IndexedNeighbor> knn_search(const Eigen::Vector2d& query, std::size_t k) const {
    std::vector<IndexedNeighbor> out;
    if (!tree_ || k == 0 || !query.allFinite()) return out;
    detail::KNearestResultSet set(std::min(k, size()));
    tree_->findNeighbors(set, query.data(), search_params());
    out.reserve(set.size());
    for (const auto& item : set.items())
      out.push_back(IndexedNeighbor{item.index, (data_->points[item.index] - query).norm()});
    sort_neighbors(out);
    return out;
  }

  /// All points with |dx| <= half_width and |dy| <= half_height from `centre` (MicMac's guided
  /// search window is such a square box, not a circle). Sorted by distance, ties by index.
  std::vector<IndexedNeighbor> box_search(const Eigen::Vector2d& centre, double half_width,
                                          double half_height) const {
    std::vector<IndexedNeighbor> out;
    if (!(half_width >= 0.0) || !(half_height >= 0.0)) return out;
    for (const IndexedNeighbor& n : radius_search(centre, std::hypot(half_width, half_height))) {
      const Eigen::Vector2d d = data_->points[n.index] - centre;
      if (std::abs(d.x()) <= half_width && std::abs(d.y()) <= half_height) out.push_back(n);
    }
    return out;
  }

 private:
  using Tree = nanoflann::KDTreeSingleIndexAdaptor<
      nanoflann::L2_Simple_Adaptor<double, detail::PointCloud2D, double, std::size_t>, detail::PointCloud2D, 2,
      std::size_t>;

  static detail::NanoflannSearchParams search_params() {
    detail::NanoflannSearchParams p;
    p.eps = 0.0f;
    p.sorted = false;  // our result sets order the results themselves
    return p;
  }

  static void sort_neighbors(std::vector<IndexedNeighbor>& v) {
    std::sort(v.begin(), v.end(), [](const IndexedNeighbor& a, const IndexedNeighbor& b) {
      return a.distance < b.distance || (a.distance == b.distance && a.index < b.index);
    });
  }

  std::unique_ptr<detail::PointCloud2D> data_;
  std::unique_ptr<Tree> tree_;
};

}  // namespace diachron
