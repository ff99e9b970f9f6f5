#pragma once
/// @file
/// Shared pieces of the robust-estimation benchmarks: synthetic correspondences with a known truth,
/// the model-error measure, a stopwatch, small statistics and a Markdown table printer.
///
/// Everything here is deterministic: a data set is a pure function of (size, outlier ratio, seed),
/// so every method in a run sees exactly the same pairs.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <limits>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <diachron/core/random.hpp>
#include <diachron/core/types.hpp>
#include <diachron/geometry/helmert3.hpp>
#include <diachron/geometry/similarity2.hpp>

namespace diachron::bench {

/// Stream indices for RandomStream: data generation and the plain-loop peer draw from different
/// streams of the same seed, so changing one never shifts the other.
inline constexpr std::uint64_t kDataStream = 0x5eed'da7aULL;
inline constexpr std::uint64_t kPeerStream = 0x5eed'9ee2ULL;

/// A synthetic problem: pairs, which of them are inliers, and the transform that made the inliers.
template <class Pair, class Model>
struct Problem {
  Model truth{};
  double sigma = 0.0;      ///< inlier noise, per coordinate, target units
  double threshold = 0.0;  ///< inlier threshold handed to every robust method (3 sigma)
  std::vector<Pair> pairs;
  std::vector<std::size_t> inlier_indices;  ///< increasing
};

using Problem2 = Problem<PointPair2, Similarity2>;
using Problem3 = Problem<PointPair3, Helmert3>;

/// Exactly round(n * (1 - outlier_ratio)) inlier slots at random positions, so the contamination is
/// the stated one and not a binomial draw around it.
inline std::vector<char> inlier_flags(std::size_t n, double outlier_ratio, RandomStream& random) {
  const auto inliers = static_cast<std::size_t>(std::llround(static_cast<double>(n) * (1.0 - outlier_ratio)));
  std::vector<char> flags(n, 0);
  std::fill(flags.begin(), flags.begin() + static_cast<std::ptrdiff_t>(std::min(inliers, n)), 1);
  for (std::size_t i = n; i > 1; --i) std::swap(flags[i - 1], flags[random.uniform_index(i)]);
  return flags;
}

/// 2D problem shaped like a DSM image pair of the rough co-registration: sources over a 4000 x 3000
/// px image, a random similarity (any angle, scale 0.5 to 2, shifts up to 500 px), inlier targets
/// with Gaussian noise of `sigma` px per coordinate, outlier targets uniform over the bounding box
/// of the true image of the source extent.
inline Problem2 make_problem2(std::size_t n, double outlier_ratio, std::uint64_t seed, double sigma = 1.0) {
  RandomStream random(seed, kDataStream);
  Problem2 p;
  p.sigma = sigma;
  p.threshold = 3.0 * sigma;
  p.truth.scale = std::exp(random.uniform(std::log(0.5), std::log(2.0)));
  p.truth.angle = random.uniform(-kPi, kPi);
  // One draw per statement, the last coordinate first: the order of a call's arguments is
  // unspecified and compilers differ (core/random.hpp, "Order of draws"); this is the order the
  // recorded figures were drawn in (GCC's).
  const double ty = random.uniform(-500.0, 500.0);
  p.truth.translation = Vec2(random.uniform(-500.0, 500.0), ty);

  const Vec2 extent(4000.0, 3000.0);
  Vec2 lo = Vec2::Constant(std::numeric_limits<double>::infinity());
  Vec2 hi = -lo;
  for (int corner = 0; corner < 4; ++corner) {
    const Vec2 c((corner & 1) ? extent.x() : 0.0, (corner & 2) ? extent.y() : 0.0);
    const Vec2 t = p.truth(c);
    lo = lo.cwiseMin(t);
    hi = hi.cwiseMax(t);
  }

  const std::vector<char> flags = inlier_flags(n, outlier_ratio, random);
  p.pairs.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    PointPair2& pair = p.pairs[i];
    const double sy = random.uniform(0.0, extent.y());
    pair.source = Vec2(random.uniform(0.0, extent.x()), sy);
    if (flags[i]) {
      const double ny = random.normal(0.0, sigma);
      pair.target = p.truth(pair.source) + Vec2(random.normal(0.0, sigma), ny);
      p.inlier_indices.push_back(i);
    } else {
      const double y = random.uniform(lo.y(), hi.y());
      pair.target = Vec2(random.uniform(lo.x(), hi.x()), y);
    }
  }
  return p;
}

