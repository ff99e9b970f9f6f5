/// @file
/// Robust-estimation benchmark: diachron's RANSAC side by side with its peers, in one run, on the
/// same data.
///
/// - 2D similarity: ransac_similarity2 (defaults, and the paper's fixed 1000 iterations) against
///   OpenCV's estimateAffinePartial2D (RANSAC, same threshold and confidence).
/// - 3D Helmert: ransac_helmert3 (same two settings) against a plain 1000-iteration RANSAC loop
///   around Eigen::umeyama (the paper's and MicMac's scheme), and OpenCV's least-squares
///   estimateAffine3D on the true inliers only (an accuracy reference, not a robust method).
/// - One "pass": a bare loop that evaluates one model's residual over all pairs; our RANSAC's cost
///   is reported in passes, by time and by the report's residual-evaluation counter.
///
/// Prints Markdown tables on stdout (progress on stderr); docs/benchmarks.md pastes them.
/// Run with --help for the options.

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/core/version.hpp>

#include <diachron/geometry/helmert3_estimator.hpp>
#include <diachron/geometry/similarity2_estimator.hpp>
#include <diachron/robust/robust_estimation.hpp>

#include "bench_common.hpp"

namespace {

using namespace diachron;
using namespace diachron::bench;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

/// Confidence handed to every adaptive method (ours' default, so "ours, defaults" stays true).
constexpr double kConfidence = RansacOptions{}.confidence;
/// The paper's and MicMac's fixed iteration count.
constexpr std::size_t kPaperIterations = 1000;
/// OpenCV's iteration cap: far above what its own stopping rule asks for at 90 % outliers
/// (about 700 two-point samples at 0.999), so the cap never decides for it.
constexpr int kOpenCvMaxIters = 100000;

/// A model counts as recovered when its error (RMS of est(x) - true(x) over the inlier sources, in
/// target units) is below this many noise sigmas. A least-squares fit on the inliers scores far
/// below 0.1 sigma; a wrong hypothesis scores hundreds of sigmas, so the verdict is not sensitive
/// to the exact factor.
constexpr double kSuccessSigmas = 2.0;

// --- one run of one method -----------------------------------------------------------------------

struct Run {
  double ms = kNaN;      // wall
  double cpu_ms = kNaN;  // thread CPU
  double error = kInf;
  // Counters, only for ours (NaN for peers).
  double iterations = kNaN;
  double hypotheses = kNaN;
  double stopped_early = kNaN;
  double bailed_out = kNaN;
  double local_optimizations = kNaN;
  double passes = kNaN;  // residual evaluations / N
};

struct Stats {
  std::vector<double> ms, cpu_ms, errors, iterations, hypotheses, stopped_early, bailed_out, local_optimizations,
      passes;
  std::size_t successes = 0;

