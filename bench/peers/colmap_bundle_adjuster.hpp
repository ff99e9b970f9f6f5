#pragma once
/// @file
/// The COLMAP bundle-adjustment peer: a diachron problem (oriented images with Fraser + affine
/// cameras, tracks of pixel observations with initial 3D points) exported as a COLMAP text model,
/// `colmap bundle_adjuster` run on it as a subprocess (timed), its binary output converted to text
/// with `colmap model_converter` and read back as diachron frames and points. For benchmarks only
/// (POSIX process calls; not part of the library). docs/adjusted-export.md, "The COLMAP peer".
///
/// What COLMAP 3.8 does with the model (src/exe/sfm.cc, BundleAdjustmentController): every image
/// of a text model is registered; it keeps the first image's pose and one translation component of
/// the second image constant (the gauge), refines the 3D points and, by default, the focal length
/// and the extra params (distortion) but not the principal point; it has no affine (B1 via fx != fy
/// only when the camera is OPENCV-like, no shear). It needs neither a display nor a GPU.

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <fcntl.h>
#include <spawn.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <Eigen/Core>

#include <diachron/camera/camera.hpp>
#include <diachron/camera/conversion.hpp>
#include <diachron/camera/distortion.hpp>
#include <diachron/camera/frame.hpp>
#include <diachron/core/error.hpp>
#include <diachron/io/cameras_json.hpp>
#include <diachron/io/adjusted_export.hpp>
#include <diachron/io/colmap_text.hpp>
#include <diachron/io/folders.hpp>

extern char** environ;

