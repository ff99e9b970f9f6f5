#pragma once
/// @file
/// XFeat (Potje et al., "XFeat: Accelerated Features for Lightweight Image Matching", CVPR 2024)
/// through OpenCV's DNN module: XFeatExtractor (a FeatureExtractor) and XFeatPairMatcher (a
/// PairMatcher, mutual nearest neighbour on cosine similarity).
///
/// The weights are not part of diachron: users pass the path of the ONNX export at run time (upstream
/// project verlab/accelerated_features, Apache-2.0; see docs/vision.md). The export takes a fixed
/// 1 x 3 x 640 x 640 float input in [0, 1] and returns dense descriptors `output` [1, 64, 80, 80],
/// keypoint logits `1266` [1, 65, 80, 80] and reliability `266` [1, 1, 80, 80].
///
/// Pre-processing of a W x H tile (exact, so keypoints map back without bias):
///   s = 640 / max(W, H), capped at 1 unless `upscale`; the tile is resized to Wr x Hr with
///   Wr = round(W s), Hr = round(H s) (cv::INTER_AREA when shrinking, cv::INTER_LINEAR when
///   enlarging), placed at the top-left of the 640 x 640 input, and the rest is filled by mirroring
///   (cv::BORDER_REFLECT_101) rather than zeros, so that no artificial step edge lines the valid
///   area; gray is replicated on the 3 channels and divided by 255.
///   cv::resize maps pixel centres with half-pixel offsets, so a network pixel (u, v) is the tile
///   point x = (u + 0.5) W / Wr - 0.5, y = (v + 0.5) H / Hr - 0.5 (per-axis ratios: the rounding of
///   Wr and Hr is taken into account). Only keypoints with u < Wr and v < Hr are kept.
/// Post-processing (upstream's XFeat.detectAndCompute, with the differences noted):
///   1. softmax over the 65 logit channels of each 8 x 8 cell; drop the dustbin; channel c of cell
///      (gx, gy) is heatmap pixel (8 gx + c % 8, 8 gy + c / 8) of a 640 x 640 heatmap;
///   2. 5 x 5 non-maximum suppression and the detection threshold (0.05) on that heatmap, as
///      upstream: a pixel is kept when no pixel of its window is strictly larger (ties survive) and
///      its heatmap value exceeds the threshold. The reliability is a sigmoid whose values are often
///      far below 0.05, so thresholding heatmap x reliability would keep almost nothing;
///   3. score = heatmap x reliability, the reliability sampled bilinearly at the keypoint; the top_k
///      (4096) scores are kept, ties broken by raster order;
///   4. descriptors: each 64-vector of the dense map is L2-normalised (as upstream), sampled
///      bilinearly at the keypoint and L2-normalised again. Map coordinates follow the half-pixel
///      (align_corners = false) geometry of a stride-8 map: m = (u + 0.5) / 8 - 0.5, clamped to the
///      map (cell gx covers network pixels 8 gx .. 8 gx + 7, its centre is 8 gx + 3.5). Upstream
///      samples at m = 80 u / 639 - 0.5 with bicubic interpolation; the difference is below 1/16 of
///      a cell.
/// Keypoints carry no scale (0) and no orientation (-1); `response` is the score.
///
/// Threads: a cv::dnn::Net is not safe for concurrent forward passes. The extractor keeps the model
/// bytes in memory and a pool of networks built from them (cv::dnn::readNetFromONNX on the buffer),
/// one per concurrent caller up to `XFeatOptions::max_networks`; callers beyond that wait. Copies of
/// an extractor share the pool, so `extract` and `match` are safe from many threads. OpenCV's own
/// parallelism inside a forward pass (cv::setNumThreads) is left as the application set it; with many
/// diachron threads, cv::setNumThreads(1) avoids oversubscription.

#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>
#include <sys/stat.h>

#include <Eigen/Core>

#include <opencv2/core.hpp>
#include <opencv2/dnn.hpp>
#include <opencv2/imgproc.hpp>