  void add(const Run& run, double tolerance) {
    ms.push_back(run.ms);
    cpu_ms.push_back(run.cpu_ms);
    errors.push_back(run.error);
    if (run.error < tolerance) ++successes;
    if (!std::isnan(run.iterations)) {
      iterations.push_back(run.iterations);
      hypotheses.push_back(run.hypotheses);
      stopped_early.push_back(run.stopped_early);
      bailed_out.push_back(run.bailed_out);
      local_optimizations.push_back(run.local_optimizations);
      passes.push_back(run.passes);
    }
  }
  std::size_t runs() const { return ms.size(); }
};

template <class Model>
void copy_counters(const RansacReport<Model>& report, Run& run) {
  run.iterations = static_cast<double>(report.iterations);
  run.hypotheses = static_cast<double>(report.hypotheses_generated);
  run.stopped_early = static_cast<double>(report.hypotheses_stopped_early);
  run.bailed_out = static_cast<double>(report.hypotheses_bailed_out);
  run.local_optimizations = static_cast<double>(report.local_optimizations);
  run.passes = report.data_passes();
}

// --- ours ----------------------------------------------------------------------------------------

/// Which of our configurations runs: the defaults, the paper's fixed 1000 iterations, the defaults
/// without the bail-out test (every early stop exact), or the defaults plus the SPRT.
enum class Ours { kDefaults, kPaperFixed, kExact, kSprt };

RansacOptions our_options(double threshold, std::uint64_t seed, Ours variant) {
  RansacOptions options;
  options.sprt = variant == Ours::kSprt;
  if (variant == Ours::kExact) options.bail_out_risk = 0.0;
  options.threshold = threshold;
  options.seed = seed;
  if (variant == Ours::kPaperFixed) {
    // confidence 1 means "never stop early": exactly max_iterations samples, as in the paper.
    options.max_iterations = kPaperIterations;
    options.confidence = 1.0;
  }
  return options;
}

Run run_ours2(const Problem2& p, std::uint64_t seed, Ours variant) {
  const RansacOptions options = our_options(p.threshold, seed, variant);
  Run run;
  const Stopwatch watch;
  const RansacReport<Similarity2> report = ransac_similarity2(p.pairs, options);
  run.ms = watch.elapsed_ms();
  run.cpu_ms = watch.elapsed_cpu_ms();
  if (report.success) run.error = model_error(p, [&](const Vec2& x) { return report.model(x); });
  copy_counters(report, run);
  return run;
}

Run run_ours3(const Problem3& p, std::uint64_t seed, Ours variant) {
  const RansacOptions options = our_options(p.threshold, seed, variant);
  Run run;
  const Stopwatch watch;
  const RansacReport<Helmert3> report = ransac_helmert3(p.pairs, options);
  run.ms = watch.elapsed_ms();
  run.cpu_ms = watch.elapsed_cpu_ms();
  if (report.success) run.error = model_error(p, [&](const Vec3& x) { return report.model(x); });
  copy_counters(report, run);
  return run;
}

// --- OpenCV peers --------------------------------------------------------------------------------

/// OpenCV's native input for estimateAffinePartial2D: it converts anything else to float32 first,
/// so handing it float32 (converted outside the timed region) is its best case.
struct CvPoints2 {
  std::vector<cv::Point2f> source, target;
  explicit CvPoints2(const Problem2& p) {
    source.reserve(p.pairs.size());
    target.reserve(p.pairs.size());
    for (const PointPair2& pair : p.pairs) {
      source.emplace_back(static_cast<float>(pair.source.x()), static_cast<float>(pair.source.y()));
      target.emplace_back(static_cast<float>(pair.target.x()), static_cast<float>(pair.target.y()));
    }
  }
};

Run run_opencv_partial2d(const Problem2& p, const CvPoints2& points) {
  Run run;
  std::vector<uchar> inlier_mask;  // asked for because ours returns its inliers too
  const Stopwatch watch;
  const cv::Mat m = cv::estimateAffinePartial2D(points.source, points.target, inlier_mask, cv::RANSAC,
                                                p.threshold, kOpenCvMaxIters, kConfidence);
  run.ms = watch.elapsed_ms();
  run.cpu_ms = watch.elapsed_cpu_ms();
  if (!m.empty()) {
    Eigen::Matrix<double, 2, 3> a;
    for (int r = 0; r < 2; ++r)
      for (int c = 0; c < 3; ++c) a(r, c) = m.at<double>(r, c);
    run.error = model_error(p, [&](const Vec2& x) -> Vec2 { return a.leftCols<2>() * x + a.col(2); });
  }
  return run;
}

/// The least-squares Umeyama overload on the true inliers: what a perfect outlier filter followed
/// by a plain fit would give. Inputs converted outside the timed region.
Run run_opencv_ls3_on_inliers(const Problem3& p) {
  std::vector<cv::Point3d> source, target;
  source.reserve(p.inlier_indices.size());
  target.reserve(p.inlier_indices.size());
  for (const std::size_t i : p.inlier_indices) {
    const PointPair3& pair = p.pairs[i];
    source.emplace_back(pair.source.x(), pair.source.y(), pair.source.z());
    target.emplace_back(pair.target.x(), pair.target.y(), pair.target.z());
  }
  Run run;
  double scale = 0.0;
  const Stopwatch watch;
  const cv::Mat m = cv::estimateAffine3D(source, target, &scale, true);
  run.ms = watch.elapsed_ms();
  run.cpu_ms = watch.elapsed_cpu_ms();
  if (!m.empty()) {
    // OpenCV returns [R | t] with the scale apart: est(x) = scale * R * x + t.
    Eigen::Matrix<double, 3, 4> a;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) a(r, c) = m.at<double>(r, c);
    run.error =
        model_error(p, [&](const Vec3& x) -> Vec3 { return scale * (a.leftCols<3>() * x) + a.col(3); });
  }
  return run;
}

