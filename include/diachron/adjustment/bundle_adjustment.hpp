#pragma once
/// @file
/// bundle_adjust(): the FraserAffine bundle adjustment with self-calibration of one or more
/// epochs (paper section 3.3, Algorithm 1 "combined processing"): triangulates tracks without
/// initial points, solves with Ceres (optionally freeing the intrinsics in stages), rejects
/// observations above a residual threshold and solves again, and reports RMS before/after per
/// epoch and kind, the intrinsics with their standard deviations, and what was rejected.

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <ceres/covariance.h>
#include <ceres/problem.h>
#include <ceres/solver.h>

#include <diachron/adjustment/bundle_options.hpp>
#include <diachron/adjustment/bundle_problem.hpp>
#include <diachron/adjustment/bundle_report.hpp>
#include <diachron/adjustment/triangulation.hpp>
#include <diachron/camera/frame.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/types.hpp>

namespace diachron {

/// The outcome of bundle_adjust: the report and adjusted copies of the input.
struct BundleResult {
  BundleReport report;
  /// Adjusted frames (same order as the input); copies of the input when !report.success.
  std::vector<Frame<FraserAffine>> frames;
  /// Adjusted point of each input track; NaN for tracks not used (or when !report.success).
  std::vector<Eigen::Vector3d> points;
  /// Whether each input track took part to the end (after rejection).
  std::vector<bool> track_used;
};

namespace detail {

inline ceres::Solver::Options bundle_solver_options(const BundleOptions& options, std::size_t images) {
  ceres::Solver::Options s;
  // Dense Schur is exact and fast while the reduced camera system is small; sparse beyond.
  s.linear_solver_type = ceres::DENSE_SCHUR;
  if (images > 100 && ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE))
    s.linear_solver_type = ceres::SPARSE_SCHUR;
  s.max_num_iterations = options.max_iterations;
  s.function_tolerance = options.function_tolerance;
  s.num_threads = options.num_threads;
  s.logging_type = ceres::SILENT;
  s.minimizer_progress_to_stdout = false;
  return s;
}

inline SolveSummary solve_summary(const std::string& stage, const ceres::Solver::Summary& s) {
  SolveSummary out;
  out.stage = stage;
  out.usable = s.IsSolutionUsable() && s.termination_type != ceres::FAILURE && std::isfinite(s.final_cost);
  out.termination = std::string(ceres::TerminationTypeToString(s.termination_type)) + ": " + s.message;
  out.iterations = static_cast<int>(s.iterations.size());
  out.initial_cost = s.initial_cost;
  out.final_cost = s.final_cost;
  out.seconds = s.total_time_in_seconds;
  return out;
}

// Deactivates tracks left with fewer than 2 active observations, or none for a track whose point
// has a prior (`anchored`: a control point seen in one image still constrains that image, as a
// ground control point measured in one photo does); returns how many observations that removed.
inline std::size_t drop_thin_tracks(std::vector<BundleProblem::Observation>& observations, std::size_t tracks,
                                    const std::vector<bool>& anchored) {
  std::vector<int> active(tracks, 0);
  for (const auto& o : observations) active[o.track] += o.active ? 1 : 0;
  std::size_t removed = 0;
  for (auto& o : observations)
    if (o.active && active[o.track] < (anchored[o.track] ? 1 : 2)) {
      o.active = false;
      ++removed;
    }
  return removed;
}

}  // namespace detail

