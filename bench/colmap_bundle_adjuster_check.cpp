// Shows that the COLMAP bundle-adjustment peer (bench/peers/colmap_bundle_adjuster.hpp) works: on a
// generated scene, epoch 1's images with the camera "as estimated" (wrong focal, principal point
// and distortion) and its intra-epoch tie points (0.3 px noise) are exported, `colmap
// bundle_adjuster` is run on them, and the result is read back. Prints the command line, the time,
// the reprojection RMS before and after, the focal length against the truth, and the check-point
// errors (epoch 1's true pixels triangulated with the orientation before and after, against the
// truth in epoch 1's frame).
//
// Usage: colmap_bundle_adjuster_check [WORK_DIR] [--seed N] [--colmap BINARY]
//   WORK_DIR defaults to ./colmap_ba_check (created; the COLMAP models and log go there).
// Exit status 0 when COLMAP ran and the RMS went down, 1 otherwise. Not a test: it needs COLMAP.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include <diachron/camera/frame.hpp>
#include <diachron/eval/check_points.hpp>
#include <diachron/eval/scene_check_points.hpp>
#include <diachron/geometry/procrustes.hpp>
#include <diachron/io/cameras_json.hpp>
#include <diachron/synth/scene.hpp>

#include "peers/colmap_bundle_adjuster.hpp"

using namespace diachron;

namespace {

// Least-squares intersection of the rays of pixel observations.
std::optional<Vec3> triangulate(const std::vector<Frame<FraserAffine>>& frames,
                                const std::vector<std::pair<std::size_t, Vec2>>& observations) {
  if (observations.size() < 2) return std::nullopt;
  Mat3 a = Mat3::Zero();
  Vec3 b = Vec3::Zero();
  for (const auto& [image, pixel] : observations) {
    const std::optional<Ray3> ray = frames.at(image).ray(pixel);
    if (!ray) return std::nullopt;
    const Mat3 p = Mat3::Identity() - ray->direction * ray->direction.transpose();
    a += p;
    b += p * ray->origin;
  }
  return Vec3(a.ldlt().solve(b));
}

std::vector<Frame<FraserAffine>> frames_of(const std::vector<CamerasJsonImage>& images) {
  std::vector<Frame<FraserAffine>> out;
  for (const CamerasJsonImage& im : images) out.push_back(im.frame());
  return out;
}

// RMS of the reprojection errors of every observation of every track with a point, px.
double reprojection_rms(const std::vector<Frame<FraserAffine>>& frames, const std::vector<bench::BaTrack>& tracks,
                        const std::vector<std::optional<Vec3>>& points, std::size_t* count) {
  double sum = 0.0;
  std::size_t n = 0;
  for (std::size_t t = 0; t < tracks.size(); ++t) {
    if (!points[t]) continue;
    for (const bench::BaObservation& o : tracks[t].observations) {
      const std::optional<Vec2> px = frames[o.image].project(*points[t]);
      if (!px) continue;
      sum += (*px - o.pixel).squaredNorm();
      ++n;
    }
  }
  *count = n;
  return n ? std::sqrt(sum / static_cast<double>(n)) : std::nan("");
}

CheckPointReport check_points(const std::vector<ObservedCheckPoint>& points, const std::vector<Frame<FraserAffine>>& frames,
                              double gsd) {
  return evaluate_check_points(
      points,
      [&frames](const std::vector<CheckPointObservation>& obs) {
        std::vector<std::pair<std::size_t, Vec2>> o;
        for (const CheckPointObservation& c : obs) o.emplace_back(c.image, c.pixel);
        return triangulate(frames, o);
      },
      gsd);
}

void print_check_points(const char* label, const CheckPointReport& r) {
  std::printf("| %-28s | %3zu | %7.3f %7.3f %7.3f | %7.3f %7.3f %7.3f | %7.3f %7.3f %7.3f | %7.3f | %6.2f |\n", label,
              r.num_used, r.axes_m[0].mean, r.axes_m[1].mean, r.axes_m[2].mean, r.axes_m[0].sigma, r.axes_m[1].sigma,
              r.axes_m[2].sigma, r.axes_m[0].mean_abs, r.axes_m[1].mean_abs, r.axes_m[2].mean_abs, r.rms_3d_m,
              r.rms_3d_gsd);
}

}  // namespace