// --- the plain Umeyama RANSAC loop (the paper's and MicMac's scheme) -----------------------------

/// Inliers of the affine map x -> a * x + t (squared comparison: no sqrt per pair).
std::size_t count_inliers(const std::vector<PointPair3>& pairs, const Eigen::Matrix3d& a,
                          const Eigen::Vector3d& t, double threshold2) {
  std::size_t count = 0;
  for (const PointPair3& pair : pairs)
    count += (a * pair.source + t - pair.target).squaredNorm() <= threshold2 ? 1 : 0;
  return count;
}

/// Draw 3 distinct pairs, Eigen::umeyama, count inliers over all pairs, keep the largest set, for a
/// fixed number of iterations; then refit umeyama on that set. No early exit, no degeneracy test
/// beyond skipping non-finite fits, no local optimisation: the loop the paper and MicMac run.
Run run_umeyama_loop(const Problem3& p, std::uint64_t seed, std::size_t iterations) {
  Run run;
  const Stopwatch watch;
  const std::size_t n = p.pairs.size();
  const double threshold2 = p.threshold * p.threshold;
  RandomStream random(seed, kPeerStream);
  std::size_t best_count = 0;
  Eigen::Matrix4d best = Eigen::Matrix4d::Identity();
  for (std::size_t it = 0; it < iterations; ++it) {
    std::size_t idx[3];
    idx[0] = random.uniform_index(n);
    do idx[1] = random.uniform_index(n); while (idx[1] == idx[0]);
    do idx[2] = random.uniform_index(n); while (idx[2] == idx[0] || idx[2] == idx[1]);
    Eigen::Matrix3d src, dst;
    for (int k = 0; k < 3; ++k) {
      src.col(k) = p.pairs[idx[k]].source;
      dst.col(k) = p.pairs[idx[k]].target;
    }
    const Eigen::Matrix4d t = Eigen::umeyama(src, dst, true);
    if (!t.allFinite()) continue;
    const std::size_t count = count_inliers(p.pairs, t.topLeftCorner<3, 3>(), t.topRightCorner<3, 1>(), threshold2);
    if (count > best_count) {
      best_count = count;
      best = t;
    }
  }
  bool ok = best_count >= 3;
  if (ok) {
    const Eigen::Matrix3d a = best.topLeftCorner<3, 3>();
    const Eigen::Vector3d b = best.topRightCorner<3, 1>();
    Eigen::Matrix3Xd src(3, static_cast<Eigen::Index>(best_count)), dst(3, static_cast<Eigen::Index>(best_count));
    Eigen::Index k = 0;
    for (const PointPair3& pair : p.pairs) {
      if ((a * pair.source + b - pair.target).squaredNorm() <= threshold2) {
        src.col(k) = pair.source;
        dst.col(k) = pair.target;
        ++k;
      }
    }
    best = Eigen::umeyama(src, dst, true);
    ok = best.allFinite();
  }
  run.ms = watch.elapsed_ms();
  run.cpu_ms = watch.elapsed_cpu_ms();
  if (ok) {
    const Eigen::Matrix3d a = best.topLeftCorner<3, 3>();
    const Eigen::Vector3d b = best.topRightCorner<3, 1>();
    run.error = model_error(p, [&](const Vec3& x) -> Vec3 { return a * x + b; });
  }
  return run;
}

// --- one pass: one model's residual over all pairs -----------------------------------------------

/// Keeps a result alive so the timed loop is not optimised away.
volatile std::size_t g_sink = 0;

/// Median wall and thread-CPU times of one pass, ms.
struct PassTime {
  double ms = kNaN;
  double cpu_ms = kNaN;
};

/// Median times of `reps` runs of `pass`.
PassTime time_pass(const std::function<std::size_t()>& pass, int reps) {
  std::vector<double> ms, cpu_ms;
  for (int r = 0; r < reps; ++r) {
    const Stopwatch watch;
    g_sink = g_sink + pass();
    ms.push_back(watch.elapsed_ms());
    cpu_ms.push_back(watch.elapsed_cpu_ms());
  }
  return {median(ms), median(cpu_ms)};
}

struct PassTimes {
  PassTime bare;       // hand-written loop, squared distance, matrix precomputed
  PassTime estimator;  // make_residual_function(estimator, model): what our RANSAC calls per datum
};

