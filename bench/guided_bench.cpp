/// @file
/// Guided matching (matching/guided_matcher.hpp) against OpenCV's brute force on the same RootSIFT
/// features: cv::BFMatcher (NORM_L2) knnMatch with k = 2 in both directions, Lowe's ratio 0.8 and a
/// mutual check, which is what the guided matcher does without the geometry.
///
/// The pair: a synthetic texture (smooth noise at two scales plus blobs) and its copy warped by a
/// known similarity, with grey-level noise and a gamma change. The guided matcher gets a slightly
/// wrong similarity (a co-registration error of a few pixels and a fraction of a degree), as it
/// would in the pipeline. A match is correct when the true similarity puts a within 3 px of b.
/// Both matchers run on one thread (cv::setNumThreads(1), threads = 1); thread CPU times (and
/// wall times) are medians of --runs runs, feature extraction excluded. Prints a Markdown table (docs/benchmarks.md).
///
///   guided_bench [--size PX] [--runs N] [--seed S]

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <iomanip>
#include <iostream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/core/version.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include <diachron/core/random.hpp>
#include <diachron/core/types.hpp>
#include <diachron/geometry/similarity2.hpp>
#include <diachron/matching/guided_matcher.hpp>
#include <diachron/terrain/transfer.hpp>
#include <diachron/vision/image.hpp>
#include <diachron/vision/sift.hpp>

#include "bench_common.hpp"

#ifndef DIACHRON_BENCH_FLAGS
#define DIACHRON_BENCH_FLAGS "(unknown)"
#endif

