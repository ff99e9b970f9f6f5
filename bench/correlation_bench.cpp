/// @file
/// Correlation search benchmark: diachron::correlation_surface (intensity measure, no
/// anti-aliasing, so both sides compute the same thing) side by side with the OpenCV way of doing
/// the same per point: cv::warpAffine of the search region through the local affine (bilinear),
/// then cv::matchTemplate with TM_CCOEFF_NORMED of the master window over it. Same points, same
/// windows (21 px), same search (+-12 px), one thread. Also the cost of the gradient and
/// orientation measures and of correlation_match's full per-point work (peak, sub-pixel rounds).
/// Times are this thread's CPU time (CLOCK_THREAD_CPUTIME_ID; OpenCV runs on the calling thread
/// with setNumThreads(1)), so that other jobs on a shared machine do not count. Then the scores:
/// ours against OpenCV's at every shift (also on OpenCV's 1/32 px sample grid, where both compute
/// the same windows) and against the same formula in double precision.
/// Prints Markdown on stdout; docs/benchmarks.md ("Correlation search") pastes it.
/// Options: --points N (2000), --repeats R (3).

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include <time.h>

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

// The time of this thread on a CPU (everything here runs on the calling thread, OpenCV's too):
// on a shared machine the wall clock also counts the time slices of other jobs.
double thread_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
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