PassTimes time_passes2(const Problem2& p, int reps) {
  const Similarity2& m = p.truth;
  const double a = m.scale * std::cos(m.angle), b = m.scale * std::sin(m.angle);
  const double tx = m.translation.x(), ty = m.translation.y();
  const double threshold2 = p.threshold * p.threshold;
  PassTimes times;
  times.bare = time_pass(
      [&] {
        std::size_t count = 0;
        for (const PointPair2& d : p.pairs) {
          const double ex = a * d.source.x() - b * d.source.y() + tx - d.target.x();
          const double ey = b * d.source.x() + a * d.source.y() + ty - d.target.y();
          count += ex * ex + ey * ey <= threshold2 ? 1 : 0;
        }
        return count;
      },
      reps);
  const Similarity2Estimator estimator;
  times.estimator = time_pass(
      [&] {
        const auto residual = make_residual_function(estimator, m);
        std::size_t count = 0;
        for (const PointPair2& d : p.pairs) count += residual(d) <= p.threshold ? 1 : 0;
        return count;
      },
      reps);
  return times;
}

PassTimes time_passes3(const Problem3& p, int reps) {
  const Eigen::Matrix3d a = p.truth.scale * p.truth.rotation;
  const Eigen::Vector3d t = p.truth.translation;
  const double threshold2 = p.threshold * p.threshold;
  PassTimes times;
  times.bare = time_pass([&] { return count_inliers(p.pairs, a, t, threshold2); }, reps);
  const Helmert3Estimator estimator;
  times.estimator = time_pass(
      [&] {
        const auto residual = make_residual_function(estimator, p.truth);
        std::size_t count = 0;
        for (const PointPair3& d : p.pairs) count += residual(d) <= p.threshold ? 1 : 0;
        return count;
      },
      reps);
  return times;
}

// --- the run -------------------------------------------------------------------------------------

struct Config {
  std::vector<std::size_t> sizes{10000, 100000, 1000000};
  std::vector<double> outlier_ratios{0.5, 0.9};
  std::size_t seeds = 20;
  /// Time budget per method and scenario, seconds: once a method has spent it (and has run at
  /// least min_seeds seeds), it skips the remaining seeds, so that runs costing seconds each (the
  /// 1000-iteration loops at 1M pairs) keep the whole benchmark to minutes. The table says how many
  /// seeds each row ran.
  double budget_s = 12.0;
  std::size_t min_seeds = 3;
  int pass_reps = 7;
  bool run2d = true;
  bool run3d = true;
  /// Only "ours, defaults", for profiling it (perf record, valgrind --tool=callgrind).
  bool ours_only = false;
};

struct Method {
  std::string name;
  bool fixed_1000 = false;  // runs the paper's fixed 1000 iterations (no counter to report them)
  bool reference = false;   // not robust (has the true inliers): success is not comparable
  bool ours = false;        // a variant of ours (not a peer): left out of the ratio table
  bool exact = false;       // ours without the bail-out test: its own ratio column
};

struct ScenarioResult {
  std::string model;  // "2D" or "3D"
  std::size_t n = 0;
  double outliers = 0.0;
  std::vector<Method> methods;
  std::vector<Stats> stats;
  PassTimes pass;
};

void progress(const std::string& text) { std::cerr << text << std::flush; }

template <class Problem, class MakeProblem, class RunMethod, class TimePasses>
ScenarioResult run_scenario(const Config& config, const std::string& model, std::size_t n, double outliers,
                            std::vector<Method> methods, const MakeProblem& make_problem,
                            const RunMethod& run_method, const TimePasses& time_passes) {
  ScenarioResult result;
  result.model = model;
  result.n = n;
  result.outliers = outliers;
  result.methods = methods;
  result.stats.resize(methods.size());
  progress(model + " n=" + format_count(n) + " outliers=" + format_number(outliers * 100, 2) + "%: seed");
  for (std::size_t seed = 1; seed <= config.seeds; ++seed) {
    progress(" " + std::to_string(seed));
    const Problem p = make_problem(n, outliers, seed);
    for (std::size_t m = 0; m < methods.size(); ++m) {
      if (config.ours_only && m != 0) continue;
      const Stats& so_far = result.stats[m];
      double spent_ms = 0.0;
      for (const double ms : so_far.ms) spent_ms += ms;
      if (so_far.runs() >= config.min_seeds && spent_ms > 1000.0 * config.budget_s) continue;
      result.stats[m].add(run_method(m, p, seed), kSuccessSigmas * p.sigma);
    }
    // The pass is timed on the first data set; its cost does not depend on the seed.
    if (seed == 1 && !config.ours_only) result.pass = time_passes(p, config.pass_reps);
  }
  progress("\n");
  return result;
}