namespace diachron::bench {

/// One observation of a track: the index of the image (in the problem's image list) and the pixel,
/// px, diachron convention.
struct BaObservation {
  std::size_t image = 0;
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
};

/// A track: its initial 3D point (frame of the images, metres) and its observations (at most one
/// per image, as COLMAP requires).
struct BaTrack {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  std::vector<BaObservation> observations;
};

/// A bundle-adjustment problem as the peer sees it. Images reuse cameras.json's entry (name, epoch,
/// exact camera, pose); images with the same camera (compared exactly) share one COLMAP camera.
struct BaProblem {
  std::vector<CamerasJsonImage> images;
  std::vector<BaTrack> tracks;
};

/// Options of run_colmap_bundle_adjuster(); the refine flags are COLMAP's, with its defaults.
struct ColmapBundleAdjusterOptions {
  std::string colmap = "colmap";        ///< the binary (PATH is searched)
  bool refine_focal_length = true;
  bool refine_principal_point = false;
  bool refine_extra_params = true;      ///< distortion (k, p; k4..k6 of FULL_OPENCV too)
  bool refine_extrinsics = true;
  int max_num_iterations = 100;
  ConversionOptions conversion;         ///< how the cameras become COLMAP cameras
};

/// Outcome of a run. `success == false` with `reason` when COLMAP fails or its output cannot be
/// read; `log_path` then holds COLMAP's output.
struct ColmapBundleAdjusterRun {
  bool success = false;
  std::string reason;
  std::string command;          ///< the bundle_adjuster command line, for the report
  double seconds = 0.0;         ///< wall-clock time of bundle_adjuster alone, s
  double convert_seconds = 0.0; ///< wall-clock time of model_converter (binary -> text), s
  std::string log_path;         ///< COLMAP's stdout and stderr
  double max_conversion_error_px = 0.0;  ///< largest camera conversion error of the export, px
  /// The adjusted images (same order, names and epochs as the problem; cameras converted back to
  /// Fraser + affine, exactly: OPENCV and FULL_OPENCV without k4..k6 are special cases).
  std::vector<CamerasJsonImage> images;
  /// The adjusted 3D points, in track order; nullopt for a track COLMAP dropped.
  std::vector<std::optional<Eigen::Vector3d>> points;
};

/// The COLMAP model of a problem: cameras (ids from 1), images (ids from 1 in order) with their
/// observations as 2D points, points3D (ids from 1 in track order) with their tracks.
/// `max_conversion_error_px` receives the largest camera conversion error. Throws diachron::Error
/// for an observation of an unknown image or a track that sees an image twice.
inline ColmapModel colmap_model_of(const BaProblem& problem, const ConversionOptions& conversion,
                                   double* max_conversion_error_px = nullptr) {
  std::vector<AdjustedCameraConversion> cameras;
  ColmapModel model = adjusted_colmap_model(problem.images, "", conversion, &cameras);
  double worst = 0.0;
  for (const AdjustedCameraConversion& c : cameras) worst = std::max(worst, c.max_error_px);
  for (std::size_t t = 0; t < problem.tracks.size(); ++t) {
    const BaTrack& track = problem.tracks[t];
    ColmapPoint3D p;
    p.id = t + 1;
    p.xyz = track.point;
    for (const BaObservation& o : track.observations) {
      DIACHRON_CHECK(o.image < problem.images.size(),
                     "colmap_model_of: track " << t << " observes image " << o.image << " of " << problem.images.size());
      ColmapImage& image = model.images.at(static_cast<std::uint32_t>(o.image + 1));
      for (const ColmapTrackElement& e : p.track)
        DIACHRON_CHECK(e.image_id != image.id, "colmap_model_of: track " << t << " sees image " << o.image << " twice");
      ColmapPoint2D point2d;
      point2d.xy = colmap_pixel_from_diachron(o.pixel);
      point2d.point3d_id = static_cast<std::int64_t>(p.id);
      p.track.push_back({image.id, static_cast<std::uint32_t>(image.points2d.size())});
      image.points2d.push_back(point2d);
    }
    model.points3d.emplace(p.id, std::move(p));
  }
  if (max_conversion_error_px) *max_conversion_error_px = worst;
  return model;
}

namespace detail {

// Runs `args` (args[0] searched in PATH) with stdout and stderr appended to `log`; the exit status,
// or -1 when the program could not be started.
inline int run_logged(const std::vector<std::string>& args, const std::string& log) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = 0;
  const int spawned = posix_spawnp(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) return -1;
  int status = 0;
  if (::waitpid(pid, &status, 0) != pid) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

inline std::string joined(const std::vector<std::string>& args) {
  std::string out;
  for (const std::string& a : args) out += (out.empty() ? "" : " ") + a;
  return out;
}

}  // namespace detail

/// Exports `problem` into `<work_dir>/input` (text), runs
///   colmap bundle_adjuster --input_path <work_dir>/input --output_path <work_dir>/output ...
/// then `colmap model_converter --output_type TXT` into `<work_dir>/output_txt`, and reads it back.
/// `work_dir` is created if needed (not its parents); files in it are replaced.
inline ColmapBundleAdjusterRun run_colmap_bundle_adjuster(const BaProblem& problem, const std::string& work_dir,
                                                          const ColmapBundleAdjusterOptions& options = {}) {
  ColmapBundleAdjusterRun run;
  make_folder(work_dir, "run_colmap_bundle_adjuster");
  const std::string input = work_dir + "/input", output = work_dir + "/output", text = work_dir + "/output_txt";
  write_colmap_text(colmap_model_of(problem, options.conversion, &run.max_conversion_error_px), input);
  make_folder(output, "run_colmap_bundle_adjuster");  // bundle_adjuster refuses an output path that is not a folder
  make_folder(text, "run_colmap_bundle_adjuster");
  run.log_path = work_dir + "/colmap.log";
  ::unlink(run.log_path.c_str());
  const auto flag = [](bool b) { return std::string(b ? "1" : "0"); };
  const std::vector<std::string> adjust{options.colmap,
                                        "bundle_adjuster",
                                        "--input_path", input,
                                        "--output_path", output,
                                        "--BundleAdjustment.max_num_iterations", std::to_string(options.max_num_iterations),
                                        "--BundleAdjustment.refine_focal_length", flag(options.refine_focal_length),
                                        "--BundleAdjustment.refine_principal_point", flag(options.refine_principal_point),
                                        "--BundleAdjustment.refine_extra_params", flag(options.refine_extra_params),
                                        "--BundleAdjustment.refine_extrinsics", flag(options.refine_extrinsics)};
  run.command = detail::joined(adjust);
  const auto t0 = std::chrono::steady_clock::now();
  const int status = detail::run_logged(adjust, run.log_path);
  const auto t1 = std::chrono::steady_clock::now();
  run.seconds = std::chrono::duration<double>(t1 - t0).count();
  if (status != 0) {
    run.reason = "colmap bundle_adjuster " + std::string(status < 0 ? "could not be started" : "failed") +
                 " (exit " + std::to_string(status) + "), see " + run.log_path;
    return run;
  }
  const std::vector<std::string> convert{options.colmap, "model_converter", "--input_path", output,
                                         "--output_path", text, "--output_type", "TXT"};
  const int converted = detail::run_logged(convert, run.log_path);
  run.convert_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
  if (converted != 0) {
    run.reason = "colmap model_converter failed (exit " + std::to_string(converted) + "), see " + run.log_path;
    return run;
  }
  ColmapModel adjusted;
  try {
    adjusted = read_colmap_text(text);
  } catch (const Error& e) {
    run.reason = std::string("cannot read COLMAP's output: ") + e.what();
    return run;
  }
  for (const CamerasJsonImage& source : problem.images) {
    const std::optional<std::uint32_t> id = adjusted.find_image(source.name);
    if (!id) {
      run.reason = "COLMAP's output has no image '" + source.name + "'";
      return run;
    }
    const ColmapImage& image = adjusted.images.at(*id);
    CamerasJsonImage out = source;
    out.camera = camera_from_colmap(adjusted.cameras.at(image.camera_id), options.conversion).model;
    out.rotation = image.pose.cam_from_world_rotation();
    out.centre = image.pose.centre();
    run.images.push_back(std::move(out));
  }
  // COLMAP keeps point ids through bundle_adjuster (it may drop points whose observations it filters).
  for (std::size_t t = 0; t < problem.tracks.size(); ++t) {
    const auto p = adjusted.points3d.find(t + 1);
    run.points.push_back(p == adjusted.points3d.end() ? std::nullopt : std::optional<Eigen::Vector3d>(p->second.xyz));
  }
  run.success = true;
  return run;
}

}  // namespace diachron::bench
