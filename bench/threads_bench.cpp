// Thread scaling of the library's parallel loops (docs/benchmarks.md, "Threads"):
//   1. parallel_for overhead: 3000 calls of 8 trivial items, the shape of RANSAC's early batches;
//   2. RANSAC: ransac_similarity2 on 3000 and 100000 pairs (50 % outliers, 1000 iterations);
//   3. tile matching: match_one_to_many with SIFT (features cached per tile) on 640 x 480 tiles.
// Each row is the median wall time of --runs runs. The machine's load average is printed because
// the timings only mean something next to it.
//
// OpenCV's own threads (SIFT runs cv::parallel_for_ inside) are off by default, so the tile row
// shows what parallel_for adds; --cv-threads N gives them back.
//
//   bench_threads [--runs N] [--threads 1,2,4] [--cv-threads N]

#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/core.hpp>

#include <diachron/core/parallel.hpp>
#include <diachron/core/random.hpp>
#include <diachron/robust/robust_estimation.hpp>
#include <diachron/tiling/feature_cache_matcher.hpp>
#include <diachron/tiling/grid_tiler.hpp>
#include <diachron/tiling/one_to_many.hpp>
#include <diachron/vision/extractor_pair_matcher.hpp>
#include <diachron/vision/sift.hpp>

#include "bench_common.hpp"

namespace {

using namespace diachron;

template <class Fn>
double median_ms(int runs, Fn&& fn) {
  std::vector<double> ms;
  for (int r = 0; r < runs; ++r) {
    const auto start = std::chrono::steady_clock::now();
    fn();
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
  }
  return bench::median(ms);
}

// Smooth random terrain-like texture: a sum of Gaussian bumps, quantised to 8 bits.
Raster<std::uint8_t> texture(int w, int h, std::uint64_t seed) {
  RandomStream random(seed);
  Raster<float> z(w, h, 0.0f);
  for (int i = 0; i < w * h / 400; ++i) {
    const double cx = random.uniform(0, w), cy = random.uniform(0, h), s = random.uniform(2, 12);
    const double a = random.uniform(-1, 1);
    const int r = static_cast<int>(3 * s);
    for (int y = std::max(0, int(cy) - r); y < std::min(h, int(cy) + r); ++y)
      for (int x = std::max(0, int(cx) - r); x < std::min(w, int(cx) + r); ++x)
        z(x, y) += static_cast<float>(a * std::exp(-((x - cx) * (x - cx) + (y - cy) * (y - cy)) / (2 * s * s)));
  }
  float lo = z(0, 0), hi = z(0, 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) lo = std::min(lo, z(x, y)), hi = std::max(hi, z(x, y));
  Raster<std::uint8_t> out(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) out(x, y) = static_cast<std::uint8_t>(255.0f * (z(x, y) - lo) / (hi - lo));
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  int runs = 7, cv_threads = 1;
  std::vector<std::size_t> thread_counts{1, 2, 4};
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--runs" && i + 1 < argc) {
      runs = std::stoi(argv[++i]);
    } else if (a == "--cv-threads" && i + 1 < argc) {
      cv_threads = std::stoi(argv[++i]);
    } else if (a == "--threads" && i + 1 < argc) {
      thread_counts.clear();
      std::stringstream ss(argv[++i]);
      for (std::string t; std::getline(ss, t, ',');) thread_counts.push_back(std::stoul(t));
    } else {
      std::cerr << "usage: bench_threads [--runs N] [--threads 1,2,4] [--cv-threads N]\n";
      return 1;
    }
  }
  cv::setNumThreads(cv_threads);
  std::cout << "OpenCV threads " << cv::getNumThreads() << ", hardware threads " << std::thread::hardware_concurrency() << ", load average before "
            << bench::load_average() << ", median of " << runs << " runs\n\n";

  bench::Table table({"workload", "threads", "median wall ms"});

  for (std::size_t t : thread_counts) {
    const double ms = median_ms(runs, [&] {
      for (int call = 0; call < 3000; ++call) {
        volatile double sink[8];
        parallel_for(8, t, [&](std::size_t i) { sink[i] = static_cast<double>(i) * 0.5; });
      }
    });
    table.add({"parallel_for, 3000 calls x 8 items", std::to_string(t), bench::format_number(ms)});
  }

  for (std::size_t n : {std::size_t{3000}, std::size_t{100000}}) {
    const bench::Problem2 problem = bench::make_problem2(n, 0.5, 7);
    for (std::size_t t : thread_counts) {
      RansacOptions o;
      o.threshold = problem.threshold;
      o.max_iterations = 1000;
      o.min_iterations = 1000;
      o.threads = t;
      std::size_t inliers = 0;
      const double ms = median_ms(runs, [&] { inliers = ransac_similarity2(problem.pairs, o).inliers.size(); });
      table.add({"ransac_similarity2, " + std::to_string(n) + " pairs, 1000 iterations (" + std::to_string(inliers) +
                     " inliers)",
                 std::to_string(t), bench::format_number(ms)});
    }
  }

  const Raster<std::uint8_t> master = texture(1280, 960, 1);
  Raster<std::uint8_t> secondary(1200, 900);
  for (int y = 0; y < secondary.height(); ++y)
    for (int x = 0; x < secondary.width(); ++x) secondary(x, y) = master(x + 37, y + 21);
  const GridTiler tiler(GridTilerOptions{640, 480, 0, 0});
  SiftOptions so;
  so.max_features = 2000;
  const ExtractorPairMatcher<SiftExtractor> sift{SiftExtractor{so}};
  for (std::size_t t : thread_counts) {
    OneToManyOptions o;
    o.threads = t;
    std::size_t matches = 0;
    const double ms = median_ms(std::max(1, runs / 2), [&] {
      const FeatureCacheMatcher<ExtractorPairMatcher<SiftExtractor>> cached(sift);
      matches = match_one_to_many(master, secondary, tiler, tiler, cached, o).matches.size();
    });
    table.add({"match_one_to_many, SIFT, 2 x 2 by 2 x 2 tiles of 640 x 480 (" + std::to_string(matches) +
                   " matches)",
               std::to_string(t), bench::format_number(ms)});
  }

  table.print(std::cout);
  std::cout << "\nload average after " << bench::load_average() << "\n";
  return 0;
}