ScenarioResult run2d(const Config& config, std::size_t n, double outliers) {
  std::vector<Method> methods{{"ours, defaults", false, false},
                              {"ours, fixed 1000 it.", true, false},
                              {"OpenCV estimateAffinePartial2D", false, false},
                              {"ours, exact (no bail-out)", false, false, true, true},
                              {"ours, + SPRT", false, false, true}};
  auto run_method = [](std::size_t m, const Problem2& p, std::uint64_t seed) {
    switch (m) {
      case 0: return run_ours2(p, seed, Ours::kDefaults);
      case 1: return run_ours2(p, seed, Ours::kPaperFixed);
      case 3: return run_ours2(p, seed, Ours::kExact);
      case 4: return run_ours2(p, seed, Ours::kSprt);
      default: return run_opencv_partial2d(p, CvPoints2(p));
    }
  };
  return run_scenario<Problem2>(
      config, "2D similarity", n, outliers, methods,
      [](std::size_t size, double ratio, std::uint64_t seed) { return make_problem2(size, ratio, seed); },
      run_method, time_passes2);
}

ScenarioResult run3d(const Config& config, std::size_t n, double outliers) {
  std::vector<Method> methods{{"ours, defaults", false, false},
                              {"ours, fixed 1000 it.", true, false},
                              {"plain loop: umeyama x 1000", true, false},
                              {"OpenCV estimateAffine3D LS, true inliers", false, true},
                              {"ours, exact (no bail-out)", false, false, true, true},
                              {"ours, + SPRT", false, false, true}};
  auto run_method = [](std::size_t m, const Problem3& p, std::uint64_t seed) {
    switch (m) {
      case 0: return run_ours3(p, seed, Ours::kDefaults);
      case 1: return run_ours3(p, seed, Ours::kPaperFixed);
      case 4: return run_ours3(p, seed, Ours::kExact);
      case 5: return run_ours3(p, seed, Ours::kSprt);
      case 2: return run_umeyama_loop(p, seed, kPaperIterations);
      default: return run_opencv_ls3_on_inliers(p);
    }
  };
  return run_scenario<Problem3>(
      config, "3D Helmert", n, outliers, methods,
      [](std::size_t size, double ratio, std::uint64_t seed) { return make_problem3(size, ratio, seed); },
      run_method, time_passes3);
}

/// First calls pay for page faults, lazy library initialisation and cold caches; do them once on a
/// small case, untimed, so the first recorded scenario is not penalised.
void warm_up() {
  const Problem2 p2 = make_problem2(10000, 0.5, 999);
  static_cast<void>(run_ours2(p2, 999, Ours::kDefaults));
  static_cast<void>(run_opencv_partial2d(p2, CvPoints2(p2)));
  const Problem3 p3 = make_problem3(10000, 0.5, 999);
  static_cast<void>(run_ours3(p3, 999, Ours::kDefaults));
  static_cast<void>(run_umeyama_loop(p3, 999, 100));
  static_cast<void>(run_opencv_ls3_on_inliers(p3));
}

std::string percent(double ratio) { return format_number(ratio * 100.0, 2) + " %"; }

void print_results(const std::vector<ScenarioResult>& results, const std::string& model) {
  Table table({"N", "outliers", "method", "seeds", "CPU ms (median)", "wall ms (median)", "success",
               "model error (median)", "model error (max)", "iterations (median)"});
  for (const ScenarioResult& r : results) {
    if (r.model != model) continue;
    for (std::size_t m = 0; m < r.methods.size(); ++m) {
      const Stats& s = r.stats[m];
      const std::string success = r.methods[m].reference
                                      ? "(ref.)"
                                      : std::to_string(s.successes) + "/" + std::to_string(s.runs());
      table.add({format_count(r.n), percent(r.outliers), r.methods[m].name, std::to_string(s.runs()),
                 format_number(median(s.cpu_ms)), format_number(median(s.ms)), success,
                 format_number(median(s.errors)), format_number(max_of(s.errors)),
                 s.iterations.empty() ? (r.methods[m].fixed_1000 ? "1000" : "-")
                                      : format_number(median(s.iterations))});
    }
  }
  std::cout << "\n### " << model << "\n\n";
  table.print(std::cout);
}