/// 3D problem shaped like DSM points of two epochs: sources over 2000 x 2000 m with 200 m of relief,
/// a random Helmert (any yaw, pitch and roll within 0.2 rad, scale 0.8 to 1.25, shifts up to
/// 1000 m), inlier targets with Gaussian noise of `sigma` m per coordinate, outlier targets uniform
/// over the bounding box of the true image of the source extent.
inline Problem3 make_problem3(std::size_t n, double outlier_ratio, std::uint64_t seed, double sigma = 0.5) {
  RandomStream random(seed, kDataStream);
  Problem3 p;
  p.sigma = sigma;
  p.threshold = 3.0 * sigma;
  const double scale = std::exp(random.uniform(std::log(0.8), std::log(1.25)));
  const double yaw = random.uniform(-kPi, kPi);
  const double pitch = random.uniform(-0.2, 0.2);
  const double roll = random.uniform(-0.2, 0.2);
  const double shift_z = random.uniform(-1000.0, 1000.0), shift_y = random.uniform(-1000.0, 1000.0);
  const Vec3 shift(random.uniform(-1000.0, 1000.0), shift_y, shift_z);  // z, y, x: as in make_problem2
  p.truth = Helmert3::from_yaw_pitch_roll(scale, yaw, pitch, roll, shift);

  const Vec3 extent(2000.0, 2000.0, 200.0);
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 hi = -lo;
  for (int corner = 0; corner < 8; ++corner) {
    const Vec3 c((corner & 1) ? extent.x() : 0.0, (corner & 2) ? extent.y() : 0.0,
                 (corner & 4) ? extent.z() : 0.0);
    const Vec3 t = p.truth(c);
    lo = lo.cwiseMin(t);
    hi = hi.cwiseMax(t);
  }

  const std::vector<char> flags = inlier_flags(n, outlier_ratio, random);
  p.pairs.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    PointPair3& pair = p.pairs[i];
    const double sz = random.uniform(0.0, extent.z()), sy = random.uniform(0.0, extent.y());
    pair.source = Vec3(random.uniform(0.0, extent.x()), sy, sz);
    if (flags[i]) {
      const double nz = random.normal(0.0, sigma), ny = random.normal(0.0, sigma);
      pair.target = p.truth(pair.source) + Vec3(random.normal(0.0, sigma), ny, nz);
      p.inlier_indices.push_back(i);
    } else {
      const double z = random.uniform(lo.z(), hi.z()), y = random.uniform(lo.y(), hi.y());
      pair.target = Vec3(random.uniform(lo.x(), hi.x()), y, z);
    }
  }
  return p;
}

/// Model error: RMS over the inlier sources of |estimate(x) - truth(x)|, in target units. It
/// measures the transform, not the noise, so a perfect estimate scores 0 whatever sigma is.
/// `estimate` is any callable mapping a source point to a target point.
template <class Pair, class Model, class Estimate>
double model_error(const Problem<Pair, Model>& p, const Estimate& estimate) {
  if (p.inlier_indices.empty()) return 0.0;
  double sum = 0.0;
  for (const std::size_t i : p.inlier_indices) {
    const auto& x = p.pairs[i].source;
    sum += (estimate(x) - p.truth(x)).squaredNorm();
  }
  const double rms = std::sqrt(sum / static_cast<double>(p.inlier_indices.size()));
  // A NaN model must count as a failure, never slip past a "< tolerance" test.
  return std::isfinite(rms) ? rms : std::numeric_limits<double>::infinity();
}

/// CPU time of the calling thread, ms. Every method benchmarked here runs on one thread, so this is
/// all of its work; unlike wall time it does not grow when other processes share the cores.
inline double thread_cpu_ms() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return 1e3 * static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_nsec);
}

