#pragma once
/// @file
/// One-call robust estimation of the two transforms of the paper: the 2D similarity of the rough
/// co-registration and the 3D Helmert of the precise matching, and of the 2D homography between
/// orthophotos without DSMs, with the library's default RANSAC composition (LO-MSAC, exact
/// adaptive stopping, final refit).

#include <cmath>
#include <cstddef>
#include <vector>

#include <diachron/core/error.hpp>
#include <diachron/core/types.hpp>
#include <diachron/geometry/helmert3.hpp>
#include <diachron/geometry/helmert3_estimator.hpp>
#include <diachron/geometry/homography.hpp>
#include <diachron/geometry/homography2_estimator.hpp>
#include <diachron/geometry/similarity2.hpp>
#include <diachron/geometry/similarity2_estimator.hpp>
#include <diachron/robust/ransac.hpp>

namespace diachron {

/// The library's default composition: uniform sampling, MSAC scoring with exact early exit,
/// adaptive termination capped at options.max_iterations, Refit local optimisation.
template <class Estimator>
using DefaultRansac = Ransac<Estimator, UniformSampler, Msac, Adaptive, Refit>;

/// The paper's composition (Zhang et al., MicMac TiePHistorical): plain RANSAC counting inliers for
/// exactly options.max_iterations (1000) iterations, no local optimisation. The final refit on the
/// inliers still runs unless options.final_refit is false, and the bail-out test unless
/// options.bail_out_risk is 0 (then every hypothesis is compared exactly, as the paper's code does).
template <class Estimator>
using PaperRansac =
    Ransac<Estimator, UniformSampler, InlierCount, FixedIterations, NoLocalOptimization>;

namespace detail {

template <class Pairs>
void check_finite_pairs(const Pairs& data, const char* function) {
  for (std::size_t i = 0; i < data.size(); ++i) {
    DIACHRON_CHECK(data[i].source.allFinite() && data[i].target.allFinite(),
                   function << ": point pair " << i << " has a non-finite coordinate");
  }
}

}  // namespace detail

/// Robust 2D similarity `target = scale * R(angle) * source + translation` from point pairs.
///
/// Defaults: MSAC with early exit and the bail-out test (options.bail_out_risk), Refit local
/// optimisation, adaptive termination with options.confidence capped at options.max_iterations
/// (1000), final least-squares refit on all inliers. For the paper's fixed 1000 iterations set `options.confidence = 1` ("never stop
/// early"), or use PaperRansac<Similarity2Estimator> for the paper's whole composition.
///
/// @param data      correspondences; `source` in the frame being moved, `target` in the reference
///                  (pixels, or map units). Not modified.
/// @param options   options.threshold in target units (the paper: 10 px on DSM images).
/// @param estimator options of the estimator (rigid instead of similarity, degeneracy tolerance).
/// @throws diachron::Error for invalid options or a non-finite coordinate (naming its index).
/// @return a report with success == false and a message when no model is supported by
///         options.min_inliers pairs (too few pairs, all outliers, all degenerate).
inline RansacReport<Similarity2> ransac_similarity2(
    const std::vector<PointPair2>& data, const RansacOptions& options,
    const Similarity2EstimatorOptions& estimator = {}) {
  detail::check_finite_pairs(data, "ransac_similarity2");
  return DefaultRansac<Similarity2Estimator>(options, Similarity2Estimator(estimator)).run(data);
}

/// Robust 3D Helmert `X2 = scale * R * X1 + T` (epoch2_from_epoch1) from 3D point pairs.
///
/// Same composition and conventions as ransac_similarity2(); residuals and options.threshold are
/// in target (epoch 2) units, e.g. metres (the paper: 10 x the secondary image's GSD).
/// @throws diachron::Error for invalid options or a non-finite coordinate (naming its index).
inline RansacReport<Helmert3> ransac_helmert3(const std::vector<PointPair3>& data,
                                              const RansacOptions& options,
                                              const Helmert3EstimatorOptions& estimator = {}) {
  detail::check_finite_pairs(data, "ransac_helmert3");
  return DefaultRansac<Helmert3Estimator>(options, Helmert3Estimator(estimator)).run(data);
}

/// Robust 2D homography `[target, 1] ~ H [source, 1]` from point pairs: the map between
/// orthophotos of two epochs when there is no DSM (Homography2Estimator: exact 4-point samples,
/// weighted normalised DLT refit, collinear and orientation-flipping samples refused).
///
/// Same composition and conventions as ransac_similarity2(); residuals are the transfer error
/// |target - H(source)| and options.threshold is in target units (px).
/// @throws diachron::Error for invalid options or a non-finite coordinate (naming its index).
inline RansacReport<Homography2> ransac_homography2(
    const std::vector<PointPair2>& data, const RansacOptions& options,
    const Homography2EstimatorOptions& estimator = {}) {
  detail::check_finite_pairs(data, "ransac_homography2");
  return DefaultRansac<Homography2Estimator>(options, Homography2Estimator(estimator)).run(data);
}

}  // namespace diachron