/// Time of every robust peer divided by ours: "x times faster" when above 1. CPU time is the figure
/// to trust on a shared machine; wall time is given as well.
void print_ratios(const std::vector<ScenarioResult>& results) {
  Table table({"model", "N", "outliers", "peer", "peer / ours (defaults), CPU", "same, wall",
               "peer / ours (exact), CPU", "peer / ours (1000 it.), CPU",
               "success ours (defaults) vs peer", "success ours (exact)"});
  for (const ScenarioResult& r : results) {
    const Stats* exact = nullptr;
    for (std::size_t m = 0; m < r.methods.size(); ++m) {
      if (r.methods[m].exact && !r.stats[m].cpu_ms.empty()) exact = &r.stats[m];
    }
    for (std::size_t m = 2; m < r.methods.size(); ++m) {
      if (r.methods[m].reference || r.methods[m].ours) continue;
      const Stats& s = r.stats[m];
      table.add({r.model, format_count(r.n), percent(r.outliers), r.methods[m].name,
                 format_number(median(s.cpu_ms) / median(r.stats[0].cpu_ms)),
                 format_number(median(s.ms) / median(r.stats[0].ms)),
                 exact ? format_number(median(s.cpu_ms) / median(exact->cpu_ms)) : "-",
                 format_number(median(s.cpu_ms) / median(r.stats[1].cpu_ms)),
                 std::to_string(r.stats[0].successes) + "/" + std::to_string(r.stats[0].runs()) + " vs " +
                     std::to_string(s.successes) + "/" + std::to_string(s.runs()),
                 exact ? std::to_string(exact->successes) + "/" + std::to_string(exact->runs()) : "-"});
    }
  }
  std::cout << "\n### Ratios\n\n";
  table.print(std::cout);
}

/// Ours' cost in passes: by CPU time and by the report's residual-evaluation counter.
void print_passes(const std::vector<ScenarioResult>& results) {
  Table table({"model", "N", "outliers", "bare pass, CPU ms", "residual fn pass, CPU ms", "ours, CPU ms",
               "ours / bare pass", "ours / residual fn pass", "residual evals / N", "hypotheses scored",
               "stopped early", "of which bailed out", "local opt."});
  for (const ScenarioResult& r : results) {
    const Stats& s = r.stats[0];
    const double ours = median(s.cpu_ms);
    table.add({r.model, format_count(r.n), percent(r.outliers), format_number(r.pass.bare.cpu_ms),
               format_number(r.pass.estimator.cpu_ms), format_number(ours),
               format_number(ours / r.pass.bare.cpu_ms), format_number(ours / r.pass.estimator.cpu_ms),
               format_number(median(s.passes)), format_number(median(s.hypotheses)),
               format_number(median(s.stopped_early)), format_number(median(s.bailed_out)),
               format_number(median(s.local_optimizations))});
  }
  std::cout << "\n### Ours (defaults) in passes over the data\n\n";
  table.print(std::cout);
}

std::vector<std::size_t> parse_sizes(const std::string& text) {
  std::vector<std::size_t> sizes;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = text.find(',', start);
    const std::string item = text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    if (!item.empty()) {
      double value = std::stod(item);
      const char suffix = item.back();
      if (suffix == 'k' || suffix == 'K') value *= 1e3;
      if (suffix == 'm' || suffix == 'M') value *= 1e6;
      sizes.push_back(static_cast<std::size_t>(value));
    }
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return sizes;
}

void usage(const char* program) {
  std::cout << "usage: " << program << " [--quick] [--sizes 10k,100k,1M] [--outliers 50,90] [--seeds S]\n"
            << "            [--budget SECONDS] [--min-seeds S]"
            << " [--only 2d|3d] [--ours-only]\n"
            << "  --quick       10k and 100k pairs, 5 seeds, 3 s budget (under a minute)\n"
            << "  --sizes       comma-separated pair counts, k and M suffixes allowed\n"
            << "  --outliers    comma-separated outlier percentages (default 50,90)\n"
            << "  --seeds       data sets (and RANSAC seeds) per scenario (default 20)\n"
            << "  --budget      seconds one method may spend on one scenario before it skips the\n"
            << "                remaining seeds (default 12; --quick: 3)\n"
            << "  --min-seeds   seeds every method runs whatever the budget (default 3)\n"
            << "  --only        run only the 2D similarity or only the 3D Helmert part\n"
            << "  --ours-only   run only ours (defaults), to profile it\n";
}

}  // namespace