#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/matching/features.hpp>
#include <diachron/matching/point_match.hpp>
#include <diachron/vision/cv_features.hpp>
#include <diachron/vision/extractor_pair_matcher.hpp>
#include <diachron/vision/image.hpp>

namespace diachron {

/// Options of XFeatExtractor; defaults follow upstream XFeat.
struct XFeatOptions {
  /// Keep at most this many keypoints, the best scores (upstream top_k, 4096).
  int top_k = 4096;
  /// Minimum heatmap probability of a keypoint, before the reliability factor (upstream 0.05).
  double detection_threshold = 0.05;
  /// Side of the non-maximum suppression window, in network pixels (odd; upstream 5).
  int nms_window = 5;
  /// Enlarge tiles smaller than 640 px on their longer side to 640 (interpolated). Off by default:
  /// interpolation adds no detail, and the tile keeps its own pixel grid (s = 1, no resampling).
  bool upscale = false;
  /// At most this many networks exist at once (each holds its activations, some tens of MB);
  /// 0 means one per concurrent caller.
  int max_networks = 0;

  void check() const {
    DIACHRON_CHECK(top_k >= 1, "XFeatOptions::top_k must be >= 1, got " << top_k);
    DIACHRON_CHECK(std::isfinite(detection_threshold) && detection_threshold >= 0.0 && detection_threshold < 1.0,
                   "XFeatOptions::detection_threshold must be in [0, 1), got " << detection_threshold);
    DIACHRON_CHECK(nms_window >= 1 && nms_window % 2 == 1,
                   "XFeatOptions::nms_window must be odd and >= 1, got " << nms_window);
    DIACHRON_CHECK(max_networks >= 0, "XFeatOptions::max_networks must be >= 0, got " << max_networks);
  }
};

/// Options of XFeatPairMatcher and match_mutual_cosine.
struct XFeatMatchOptions {
  /// Keep a pair only when its cosine similarity is strictly above this (upstream min_cossim 0.82).
  double min_similarity = 0.82;
  /// Keep a pair only when each descriptor is the other's most similar one (upstream: always on).
  bool mutual = true;

