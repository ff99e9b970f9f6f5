#pragma once
/// @file
/// refine_surface_alignment(): least-squares matching of two DSM surfaces, robust to change. Given
/// a rough Helmert that maps the master DSM (epoch 1) into the secondary's frame (epoch 2), it
/// refines all 7 parameters so that the master's cells, moved, lie on the secondary surface:
///   d_i = (z2(X_i, Y_i) - Z_i) / sqrt(1 + |grad z2|^2),   (X_i, Y_i, Z_i) = H(x_i, y_i, z1_i),
/// the distance of each moved master cell to the secondary surface (bilinear) along its normal,
/// to first order (point-to-plane). The slopes of the secondary surface carry the planimetric
/// shift, rotation and scale, as in DEM co-registration by least-squares surface matching
/// (Gruen & Akca 2005).
///
/// Why after the rough co-registration: its Helmert comes from 2D matches of DSM images and a 3D
/// RANSAC whose threshold (10 cells) lets the ground that changed between the epochs in; where a
/// dome grew or a glacier thinned, that ground pulls the fit by cells. Here each iteration weighs
/// the residuals with Tukey's biweight at 4.685 robust sigmas (1.4826 x the median absolute
/// residual), so the changed ground gets no weight once the stable ground agrees.
///
/// The result is refused (the input Helmert kept, `accepted == false`, the reason in `message`)
/// when too few cells overlap, when the surfaces do not fix the parameters (flat ground: the
/// normal matrix is near singular), when it does not converge within `max_iterations` (on a
/// surface that changed broadly, e.g. a growing lava dome, it drifts along a flat cost), when the
/// solve does not lower the robust cost, or when it moves the overlap by more than
/// `max_move_cells` cells of the coarser DSM (a refinement, not a new search).
///
/// Units: heights and planimetry of each DSM in its own frame (metric); residuals, sigmas and the
/// move in the secondary's units; `max_move_cells` in cells of the coarser DSM (see the option).
/// Deterministic (fixed sampling grid, sequential sums).

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include <diachron/core/error.hpp>
#include <diachron/geometry/helmert3.hpp>
#include <diachron/geometry/rotation.hpp>
#include <diachron/terrain/dsm.hpp>

namespace diachron {

/// Options of refine_surface_alignment().
struct SurfaceAlignmentOptions {
  /// Master cells sampled on a regular grid (every k-th cell in both directions, k chosen so that
  /// at most this many are taken). >= 100.
  int max_points = 20000;
  /// Fewest moved master cells that must land on valid secondary heights. >= 20.
  int min_points = 200;
  /// Iterations at most. >= 1. Reweighting converges linearly (each step about 0.9 of the one
  /// before on the synthetic epochs' DSMs): about 20 iterations from a few cells off.
  int max_iterations = 50;
  /// Tukey biweight constant, in robust sigmas (4.685: 95 % efficiency on Gaussian residuals). > 0.
  double tukey_sigmas = 4.685;
  /// The robust sigma is not taken below this fraction of a secondary cell (a surface that agrees
  /// to the last bit would otherwise weigh everything out). > 0.
  double min_sigma_cells = 0.01;
  /// Refuse a refinement that moves any sampled master cell on the secondary surface by more than
  /// this many cells of the coarser DSM (the master's cell times the Helmert's scale, or the
  /// secondary's). > 0. The rough co-registration's 3D guard accepts residuals up to 10 cells.
  double max_move_cells = 10.0;
  /// Refuse when the smallest eigenvalue of the scaled normal matrix is below this fraction of the
  /// largest: the surfaces do not fix all 7 parameters (flat or one-directional ground). > 0.
  double min_conditioning = 1e-7;
  /// Stop when an iteration moves no sampled cell by more than this, secondary cells. > 0. A
  /// rough co-registration needs no more; a surface that changed broadly makes steps of tenths
  /// of a cell that do not shrink.
  double converged_move_cells = 1e-2;