int main(int argc, char** argv) {
  Config config;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const bool has_value = i + 1 < argc;
    if (arg == "--quick") {
      config.sizes = {10000, 100000};
      config.seeds = 5;
      config.budget_s = 3.0;
      config.pass_reps = 5;
    } else if (arg == "--sizes" && has_value) {
      config.sizes = parse_sizes(argv[++i]);
    } else if (arg == "--outliers" && has_value) {
      config.outlier_ratios.clear();
      for (const std::size_t percent : parse_sizes(argv[++i])) config.outlier_ratios.push_back(static_cast<double>(percent) / 100.0);
    } else if (arg == "--seeds" && has_value) {
      config.seeds = static_cast<std::size_t>(std::stoul(argv[++i]));
    } else if (arg == "--budget" && has_value) {
      config.budget_s = std::stod(argv[++i]);
    } else if (arg == "--min-seeds" && has_value) {
      config.min_seeds = static_cast<std::size_t>(std::stoul(argv[++i]));
    } else if (arg == "--ours-only") {
      config.ours_only = true;
    } else if (arg == "--only" && has_value) {
      const std::string which = argv[++i];
      config.run2d = which == "2d";
      config.run3d = which == "3d";
    } else {
      usage(argv[0]);
      return arg == "--help" || arg == "-h" ? EXIT_SUCCESS : EXIT_FAILURE;
    }
  }
  if (config.sizes.empty() || config.outlier_ratios.empty() || config.seeds == 0 || !(config.budget_s >= 0.0)) {
    usage(argv[0]);
    return EXIT_FAILURE;
  }

  // Every method runs on one thread: ours' default is threads = 1, and OpenCV is pinned to match.
  cv::setNumThreads(1);

  std::cout << "## Robust estimation benchmark\n\n"
            << "- compiler: " << __VERSION__ << ", flags: " << DIACHRON_BENCH_FLAGS
#ifdef NDEBUG
            << " (NDEBUG)"
#else
            << " (WARNING: assertions on, not a release build)"
#endif
            << "\n- OpenCV " << CV_VERSION << ", Eigen " << EIGEN_WORLD_VERSION << '.' << EIGEN_MAJOR_VERSION << '.'
            << EIGEN_MINOR_VERSION << ", one thread per method\n"
            << "- seeds per scenario: " << config.seeds << ", fewer (at least " << config.min_seeds
            << ") for a method once it has spent " << config.budget_s << " s on the scenario\n"
            << "- 2D: 4000 x 3000 px sources, sigma 1 px, threshold 3 px; 3D: 2000 x 2000 x 200 m sources, "
               "sigma 0.5 m, threshold 1.5 m\n"
            << "- success: model error < " << kSuccessSigmas << " sigma; model error = RMS |est(x) - true(x)| over "
            << "the inlier sources, target units (px, m)\n"
            << "- confidence " << kConfidence << " for ours and OpenCV; OpenCV maxIters " << kOpenCvMaxIters
            << ", refineIters default\n"
            << "- load average at start: " << load_average() << "\n";
  std::cout.flush();

  const Stopwatch total;
  if (!config.ours_only) warm_up();
  std::vector<ScenarioResult> results;
  if (config.run2d)
    for (const std::size_t n : config.sizes)
      for (const double outliers : config.outlier_ratios) results.push_back(run2d(config, n, outliers));
  if (config.run3d)
    for (const std::size_t n : config.sizes)
      for (const double outliers : config.outlier_ratios) results.push_back(run3d(config, n, outliers));

  if (config.run2d) print_results(results, "2D similarity");
  if (config.run3d) print_results(results, "3D Helmert");
  print_ratios(results);
  print_passes(results);
  std::cout << "\nload average at end: " << load_average() << "; total run time "
            << format_number(total.elapsed_ms() / 1000.0) << " s\n";
  return EXIT_SUCCESS;
}
