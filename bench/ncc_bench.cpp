/// @file
/// NCC validation benchmark: diachron::ncc_validate side by side with the OpenCV way of doing the
/// same per match (cv::warpAffine of each window through the local affine, bilinear, then
/// cv::matchTemplate with TM_CCOEFF_NORMED), in one run, on the same matches, one thread and with
/// threads; then the cost and accuracy of the sub-pixel refinement. Prints Markdown on stdout;
/// docs/benchmarks.md ("NCC validation") pastes it. Options: --matches N (10000), --repeats R (5),
/// --threads T (2).
///
/// Both compute the same windows: a window sample at master offset o (o in [-16, 16) per axis) is
/// at a + o in the master and b + A o in the secondary. cv::warpAffine with WARP_INVERSE_MAP reads
/// dst(i, j) from src(M (i, j, 1)), pixel centres at integers as in diachron, so
/// M = [A | b - A (16, 16)]. OpenCV quantises source positions to 1/32 px (INTER_BITS = 5), so the
/// windows agree exactly only for positions on that grid: the "grid" matches have a, b and A in
/// multiples of 1/32; the "any" matches are arbitrary sub-pixel positions.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <iomanip>
#include <iostream>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/core/version.hpp>
#include <opencv2/imgproc.hpp>

#include <diachron/core/parallel.hpp>
#include <diachron/core/random.hpp>
#include <diachron/terrain/local_affine.hpp>
#include <diachron/terrain/transfer.hpp>
#include <diachron/validation/ncc_validator.hpp>
#include <diachron/vision/image.hpp>

#include "bench_common.hpp"

namespace {

using diachron::PointMatches;
using diachron::Raster;

constexpr int kWindow = 32;

// Smoothed noise at two scales: structure in every window, nothing repeats.
cv::Mat texture(int size, std::uint64_t seed) {
  cv::RNG rng(seed);
  cv::Mat acc(size, size, CV_32F, cv::Scalar(0));
  for (double sigma : {2.0, 6.0}) {
    cv::Mat noise(size, size, CV_32F);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, 1.0);
    cv::GaussianBlur(noise, noise, cv::Size(0, 0), sigma);
    cv::normalize(noise, noise, -1.0, 1.0, cv::NORM_MINMAX);
    acc += noise;
  }
  cv::Mat out;
  cv::normalize(acc, acc, 0, 255, cv::NORM_MINMAX);
  acc.convertTo(out, CV_8U);
  return out;
}

struct AffineMap {
  Eigen::Matrix2d linear;
  Eigen::Vector2d translation;
  Eigen::Vector2d operator()(const Eigen::Vector2d& p) const { return linear * p + translation; }
};

// The OpenCV peer for one match: two bilinear warps and a 1 x 1 matchTemplate.
struct CvScratch {
  cv::Mat window_a, window_b, result;
};

// centred: each window minus its mean before matchTemplate. The score is the same NCC, but
// matchTemplate's float32 cross sum no longer cancels the product of two means of about 128
// (its TM_CCOEFF subtracts the means after correlating), which is where its 1e-6-level
// disagreement with a double-precision NCC comes from.
double cv_ncc(const cv::Mat& master, const cv::Mat& secondary, const Eigen::Vector2d& a, const Eigen::Vector2d& b,
              const Eigen::Matrix2d& affine, CvScratch& s, bool centred = false) {
  const double h = kWindow / 2;
  const cv::Matx23d ma(1, 0, a.x() - h, 0, 1, a.y() - h);
  const Eigen::Vector2d t = b - affine * Eigen::Vector2d(h, h);
  const cv::Matx23d mb(affine(0, 0), affine(0, 1), t.x(), affine(1, 0), affine(1, 1), t.y());
  cv::warpAffine(master, s.window_a, ma, cv::Size(kWindow, kWindow), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP);
  cv::warpAffine(secondary, s.window_b, mb, cv::Size(kWindow, kWindow), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP);
  if (centred) {
    s.window_a -= cv::mean(s.window_a);
    s.window_b -= cv::mean(s.window_b);
  }
  cv::matchTemplate(s.window_b, s.window_a, s.result, cv::TM_CCOEFF_NORMED);
  return static_cast<double>(s.result.at<float>(0, 0));
}

template <class Transfer>
std::vector<double> cv_validate(const cv::Mat& master, const cv::Mat& secondary, const PointMatches& matches,
                                const Transfer& transfer, std::size_t threads, bool centred) {
  std::vector<double> score(matches.size(), std::numeric_limits<double>::quiet_NaN());
  constexpr std::size_t kChunk = 64;
  diachron::parallel_for((matches.size() + kChunk - 1) / kChunk, threads, [&](std::size_t chunk) {
    CvScratch s;
    const std::size_t end = std::min(matches.size(), (chunk + 1) * kChunk);
    for (std::size_t i = chunk * kChunk; i < end; ++i) {
      const auto affine = diachron::local_affine(transfer, matches[i].a);
      if (affine) score[i] = cv_ncc(master, secondary, matches[i].a, matches[i].b, *affine, s, centred);
    }
  });
  return score;
}