  void check() const {
    DIACHRON_CHECK(std::isfinite(min_similarity) && min_similarity >= -1.0 && min_similarity <= 1.0,
                   "XFeatMatchOptions::min_similarity must be in [-1, 1], got " << min_similarity);
  }
};

/// Nearest neighbours by cosine similarity of unit-norm descriptor rows (XFeat's matching), with
/// the mutual check and the similarity floor of `options`. The returned `distance` is the cosine
/// distance 1 - similarity. Blocked so that memory stays at 256 x rows(b) floats whatever the sizes.
/// Results are sorted by row of A; ties go to the lowest index.
inline std::vector<FeatureIndexMatch> match_mutual_cosine(const Features& a, const Features& b,
                                                          const XFeatMatchOptions& options = {}) {
  options.check();
  DIACHRON_CHECK(static_cast<std::size_t>(a.descriptors.rows()) == a.keypoints.size() &&
                     static_cast<std::size_t>(b.descriptors.rows()) == b.keypoints.size(),
                 "features need one descriptor row per keypoint, got " << a.descriptors.rows() << " rows for "
                     << a.keypoints.size() << " keypoints (A) and " << b.descriptors.rows() << " for "
                     << b.keypoints.size() << " (B)");
  std::vector<FeatureIndexMatch> out;
  if (a.empty() || b.empty()) return out;
  DIACHRON_CHECK(a.descriptors.cols() == b.descriptors.cols(),
                 "descriptor widths differ: " << a.descriptors.cols() << " (A) vs " << b.descriptors.cols() << " (B)");
  const Eigen::Index na = a.descriptors.rows();
  const Eigen::Index nb = b.descriptors.rows();
  std::vector<Eigen::Index> best_of_a(static_cast<std::size_t>(na), 0);
  std::vector<float> sim_of_a(static_cast<std::size_t>(na), -2.0f);
  std::vector<Eigen::Index> best_of_b(static_cast<std::size_t>(nb), 0);
  std::vector<float> sim_of_b(static_cast<std::size_t>(nb), -2.0f);
  constexpr Eigen::Index kBlock = 256;
  Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> s;
  for (Eigen::Index start = 0; start < na; start += kBlock) {
    const Eigen::Index rows = std::min(kBlock, na - start);
    s.noalias() = a.descriptors.middleRows(start, rows) * b.descriptors.transpose();
    for (Eigen::Index r = 0; r < rows; ++r) {
      const std::size_t i = static_cast<std::size_t>(start + r);
      for (Eigen::Index j = 0; j < nb; ++j) {
        const float v = s(r, j);
        if (v > sim_of_a[i]) {
          sim_of_a[i] = v;
          best_of_a[i] = j;
        }
        const std::size_t jj = static_cast<std::size_t>(j);
        if (v > sim_of_b[jj]) {
          sim_of_b[jj] = v;
          best_of_b[jj] = start + r;
        }
      }
    }
  }
  for (Eigen::Index i = 0; i < na; ++i) {
    const std::size_t ii = static_cast<std::size_t>(i);
    const Eigen::Index j = best_of_a[ii];
    if (options.mutual && best_of_b[static_cast<std::size_t>(j)] != i) continue;
    if (!(static_cast<double>(sim_of_a[ii]) > options.min_similarity)) continue;
    out.push_back({ii, static_cast<std::size_t>(j), 1.0 - static_cast<double>(sim_of_a[ii])});
  }
  return out;
}

namespace detail {

/// The model bytes plus a pool of networks built from them (see the file comment on threads).
class XFeatNetPool {
 public:
  XFeatNetPool(std::string path, int max_networks) : path_(std::move(path)), max_networks_(max_networks) {
    struct stat info {};
    DIACHRON_CHECK(::stat(path_.c_str(), &info) == 0, "cannot load the XFeat model '" << path_ << "': no such file");
    DIACHRON_CHECK(S_ISREG(info.st_mode), "cannot load the XFeat model '" << path_ << "': not a regular file");
    std::ifstream file(path_, std::ios::binary);
    DIACHRON_CHECK(file.good(), "cannot load the XFeat model '" << path_ << "': the file cannot be opened");
    bytes_.assign(std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>());
    DIACHRON_CHECK(!file.bad(), "cannot load the XFeat model '" << path_ << "': read error");
    DIACHRON_CHECK(!bytes_.empty(), "cannot load the XFeat model '" << path_ << "': the file is empty");
    idle_.push_back(build());  // fail now, at construction, rather than on the first tile
    created_ = 1;
  }

  const std::string& path() const { return path_; }

  /// A network for the caller's exclusive use; give it back with release().
  std::unique_ptr<cv::dnn::Net> acquire() {
    std::unique_lock<std::mutex> lock(mutex_);
    available_.wait(lock, [&] { return !idle_.empty() || max_networks_ == 0 || created_ < max_networks_; });
    if (!idle_.empty()) {
      std::unique_ptr<cv::dnn::Net> net = std::move(idle_.back());
      idle_.pop_back();
      return net;
    }
    ++created_;
    lock.unlock();
    try {
      return build();
    } catch (...) {
      forget();
      throw;
    }
  }

  void release(std::unique_ptr<cv::dnn::Net> net) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      idle_.push_back(std::move(net));
    }
    available_.notify_one();
  }

