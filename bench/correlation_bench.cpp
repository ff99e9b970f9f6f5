/// @file
/// Correlation search benchmark: diachron::correlation_surface (intensity measure, no
/// anti-aliasing, so both sides compute the same thing) side by side with the OpenCV way of doing
/// the same per point: cv::warpAffine of the search region through the local affine (bilinear),
/// then cv::matchTemplate with TM_CCOEFF_NORMED of the master window over it. Same points, same
/// windows (21 px), same search (+-12 px), one thread. Also the cost of the gradient and
/// orientation measures and of correlation_match's full per-point work (peak, sub-pixel rounds).
/// Prints Markdown on stdout; docs/benchmarks.md ("Correlation search") pastes it.
/// Options: --points N (2000), --repeats R (3).

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include <diachron/core/random.hpp>
#include <diachron/matching/correlation_matcher.hpp>
#include <diachron/terrain/transfer.hpp>
#include <diachron/vision/image.hpp>

using namespace diachron;

namespace {

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// Smoothed noise: texture at several scales, no repetition.
Raster<std::uint8_t> texture(int w, int h, std::uint64_t seed) {
  RandomStream rng(seed);
  cv::Mat img(h, w, CV_32F);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) img.at<float>(y, x) = static_cast<float>(rng.uniform(0.0, 1.0));
  cv::GaussianBlur(img, img, cv::Size(0, 0), 2.0);
  cv::normalize(img, img, 0, 255, cv::NORM_MINMAX);
  cv::Mat out;
  img.convertTo(out, CV_8U);
  return to_raster<std::uint8_t>(out);
}

}  // namespace

