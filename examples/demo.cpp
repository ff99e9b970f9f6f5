// demo: the pipeline so far, on a synthetic two-epoch scene generated on the fly.
//
//   demo [--seed N] [--out DIR]
//
// 1. generates two epochs over one terrain (synth/): images, cameras and poses as an SfM would
//    estimate them, and each epoch's DSM in its own arbitrary frame;
// 2. co-registers the epochs roughly from their DSMs (pipeline/rough_coregistration.hpp);
// 3. measures the recovered Helmert against the truth at the check points, and transfers each
//    check point's pixel from an epoch-1 image into an epoch-2 image through the epoch-1 DSM and the
//    Helmert (terrain/transfer.hpp): the prediction guided matching will search around.
// With --out, writes the scene and the DSM-image matches there. Exit 0 on success, 2 otherwise.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <diachron/pipeline/rough_coregistration.hpp>
#include <diachron/synth/scene.hpp>
#include <diachron/synth/scene_io.hpp>
#include <diachron/terrain/transfer.hpp>
#include <diachron/vision/draw_matches.hpp>
#include <diachron/vision/extractor_pair_matcher.hpp>
#include <diachron/vision/sift.hpp>

using namespace diachron;

int main(int argc, char** argv) {
  std::uint64_t seed = 0;
  std::string out_dir;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--seed" && i + 1 < argc) seed = std::stoull(argv[++i]);
    else if (a == "--out" && i + 1 < argc) out_dir = argv[++i];
    else {
      std::fprintf(stderr, "usage: demo [--seed N] [--out DIR]\n");
      return 1;
    }
  }
  try {
    auto t0 = std::chrono::steady_clock::now();
    SceneOptions scene_options;
    scene_options.seed = seed;
    const Scene scene = generate_scene(scene_options);
    const SyntheticEpoch& e1 = scene.epochs[0];
    const SyntheticEpoch& e2 = scene.epochs[1];
    const Helmert3 truth = scene.epoch2_from_epoch1();
    std::printf("scene (seed %llu): %zu + %zu images, DSMs %d x %d and %d x %d, %zu check points, %.1f s\n",
                static_cast<unsigned long long>(seed), e1.images.size(), e2.images.size(), e1.dsm.width(),
                e1.dsm.height(), e2.dsm.width(), e2.dsm.height(), scene.check_points.size(),
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    std::printf("true epoch2_from_epoch1: scale %.4f, rotation about Z %.2f deg\n", truth.scale,
                rad_to_deg(std::atan2(truth.rotation(1, 0), truth.rotation(0, 0))));

    // Rough co-registration from the DSMs alone.
    RoughCoregistrationOptions options;
    const ExtractorPairMatcher<SiftExtractor> sift{SiftExtractor{}};
    const RoughCoregistrationReport report = rough_coregistration(e1.dsm, e2.dsm, sift, options);
    for (const auto& h : report.hypotheses)
      std::printf("  rotation %3d deg: %5zu matches, %4zu 2D inliers\n", h.rotation_deg, h.matches, h.inliers);
    std::printf("rough co-registration: %s (%.1f s)\n", report.message.c_str(), report.seconds.total);
    if (!out_dir.empty()) {
      write_scene(scene, out_dir);
      std::vector<bool> mask(report.tentative_2d.size(), false);
      for (std::size_t i : report.inlier_indices_2d) mask[i] = true;
      write_matches_png(out_dir + "/dsm_matches.png", make_dsm_image(e1.dsm, options), make_dsm_image(e2.dsm, options),
                        report.tentative_2d, mask);
      std::printf("wrote the scene and dsm_matches.png to %s\n", out_dir.c_str());
    }
    if (!report.success) return 2;

    // The Helmert at the check points, in epoch-2 units and in ground sampling distances.
    const Helmert3& estimate = report.epoch2_from_epoch1;
    double sum2 = 0.0;
    for (const CheckPoint& cp : scene.check_points) {
      const Vec3 x1 = e1.epoch_from_world()(cp.world);
      const Vec3 x2 = e2.epoch_from_world()(cp.world);
      sum2 += (estimate(x1) - x2).squaredNorm();
    }
    const double rms = std::sqrt(sum2 / std::max<std::size_t>(scene.check_points.size(), 1));
    const double gsd2 = e2.gsd_m * e2.epoch_from_world().scale;  // epoch-2 units per pixel
    std::printf("check points: Helmert RMS %.3f epoch-2 units = %.2f GSD of epoch 2\n", rms, rms / gsd2);

    // Transfer check points from their epoch-1 image to their epoch-2 image with the estimated
    // cameras and poses: epoch-1 pixel -> epoch-1 DSM -> Helmert -> epoch-2 pixel.
    std::vector<double> errors;
    for (const CheckPoint& cp : scene.check_points) {
      const CheckPoint::Observation* a = nullptr;
      const CheckPoint::Observation* b = nullptr;
      for (const auto& o : cp.observations) {
        if (o.epoch == 0 && !a) a = &o;
        if (o.epoch == 1 && !b) b = &o;
      }
      if (!a || !b) continue;
      const Frame<FraserAffine> master(e1.estimated_camera, e1.images[a->image].estimated_pose);
      const Frame<FraserAffine> secondary(e2.estimated_camera, e2.images[b->image].estimated_pose);
      const auto transfer = make_dsm_transfer(master, e1.dsm, secondary, estimate);
      if (const auto predicted = transfer(a->pixel)) errors.push_back((*predicted - b->pixel).norm());
    }
    std::sort(errors.begin(), errors.end());
    if (!errors.empty())
      std::printf("transfer of %zu check points, epoch-1 image -> epoch-2 image: median %.1f px, 90 %% %.1f px, max %.1f px\n",
                  errors.size(), errors[errors.size() / 2], errors[errors.size() * 9 / 10], errors.back());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "demo: %s\n", e.what());
    return 1;
  }
}