// The zero-mean normalised correlation of the master window at a with the secondary window at
// b0 + A (dx, dy), both sampled bilinearly in double precision (the secondary at b0 + A (dx + i, dy + j)).
double double_ncc(const Raster<std::uint8_t>& master, const Eigen::Vector2d& a, const Raster<std::uint8_t>& secondary,
                  const Eigen::Vector2d& b0, const Eigen::Matrix2d& A, int dx, int dy, int half) {
  const auto bilinear = [](const Raster<std::uint8_t>& img, double x, double y) {
    const int x0 = std::clamp(static_cast<int>(std::floor(x)), 0, img.width() - 2);
    const int y0 = std::clamp(static_cast<int>(std::floor(y)), 0, img.height() - 2);
    const double fx = x - x0, fy = y - y0;
    const double top = img(x0, y0) + fx * (img(x0 + 1, y0) - img(x0, y0));
    const double bottom = img(x0, y0 + 1) + fx * (img(x0 + 1, y0 + 1) - img(x0, y0 + 1));
    return top + fy * (bottom - top);
  };
  std::vector<double> u, v;
  for (int j = -half; j <= half; ++j)
    for (int i = -half; i <= half; ++i) {
      u.push_back(bilinear(master, a.x() + i, a.y() + j));
      const Eigen::Vector2d p = b0 + A * Eigen::Vector2d(dx + i, dy + j);
      v.push_back(bilinear(secondary, p.x(), p.y()));
    }
  double mu = 0.0, mv = 0.0;
  for (std::size_t k = 0; k < u.size(); ++k) {
    mu += u[k];
    mv += v[k];
  }
  mu /= static_cast<double>(u.size());
  mv /= static_cast<double>(v.size());
  double uu = 0.0, vv = 0.0, uv = 0.0;
  for (std::size_t k = 0; k < u.size(); ++k) {
    uu += (u[k] - mu) * (u[k] - mu);
    vv += (v[k] - mv) * (v[k] - mv);
    uv += (u[k] - mu) * (v[k] - mv);
  }
  return uu > 0.0 && vv > 0.0 ? uv / std::sqrt(uu * vv) : std::numeric_limits<double>::quiet_NaN();
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
    double t = thread_seconds();
    for (std::size_t i = 0; i < points.size(); ++i) {
      const Eigen::MatrixXd s = correlation_surface(master, points[i], secondary, predictions[i], linear, options);
      Eigen::Index y = 0, x = 0;
      s.maxCoeff(&y, &x);
      ours_peak[i] = Eigen::Vector2i(static_cast<int>(x), static_cast<int>(y));
    }
    ours = std::min(ours, (thread_seconds() - t));
    // The peer: warp the search region into the master geometry, then matchTemplate.
    t = thread_seconds();
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
    peer = std::min(peer, (thread_seconds() - t));
  }
  for (std::size_t i = 0; i < points.size(); ++i) agree += ours_peak[i] == peer_peak[i];
  // The scores, outside the timing: ours against OpenCV's at every shift, and against the same
  // formula in double precision (bilinear samples, two-pass means) on the first 100 points.
  double largest_vs_peer = 0.0, largest_vs_double = 0.0;
  std::vector<double> point_vs_peer;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::MatrixXd s = correlation_surface(master, points[i], secondary, predictions[i], linear, options);
    const Eigen::Vector2d b0 = predictions[i] - linear * Eigen::Vector2d(half + r, half + r);
    const cv::Mat m = (cv::Mat_<double>(2, 3) << linear(0, 0), linear(0, 1), b0.x(), linear(1, 0), linear(1, 1), b0.y());
    cv::Mat patch, result;
    cv::warpAffine(secondary_mat, patch, m, cv::Size(region, region), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP);
    const cv::Rect window(static_cast<int>(points[i].x()) - half, static_cast<int>(points[i].y()) - half, w, w);
    cv::matchTemplate(patch, as_mat(master)(window), result, cv::TM_CCOEFF_NORMED);
    double worst = 0.0;
    for (int dy = 0; dy < 2 * r + 1; ++dy)
      for (int dx = 0; dx < 2 * r + 1; ++dx)
        if (std::isfinite(s(dy, dx))) worst = std::max(worst, std::abs(s(dy, dx) - result.at<float>(dy, dx)));
    point_vs_peer.push_back(worst);
    largest_vs_peer = std::max(largest_vs_peer, worst);
    if (i < 100)
      for (int dy = -r; dy <= r; ++dy)
        for (int dx = -r; dx <= r; ++dx) {
          const double exact = double_ncc(master, points[i], secondary, predictions[i], linear, dx, dy, half);
          if (std::isfinite(exact) && std::isfinite(s(dy + r, dx + r)))
            largest_vs_double = std::max(largest_vs_double, std::abs(s(dy + r, dx + r) - exact));
        }
  }
  std::sort(point_vs_peer.begin(), point_vs_peer.end());
  // On OpenCV's own grid: warpAffine places its samples at multiples of 1/32 px and an 8-bit output
  // rounds them to integers. With the affine and the predictions in multiples of 1/32 and a float
  // secondary image on OpenCV's side, both compute the same windows (first 200 points).
  double largest_on_grid = 0.0;
  {
    const auto grid = [](double v) { return std::round(32.0 * v) / 32.0; };
    const Eigen::Matrix2d linear_q = linear.unaryExpr(grid);
    cv::Mat secondary_float;
    secondary_mat.convertTo(secondary_float, CV_32F);
    cv::Mat master_float;
    as_mat(master).convertTo(master_float, CV_32F);
    for (std::size_t i = 0; i < std::min<std::size_t>(200, points.size()); ++i) {
      const Eigen::Vector2d b0q = predictions[i].unaryExpr(grid);
      const Eigen::MatrixXd s = correlation_surface(master, points[i], secondary, b0q, linear_q, options);
      const Eigen::Vector2d corner = b0q - linear_q * Eigen::Vector2d(half + r, half + r);
      const cv::Mat m = (cv::Mat_<double>(2, 3) << linear_q(0, 0), linear_q(0, 1), corner.x(), linear_q(1, 0),
                         linear_q(1, 1), corner.y());
      cv::Mat patch, result;
      cv::warpAffine(secondary_float, patch, m, cv::Size(region, region), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP);
      const cv::Rect window(static_cast<int>(points[i].x()) - half, static_cast<int>(points[i].y()) - half, w, w);
      cv::matchTemplate(patch, master_float(window), result, cv::TM_CCOEFF_NORMED);
      for (int dy = 0; dy < 2 * r + 1; ++dy)
        for (int dx = 0; dx < 2 * r + 1; ++dx)
          if (std::isfinite(s(dy, dx)))
            largest_on_grid = std::max(largest_on_grid, std::abs(s(dy, dx) - result.at<float>(dy, dx)));
    }
  }

  std::printf("| what (%d points, 21 px window, +-12 px, 1 thread, best of %d) | us / point |\n|---|---|\n", points_n,
              repeats);
  std::printf("| diachron correlation_surface, intensity | %.1f |\n", 1e6 * ours / points_n);
  std::printf("| OpenCV warpAffine + matchTemplate (TM_CCOEFF_NORMED) | %.1f |\n", 1e6 * peer / points_n);
  for (const CorrelationMeasure m : {CorrelationMeasure::gradient, CorrelationMeasure::orientation}) {
    CorrelationMatchOptions o = options;
    o.measure = m;
    double best = 1e30;
    for (int rep = 0; rep < repeats; ++rep) {
      const double t = thread_seconds();
      for (std::size_t i = 0; i < points.size(); ++i)
        (void)correlation_surface(master, points[i], secondary, predictions[i], linear, o);
      best = std::min(best, (thread_seconds() - t));
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
      const double t = thread_seconds();
      matched = correlation_match(master, secondary, points, transfer, o).matches.size();
      best = std::min(best, (thread_seconds() - t));
    }
    std::printf("| diachron correlation_match, defaults (orientation, anti-aliasing, peak, 3 sub-pixel rounds) | %.1f |\n",
                1e6 * best / points_n);
    std::printf("\nratio OpenCV / diachron (intensity surface): %.2f; the two integer peaks agree on %zu of %d points; "
                "correlation_match matched %zu of %d\n",
                peer / ours, agree, points_n, matched, points_n);
    std::printf("intensity scores: largest difference from OpenCV's %.2e (median over points of their largest %.2e; "
                "OpenCV's warpAffine places its samples on a 1/32 px grid and rounds an 8-bit patch), %.2e with "
                "positions on that grid and a float patch (first 200 points), %.2e from the same formula in double "
                "precision (first 100 points)\n",
                largest_vs_peer, point_vs_peer[point_vs_peer.size() / 2], largest_on_grid, largest_vs_double);
  }
  return 0;
}