int main(int argc, char** argv) {
  std::string work = "colmap_ba_check";
  std::uint64_t seed = 1;
  bench::ColmapBundleAdjusterOptions options;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--seed" && i + 1 < argc) {
      seed = std::strtoull(argv[++i], nullptr, 10);
    } else if (a == "--colmap" && i + 1 < argc) {
      options.colmap = argv[++i];
    } else if (!a.empty() && a[0] != '-') {
      work = a;
    } else {
      std::cerr << "usage: colmap_bundle_adjuster_check [WORK_DIR] [--seed N] [--colmap BINARY]\n";
      return 1;
    }
  }
  try {
    SceneOptions scene_options;
    scene_options.seed = seed;
    scene_options.check_points = 60;
    const Scene scene = generate_scene(scene_options);
    const SyntheticEpoch& epoch = scene.epochs[0];

    bench::BaProblem problem;
    for (std::size_t i = 0; i < epoch.images.size(); ++i)
      problem.images.push_back(CamerasJsonImage::from_frame(epoch.images[i].name, epoch.name, epoch.estimated_frame(i)));
    const std::vector<Frame<FraserAffine>> before = frames_of(problem.images);
    std::vector<std::optional<Vec3>> initial;
    for (const TiePoint& tie : epoch.tie_points) {
      std::vector<std::pair<std::size_t, Vec2>> obs;
      bench::BaTrack track;
      for (const ImageObservation& o : tie.observations) {
        obs.emplace_back(static_cast<std::size_t>(o.image), o.pixel);
        track.observations.push_back({static_cast<std::size_t>(o.image), o.pixel});
      }
      const std::optional<Vec3> x = triangulate(before, obs);
      if (!x) continue;
      track.point = *x;
      problem.tracks.push_back(track);
      initial.push_back(x);
    }

    std::size_t n_before = 0, n_after = 0;
    const double rms_before = reprojection_rms(before, problem.tracks, initial, &n_before);
    const bench::ColmapBundleAdjusterRun run = bench::run_colmap_bundle_adjuster(problem, work, options);
    std::printf("scene seed %llu, epoch %s: %zu images of %d x %d px, %zu tracks, %zu observations\n",
                static_cast<unsigned long long>(seed), epoch.name.c_str(), problem.images.size(), epoch.camera.width(),
                epoch.camera.height(), problem.tracks.size(), n_before);
    std::printf("export: largest camera conversion error %.3g px\n", run.max_conversion_error_px);
    std::printf("command: %s\n", run.command.c_str());
    if (!run.success) {
      std::printf("COLMAP failed: %s\n", run.reason.c_str());
      return 1;
    }
    const std::vector<Frame<FraserAffine>> after = frames_of(run.images);
    const double rms_after = reprojection_rms(after, problem.tracks, run.points, &n_after);
    std::printf("bundle_adjuster: %.3f s (model_converter %.3f s), log %s\n", run.seconds, run.convert_seconds,
                run.log_path.c_str());
    std::printf("reprojection RMS: before %.4f px (%zu obs), after %.4f px (%zu obs); tie-point noise %.2f px\n",
                rms_before, n_before, rms_after, n_after, scene_options.epochs[0].tie_noise_px);
    std::printf("focal: true %.3f, estimated %.3f, COLMAP %.3f px\n", epoch.camera.focal(),
                epoch.estimated_camera.focal(), run.images[0].camera.focal());

    const std::vector<ObservedCheckPoint> cps = scene_check_points(scene, 0, 0);
    const double gsd_epoch = epoch.gsd_m * epoch.world_from_epoch.inverse().scale;  // epoch units per pixel
    std::printf("\ncheck points in epoch 1's own frame (units of that frame; GSD = %.4f units), e = estimated - true\n",
                gsd_epoch);
    std::printf("| %-28s | %3s | %-23s | %-23s | %-23s | %-7s | %-6s |\n", "orientation", "n", "mu x y z", "sigma x y z",
                "|mu| x y z", "RMS 3D", "GSD");
    std::printf("|---|---|---|---|---|---|---|\n");
    print_check_points("true (control)", check_points(cps, [&] {
                         std::vector<Frame<FraserAffine>> f;
                         for (std::size_t i = 0; i < epoch.images.size(); ++i) f.push_back(epoch.epoch_frame(i));
                         return f;
                       }(), gsd_epoch));
    print_check_points("as estimated (input)", check_points(cps, before, gsd_epoch));
    print_check_points("COLMAP bundle_adjuster", check_points(cps, after, gsd_epoch));
    // The datum COLMAP leaves (its gauge) removed: COLMAP's centres fitted onto the input centres by
    // a 3D similarity, as a benchmark would fit it onto the frozen reference epoch's centres.
    std::vector<PointPair3> centres;
    for (std::size_t i = 0; i < after.size(); ++i) centres.push_back({after[i].pose().centre(), before[i].pose().centre()});
    if (const std::optional<Helmert3> h = fit_helmert3(centres)) {
      std::vector<Frame<FraserAffine>> aligned;
      for (const Frame<FraserAffine>& f : after) aligned.push_back(f.transformed(*h));
      print_check_points("COLMAP, Helmert onto input C", check_points(cps, aligned, gsd_epoch));
    }

    // COLMAP's gauge (first pose and one coordinate of the second image's translation) leaves the
    // focal length free against the flying height over a nearly flat block: the same run with the
    // focal length held shows how much of the drift that is.
    bench::ColmapBundleAdjusterOptions held = options;
    held.refine_focal_length = false;
    const bench::ColmapBundleAdjusterRun run2 = bench::run_colmap_bundle_adjuster(problem, work + "_fixed_focal", held);
    if (run2.success) {
      std::size_t n2 = 0;
      const std::vector<Frame<FraserAffine>> after2 = frames_of(run2.images);
      const double rms2 = reprojection_rms(after2, problem.tracks, run2.points, &n2);
      print_check_points("COLMAP, focal length held", check_points(cps, after2, gsd_epoch));
      std::printf("\nfocal held: %.3f s, reprojection RMS after %.4f px (%zu obs)\n", run2.seconds, rms2, n2);
    } else {
      std::printf("\nfocal held: COLMAP failed: %s\n", run2.reason.c_str());
    }

    // The plumbing itself: with only the 3D points free, what comes back must be the input
    // orientation (to COLMAP's text precision) and the projections of the input frames.
    bench::ColmapBundleAdjusterOptions points_only = options;
    points_only.refine_focal_length = points_only.refine_extra_params = points_only.refine_extrinsics = false;
    const bench::ColmapBundleAdjusterRun run3 = bench::run_colmap_bundle_adjuster(problem, work + "_points_only", points_only);
    double worst_px = 0.0;
    if (run3.success) {
      const std::vector<Frame<FraserAffine>> back = frames_of(run3.images);
      for (std::size_t t = 0; t < problem.tracks.size(); ++t) {
        if (!run3.points[t]) continue;
        for (const bench::BaObservation& o : problem.tracks[t].observations) {
          const std::optional<Vec2> a = back[o.image].project(*run3.points[t]);
          const std::optional<Vec2> b = before[o.image].project(*run3.points[t]);
          if (a && b) worst_px = std::max(worst_px, (*a - *b).norm());
        }
      }
      std::size_t n3 = 0;
      const double rms3 = reprojection_rms(back, problem.tracks, run3.points, &n3);
      std::printf("points only: %.3f s, reprojection RMS after %.4f px (%zu obs); orientation read back projects "
                  "within %.2g px of the input\n",
                  run3.seconds, rms3, n3, worst_px);
    } else {
      std::printf("points only: COLMAP failed: %s\n", run3.reason.c_str());
    }
    return rms_after < rms_before && run3.success && worst_px < 1e-6 ? 0 : 1;
  } catch (const std::exception& e) {
    std::cerr << "colmap_bundle_adjuster_check: " << e.what() << "\n";
    return 1;
  }
}