/// Wall-clock (steady clock: immune to clock adjustments) and thread-CPU stopwatch, milliseconds.
class Stopwatch {
 public:
  Stopwatch() : start_(std::chrono::steady_clock::now()), start_cpu_(thread_cpu_ms()) {}
  double elapsed_ms() const {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start_).count();
  }
  double elapsed_cpu_ms() const { return thread_cpu_ms() - start_cpu_; }

 private:
  std::chrono::steady_clock::time_point start_;
  double start_cpu_;
};

/// Median (mean of the two middle values for an even count); NaN for an empty set.
inline double median(std::vector<double> values) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  const std::size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(mid), values.end());
  const double upper = values[mid];
  if (values.size() % 2 == 1) return upper;
  const double lower = *std::max_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(mid));
  return 0.5 * (lower + upper);
}

inline double max_of(const std::vector<double>& values) {
  return values.empty() ? std::numeric_limits<double>::quiet_NaN()
                        : *std::max_element(values.begin(), values.end());
}

/// Fixed-point or scientific text, whichever keeps a value readable in a narrow column.
inline std::string format_number(double value, int digits = 3) {
  if (std::isnan(value)) return "-";
  if (std::isinf(value)) return "inf";
  std::ostringstream out;
  const double magnitude = std::fabs(value);
  if (magnitude != 0.0 && (magnitude < 1e-3 || magnitude >= 1e6)) {
    out << std::scientific << std::setprecision(digits - 1) << value;
  } else {
    // Significant digits rather than decimals, so 0.0123 and 1234 both keep `digits` of them.
    const int whole = magnitude >= 1.0 ? static_cast<int>(std::floor(std::log10(magnitude))) + 1 : 1;
    const int decimals = std::max(0, digits - whole);
    out << std::fixed << std::setprecision(magnitude >= 1.0 ? decimals : digits) << value;
  }
  return out.str();
}

/// "1k", "100k", "1M": the sizes the tables speak of.
inline std::string format_count(std::size_t n) {
  if (n >= 1000000 && n % 1000000 == 0) return std::to_string(n / 1000000) + "M";
  if (n >= 1000 && n % 1000 == 0) return std::to_string(n / 1000) + "k";
  return std::to_string(n);
}

/// A Markdown table whose columns are padded, so it reads well both in a terminal and rendered.
class Table {
 public:
  explicit Table(std::vector<std::string> header) : header_(std::move(header)) {}

  void add(std::vector<std::string> row) {
    row.resize(header_.size());
    rows_.push_back(std::move(row));
  }

  void print(std::ostream& out) const {
    std::vector<std::size_t> width(header_.size(), 3);
    for (std::size_t c = 0; c < header_.size(); ++c) width[c] = std::max(width[c], header_[c].size());
    for (const auto& row : rows_)
      for (std::size_t c = 0; c < row.size(); ++c) width[c] = std::max(width[c], row[c].size());
    auto line = [&](const std::vector<std::string>& cells) {
      out << '|';
      for (std::size_t c = 0; c < cells.size(); ++c)
        out << ' ' << cells[c] << std::string(width[c] - cells[c].size(), ' ') << " |";
      out << '\n';
    };
    line(header_);
    out << '|';
    for (std::size_t c = 0; c < header_.size(); ++c) out << std::string(width[c] + 2, '-') << '|';
    out << '\n';
    for (const auto& row : rows_) line(row);
    out.flush();
  }

 private:
  std::vector<std::string> header_;
  std::vector<std::vector<std::string>> rows_;
};

/// The 1-, 5- and 15-minute load averages, so a recorded run says how busy the machine was.
inline std::string load_average() {
  std::ifstream in("/proc/loadavg");
  double one = 0.0, five = 0.0, fifteen = 0.0;
  if (!(in >> one >> five >> fifteen)) return "unknown";
  std::ostringstream out;
  out << std::fixed << std::setprecision(2) << one << ' ' << five << ' ' << fifteen;
  return out.str();
}

}  // namespace diachron::bench