/// Adjusts `input` (never modified). Data failures (too few inter-epoch tracks, a camera with no
/// observations, non-finite initial points, a Ceres failure, a diverged camera) give
/// report.success == false with a message and copies of the input; malformed input (sizes,
/// out-of-range indices, bad options) throws diachron::Error.
inline BundleResult bundle_adjust(const BundleInput& input, const BundleOptions& options = {}) {
  const auto start = std::chrono::steady_clock::now();
  options.check();
  BundleResult result;
  result.frames = input.frames;
  result.points.assign(input.tracks.size(), Vec3::Constant(std::numeric_limits<double>::quiet_NaN()));
  result.track_used.assign(input.tracks.size(), false);
  BundleReport& report = result.report;
  report.tracks_input = input.tracks.size();
  const auto finish = [&](std::string message) {
    report.message = std::move(message);
    report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return result;
  };

  BundleInput working;
  const BundleInput* source = &input;
  if (input.points.empty() && !input.tracks.empty()) {
    // Triangulate with the initial frames; a failed track gets a NaN point and stays out.
    working = input;
    working.points.resize(input.tracks.size());
    for (std::size_t t = 0; t < input.tracks.size(); ++t) {
      const TriangulationResult tri = triangulate_track(input.frames, input.tracks[t], options.triangulation);
      working.points[t] = tri.success ? tri.point : Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
      report.tracks_not_triangulated += tri.success ? 0 : 1;
    }
    // A control point seen in one image cannot be triangulated: it starts at its given position.
    for (const GroundControlPoint& g : input.control_points)
      if (g.track < input.tracks.size() && input.tracks[g.track].observations.size() == 1 &&
          !working.points[g.track].allFinite() && g.position.allFinite()) {
        working.points[g.track] = g.position;
        --report.tracks_not_triangulated;
      }
    source = &working;
  } else {
    for (std::size_t t = 0; t < input.points.size(); ++t)
      if (!input.points[t].allFinite()) {
        BundleProblem check(input, options);  // malformed input throws before the data failure
        return finish("non-finite initial value: the point of track " + std::to_string(t));
      }
  }
  BundleProblem problem(*source, options);
  auto& observations = problem.observations();
  std::vector<bool> anchored(input.tracks.size(), false);
  for (const GroundControlPoint& g : problem.control_points()) anchored[g.track] = true;
  detail::drop_thin_tracks(observations, input.tracks.size(), anchored);

  // Usable tracks, inter-epoch links, observed cameras.
  std::vector<bool> used(input.tracks.size(), false);
  std::vector<bool> inter(input.tracks.size(), false);
  std::vector<bool> camera_seen(problem.camera_count(), false);
  for (const auto& o : observations) {
    if (!o.active) continue;
    used[o.track] = true;
    inter[o.track] = inter[o.track] || o.kind == ObservationKind::inter_epoch;
    camera_seen[static_cast<std::size_t>(problem.camera_of(static_cast<std::size_t>(o.image)))] = true;
  }
  std::size_t inter_tracks = 0, used_tracks = 0;
  for (std::size_t t = 0; t < used.size(); ++t) {
    used_tracks += used[t] ? 1 : 0;
    inter_tracks += used[t] && inter[t] ? 1 : 0;
  }
  report.tracks_used = used_tracks;
  report.tracks_rejected = input.tracks.size() - used_tracks;
  report.inter_epoch_tracks = inter_tracks;
  if (problem.epoch_count() > 1 && inter_tracks < options.min_inter_epoch_tracks)
    return finish("too few inter-epoch tracks: " + std::to_string(inter_tracks) + " < " +
                  std::to_string(options.min_inter_epoch_tracks));
  for (std::size_t c = 0; c < camera_seen.size(); ++c)
    if (!camera_seen[c]) return finish("camera " + std::to_string(c) + " has no observations");

  report.before = problem.rms();
  // Each image's B1, B2 as the solve starts (per camera, the shared block's starting values).
  std::vector<std::array<double, kAffineBlockSize>> affine_before;
  for (std::size_t i = 0; i < problem.image_count(); ++i) affine_before.push_back(problem.affine_block_of(i));
  const ceres::Solver::Options solver = detail::bundle_solver_options(options, problem.image_count());
  std::unique_ptr<ceres::Problem> last;
  const auto solve = [&](IntrinsicsStage stage, const std::string& name) {
    last = std::make_unique<ceres::Problem>();
    problem.add_to(*last, stage);
    ceres::Solver::Summary summary;
    ceres::Solve(solver, last.get(), &summary);
    report.solves.push_back(detail::solve_summary(name, summary));
    return report.solves.back().usable;
  };
  std::vector<std::pair<IntrinsicsStage, std::string>> stages = {{IntrinsicsStage::all, "all"}};
  if (options.staged_intrinsics)
    stages = {{IntrinsicsStage::focal_principal_point, "focal+pp"},
              {IntrinsicsStage::radial, "+radial"},
              {IntrinsicsStage::all, "all"}};
  for (const auto& [stage, name] : stages)
    if (!solve(stage, name)) return finish("the solve failed (" + name + "): " + report.solves.back().termination);

  for (int round = 0; round < options.rejection_rounds && options.reject_residual_px > 0.0; ++round) {
    std::size_t rejected = 0;
    for (auto& o : observations)
      if (o.active && !(problem.residual_px(o) <= options.reject_residual_px)) {
        o.active = false;
        ++rejected;
      }
    if (rejected == 0) break;
    rejected += detail::drop_thin_tracks(observations, input.tracks.size(), anchored);
    report.observations_rejected += rejected;
    if (!solve(IntrinsicsStage::all, "after rejection " + std::to_string(round + 1)))
      return finish("the solve failed after rejection: " + report.solves.back().termination);
  }

  // Adjusted frames; a camera the solve drove out of validity (det(f I + A) <= 0) is a failure.
  std::vector<Frame<FraserAffine>> frames;
  try {
    for (std::size_t i = 0; i < problem.image_count(); ++i) frames.push_back(problem.frame(i));
  } catch (const Error& e) {
    return finish(std::string("the solve diverged to an invalid camera: ") + e.what());
  }

  // Final bookkeeping: tracks and observations kept.
  std::fill(used.begin(), used.end(), false);
  std::fill(inter.begin(), inter.end(), false);
  report.observations_used = 0;
  for (const auto& o : observations) {
    if (!o.active) continue;
    used[o.track] = true;
    inter[o.track] = inter[o.track] || o.kind == ObservationKind::inter_epoch;
    ++report.observations_used;
  }
  report.tracks_used = 0;
  report.inter_epoch_tracks = 0;
  std::vector<Vec3> points(input.tracks.size(), Vec3::Constant(std::numeric_limits<double>::quiet_NaN()));
  for (std::size_t t = 0; t < used.size(); ++t) {
    if (!used[t]) continue;
    ++report.tracks_used;
    report.inter_epoch_tracks += inter[t] ? 1 : 0;
    const auto& p = problem.point_block(t);
    points[t] = Vec3(p[0], p[1], p[2]);
  }
  report.tracks_rejected = input.tracks.size() - report.tracks_used;
  for (const auto& g : problem.control_points()) report.control_points += used[g.track] ? 1 : 0;
  report.after = problem.rms();

  // Intrinsics before/after and their standard deviations.
  const double redundancy = BundleProblem::redundancy(*last);
  report.sigma0 = redundancy > 0.0 ? std::sqrt(2.0 * report.solves.back().final_cost / redundancy)
                                   : std::numeric_limits<double>::quiet_NaN();
  std::vector<std::pair<const double*, const double*>> blocks;
  for (std::size_t c = 0; c < problem.camera_count(); ++c) {
    const double* b = problem.camera_block(c).data();
    if (last->HasParameterBlock(b) && !last->IsParameterBlockConstant(b)) blocks.emplace_back(b, b);
  }
  for (std::size_t k = 0; k < problem.affine_entry_count(); ++k) {
    const double* b = problem.affine_entry(k).data();
    if (last->HasParameterBlock(b) && !last->IsParameterBlockConstant(b)) blocks.emplace_back(b, b);
  }
  ceres::Covariance::Options covariance_options;
  covariance_options.num_threads = options.num_threads;
  ceres::Covariance covariance(covariance_options);
  if (!options.compute_covariance) {
    report.covariance_message = "not requested";
  } else if (blocks.empty()) {
    report.covariance_message = "no free intrinsics";
  } else if (!std::isfinite(report.sigma0)) {
    report.covariance_message = "no redundancy";
  } else if (!covariance.Compute(blocks, last.get())) {
    report.covariance_message = "the normal equations are rank deficient (the gauge or the intrinsics are not determined)";
  } else {
    report.covariance_available = true;
  }
  // The block's a-posteriori covariance (row-major, scaled by sigma0^2); empty when there is none.
  const auto block_covariance = [&](const double* block, int size) {
    std::vector<double> c;
    if (!report.covariance_available || !last->HasParameterBlock(block) || last->IsParameterBlockConstant(block)) return c;
    c.resize(static_cast<std::size_t>(size * size));
    if (!covariance.GetCovarianceBlock(block, block, c.data())) return std::vector<double>{};
    for (double& v : c) v *= report.sigma0 * report.sigma0;
    return c;
  };
  const auto sigmas = [&](const std::vector<double>& c, int size) {
    std::vector<double> out(static_cast<std::size_t>(size), std::numeric_limits<double>::quiet_NaN());
    if (c.empty()) return out;
    for (int k = 0; k < size; ++k) out[static_cast<std::size_t>(k)] = std::sqrt(std::max(0.0, c[static_cast<std::size_t>(k * size + k)]));
    return out;
  };
  std::vector<bool> camera_done(problem.camera_count(), false);
  for (std::size_t i = 0; i < problem.image_count(); ++i) {
    const auto c = static_cast<std::size_t>(problem.camera_of(i));
    const auto before_camera = fraser_camera_block(input.frames[i].camera());
    if (!camera_done[c]) {
      camera_done[c] = true;
      CameraReport cam;
      cam.camera = static_cast<int>(c);
      cam.free = problem.camera_free(c);
      cam.covariance = block_covariance(problem.camera_block(c).data(), kFraserCameraBlockSize);
      std::vector<double> s = sigmas(cam.covariance, kFraserCameraBlockSize);
      // A held intrinsic has no standard deviation (its covariance rows are zero).
      for (int k : problem.held_intrinsics(c)) {
        s[static_cast<std::size_t>(k)] = std::numeric_limits<double>::quiet_NaN();
        if (cam.free) cam.held.push_back(intrinsic_name(static_cast<Intrinsic>(k)));
      }
      if (cam.free)
        for (const auto& [k, sigma] : problem.intrinsic_priors(c)) {
          cam.priors.push_back(intrinsic_name(static_cast<Intrinsic>(k)));
          cam.prior_sigmas.push_back(sigma);
        }
      for (int k = 0; k < kFraserCameraBlockSize; ++k) {
        const auto uk = static_cast<std::size_t>(k);
        cam.values.push_back({intrinsic_name(static_cast<Intrinsic>(k)), before_camera[uk], problem.camera_block(c)[uk], s[uk]});
      }
      report.cameras.push_back(std::move(cam));
    }
    ImageAffineReport affine;
    affine.image = static_cast<int>(i);
    affine.free = problem.affine_free(i);
    const auto& before_affine = affine_before[i];
    const std::vector<double> s = sigmas(block_covariance(problem.affine_block_of(i).data(), kAffineBlockSize), kAffineBlockSize);
    affine.values.push_back({"B1", before_affine[0], problem.affine_block_of(i)[0], s[0]});
    affine.values.push_back({"B2", before_affine[1], problem.affine_block_of(i)[1], s[1]});
    report.affine.push_back(std::move(affine));
  }
  std::sort(report.cameras.begin(), report.cameras.end(),
            [](const CameraReport& a, const CameraReport& b) { return a.camera < b.camera; });

  result.frames = std::move(frames);
  result.points = std::move(points);
  result.track_used = used;
  report.success = true;
  return finish("adjusted " + std::to_string(report.tracks_used) + " tracks (" + std::to_string(report.inter_epoch_tracks) +
                " inter-epoch), RMS " + std::to_string(report.before.all.rms_px) + " -> " +
                std::to_string(report.after.all.rms_px) + " px");
}

}  // namespace diachron