namespace {

using namespace diachron;

constexpr double kCorrectPx = 3.0;
constexpr float kRatio = 0.8f;

// Smooth noise at a coarse and a fine scale plus random discs: blob and corner features at many
// scales, nothing repeated (so a correct match is unambiguous).
cv::Mat make_texture(int size, std::uint64_t seed) {
  RandomStream rng(seed, 1);
  cv::Mat img(size, size, CV_32F, cv::Scalar(0));
  for (const auto& [cell, weight] : {std::pair<int, double>{48, 1.0}, {12, 0.6}}) {
    cv::Mat coarse(size / cell + 4, size / cell + 4, CV_32F);
    for (int y = 0; y < coarse.rows; ++y)
      for (int x = 0; x < coarse.cols; ++x) coarse.at<float>(y, x) = static_cast<float>(rng.uniform(-1, 1));
    cv::Mat up;
    cv::resize(coarse, up, cv::Size(coarse.cols * cell, coarse.rows * cell), 0, 0, cv::INTER_CUBIC);
    img += up(cv::Rect(cell, cell, size, size)) * weight;
  }
  for (int i = 0; i < size * size / 900; ++i) {
    // One draw per statement, in the order GCC evaluated the calls' arguments (core/random.hpp,
    // "Order of draws"): y, x, then the shade, then the radius.
    const int cy = static_cast<int>(rng.uniform(0, size));
    const cv::Point c(static_cast<int>(rng.uniform(0, size)), cy);
    const double shade = rng.uniform(-1.5, 1.5);
    cv::circle(img, c, static_cast<int>(rng.uniform(2, 14)), cv::Scalar(shade), cv::FILLED, cv::LINE_AA);
  }
  cv::GaussianBlur(img, img, cv::Size(0, 0), 1.0);
  cv::normalize(img, img, 0, 255, cv::NORM_MINMAX);
  cv::Mat out;
  img.convertTo(out, CV_8U);
  return out;
}

// The secondary image: the master warped by `truth` (both in diachron's pixel-centre convention,
// which is cv::warpAffine's), then a gamma change and Gaussian grey noise.
cv::Mat make_secondary(const cv::Mat& master, const Similarity2& truth, std::uint64_t seed) {
  const Eigen::Matrix<double, 3, 3> m = truth.matrix();
  const cv::Mat affine = (cv::Mat_<double>(2, 3) << m(0, 0), m(0, 1), m(0, 2), m(1, 0), m(1, 1), m(1, 2));
  cv::Mat warped;
  cv::warpAffine(master, warped, affine, master.size(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::Mat f;
  warped.convertTo(f, CV_32F, 1.0 / 255.0);
  cv::pow(f, 0.8, f);
  cv::Mat noise(f.size(), CV_32F);
  RandomStream rng(seed, 2);
  for (int y = 0; y < noise.rows; ++y)
    for (int x = 0; x < noise.cols; ++x) noise.at<float>(y, x) = static_cast<float>(rng.normal(0.0, 4.0 / 255.0));
  f += noise;
  cv::Mat out;
  f.convertTo(out, CV_8U, 255.0);
  return out;
}

cv::Mat to_cv(const DescriptorMatrix& d) {
  return cv::Mat(static_cast<int>(d.rows()), static_cast<int>(d.cols()), CV_32F, const_cast<float*>(d.data()));
}

struct Pairs {
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
};

// Brute force as OpenCV users write it: 2-NN both ways, ratio test on the forward side, mutual.
Pairs brute_force(const Features& m, const Features& s) {
  cv::BFMatcher bf(cv::NORM_L2);
  std::vector<std::vector<cv::DMatch>> fwd, bwd;
  bf.knnMatch(to_cv(m.descriptors), to_cv(s.descriptors), fwd, 2);
  bf.knnMatch(to_cv(s.descriptors), to_cv(m.descriptors), bwd, 1);
  Pairs out;
  for (const auto& k : fwd) {
    if (k.empty()) continue;
    if (k.size() == 2 && !(k[0].distance < kRatio * k[1].distance)) continue;
    const auto& back = bwd[static_cast<std::size_t>(k[0].trainIdx)];
    if (back.empty() || back[0].trainIdx != k[0].queryIdx) continue;
    out.pairs.emplace_back(static_cast<std::size_t>(k[0].queryIdx), static_cast<std::size_t>(k[0].trainIdx));
  }
  return out;
}

std::size_t count_correct(const Pairs& p, const Features& m, const Features& s, const Similarity2& truth) {
  std::size_t n = 0;
  for (const auto& [i, j] : p.pairs)
    if ((truth(m.keypoints[i].position) - s.keypoints[j].position).norm() <= kCorrectPx) ++n;
  return n;
}

}  // namespace

int main(int argc, char** argv) {
  int size = 2000, runs = 3;
  std::uint64_t seed = 1;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--size" && i + 1 < argc) {
      size = std::stoi(argv[++i]);
    } else if (a == "--runs" && i + 1 < argc) {
      runs = std::max(1, std::stoi(argv[++i]));
    } else if (a == "--seed" && i + 1 < argc) {
      seed = std::stoull(argv[++i]);
    } else {
      std::cerr << "usage: guided_bench [--size PX] [--runs N] [--seed S]\n";
      return a == "--help" ? 0 : 2;
    }
  }
  cv::setNumThreads(1);

  // Turn and zoom about the image centre, so that most of the master stays in view.
  const Eigen::Vector2d centre = Eigen::Vector2d::Constant(0.5 * (size - 1));
  Similarity2 truth{0.85, deg_to_rad(25.0), Eigen::Vector2d::Zero()};
  truth.translation = centre - truth.linear() * centre + Eigen::Vector2d(12.0, -7.0);
  // What the co-registration would hand over: 0.3 degree, 0.5 % and a few pixels off.
  Similarity2 estimate = truth;
  estimate.angle += deg_to_rad(0.3);
  estimate.scale *= 1.005;
  estimate.translation += Eigen::Vector2d(5.0, -4.0);
  double worst_px = 0.0;
  for (const Eigen::Vector2d& c : {Eigen::Vector2d(0, 0), Eigen::Vector2d(size - 1, 0), Eigen::Vector2d(0, size - 1),
                                   Eigen::Vector2d(size - 1, size - 1)})
    worst_px = std::max(worst_px, (estimate(c) - truth(c)).norm());