  /// A network that was acquired and will not come back (its forward pass failed).
  void forget() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      --created_;
    }
    available_.notify_one();
  }

 private:
  std::unique_ptr<cv::dnn::Net> build() const {
    cv::dnn::Net net;
    try {
      net = cv::dnn::readNetFromONNX(bytes_);
    } catch (const cv::Exception& e) {
      DIACHRON_CHECK(false, "cannot load the XFeat model '" << path_ << "': not a readable ONNX model ("
                                                            << e.what() << ")");
    }
    DIACHRON_CHECK(!net.empty(), "cannot load the XFeat model '" << path_ << "': OpenCV built an empty network");
    for (const char* name : {"output", "1266", "266"})
      DIACHRON_CHECK(net.getLayerId(name) >= 0, "'" << path_ << "' is an ONNX model but not the XFeat export: it "
                                                    << "has no output '" << name << "'");
    return std::make_unique<cv::dnn::Net>(std::move(net));
  }

  std::string path_;
  int max_networks_;
  std::vector<uchar> bytes_;
  std::mutex mutex_;
  std::condition_variable available_;
  std::vector<std::unique_ptr<cv::dnn::Net>> idle_;
  int created_ = 0;
};

/// Bilinear sample of a row-major `size` x `size` map at map coordinates (mx, my), clamped to the map.
inline float sample_bilinear(const float* map, int size, double mx, double my) {
  mx = std::clamp(mx, 0.0, static_cast<double>(size - 1));
  my = std::clamp(my, 0.0, static_cast<double>(size - 1));
  // Upper cells clamp to size - 2 so that x0 + 1 stays inside; fx = 1 then lands on the last cell.
  const int x0 = std::max(0, std::min(static_cast<int>(mx), size - 2));
  const int y0 = std::max(0, std::min(static_cast<int>(my), size - 2));
  const int x1 = std::min(x0 + 1, size - 1);
  const int y1 = std::min(y0 + 1, size - 1);
  const double fx = mx - x0;
  const double fy = my - y0;
  const double top = (1.0 - fx) * map[y0 * size + x0] + fx * map[y0 * size + x1];
  const double bottom = (1.0 - fx) * map[y1 * size + x0] + fx * map[y1 * size + x1];
  return static_cast<float>((1.0 - fy) * top + fy * bottom);
}

inline void check_blob(const cv::Mat& blob, int channels, int size, const char* name, const std::string& path) {
  DIACHRON_CHECK(blob.dims == 4 && blob.size[0] == 1 && blob.size[1] == channels && blob.size[2] == size &&
                     blob.size[3] == size && blob.type() == CV_32F && blob.isContinuous(),
                 "the XFeat model '" << path << "' returned an unexpected '" << name << "' blob (expected 1 x "
                                     << channels << " x " << size << " x " << size << " float)");
}

}  // namespace detail

/// FeatureExtractor running XFeat on an 8-bit raster of any size (see the file comment for the
/// exact pre- and post-processing). Descriptors: 64 floats, unit L2 norm; compare with cosine
/// similarity (DescriptorMetric::Cosine).
class XFeatExtractor {
 public:
  /// Network input side, in pixels.
  static constexpr int kInputSize = 640;
  /// Network output stride (cell side), in pixels.
  static constexpr int kCell = 8;
  /// Side of the output maps, in cells.
  static constexpr int kGrid = kInputSize / kCell;
  /// Descriptor length.
  static constexpr int kDescriptorSize = 64;

  /// Loads the ONNX file at `onnx_path` once. Throws diachron::Error naming the path and the reason
  /// when the file is missing, unreadable, not ONNX, or not the XFeat export.
  explicit XFeatExtractor(const std::string& onnx_path, XFeatOptions options = {})
      : options_((options.check(), options)),
        pool_(std::make_shared<detail::XFeatNetPool>(onnx_path, options.max_networks)) {}

  const XFeatOptions& options() const { return options_; }
  const std::string& model_path() const { return pool_->path(); }
  static constexpr DescriptorMetric descriptor_metric() { return DescriptorMetric::Cosine; }

  /// The same, keeping only keypoints where `mask` (the image's size) is nonzero. The network has
  /// no mask input: the top_k keypoints are detected on the whole image and the masked ones
  /// dropped, so fewer than top_k may remain.
  Features extract(const Raster<std::uint8_t>& image, const Raster<std::uint8_t>& mask) const {
    detail::check_mask_size(image, mask, "XFeatExtractor");
    Features out = extract(image);
    drop_masked_features(out, mask);
    return out;
  }

