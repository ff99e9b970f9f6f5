// demo: the whole of Algorithm 1 (the paper's combined processing) on a decades-apart synthetic scene
// generated on the fly.
//
//   demo [--seed N] [--out DIR] [--threads N]
//
// 1. generates two epochs decades apart over one terrain (synth/, SceneOptions::decades_apart()):
//    a 1960s-like film flight and a recent one, with the cameras, poses, tie points and DSMs an SfM
//    would have given each, every epoch in its own arbitrary frame;
// 2. co-registers the epochs roughly from their DSMs (pipeline/rough_coregistration.hpp);
// 3. lists the overlapping image pairs and matches each precisely (pipeline/overlapping_pairs.hpp,
//    pipeline/precise_matching.hpp, the default method of match_epochs);
// 4. adjusts both epochs together with the intra- and inter-epoch tie points, epoch 2 fixed and
//    epoch 1 self-calibrated with the Fraser + affine model (pipeline/combined_adjustment.hpp);
// 5. prints the paper's table: check-point errors after the rough co-registration alone and after
//    the full pipeline, and epoch 1's camera as the SfM had it and as the adjustment recovered it,
//    against the truth.
// With --out, writes there the scene (make_scene's layout), the DSM matches, each pair's final
// matches and the adjusted orientation (adjusted/cameras.json and COLMAP text models).
// Exit status: 0 success, 2 when a stage finds no answer (the reason is printed), 1 on bad input.

#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include <diachron/adjustment/triangulation.hpp>
#include <diachron/eval/check_points.hpp>
#include <diachron/eval/distortion_difference.hpp>
#include <diachron/eval/distortion_precision.hpp>
#include <diachron/eval/scene_check_points.hpp>
#include <diachron/io/adjusted_export.hpp>
#include <diachron/pipeline/combined_adjustment.hpp>
#include <diachron/pipeline/overlapping_pairs.hpp>
#include <diachron/pipeline/precise_matching.hpp>
#include <diachron/pipeline/rough_coregistration.hpp>
#include <diachron/synth/scene.hpp>
#include <diachron/synth/scene_io.hpp>
#include <diachron/vision/draw_matches.hpp>
#include <diachron/vision/extractor_pair_matcher.hpp>
#include <diachron/vision/sift.hpp>
#include <glog/logging.h>

using namespace diachron;

namespace {

using Frames = std::vector<Frame<FraserAffine>>;

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Epoch 1's check points triangulated from their true pixels with `frames` (epoch-2 frame), against
// their true position; errors in world metres and in epoch-1 GSD.
CheckPointReport check_points(const Scene& scene, const Frames& frames) {
  return evaluate_scene_check_points(scene, 0, 1, FrameTriangulator<FraserAffine>(frames));
}

void print_check_points(const char* name, const CheckPointReport& r) {
  const char* axis[3] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a)
    std::printf("| %-14s | %s    | %7.2f | %6.2f | %8.2f | %6.2f |\n", a == 0 ? name : "", axis[a], r.axes_m[a].mean,
                r.axes_m[a].sigma, r.axes_m[a].mean_abs, r.axes_m[a].rms);
}

}  // namespace