  /// Throws diachron::Error naming the first invalid field.
  void check() const {
    DIACHRON_CHECK(max_points >= 100, "SurfaceAlignmentOptions::max_points must be >= 100, got " << max_points);
    DIACHRON_CHECK(min_points >= 20, "SurfaceAlignmentOptions::min_points must be >= 20, got " << min_points);
    DIACHRON_CHECK(max_iterations >= 1, "SurfaceAlignmentOptions::max_iterations must be >= 1");
    DIACHRON_CHECK(tukey_sigmas > 0.0 && std::isfinite(tukey_sigmas), "SurfaceAlignmentOptions::tukey_sigmas must be > 0");
    DIACHRON_CHECK(min_sigma_cells > 0.0 && std::isfinite(min_sigma_cells),
                   "SurfaceAlignmentOptions::min_sigma_cells must be > 0");
    DIACHRON_CHECK(max_move_cells > 0.0 && std::isfinite(max_move_cells),
                   "SurfaceAlignmentOptions::max_move_cells must be > 0");
    DIACHRON_CHECK(min_conditioning > 0.0 && min_conditioning < 1.0,
                   "SurfaceAlignmentOptions::min_conditioning must be in (0, 1)");
    DIACHRON_CHECK(converged_move_cells > 0.0 && std::isfinite(converged_move_cells),
                   "SurfaceAlignmentOptions::converged_move_cells must be > 0");
  }
};

/// What refine_surface_alignment() did. Defaults: nothing refined.
struct SurfaceAlignmentResult {
  bool accepted = false;                 ///< `epoch2_from_epoch1` is the refined Helmert
  std::string message = "not run";       ///< the reason when refused, else a one-line summary
  Helmert3 epoch2_from_epoch1 = Helmert3::identity();  ///< refined when accepted, else the input
  int iterations = 0;                    ///< iterations run (each a weighted Gauss-Newton step)
  bool converged = false;                ///< the last iteration moved every cell by less than the tolerance
  std::size_t points = 0;                ///< sampled master cells on valid secondary heights, at the end
  /// Share of those whose residual is within 3 robust sigmas (of the end) before and after: the
  /// ground on which the surfaces agree.
  double agreeing_before = 0.0;
  double agreeing_after = 0.0;
  /// Robust sigma of the normal distances (1.4826 x their median absolute deviation), secondary units.
  double sigma_before = std::numeric_limits<double>::infinity();
  double sigma_after = std::numeric_limits<double>::infinity();
  /// Largest planimetric move of a sampled master cell on the secondary surface from the input
  /// Helmert to the refined one, secondary units.
  double moved = 0.0;
  double seconds = 0.0;
};

namespace detail {

// The element at the middle of `v` once sorted (the upper median; v is reordered); 0 when empty.
inline double median_in_place(std::vector<double>& v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// Grid stride that takes at most about `max_points` of `cells` cells (every stride-th cell in both
// directions).
inline int sampling_stride(double cells, int max_points) {
  return std::max(1, static_cast<int>(std::ceil(std::sqrt(cells / static_cast<double>(max_points)))));
}

// Robust sigma of `v` about its median: 1.4826 x the median absolute deviation (v is reordered and
// overwritten); NaN when empty.
inline double robust_sigma_in_place(std::vector<double>& v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const double middle = median_in_place(v);
  for (double& x : v) x = std::fabs(x - middle);
  return 1.4826 * median_in_place(v);
}

// Residual z2(X, Y) - Z of a moved point and the secondary surface's gradient there (central
// differences over one cell in world X and Y). False when the height or the gradient is undefined.
inline bool surface_residual(const Dsm& secondary, const Eigen::Vector3d& p, double step, double& r,
                             Eigen::Vector2d& gradient) {
  const double z = secondary.height_at(p.x(), p.y());
  if (!std::isfinite(z)) return false;
  const double zx0 = secondary.height_at(p.x() - step, p.y()), zx1 = secondary.height_at(p.x() + step, p.y());
  const double zy0 = secondary.height_at(p.x(), p.y() - step), zy1 = secondary.height_at(p.x(), p.y() + step);
  if (!std::isfinite(zx0) || !std::isfinite(zx1) || !std::isfinite(zy0) || !std::isfinite(zy1)) return false;
  r = z - p.z();
  gradient = Eigen::Vector2d((zx1 - zx0) / (2.0 * step), (zy1 - zy0) / (2.0 * step));
  return true;
}

}  // namespace detail

/// Refines `epoch2_from_epoch1` (X2 = scale R X1 + T, master -> secondary) by robust least-squares
/// matching of the two surfaces (see the file comment).
/// @throws diachron::Error for empty DSMs, invalid options or a non-finite Helmert.
inline SurfaceAlignmentResult refine_surface_alignment(const Dsm& master, const Dsm& secondary,
                                                       const Helmert3& epoch2_from_epoch1,
                                                       const SurfaceAlignmentOptions& options = {}) {
  options.check();
  DIACHRON_CHECK(!master.empty() && !secondary.empty(), "refine_surface_alignment: empty DSM");
  DIACHRON_CHECK(std::isfinite(epoch2_from_epoch1.scale) && epoch2_from_epoch1.scale > 0.0 &&
                     epoch2_from_epoch1.rotation.allFinite() && epoch2_from_epoch1.translation.allFinite(),
                 "refine_surface_alignment: the initial Helmert is not finite");
  const auto start = std::chrono::steady_clock::now();
  SurfaceAlignmentResult out;
  out.epoch2_from_epoch1 = epoch2_from_epoch1;
  const double cell = secondary.min_cell_size();
  // With a resolution gap the rough Helmert is as precise as the coarser DSM: the move is bounded in
  // its cells (the master's brought to secondary units by the scale).
  const double bound_cell = std::max(cell, master.min_cell_size() * epoch2_from_epoch1.scale);
  const auto finish = [&](const std::string& why) {
    out.message = why;
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return out;
  };

  // Master cells on a regular grid.
  const int stride = detail::sampling_stride(static_cast<double>(master.statistics().count), options.max_points);
  std::vector<Eigen::Vector3d> cells;
  for (int y = 0; y < master.height(); y += stride)
    for (int x = 0; x < master.width(); x += stride)
      if (master.valid(x, y)) {
        const Eigen::Vector2d w = master.pixel_to_world(Eigen::Vector2d(x, y));
        cells.emplace_back(w.x(), w.y(), static_cast<double>(master.heights()(x, y)));
      }

  // Residuals, gradients and moved points of every cell that lands on the secondary surface.
  struct Term {
    std::size_t cell;
    Eigen::Vector3d moved;
    double r;           // vertical residual z2 - Z
    Eigen::Vector2d g;  // secondary surface gradient
    double d;           // distance along the surface normal, r / sqrt(1 + |g|^2)
  };
  const auto evaluate = [&](const Helmert3& h) {
    std::vector<Term> terms;
    terms.reserve(cells.size());
    for (std::size_t i = 0; i < cells.size(); ++i) {
      Term t{i, h(cells[i]), 0.0, Eigen::Vector2d::Zero(), 0.0};
      if (!detail::surface_residual(secondary, t.moved, cell, t.r, t.g)) continue;
      t.d = t.r / std::sqrt(1.0 + t.g.squaredNorm());
      terms.push_back(t);
    }
    return terms;
  };
  const auto robust_sigma = [&](const std::vector<Term>& terms) {
    std::vector<double> r;
    r.reserve(terms.size());
    for (const Term& t : terms) r.push_back(t.d);
    // Distances about their median: a vertical offset left by the rough Helmert is not spread.
    return std::max(detail::robust_sigma_in_place(r), options.min_sigma_cells * cell);
  };
  const auto tukey_cost = [&](const std::vector<Term>& terms, double sigma) {
    const double c = options.tukey_sigmas * sigma;
    double cost = 0.0;
    for (const Term& t : terms) {
      const double u = t.d / c;
      cost += std::fabs(u) < 1.0 ? (1.0 - std::pow(1.0 - u * u, 3)) : 1.0;
    }
    return cost;
  };
  const auto agreeing = [&](const std::vector<Term>& terms, double sigma) {
    std::size_t n = 0;
    for (const Term& t : terms) n += std::fabs(t.d) <= 3.0 * sigma;
    return terms.empty() ? 0.0 : static_cast<double>(n) / static_cast<double>(terms.size());
  };

  // The input's terms, kept: the refinement is judged against them at the end.
  const std::vector<Term> initial = evaluate(epoch2_from_epoch1);
  if (initial.size() < static_cast<std::size_t>(options.min_points)) {
    std::ostringstream why;
    why << "only " << initial.size() << " master cells land on the secondary surface, fewer than "
        << options.min_points;
    return finish(why.str());
  }
  out.sigma_before = robust_sigma(initial);
  // A vertical offset the rough Helmert left would put every residual beyond the biweight's bound:
  // the median residual is taken up first.
  Helmert3 h = epoch2_from_epoch1;
  {
    std::vector<double> r;
    r.reserve(initial.size());
    for (const Term& t : initial) r.push_back(t.r);
    h.translation.z() += detail::median_in_place(r);
  }
  std::vector<Term> terms = evaluate(h);
  double sigma = out.sigma_before;
  for (int iteration = 0; iteration < options.max_iterations; ++iteration) {
    out.iterations = iteration + 1;
    // Parameters about the moved cells' centroid, scaled to cell units for conditioning:
    // X' = c + (1 + ds) (I + [w]x) (X - c) + dt; unknowns dt, w times the spread and ds times it,
    // all lengths, with v = (X - c) / spread.
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (const Term& t : terms) centroid += t.moved;
    centroid /= static_cast<double>(terms.size());
    double spread = 0.0;
    for (const Term& t : terms) spread += (t.moved - centroid).head<2>().squaredNorm();
    spread = std::max(std::sqrt(spread / static_cast<double>(terms.size())), cell);
    const double c = options.tukey_sigmas * sigma;
    Eigen::Matrix<double, 7, 7> normal = Eigen::Matrix<double, 7, 7>::Zero();
    Eigen::Matrix<double, 7, 1> rhs = Eigen::Matrix<double, 7, 1>::Zero();
    std::size_t weighted = 0;
    for (const Term& t : terms) {
      const double u = t.d / c;
      if (std::fabs(u) >= 1.0) continue;
      const double w = (1.0 - u * u) * (1.0 - u * u);
      ++weighted;
      // r = z2(X') - Z': dr/dX' = (gx, gy, -1); d = r / |(gx, gy, -1)|, the normaliser held fixed
      // (point-to-plane): steep ground then weighs by its distance, not by its height error.
      const double norm = std::sqrt(1.0 + t.g.squaredNorm());
      const Eigen::Vector3d grad = Eigen::Vector3d(t.g.x(), t.g.y(), -1.0) / norm;
      const Eigen::Vector3d v = (t.moved - centroid) / spread;
      Eigen::Matrix<double, 1, 7> j;
      j.head<3>() = grad.transpose();
      // grad . (w x v) = w . (v x grad).
      j.segment<3>(3) = v.cross(grad).transpose();
      j(6) = grad.dot(v);
      normal.noalias() += w * j.transpose() * j;
      rhs.noalias() -= w * j.transpose() * t.d;
    }
    if (weighted < static_cast<std::size_t>(options.min_points)) {
      std::ostringstream why;
      why << "only " << weighted << " cells within the robust bound at iteration " << iteration + 1;
      return finish(why.str());
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 7, 7>> eig(normal);
    const double smallest = eig.eigenvalues()(0), largest = eig.eigenvalues()(6);
    if (!(smallest > options.min_conditioning * largest)) {
      std::ostringstream why;
      why << "the surfaces do not fix the 7 parameters (normal matrix conditioning " << smallest / largest
          << "): too flat or too uniform";
      return finish(why.str());
    }
    const Eigen::Matrix<double, 7, 1> delta = normal.ldlt().solve(rhs);
    const Eigen::Vector3d dt = delta.head<3>();
    const Eigen::Vector3d dw = delta.segment<3>(3) / spread;
    const double ds = delta(6) / spread;
    // Compose: Delta(X) = c + (1 + ds) R_w (X - c) + dt, applied after h.
    const Eigen::Matrix3d rw = rotation_from_axis_angle<double>(dw);
    Helmert3 next;
    next.scale = (1.0 + ds) * h.scale;
    next.rotation = rw * h.rotation;
    next.translation = centroid + (1.0 + ds) * (rw * (h.translation - centroid)) + dt;
    double step_move = 0.0;
    for (const Term& t : terms) step_move = std::max(step_move, (next(cells[t.cell]) - t.moved).head<2>().norm());
    h = next;
    terms = evaluate(h);
    if (terms.size() < static_cast<std::size_t>(options.min_points)) {
      std::ostringstream why;
      why << "the refinement moved the master off the secondary (" << terms.size() << " cells left)";
      return finish(why.str());
    }
    sigma = robust_sigma(terms);
    if (step_move < options.converged_move_cells * cell) {
      out.converged = true;
      break;
    }
  }
  out.sigma_after = sigma;
  out.points = terms.size();
  out.agreeing_before = agreeing(initial, sigma);
  out.agreeing_after = agreeing(terms, sigma);
  // The move over the overlap (the cells on the secondary surface): a master far larger than the
  // secondary would otherwise be judged by its far corners, where a small turn moves the most.
  for (const Term& t : terms)
    out.moved = std::max(out.moved, (t.moved - epoch2_from_epoch1(cells[t.cell])).head<2>().norm());
  std::ostringstream summary;
  summary.precision(3);
  summary << out.iterations << " iterations, " << out.points << " cells, robust sigma " << out.sigma_before << " -> "
          << out.sigma_after << ", agreeing " << out.agreeing_before << " -> " << out.agreeing_after << ", moved "
          << out.moved / cell << " cells";
  if (!out.converged)
    return finish("it did not converge in " + std::to_string(options.max_iterations) +
                  " iterations (the surfaces fix it poorly, or they changed too much): " + summary.str());
  if (!(tukey_cost(terms, sigma) < tukey_cost(initial, sigma)))
    return finish("the robust cost did not fall: " + summary.str());
  if (out.moved > options.max_move_cells * bound_cell) {
    std::ostringstream why;
    why << "it moved the master by more than " << options.max_move_cells << " cells of the coarser DSM ("
        << options.max_move_cells * bound_cell << " units): " << summary.str();
    return finish(why.str());
  }
  out.accepted = true;
  out.epoch2_from_epoch1 = h;
  return finish(summary.str());
}

}  // namespace diachron