  const cv::Mat master_img = make_texture(size, seed);
  const cv::Mat secondary_img = make_secondary(master_img, truth, seed);
  const RootSiftExtractor sift;
  const Features master = sift.extract(to_raster<std::uint8_t>(master_img));
  const Features secondary = sift.extract(to_raster<std::uint8_t>(secondary_img));

  const auto forward = make_map_transfer(estimate);
  const auto inverse = make_map_transfer(estimate.inverse());
  GuidedMatchOptions options;
  options.threads = 1;

  std::vector<double> bf_ms, guided_ms, bf_cpu, guided_cpu;
  Pairs bf_pairs, guided_pairs;
  GuidedMatchResult guided;
  for (int r = 0; r < runs; ++r) {
    bench::Stopwatch bf_clock;
    bf_pairs = brute_force(master, secondary);
    bf_ms.push_back(bf_clock.elapsed_ms());
    bf_cpu.push_back(bf_clock.elapsed_cpu_ms());
    bench::Stopwatch guided_clock;
    guided = guided_match(master, secondary, forward, inverse, options);
    guided_ms.push_back(guided_clock.elapsed_ms());
    guided_cpu.push_back(guided_clock.elapsed_cpu_ms());
  }
  guided_pairs.pairs.clear();
  for (const GuidedMatch& g : guided.pairs) guided_pairs.pairs.emplace_back(g.master, g.secondary);

  // Thread CPU time is the comparison: both run on the calling thread, and unlike wall time it
  // does not grow when other processes share the cores.
  const double bf_t = bench::median(bf_cpu), guided_t = bench::median(guided_cpu);
  const double bf_wall = bench::median(bf_ms), guided_wall = bench::median(guided_ms);
  const std::size_t bf_ok = count_correct(bf_pairs, master, secondary, truth);
  const std::size_t guided_ok = count_correct(guided_pairs, master, secondary, truth);

  double load[1] = {0.0};
  if (getloadavg(load, 1) != 1) load[0] = -1.0;
  std::cout << "guided_bench: " << size << " x " << size << " px texture, similarity scale 0.85, 25 deg; "
            << "estimate off by up to " << std::fixed << std::setprecision(1) << worst_px << " px; " << master.size()
            << " / " << secondary.size() << " RootSIFT keypoints; OpenCV " << CV_VERSION
            << "; one thread each; median of " << runs << " runs; load average " << std::setprecision(2) << load[0]
            << "\n"
            << "flags: " << DIACHRON_BENCH_FLAGS << "\n\n";
  std::cout << "| matcher | CPU time (ms) | wall time (ms) | matches | correct (<= 3 px) | precision |\n"
            << "|---|---|---|---|---|---|\n";
  auto row = [&](const char* name, double t, double wall, const Pairs& p, std::size_t ok) {
    std::cout << "| " << name << " | " << std::setprecision(1) << t << " | " << wall << " | " << p.pairs.size() << " | "
              << ok << " | " << std::setprecision(3)
              << (p.pairs.empty() ? 0.0 : static_cast<double>(ok) / p.pairs.size()) << " |\n";
  };
  row("cv::BFMatcher knn 2 + ratio 0.8 + mutual", bf_t, bf_wall, bf_pairs, bf_ok);
  row("guided_match (defaults, radius 100 px)", guided_t, guided_wall, guided_pairs, guided_ok);
  std::cout << "\nspeed-up (CPU) " << std::setprecision(1) << bf_t / guided_t << "x; guided: " << guided.predicted
            << " predicted, " << guided.no_candidate << " without candidate, " << guided.failed_ratio
            << " failed ratio, " << guided.failed_mutual << " failed mutual, " << guided.candidates
            << " descriptor comparisons (brute force: " << 2 * master.size() * secondary.size() << ")\n";
  return 0;
}