int main(int argc, char** argv) {
  std::uint64_t seed = 0;
  std::string out_dir;
  std::size_t threads = 0;
  // Ceres logs through glog on stderr (e.g. a trust-region step it rejected); the adjustment's
  // report says what matters, so only fatal messages are let through.
  FLAGS_minloglevel = google::GLOG_FATAL;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--seed" && i + 1 < argc) seed = std::stoull(argv[++i]);
    else if (a == "--out" && i + 1 < argc) out_dir = argv[++i];
    else if (a == "--threads" && i + 1 < argc) threads = std::stoul(argv[++i]);
    else {
      std::fprintf(stderr, "usage: demo [--seed N] [--out DIR] [--threads N]\n");
      return 1;
    }
  }
  try {
    const auto start = std::chrono::steady_clock::now();
    auto t0 = start;
    SceneOptions scene_options = SceneOptions::decades_apart();
    scene_options.seed = seed;
    scene_options.threads = threads;
    const Scene scene = generate_scene(scene_options);
    const SyntheticEpoch& e1 = scene.epochs[0];
    const SyntheticEpoch& e2 = scene.epochs[1];
    std::printf("1. scene (seed %llu, decades apart): %zu + %zu images of %d x %d px, GSD %.1f and %.1f m, "
                "%zu check points (%.1f s)\n",
                static_cast<unsigned long long>(seed), e1.images.size(), e2.images.size(), e1.camera.width(),
                e1.camera.height(), e1.gsd_m, e2.gsd_m, scene.check_points.size(), seconds_since(t0));
    if (!out_dir.empty()) write_scene(scene, out_dir);

    // 2. Rough co-registration from the DSMs alone.
    t0 = std::chrono::steady_clock::now();
    RoughCoregistrationOptions rough_options;
    rough_options.threads = threads;
    const ExtractorPairMatcher<SiftExtractor> sift{SiftExtractor{}};
    const RoughCoregistrationReport rough = rough_coregistration(e1.dsm, e2.dsm, sift, rough_options);
    std::printf("2. rough co-registration: %s (%.1f s)\n", rough.message.c_str(), seconds_since(t0));
    if (!out_dir.empty()) {
      std::vector<bool> mask(rough.tentative_2d.size(), false);
      for (std::size_t i : rough.inlier_indices_2d) mask[i] = true;
      write_matches_png(out_dir + "/dsm_matches.png", make_dsm_image(e1.dsm, rough_options),
                        make_dsm_image(e2.dsm, rough_options), rough.tentative_2d, mask);
    }
    if (!rough.success) return 2;
    const Helmert3& helmert = rough.epoch2_from_epoch1;

    // 3. Overlapping pairs and precise matching, with the orientations the SfM gave each epoch.
    t0 = std::chrono::steady_clock::now();
    const Frames frames1 = e1.estimated_frames(), frames2 = e2.estimated_frames();
    OverlappingPairsOptions overlap_options;
    overlap_options.min_overlap_fraction = 0.1;
    overlap_options.threads = threads;
    const OverlappingPairsResult overlap = overlapping_pairs(make_footprint_images(frames1), e1.dsm,
                                                             make_footprint_images(frames2), e2.dsm, helmert, overlap_options);
    const PreciseEpoch<Frame<FraserAffine>> p1{frames1, [&e1](std::size_t i) { return e1.images[i].pixels; }, &e1.dsm};
    const PreciseEpoch<Frame<FraserAffine>> p2{frames2, [&e2](std::size_t i) { return e2.images[i].pixels; }, &e2.dsm};
    PreciseMatchingOptions precise_options;
    precise_options.threads = threads;
    const PreciseMatchingReport precise = precise_matching_correlation(p1, p2, helmert, overlap.pairs, precise_options);
    const std::vector<EpochPairMatches> matches = epoch_pair_matches(precise.pairs);
    std::size_t count = 0;
    for (const EpochPairMatches& m : matches) count += m.matches.size();
    std::printf("3. precise matching: %zu overlapping pairs, %zu with matches, %zu inter-epoch tie points (%.1f s)\n",
                overlap.pairs.size(), matches.size(), count, seconds_since(t0));
    if (!out_dir.empty())
      for (const PrecisePairReport& p : precise.pairs)
        if (!p.matches.empty())
          write_matches_png(out_dir + "/pair_" + e1.images[p.master].name + "--" + e2.images[p.secondary].name + ".png",
                            e1.images[p.master].pixels, e2.images[p.secondary].pixels, p.matches);

    // 4. The combined adjustment: epoch 2 fixed, epoch 1's poses, camera and affine parts free.
    t0 = std::chrono::steady_clock::now();
    const CombinedEpoch c1{frames1, e1.tie_point_observations()}, c2{frames2, e2.tie_point_observations()};
    const CombinedAdjustmentResult adjusted = combined_adjustment(c1, c2, matches, helmert);
    const BundleReport& r = adjusted.report;
    std::printf("4. combined adjustment: %s (%.1f s)\n", r.message.c_str(), seconds_since(t0));
    if (!r.success) return 2;
    if (!out_dir.empty()) {
      std::vector<CamerasJsonImage> images;
      for (std::size_t i = 0; i < e1.images.size(); ++i)
        images.push_back(CamerasJsonImage::from_frame(e1.images[i].name, e1.name, adjusted.epoch1[i]));
      for (std::size_t i = 0; i < e2.images.size(); ++i)
        images.push_back(CamerasJsonImage::from_frame(e2.images[i].name, e2.name, adjusted.epoch2[i]));
      write_adjusted_export(images, out_dir);
      std::printf("   wrote the scene, dsm_matches.png, pair_*.png and adjusted/ to %s\n", out_dir.c_str());
    }

    // 5. The paper's table: check points (true pixels in epoch 1 triangulated, against the truth).
    const CheckPointReport before = check_points(scene, transformed_frames(frames1, helmert));
    const CheckPointReport after = check_points(scene, adjusted.epoch1);
    std::printf("\nCheck points of epoch 1 in the world frame, metres (GSD of epoch 1: %.1f m):\n", e1.gsd_m);
    std::printf("| method         | axis |    mean |  sigma | mean |e| |    RMS |\n");
    std::printf("|----------------|------|---------|--------|----------|--------|\n");
    print_check_points("rough only", before);
    print_check_points("full pipeline", after);
    std::printf("3D RMS: rough only %.2f m (%.2f GSD, %zu points), full pipeline %.2f m (%.2f GSD, %zu points): %.1f x smaller\n",
                before.rms_3d_m, before.rms_3d_gsd, before.num_used, after.rms_3d_m, after.rms_3d_gsd, after.num_used,
                before.rms_3d_m / after.rms_3d_m);

    const Camera<FraserAffine>& truth = e1.camera;
    const Camera<FraserAffine>& sfm = e1.estimated_camera;
    const Camera<FraserAffine>& recovered = adjusted.epoch1.front().camera();
    std::printf("\nEpoch 1's camera against the truth (px):\n");
    // Worst over the image: the distortion alone; the whole camera with the focal length and
    // principal point refitted; what no change of pose absorbs (eval/distortion_difference.hpp).
    std::printf("| camera             | focal error | principal point error | distortion, worst | f, pp refitted, worst | beyond a pose, worst |\n");
    std::printf("|--------------------|-------------|-----------------------|-------------------|-----------------------|----------------------|\n");
    for (const auto& [name, c] : {std::pair<const char*, const Camera<FraserAffine>*>{"as the SfM had it", &sfm},
                                  std::pair<const char*, const Camera<FraserAffine>*>{"after adjustment", &recovered}}) {
      const DistortionDifference d = distortion_difference(*c, truth);
      std::printf("| %-18s | %11.2f | %21.2f | %17.2f | %21.2f | %20.2f |\n", name, c->focal() - truth.focal(),
                  (c->principal_point() - truth.principal_point()).norm(), d.max_px, d.refit_max_px, d.beyond_pose_max_px);
    }
    // What the adjustment itself says about it, without the truth: the distortion's 1-sigma over the
    // image from the covariance of epoch 1's camera (camera 0).
    if (!r.cameras.empty() && !r.cameras.front().covariance.empty()) {
      const DistortionPrecision p = distortion_precision(recovered, r.cameras.front().covariance);
      std::printf("Predicted by the adjustment (covariance): distortion 1-sigma %.2f px at worst (pixel %.0f, %.0f), %.2f px RMS\n",
                  p.max_sigma_px, p.worst_pixel.x(), p.worst_pixel.y(), p.rms_sigma_px);
    }
    std::printf("\ntotal %.1f s\n", seconds_since(start));
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "demo: %s\n", e.what());
    return 1;
  }
}