  /// Keypoints (tile pixels, scale 0, no angle, response = score) and unit 64-float descriptors,
  /// best score first. An empty raster throws diachron::Error.
  Features extract(const Raster<std::uint8_t>& image) const {
    DIACHRON_CHECK(!image.empty(), "XFeatExtractor: the image is empty");
    const int w = image.width();
    const int h = image.height();
    double s = static_cast<double>(kInputSize) / std::max(w, h);
    if (!options_.upscale) s = std::min(s, 1.0);
    const int wr = std::clamp(static_cast<int>(std::lround(w * s)), 1, kInputSize);
    const int hr = std::clamp(static_cast<int>(std::lround(h * s)), 1, kInputSize);

    const cv::Mat blob = make_input(image, wr, hr);
    std::vector<cv::Mat> outs = forward(blob);
    detail::check_blob(outs[0], kDescriptorSize, kGrid, "output", model_path());
    detail::check_blob(outs[1], kDescriptorSize + 1, kGrid, "1266", model_path());
    detail::check_blob(outs[2], 1, kGrid, "266", model_path());

    const std::vector<float> heat = heatmap(outs[1].ptr<float>());
    const std::vector<Candidate> kept = detect(heat, outs[2].ptr<float>(), wr, hr);

    const double ratio_x = static_cast<double>(w) / wr;
    const double ratio_y = static_cast<double>(h) / hr;
    const std::vector<float> dense = normalised_dense(outs[0].ptr<float>());
    Features out;
    out.keypoints.reserve(kept.size());
    out.descriptors.resize(static_cast<Eigen::Index>(kept.size()), kDescriptorSize);
    constexpr int kMapArea = kGrid * kGrid;
    for (std::size_t k = 0; k < kept.size(); ++k) {
      const int u = kept[k].index % kInputSize;
      const int v = kept[k].index / kInputSize;
      Keypoint kp;
      kp.position = Vec2((u + 0.5) * ratio_x - 0.5, (v + 0.5) * ratio_y - 0.5);
      kp.scale = 0.0;
      kp.angle = -1.0;
      kp.response = kept[k].score;
      out.keypoints.push_back(kp);
      const double mx = (u + 0.5) / kCell - 0.5;
      const double my = (v + 0.5) / kCell - 0.5;
      auto row = out.descriptors.row(static_cast<Eigen::Index>(k));
      for (int c = 0; c < kDescriptorSize; ++c)
        row(c) = detail::sample_bilinear(dense.data() + static_cast<std::size_t>(c) * kMapArea, kGrid, mx, my);
      const float norm = row.norm();
      if (norm > 0.0f) row /= norm;
    }
    return out;
  }

 private:
  struct Candidate {
    int index;  // v * 640 + u in the network input
    double score;
  };

  cv::Mat make_input(const Raster<std::uint8_t>& image, int wr, int hr) const {
    cv::Mat resized;
    try {
      const cv::Mat src = as_mat(image);
      if (wr == image.width() && hr == image.height()) {
        resized = src;
      } else {
        const bool shrink = wr < image.width() || hr < image.height();
        cv::resize(src, resized, cv::Size(wr, hr), 0, 0, shrink ? cv::INTER_AREA : cv::INTER_LINEAR);
      }
      cv::Mat padded;
      cv::copyMakeBorder(resized, padded, 0, kInputSize - hr, 0, kInputSize - wr, cv::BORDER_REFLECT_101);
      const int dims[4] = {1, 3, kInputSize, kInputSize};
      cv::Mat blob(4, dims, CV_32F);
      cv::Mat plane0(kInputSize, kInputSize, CV_32F, blob.ptr<float>(0, 0));
      padded.convertTo(plane0, CV_32F, 1.0 / 255.0);
      for (int c = 1; c < 3; ++c) plane0.copyTo(cv::Mat(kInputSize, kInputSize, CV_32F, blob.ptr<float>(0, c)));
      return blob;
    } catch (const cv::Exception& e) {
      DIACHRON_CHECK(false, "XFeatExtractor: preparing a " << image.width() << " x " << image.height()
                                                           << " tile failed in OpenCV: " << e.what());
    }
    return cv::Mat();
  }