// The NCC of OpenCV's own two windows, in double: separates a window disagreement from the
// float32 arithmetic of matchTemplate.
double ncc_double(const cv::Mat& wa, const cv::Mat& wb) {
  double ma = cv::mean(wa)[0], mb = cv::mean(wb)[0], saa = 0, sbb = 0, sab = 0;
  for (int y = 0; y < wa.rows; ++y)
    for (int x = 0; x < wa.cols; ++x) {
      const double da = wa.at<float>(y, x) - ma, db = wb.at<float>(y, x) - mb;
      saa += da * da;
      sbb += db * db;
      sab += da * db;
    }
  return sab / std::sqrt(saa * sbb);
}

double max_difference(const std::vector<double>& x, const std::vector<double>& y) {
  double worst = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i)
    if (std::isfinite(x[i]) && std::isfinite(y[i])) worst = std::max(worst, std::abs(x[i] - y[i]));
  return worst;
}

template <class F>
double median_ms(int repeats, bool cpu, F&& f) {
  std::vector<double> t;
  for (int r = 0; r < repeats; ++r) {
    diachron::bench::Stopwatch watch;
    f();
    t.push_back(cpu ? watch.elapsed_cpu_ms() : watch.elapsed_ms());
  }
  return diachron::bench::median(t);
}

}  // namespace