int main(int argc, char** argv) {
  int points_n = 2000, repeats = 3;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--points") points_n = std::stoi(argv[i + 1]);
    else if (a == "--repeats") repeats = std::stoi(argv[i + 1]);
  }
  cv::setNumThreads(1);
  const Raster<std::uint8_t> master = texture(1200, 900, 1);
  // The secondary: the master turned by 0.3 rad and scaled by 1.3, about the image centre.
  Eigen::Matrix2d linear = 1.3 * Eigen::Rotation2Dd(0.3).toRotationMatrix();
  const Eigen::Vector2d centre(600, 450), offset(800, 600);
  cv::Mat warp = (cv::Mat_<double>(2, 3) << linear(0, 0), linear(0, 1), offset.x() - (linear * centre).x(),
                  linear(1, 0), linear(1, 1), offset.y() - (linear * centre).y());
  cv::Mat secondary_mat;
  cv::warpAffine(as_mat(master), secondary_mat, warp, cv::Size(1600, 1200), cv::INTER_LINEAR);
  const Raster<std::uint8_t> secondary = to_raster<std::uint8_t>(secondary_mat);
  const auto truth = [&](const Eigen::Vector2d& p) { return Eigen::Vector2d(linear * (p - centre) + offset); };

  RandomStream rng(2);
  std::vector<Eigen::Vector2d> points, predictions;
  for (int i = 0; i < points_n; ++i) {
    // One draw per statement, y before x (core/random.hpp, "Order of draws").
    const double ay = std::round(rng.uniform(250.0, 650.0));
    const Eigen::Vector2d a(std::round(rng.uniform(300.0, 900.0)), ay);
    points.push_back(a);
    const double ey = rng.uniform(-6.0, 6.0);
    predictions.push_back(truth(a) + Eigen::Vector2d(rng.uniform(-6.0, 6.0), ey));
  }
  CorrelationMatchOptions options;
  options.measure = CorrelationMeasure::intensity;
  options.antialias = false;
  options.threads = 1;
  const int w = options.window_px, r = options.search_radius_px, half = w / 2, region = w + 2 * r;

  // Ours: the surface alone.
  double ours = 1e30, peer = 1e30;
  std::size_t agree = 0;
  std::vector<Eigen::Vector2i> ours_peak(points.size()), peer_peak(points.size());
  for (int rep = 0; rep < repeats; ++rep) {
    auto t = std::chrono::steady_clock::now();
    for (std::size_t i = 0; i < points.size(); ++i) {
      const Eigen::MatrixXd s = correlation_surface(master, points[i], secondary, predictions[i], linear, options);
      Eigen::Index y = 0, x = 0;
      s.maxCoeff(&y, &x);
      ours_peak[i] = Eigen::Vector2i(static_cast<int>(x), static_cast<int>(y));
    }
    ours = std::min(ours, seconds_since(t));
    // The peer: warp the search region into the master geometry, then matchTemplate.
    t = std::chrono::steady_clock::now();
    cv::Mat patch, result;
    for (std::size_t i = 0; i < points.size(); ++i) {
      const Eigen::Vector2d b0 = predictions[i] - linear * Eigen::Vector2d(half + r, half + r);
      const cv::Mat m = (cv::Mat_<double>(2, 3) << linear(0, 0), linear(0, 1), b0.x(), linear(1, 0), linear(1, 1),
                         b0.y());
      cv::warpAffine(secondary_mat, patch, m, cv::Size(region, region), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP);
      const cv::Rect window(static_cast<int>(points[i].x()) - half, static_cast<int>(points[i].y()) - half, w, w);
      // Integer master points on both sides (the peer cannot place a window at a fraction).
      cv::matchTemplate(patch, as_mat(master)(window), result, cv::TM_CCOEFF_NORMED);
      cv::Point loc;
      cv::minMaxLoc(result, nullptr, nullptr, nullptr, &loc);
      peer_peak[i] = Eigen::Vector2i(loc.x, loc.y);
    }
    peer = std::min(peer, seconds_since(t));
  }
  for (std::size_t i = 0; i < points.size(); ++i) agree += ours_peak[i] == peer_peak[i];

  std::printf("| what (%d points, 21 px window, +-12 px, 1 thread, best of %d) | us / point |\n|---|---|\n", points_n,
              repeats);
  std::printf("| diachron correlation_surface, intensity | %.1f |\n", 1e6 * ours / points_n);
  std::printf("| OpenCV warpAffine + matchTemplate (TM_CCOEFF_NORMED) | %.1f |\n", 1e6 * peer / points_n);
  for (const CorrelationMeasure m : {CorrelationMeasure::gradient, CorrelationMeasure::orientation}) {
    CorrelationMatchOptions o = options;
    o.measure = m;
    double best = 1e30;
    for (int rep = 0; rep < repeats; ++rep) {
      const auto t = std::chrono::steady_clock::now();
      for (std::size_t i = 0; i < points.size(); ++i)
        (void)correlation_surface(master, points[i], secondary, predictions[i], linear, o);
      best = std::min(best, seconds_since(t));
    }
    std::printf("| diachron correlation_surface, %s | %.1f |\n", to_string(m), 1e6 * best / points_n);
  }
  {
    CorrelationMatchOptions o;  // the defaults: orientation, anti-aliasing, sub-pixel rounds
    o.threads = 1;
    const auto transfer = make_map_transfer([&](const Eigen::Vector2d& p) {
      return Eigen::Vector2d(truth(p) + Eigen::Vector2d(3.0, -2.0));
    });
    double best = 1e30;
    std::size_t matched = 0;
    for (int rep = 0; rep < repeats; ++rep) {
      const auto t = std::chrono::steady_clock::now();
      matched = correlation_match(master, secondary, points, transfer, o).matches.size();
      best = std::min(best, seconds_since(t));
    }
    std::printf("| diachron correlation_match, defaults (orientation, anti-aliasing, peak, 3 sub-pixel rounds) | %.1f |\n",
                1e6 * best / points_n);
    std::printf("\nratio OpenCV / diachron (intensity surface): %.2f; the two integer peaks agree on %zu of %d points; "
                "correlation_match matched %zu of %d\n",
                peer / ours, agree, points_n, matched, points_n);
  }
  return 0;
}