  std::vector<cv::Mat> forward(const cv::Mat& blob) const {
    // Returns the network to the pool on every path; one whose forward pass failed is dropped.
    struct Lease {
      detail::XFeatNetPool& pool;
      std::unique_ptr<cv::dnn::Net> net;
      bool healthy = false;
      ~Lease() {
        if (healthy) {
          pool.release(std::move(net));
        } else {
          pool.forget();
        }
      }
    };
    Lease lease{*pool_, pool_->acquire()};
    std::vector<cv::Mat> outs;
    try {
      lease.net->setInput(blob);
      lease.net->forward(outs, std::vector<cv::String>{"output", "1266", "266"});
      // The output Mats may share memory with the network's internal blobs, which the next forward
      // pass (possibly another thread's, once the network is back in the pool) overwrites: own them.
      for (cv::Mat& out : outs) out = out.clone();
    } catch (const cv::Exception& e) {
      DIACHRON_CHECK(false, "XFeatExtractor: the forward pass of '" << model_path() << "' failed: " << e.what());
    }
    lease.healthy = true;
    DIACHRON_CHECK(outs.size() == 3, "the XFeat model '" << model_path() << "' returned " << outs.size()
                                                         << " outputs instead of 3");
    return outs;
  }

  /// Softmax over the 65 channels of each cell, dustbin dropped, unfolded to 640 x 640.
  static std::vector<float> heatmap(const float* logits) {
    constexpr int kMapArea = kGrid * kGrid;
    constexpr int kChannels = kCell * kCell + 1;
    std::vector<float> heat(static_cast<std::size_t>(kInputSize) * kInputSize);
    double e[kChannels];
    for (int gy = 0; gy < kGrid; ++gy) {
      for (int gx = 0; gx < kGrid; ++gx) {
        const int cell = gy * kGrid + gx;
        double top = logits[cell];
        for (int c = 1; c < kChannels; ++c) top = std::max(top, static_cast<double>(logits[c * kMapArea + cell]));
        double sum = 0.0;
        for (int c = 0; c < kChannels; ++c) sum += (e[c] = std::exp(logits[c * kMapArea + cell] - top));
        for (int c = 0; c + 1 < kChannels; ++c) {
          const int u = gx * kCell + c % kCell;
          const int v = gy * kCell + c / kCell;
          heat[static_cast<std::size_t>(v) * kInputSize + static_cast<std::size_t>(u)] =
              static_cast<float>(e[c] / sum);
        }
      }
    }
    return heat;
  }

  /// NMS and threshold on the heatmap inside the valid wr x hr area, score with the reliability,
  /// keep the top_k by score (ties by raster order).
  std::vector<Candidate> detect(const std::vector<float>& heat, const float* reliability, int wr, int hr) const {
    const int r = options_.nms_window / 2;
    const float threshold = static_cast<float>(options_.detection_threshold);
    std::vector<Candidate> candidates;
    for (int v = 0; v < hr; ++v) {
      for (int u = 0; u < wr; ++u) {
        const float value = heat[static_cast<std::size_t>(v) * kInputSize + static_cast<std::size_t>(u)];
        if (!(value > threshold)) continue;
        bool is_max = true;
        for (int y = std::max(0, v - r); y <= std::min(kInputSize - 1, v + r) && is_max; ++y)
          for (int x = std::max(0, u - r); x <= std::min(kInputSize - 1, u + r); ++x)
            if (heat[static_cast<std::size_t>(y) * kInputSize + static_cast<std::size_t>(x)] > value) {
              is_max = false;
              break;
            }
        if (!is_max) continue;
        const double rel = detail::sample_bilinear(reliability, kGrid, (u + 0.5) / kCell - 0.5, (v + 0.5) / kCell - 0.5);
        candidates.push_back({v * kInputSize + u, static_cast<double>(value) * rel});
      }
    }
    const auto better = [](const Candidate& l, const Candidate& r2) {
      return l.score > r2.score || (l.score == r2.score && l.index < r2.index);
    };
    const std::size_t k = std::min(candidates.size(), static_cast<std::size_t>(options_.top_k));
    std::partial_sort(candidates.begin(), candidates.begin() + static_cast<std::ptrdiff_t>(k), candidates.end(),
                      better);
    candidates.resize(k);
    return candidates;
  }

