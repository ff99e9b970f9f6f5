#pragma once
/// @file
/// The Eigen-only part of diachron in one include: core, geometry, robust estimation, cameras,
/// terrain, tiling, matching, validation, the rough co-registration and precise matching pipelines,
/// evaluation and the synthetic scene generator. Needs Eigen, nanoflann and the standard library
/// only (target diachron::core). The OpenCV adapters (diachron/vision/...) and the I/O
/// (diachron/io/..., diachron/synth/scene_io.hpp; GDAL for GeoTIFFs and images, while
/// io/colmap_text.hpp, io/colmap_binary.hpp, io/colmap_model.hpp, io/micmac_orientation.hpp,
/// io/xml_lite.hpp, io/homol.hpp and io/helmert_json.hpp need only the standard library and Eigen)
/// and the Ceres bundle adjustment (diachron/adjustment/... but its track builder and
/// triangulation, and diachron/pipeline/combined_adjustment.hpp and combined_epochs.hpp; target
/// diachron::adjustment) are included separately, so that this header never pulls them.

#include <diachron/core/byte_budget_cache.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/geo_transform.hpp>
#include <diachron/core/index_ranges.hpp>
#include <diachron/core/memory_usage.hpp>
#include <diachron/core/parallel.hpp>
#include <diachron/core/progress.hpp>
#include <diachron/core/random.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/core/static_vector.hpp>
#include <diachron/core/subset.hpp>
#include <diachron/core/types.hpp>
#include <diachron/geometry/helmert3.hpp>
#include <diachron/geometry/helmert3_estimator.hpp>
#include <diachron/geometry/homography.hpp>
#include <diachron/geometry/procrustes.hpp>
#include <diachron/geometry/ray.hpp>
#include <diachron/geometry/rotation.hpp>
#include <diachron/geometry/similarity2.hpp>
#include <diachron/geometry/similarity2_estimator.hpp>
#include <diachron/robust/adaptive_termination.hpp>
#include <diachron/robust/chance_inliers.hpp>
#include <diachron/robust/estimator.hpp>
#include <diachron/robust/fixed_iterations.hpp>
#include <diachron/robust/inlier_count_scoring.hpp>
#include <diachron/robust/msac_scoring.hpp>
#include <diachron/robust/no_local_optimization.hpp>
#include <diachron/robust/prosac_sampler.hpp>
#include <diachron/robust/prosac_termination.hpp>
#include <diachron/robust/ransac.hpp>
#include <diachron/robust/ransac_options.hpp>
#include <diachron/robust/ransac_problem.hpp>
#include <diachron/robust/ransac_report.hpp>
#include <diachron/robust/refit_local_optimization.hpp>
#include <diachron/robust/robust_estimation.hpp>
#include <diachron/robust/uniform_sampler.hpp>
#include <diachron/camera/camera.hpp>
#include <diachron/camera/colmap_conversion.hpp>
#include <diachron/camera/conversion.hpp>
#include <diachron/camera/distortion.hpp>
#include <diachron/camera/frame.hpp>
#include <diachron/camera/micmac_conversion.hpp>
#include <diachron/camera/pose.hpp>
#include <diachron/terrain/crs_kind.hpp>
#include <diachron/terrain/dsm.hpp>
#include <diachron/terrain/dsm_correlation_search.hpp>
#include <diachron/terrain/dsm_image.hpp>
#include <diachron/terrain/fft2.hpp>
#include <diachron/terrain/gsd.hpp>
#include <diachron/terrain/local_affine.hpp>
#include <diachron/terrain/local_relief.hpp>
#include <diachron/terrain/masked_ncc.hpp>
#include <diachron/terrain/model_dsm_agreement.hpp>
#include <diachron/terrain/ray_dsm_intersection.hpp>
#include <diachron/terrain/relief_image.hpp>
#include <diachron/terrain/surface_alignment.hpp>
#include <diachron/terrain/tile_agreement.hpp>
#include <diachron/terrain/transfer.hpp>
#include <diachron/tiling/feature_cache_matcher.hpp>
#include <diachron/tiling/grid_tiler.hpp>
#include <diachron/tiling/one_to_many.hpp>
#include <diachron/tiling/one_to_one.hpp>
#include <diachron/tiling/pair_matcher.hpp>
#include <diachron/tiling/patch_warp.hpp>
#include <diachron/validation/ground_filter.hpp>
#include <diachron/validation/match_filter.hpp>
#include <diachron/validation/ncc_validator.hpp>
#include <diachron/matching/correlation_kernel.hpp>
#include <diachron/matching/correlation_matcher.hpp>
#include <diachron/matching/descriptor_matching.hpp>
#include <diachron/matching/features.hpp>
#include <diachron/matching/grid_interest_points.hpp>
#include <diachron/matching/guided_matcher.hpp>
#include <diachron/matching/image_mask.hpp>
#include <diachron/matching/point_index_2d.hpp>
#include <diachron/matching/point_match.hpp>
#include <diachron/matching/rotation_hypotheses.hpp>
#include <diachron/matching/scale_hypotheses.hpp>
#include <diachron/matching/unsharp_mask.hpp>
#include <diachron/matching/window_sampler.hpp>
#include <diachron/adjustment/tracks.hpp>
#include <diachron/eval/check_points.hpp>
#include <diachron/eval/coregistration_case.hpp>
#include <diachron/eval/dod.hpp>
#include <diachron/eval/dod_map.hpp>
#include <diachron/eval/dsm_reintersection.hpp>
#include <diachron/eval/error_statistics.hpp>
#include <diachron/eval/match_truth.hpp>
#include <diachron/eval/scene_check_points.hpp>
#include <diachron/synth/epoch.hpp>
#include <diachron/synth/noise.hpp>
#include <diachron/synth/render.hpp>
#include <diachron/synth/scan_frame.hpp>
#include <diachron/synth/scene.hpp>
#include <diachron/synth/terrain.hpp>
#include <diachron/synth/texture.hpp>
#include <diachron/pipeline/epoch_placement.hpp>
#include <diachron/pipeline/overlapping_pairs.hpp>
#include <diachron/pipeline/precise_matching.hpp>
#include <diachron/pipeline/rough_coregistration.hpp>