int main(int argc, char** argv) {
  std::size_t count = 10000, threads = 2;
  int repeats = 5;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string arg = argv[i];
    if (arg == "--matches") count = std::strtoul(argv[i + 1], nullptr, 10);
    else if (arg == "--repeats") repeats = std::atoi(argv[i + 1]);
    else if (arg == "--threads") threads = std::strtoul(argv[i + 1], nullptr, 10);
  }
  cv::setNumThreads(1);  // the peer's threads are ours (parallel_for over matches), never nested

  // The secondary is the master seen through an affine whose linear part and translation are
  // multiples of 1/32, so grid matches stay on OpenCV's 1/32 px lattice.
  const int size = 1600;
  const cv::Mat master8 = texture(size, 7);
  AffineMap truth;
  truth.linear << 36.0 / 32, -9.0 / 32, 10.0 / 32, 34.0 / 32;
  truth.translation = Eigen::Vector2d(-96.0, -224.0) / 32.0 * 8.0;
  cv::Mat secondary8;
  cv::warpAffine(master8, secondary8,
                 cv::Matx23d(truth.linear(0, 0), truth.linear(0, 1), truth.translation.x(), truth.linear(1, 0),
                             truth.linear(1, 1), truth.translation.y()),
                 cv::Size(size, size), cv::INTER_CUBIC, cv::BORDER_REFLECT_101);
  const Raster<std::uint8_t> master = diachron::to_raster<std::uint8_t>(master8);
  const Raster<std::uint8_t> secondary = diachron::to_raster<std::uint8_t>(secondary8);
  cv::Mat master32, secondary32;  // the peer's type: warpAffine of 8-bit rounds the samples to integers
  master8.convertTo(master32, CV_32F);
  secondary8.convertTo(secondary32, CV_32F);
  const auto transfer = diachron::make_map_transfer(truth);

  // Matches: b is the truth plus up to 1.5 px of error, so scores spread over [-1, 1].
  diachron::RandomStream rng(3);
  PointMatches grid, any;
  while (grid.size() < count) {
    // One draw per statement, y before x (core/random.hpp, "Order of draws").
    const double ay = rng.uniform(40.0, size - 40.0);
    const Eigen::Vector2d a(rng.uniform(40.0, size - 40.0), ay);
    const double ey = rng.uniform(-1.5, 1.5);
    const Eigen::Vector2d b = truth(a) + Eigen::Vector2d(rng.uniform(-1.5, 1.5), ey);
    if (b.minCoeff() < 40.0 || b.maxCoeff() > size - 40.0) continue;
    any.push_back({a, b, 0.0});
    const auto snap = [](const Eigen::Vector2d& p) { return Eigen::Vector2d((p * 32.0).array().round() / 32.0); };
    grid.push_back({snap(a), snap(b), 0.0});
  }

  diachron::NccOptions options;
  std::cout << "# NCC validation: " << count << " matches, " << kWindow << " x " << kWindow
            << " windows, images " << size << " x " << size << ", OpenCV " << CV_VERSION << ", median of " << repeats
            << " runs\n\n";
  std::cout << "| matches | threads | ours (ms) | OpenCV warpAffine + matchTemplate (ms) | OpenCV / ours | largest "
               "|score difference| | the same on zero-mean windows (ms) | OpenCV / ours | largest |score difference| |\n"
               "|---|---|---|---|---|---|---|---|---|\n";
  for (const auto* set : {&grid, &any}) {
    const char* name = set == &grid ? "on the 1/32 px grid" : "any sub-pixel position";
    for (const std::size_t t : {std::size_t{1}, threads}) {
      options.threads = t;
      diachron::NccResult ours;
      std::vector<double> peer;
      const bool cpu = t == 1;  // one thread: thread CPU time, immune to other load on the machine
      const double ours_ms = median_ms(repeats, cpu, [&] {
        ours = diachron::ncc_validate(master, secondary, *set, transfer, options);
      });
      const double peer_ms =
          median_ms(repeats, cpu, [&] { peer = cv_validate(master32, secondary32, *set, transfer, t, false); });
      std::vector<double> centred;
      const double centred_ms =
          median_ms(repeats, cpu, [&] { centred = cv_validate(master32, secondary32, *set, transfer, t, true); });
      std::cout << "| " << name << " | " << t << (cpu ? " (CPU time)" : " (wall)") << " | " << std::fixed
                << std::setprecision(1) << ours_ms << " | " << peer_ms << " | " << std::setprecision(2)
                << peer_ms / ours_ms << " | " << std::scientific << std::setprecision(1)
                << max_difference(ours.score, peer) << std::defaultfloat << " | " << std::fixed << std::setprecision(1)
                << centred_ms << " | " << std::setprecision(2) << centred_ms / ours_ms << " | " << std::scientific
                << std::setprecision(1) << max_difference(ours.score, centred) << std::defaultfloat << " |\n";
    }
  }
  // Same windows? OpenCV's warped windows scored in double against ours.
  std::cout << "\n| matches | largest |ours - NCC in double of OpenCV's two warped windows| |\n|---|---|\n";
  for (const auto* set : {&grid, &any}) {
    options.threads = 1;
    const diachron::NccResult ours = diachron::ncc_validate(master, secondary, *set, transfer, options);
    double worst = 0.0;
    CvScratch s;
    for (std::size_t i = 0; i < set->size(); ++i) {
      const auto affine = diachron::local_affine(transfer, (*set)[i].a);
      cv_ncc(master32, secondary32, (*set)[i].a, (*set)[i].b, *affine, s);
      worst = std::max(worst, std::abs(ncc_double(s.window_a, s.window_b) - ours.score[i]));
    }
    std::cout << "| " << (set == &grid ? "on the 1/32 px grid" : "any sub-pixel position") << " | " << std::scientific
              << std::setprecision(1) << worst << std::defaultfloat << " |\n";
  }

  // Refinement: b off the truth by 0.3 to 0.7 px in a random direction; error before and after.
  PointMatches off;
  for (const auto& m : any) {
    const double angle = rng.uniform(0.0, 2.0 * diachron::kPi), r = rng.uniform(0.3, 0.7);
    off.push_back({m.a, truth(m.a) + r * Eigen::Vector2d(std::cos(angle), std::sin(angle)), 0.0});
  }
  std::cout << "\n| refinement | ms, 1 thread (CPU) | per kept match (us) | applied | rejected (move) | failed | "
               "error before: mean / max (px) | after: mean / max (px) |\n|---|---|---|---|---|---|---|---|\n";
  options.threads = 1;
  diachron::NccResult plain;
  const double plain_ms = median_ms(repeats, true, [&] { plain = diachron::ncc_validate(master, secondary, off, transfer, options); });
  std::cout << "| none (NCC only) | " << std::fixed << std::setprecision(1) << plain_ms << " | - | - | - | - | - | - |\n";
  for (const auto method : {diachron::NccRefineMethod::lsm, diachron::NccRefineMethod::ncc_peak}) {
    diachron::NccOptions refine = options;
    refine.refine = true;
    refine.refinement.method = method;
    refine.refinement.fallback_to_ncc_peak = method == diachron::NccRefineMethod::lsm;
    diachron::NccResult r;
    const double ms = median_ms(repeats, true, [&] { r = diachron::ncc_validate(master, secondary, off, transfer, refine); });
    double sum_before = 0.0, max_before = 0.0, sum_after = 0.0, max_after = 0.0;
    std::size_t n = 0;
    for (std::size_t i = 0; i < off.size(); ++i) {
      if (!r.refinement[i].applied()) continue;
      const Eigen::Vector2d t = truth(off[i].a);
      const double before = (off[i].b - t).norm(), after = (r.refinement[i].b - t).norm();
      sum_before += before;
      sum_after += after;
      max_before = std::max(max_before, before);
      max_after = std::max(max_after, after);
      ++n;
    }
    const double per_match_us = 1e3 * (ms - plain_ms) / static_cast<double>(std::max<std::size_t>(1, r.kept()));
    std::cout << "| " << (method == diachron::NccRefineMethod::lsm ? "least squares (NCC-peak fallback)" : "NCC peak")
              << " | " << std::setprecision(1) << ms << " | " << per_match_us << " | "
              << r.refined_lsm + r.refined_ncc_peak << " of " << r.kept() << " | " << r.refine_rejected_move << " | "
              << r.refine_failed << " | " << std::setprecision(3) << sum_before / static_cast<double>(std::max<std::size_t>(1, n))
              << " / " << max_before << " | " << sum_after / static_cast<double>(std::max<std::size_t>(1, n)) << " / "
              << max_after << " |\n";
  }
  std::cout << "\n- compiler: " << __VERSION__ << ", flags: " << DIACHRON_BENCH_FLAGS << "\n";
  return 0;
}