  /// The dense descriptor map with every cell's 64-vector L2-normalised (upstream F.normalize).
  static std::vector<float> normalised_dense(const float* dense) {
    constexpr int kMapArea = kGrid * kGrid;
    std::vector<float> out(dense, dense + static_cast<std::size_t>(kDescriptorSize) * kMapArea);
    for (int cell = 0; cell < kMapArea; ++cell) {
      double sq = 0.0;
      for (int c = 0; c < kDescriptorSize; ++c) sq += static_cast<double>(out[c * kMapArea + cell]) * out[c * kMapArea + cell];
      // Same guard as torch's F.normalize (eps 1e-12 on the norm).
      const float inv = static_cast<float>(1.0 / std::max(std::sqrt(sq), 1e-12));
      for (int c = 0; c < kDescriptorSize; ++c) out[c * kMapArea + cell] *= inv;
    }
    return out;
  }

  XFeatOptions options_;
  std::shared_ptr<detail::XFeatNetPool> pool_;
};

/// PairMatcher running XFeat on both rasters and matching by mutual nearest neighbour on cosine
/// similarity (similarity > 0.82 by default, as upstream). `PointMatch::score` is the cosine
/// similarity. Thread-safe (see the file comment).
class XFeatPairMatcher {
 public:
  /// Loads the model at `onnx_path` (errors as XFeatExtractor).
  explicit XFeatPairMatcher(const std::string& onnx_path, XFeatOptions options = {},
                            XFeatMatchOptions match_options = {})
      : XFeatPairMatcher(XFeatExtractor(onnx_path, options), match_options) {}
  /// Shares `extractor`'s loaded model and network pool.
  explicit XFeatPairMatcher(XFeatExtractor extractor, XFeatMatchOptions match_options = {})
      : extractor_(std::move(extractor)), options_(match_options) {
    options_.check();
  }

  const XFeatExtractor& extractor() const { return extractor_; }
  const XFeatMatchOptions& options() const { return options_; }

  /// Matches of raster `a` (master) against raster `b` (secondary), in each raster's pixels.
  std::vector<PointMatch> match(const Raster<std::uint8_t>& a, const Raster<std::uint8_t>& b) const {
    return match(extractor_.extract(a), extractor_.extract(b));
  }

  /// The same, with features only where the masks (each its image's size) are nonzero.
  std::vector<PointMatch> match(const Raster<std::uint8_t>& a, const Raster<std::uint8_t>& b,
                                const Raster<std::uint8_t>& mask_a, const Raster<std::uint8_t>& mask_b) const {
    return match(extractor_.extract(a, mask_a), extractor_.extract(b, mask_b));
  }

  /// Matches of already extracted XFeat features.
  std::vector<PointMatch> match(const Features& a, const Features& b) const {
    std::vector<PointMatch> out;
    for (const FeatureIndexMatch& m : match_mutual_cosine(a, b, options_))
      out.push_back({a.keypoints[m.a].position, b.keypoints[m.b].position, 1.0 - m.distance});
    return out;
  }

 private:
  XFeatExtractor extractor_;
  XFeatMatchOptions options_;
};

}  // namespace diachron
