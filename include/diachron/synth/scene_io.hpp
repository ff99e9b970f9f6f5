#pragma once
/// @file
/// Writes a synthetic scene to a folder laid out as an SfM delivers each epoch, with the truth
/// apart, and reads it back. Needs GDAL (diachron::io); the generator itself does not.
///
/// Folder layout (docs/synthetic-scenes.md describes every file):
/// @code
/// OUT/<epoch>/images/<image name>.png     8-bit grey images
/// OUT/<epoch>/cameras.txt                 COLMAP text model of the epoch as its SfM estimated it:
/// OUT/<epoch>/images.txt                    estimated camera and poses, epoch frame, COLMAP
/// OUT/<epoch>/points3D.txt                  conventions; the intra-epoch tie points as tracks
/// OUT/<epoch>/dsm.tif                     the epoch's DSM as its SfM delivers it (epoch frame)
/// OUT/truth/scene.txt                     truth: frames, true cameras and poses, tie points in the
///                                           world, check points
/// OUT/truth/<epoch>_true_surface.tif      the epoch's true surface (world frame)
/// OUT/truth/<epoch>_albedo.tif            the epoch's ground albedo (world frame, 0..1)
/// @endcode
/// An epoch delivered as a true orthophoto (synth/ortho_reference.hpp) has instead only
/// OUT/<epoch>/ortho.tif (8-bit grey GeoTIFF, north-up geotransform in the epoch frame) and
/// OUT/<epoch>/dsm.tif (its true surface in the epoch frame); no images/ and no COLMAP model.
/// Written as MicMac projects (SceneWriteOptions::format), a photo epoch has instead of the COLMAP
/// model the same orientation as `OUT/<epoch>/Ori-SfM/` (io/micmac_orientation.hpp) and its tie
/// points as `OUT/<epoch>/Homol/` (io/homol.hpp); the truth is the same.
/// Nothing an SfM of the epoch would not know is in OUT/<epoch>/; OUT/truth/ is for scoring.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <functional>
#include <iomanip>
#include <limits>
#include <locale>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <sys/stat.h>
#include <sys/types.h>

#include <Eigen/Core>

#include <diachron/camera/camera.hpp>
#include <diachron/camera/distortion.hpp>
#include <diachron/camera/ortho_frame.hpp>
#include <diachron/camera/pose.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/geo_transform.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/geometry/helmert3.hpp>
#include <diachron/io/colmap_text.hpp>
#include <diachron/io/folders.hpp>
#include <diachron/io/geotiff.hpp>
#include <diachron/io/homol.hpp>
#include <diachron/io/micmac_orientation.hpp>
#include <diachron/synth/scene.hpp>
#include <diachron/terrain/dsm.hpp>

namespace diachron {

/// Version written on the first line of truth/scene.txt (1 was the single-folder layout).
inline constexpr int kSceneFileVersion = 2;

/// Name of the truth folder inside a scene folder (so no epoch may have this name).
inline constexpr const char* kSceneTruthFolder = "truth";

/// Name of the orientation a scene's MicMac epoch holds: `OUT/<epoch>/Ori-SfM/`.
inline constexpr const char* kSceneMicmacOri = "SfM";

/// The form in which write_scene delivers each photo epoch's SfM result.
enum class SceneEpochFormat {
  colmap,  ///< cameras.txt, images.txt, points3D.txt (the default)
  micmac,  ///< a MicMac project: Ori-SfM/ and Homol/ (docs/synthetic-scenes.md, "MicMac epochs")
};

/// Options of write_scene. Default: the COLMAP layout, byte for byte what write_scene always wrote.
struct SceneWriteOptions {
  SceneEpochFormat format = SceneEpochFormat::colmap;
  /// When set, writes image `image` of epoch `epoch` (indices) to `path` (OUT/<epoch>/images/<name>.png)
  /// instead of write_image_u8(pixels, path): the full-size scans of make_scene --scan-px
  /// (synth/full_size_scan.hpp) are made there, one at a time, rather than held by the scene. It
  /// must write what the epoch's camera sees, at the camera's size.
  std::function<void(std::size_t epoch, std::size_t image, const std::string& path)> write_image;
};

namespace detail {


inline void write_scene_matrix(std::ostream& out, const Mat3& m) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out << ' ' << m(r, c);
}

inline void write_scene_pose(std::ostream& out, const char* key, const Pose& pose) {
  out << key;
  write_scene_matrix(out, pose.cam_from_world_rotation());
  out << ' ' << pose.centre().x() << ' ' << pose.centre().y() << ' ' << pose.centre().z() << '\n';
}

inline void write_scene_camera(std::ostream& out, const char* key, const Camera<FraserAffine>& camera) {
  out << key << ' ' << camera.focal() << ' ' << camera.cx() << ' ' << camera.cy() << ' ' << camera.width() << ' '
      << camera.height();
  for (double p : camera.params()) out << ' ' << p;
  out << '\n';
}

/// Line-by-line reader of scene.txt: skips blank and '#' lines, names the file and line in errors.
class SceneTextReader {
 public:
  explicit SceneTextReader(const std::string& path) : path_(path), in_(path) {
    DIACHRON_CHECK(in_.good(), "cannot read '" << path << "': the file cannot be opened");
  }

  /// The next line, split off its keyword; throws when the keyword is not `expected`.
  std::istringstream& expect(const std::string& expected) {
    std::string line;
    for (;;) {
      DIACHRON_CHECK(std::getline(in_, line), "'" << path_ << "': unexpected end of file, expected '" << expected << "'");
      ++number_;
      const auto first = line.find_first_not_of(" \t\r");
      if (first == std::string::npos || line[first] == '#') continue;
      break;
    }
    fields_.clear();
    fields_.str(line);
    std::string keyword;
    fields_ >> keyword;
    DIACHRON_CHECK(keyword == expected,
                   "'" << path_ << "' line " << number_ << ": expected '" << expected << "', found '" << keyword << "'");
    return fields_;
  }

  /// Reads `n` values of type T from the current line; throws naming the line when they are absent.
  template <class T>
  void read(T* values, int n, const char* what) {
    for (int i = 0; i < n; ++i)
      DIACHRON_CHECK(static_cast<bool>(fields_ >> values[i]),
                     "'" << path_ << "' line " << number_ << ": cannot read " << what);
  }
  template <class T>
  T value(const char* what) {
    T v{};
    read(&v, 1, what);
    return v;
  }
  std::string word(const char* what) {
    std::string w;
    DIACHRON_CHECK(static_cast<bool>(fields_ >> w), "'" << path_ << "' line " << number_ << ": cannot read " << what);
    return w;
  }
  /// The next word of the current line, or nullopt when the line has no more.
  std::optional<std::string> optional_word() {
    std::string w;
    if (fields_ >> w) return w;
    return std::nullopt;
  }
  void check(bool condition, const std::string& message) const {
    DIACHRON_CHECK(condition, "'" << path_ << "' line " << number_ << ": " << message);
  }

  Mat3 matrix(const char* what) {
    double v[9];
    read(v, 9, what);
    Mat3 m;
    m << v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8];
    return m;
  }

  Pose pose(const char* key) {
    expect(key);
    const Mat3 r = matrix(key);
    double c[3];
    read(c, 3, key);
    try {
      return Pose(r, Vec3(c[0], c[1], c[2]));
    } catch (const Error& e) {
      check(false, std::string("invalid pose: ") + e.what());
    }
    return {};
  }

  Camera<FraserAffine> camera(const char* key) {
    expect(key);
    double f[3];
    read(f, 3, key);
    int size[2];
    read(size, 2, key);
    Camera<FraserAffine>::Params p{};
    read(p.data(), static_cast<int>(p.size()), key);
    try {
      return Camera<FraserAffine>(f[0], f[1], f[2], size[0], size[1], p);
    } catch (const Error& e) {
      check(false, std::string("invalid camera: ") + e.what());
    }
    return Camera<FraserAffine>(1.0, 0.0, 0.0, 1, 1);
  }

 private:
  std::string path_;
  std::ifstream in_;
  std::istringstream fields_;
  int number_ = 0;
};

inline Raster<std::uint8_t> read_scene_image(const std::string& path) {
  GeoTiffReadOptions options;
  options.allow_missing_geotransform = true;
  const Dsm raster = read_geotiff_dsm(path, options);
  Raster<std::uint8_t> out(raster.width(), raster.height());
  for (int y = 0; y < raster.height(); ++y)
    for (int x = 0; x < raster.width(); ++x) {
      const float v = raster.heights()(x, y);
      DIACHRON_CHECK(v >= 0.0f && v <= 255.0f, "'" << path << "': not an 8-bit image (value " << v << ")");
      out(x, y) = static_cast<std::uint8_t>(v);
    }
  return out;
}

inline Dsm albedo_as_dsm(const AlbedoMap& albedo) { return Dsm(albedo.values, albedo.transform); }

/// Writes an 8-bit grey image as a GeoTIFF with a geotransform (io/geotiff.hpp's write_image_u8
/// writes none). Throws diachron::Error naming the file on failure.
inline void write_geotiff_u8(const Raster<std::uint8_t>& image, const GeoTransform& transform,
                             const std::string& path) {
  DIACHRON_CHECK(!image.empty(), "cannot write '" << path << "': empty image");
  gdal_register_once();
  const QuietGdalErrors quiet;
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  DIACHRON_CHECK(driver != nullptr, "cannot write '" << path << "': GDAL has no GTiff driver");
  char** create_options = CSLSetNameValue(nullptr, "COMPRESS", "DEFLATE");
  GdalDatasetPtr ds(driver->Create(path.c_str(), image.width(), image.height(), 1, GDT_Byte, create_options));
  CSLDestroy(create_options);
  DIACHRON_CHECK(ds != nullptr,
                 "cannot write '" << path << "': cannot create the file" << QuietGdalErrors::last_message());
  GeoTransform gt = transform;
  ds->SetGeoTransform(gt.c.data());
  const CPLErr err = ds->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, image.width(), image.height(),
                                                    const_cast<std::uint8_t*>(image.data()), image.width(),
                                                    image.height(), GDT_Byte, 0, 0, nullptr);
  DIACHRON_CHECK(err == CE_None, "cannot write '" << path << "': write failed" << QuietGdalErrors::last_message());
  close_written(ds, path);
}

/// Reads an orthophoto written by write_geotiff_u8: its pixels and its (north-up) frame.
inline SyntheticOrthophoto read_scene_orthophoto(const std::string& path) {
  const Dsm raster = read_geotiff_dsm(path);
  SyntheticOrthophoto out;
  out.pixels.resize(raster.width(), raster.height());
  for (int y = 0; y < raster.height(); ++y)
    for (int x = 0; x < raster.width(); ++x) {
      const float v = raster.heights()(x, y);
      DIACHRON_CHECK(v >= 0.0f && v <= 255.0f, "'" << path << "': not an 8-bit image (value " << v << ")");
      out.pixels(x, y) = static_cast<std::uint8_t>(v);
    }
  try {
    out.frame = OrthoFrame(raster.transform(), raster.width(), raster.height());
  } catch (const Error& e) {
    DIACHRON_CHECK(false, "'" << path << "': " << e.what());
  }
  return out;
}

}  // namespace detail


namespace detail {

// The epoch as its SfM would deliver it: estimated camera (id 1) and poses (ids 1..N in image
// order) in the epoch frame, the tie points as 3D points (ids 1..T) at their epoch-frame position,
// observed by their (noisy) pixels; each point's error is its mean reprojection error with the
// estimated orientation and its colour the grey value at its first observation.
inline ColmapModel colmap_model_of_epoch(const SyntheticEpoch& epoch) {
  ColmapModel model;
  const ConversionResult<ColmapCamera> camera = colmap_camera_from_camera(epoch.estimated_camera, 1);
  model.cameras.emplace(1u, camera.model);
  for (std::size_t i = 0; i < epoch.images.size(); ++i) {
    ColmapImage image;
    image.id = static_cast<std::uint32_t>(i + 1);
    image.name = epoch.images[i].name + ".png";
    image.camera_id = 1;
    image.pose = epoch.images[i].estimated_pose;
    model.images.emplace(image.id, std::move(image));
  }
  for (std::size_t k = 0; k < epoch.tie_points.size(); ++k) {
    const TiePoint& tie = epoch.tie_points[k];
    ColmapPoint3D point;
    point.id = k + 1;
    point.xyz = tie.epoch;
    double error_sum = 0.0;
    int error_count = 0;
    for (const ImageObservation& ob : tie.observations) {
      DIACHRON_CHECK(ob.image >= 0 && static_cast<std::size_t>(ob.image) < epoch.images.size(),
                     "write_scene: a tie point of epoch " << epoch.name << " observes image " << ob.image);
      ColmapImage& image = model.images.at(static_cast<std::uint32_t>(ob.image + 1));
      point.track.push_back({image.id, static_cast<std::uint32_t>(image.points2d.size())});
      image.points2d.push_back({colmap_pixel_from_diachron(ob.pixel), static_cast<std::int64_t>(point.id)});
      if (const std::optional<Vec2> px = epoch.estimated_frame(static_cast<std::size_t>(ob.image)).project(tie.epoch)) {
        error_sum += (*px - ob.pixel).norm();
        ++error_count;
      }
    }
    point.error = error_count > 0 ? error_sum / error_count : -1.0;
    if (!tie.observations.empty()) {
      const ImageObservation& first = tie.observations.front();
      const Raster<std::uint8_t>& pixels = epoch.images[static_cast<std::size_t>(first.image)].pixels;
      Vec2 at = first.pixel;
      // Images kept smaller than the camera (full-size scans written apart): the same spot there.
      if (pixels.width() != epoch.camera.width() && epoch.camera.width() > 0)
        at = (at + Vec2(0.5, 0.5)) * (static_cast<double>(pixels.width()) / epoch.camera.width()) - Vec2(0.5, 0.5);
      const int x = static_cast<int>(std::lround(at.x())), y = static_cast<int>(std::lround(at.y()));
      if (pixels.contains(x, y)) point.rgb = {pixels(x, y), pixels(x, y), pixels(x, y)};
    }
    model.points3d.emplace(point.id, std::move(point));
  }
  return model;
}

// The epoch as a MicMac project would hold it: the estimated camera and poses as
// `<epoch_dir>/Ori-SfM/` (AltiSol the DSM's mean height, the calibration AutoCal-<epoch>-0.xml),
// every pair of observations of each tie point as `<epoch_dir>/Homol/` (both directions). Image
// names as in images/ (<name>.png). A COLMAP model left by an earlier write is removed, since a
// folder with one is read as a COLMAP epoch.
inline void write_micmac_epoch(const SyntheticEpoch& epoch, const std::string& epoch_dir) {
  std::vector<CamerasJsonImage> images;
  images.reserve(epoch.images.size());
  for (std::size_t i = 0; i < epoch.images.size(); ++i)
    images.push_back(CamerasJsonImage::from_frame(epoch.images[i].name + ".png", epoch.name, epoch.estimated_frame(i)));
  MicmacWriteOptions ori;
  ori.overwrite = true;  // a scene written again replaces its files, as the COLMAP model is replaced
  ori.ground_altitude = epoch.dsm.statistics().mean;
  write_micmac_ori_folder(epoch_dir, kSceneMicmacOri, images, ori);

  // One match list per image pair (first image of lower index), in tie-point order.
  std::map<std::pair<int, int>, PointMatches> pairs;
  for (const TiePoint& tie : epoch.tie_points)
    for (std::size_t a = 0; a < tie.observations.size(); ++a)
      for (std::size_t b = a + 1; b < tie.observations.size(); ++b) {
        const ImageObservation* p = &tie.observations[a];
        const ImageObservation* q = &tie.observations[b];
        DIACHRON_CHECK(p->image >= 0 && static_cast<std::size_t>(p->image) < epoch.images.size() && q->image >= 0 &&
                           static_cast<std::size_t>(q->image) < epoch.images.size(),
                       "write_scene: a tie point of epoch " << epoch.name << " observes an unknown image");
        if (p->image == q->image) continue;
        if (p->image > q->image) std::swap(p, q);
        pairs[{p->image, q->image}].push_back(PointMatch{p->pixel, q->pixel, 0.0});
      }
  for (const auto& [pair, matches] : pairs)
    write_homol(epoch_dir + "/Homol", epoch.images[static_cast<std::size_t>(pair.first)].name + ".png",
                epoch.images[static_cast<std::size_t>(pair.second)].name + ".png", matches);
  for (const char* table : {"cameras", "images", "points3D"}) std::remove((epoch_dir + "/" + table + ".txt").c_str());
}

// A MicMac epoch read back (read_scene): the estimated camera (one for the epoch) and each image's
// estimated pose from `<epoch_dir>/Ori-SfM/`, keyed by image name (<name>.png).
inline std::map<std::string, MicmacOriImage> read_micmac_epoch(const std::string& epoch_dir, SyntheticEpoch& epoch) {
  std::map<std::string, MicmacOriImage> out;
  for (MicmacOriImage& image : read_micmac_ori_folder(epoch_dir, kSceneMicmacOri)) {
    DIACHRON_CHECK(out.empty() || same_micmac_camera(out.begin()->second.camera, image.camera),
                   "'" << image.orientation_file << "': its camera is not the one of the epoch's other images ("
                       << out.begin()->second.orientation_file << "), a synthetic epoch has one");
    std::string name = image.name;
    out.emplace(std::move(name), std::move(image));
  }
  epoch.estimated_camera = out.begin()->second.camera;
  return out;
}

inline std::string scene_file_name(const std::string& directory) {
  return directory + "/" + kSceneTruthFolder + "/scene.txt";
}

}  // namespace detail

/// Writes `scene` into the folder `directory` in the layout of the file comment (folders created
/// if needed; files in them are overwritten). The estimated camera goes out as COLMAP OPENCV, or
/// FULL_OPENCV when it has K3 (fitted, not exact, when it has the shear B2, which no COLMAP model
/// holds). An epoch with an orthophoto goes out as ortho.tif and dsm.tif only, and the truth
/// records its grid ("epoch <name> orthophoto", then "orthophoto W H" and the six GDAL
/// coefficients) instead of a camera, images and tie points; the scene file's version stays 2,
/// as scenes without one are written exactly as before. The landscape description (roads,
/// buildings) is not written: its effect is in the true surfaces and albedo rasters. With
/// `options.format` micmac, each photo epoch's estimated camera and poses go out as
/// `<epoch>/Ori-SfM/` instead (write_micmac_ori_folder: AltiSol the epoch DSM's mean height, exact
/// since the estimated camera has B1 = B2 = 0) and every pair of observations of each tie point
/// as `<epoch>/Homol/Pastis<image>/<other>.txt`, both directions (write_homol); the images, DSM and
/// truth are as in the COLMAP layout. Throws
/// diachron::Error naming the file that cannot be written, or for an epoch named like the truth
/// folder.
inline void write_scene(const Scene& scene, const std::string& directory, const SceneWriteOptions& options = {}) {
  DIACHRON_CHECK(!directory.empty(), "write_scene: empty folder name");
  for (const SyntheticEpoch& epoch : scene.epochs)
    DIACHRON_CHECK(epoch.name != kSceneTruthFolder && !epoch.name.empty() && epoch.name.find('/') == std::string::npos,
                   "write_scene: an epoch cannot be named '" << epoch.name << "' (it names its folder)");
  make_folder(directory, "write_scene");
  const std::string truth = directory + "/" + kSceneTruthFolder;
  make_folder(truth, "write_scene");
  const std::string text_path = detail::scene_file_name(directory);
  std::ofstream out(text_path);
  DIACHRON_CHECK(out.good(), "cannot write '" << text_path << "': the file cannot be created");
  out.imbue(std::locale::classic());
  out << std::setprecision(std::numeric_limits<double>::max_digits10);
  out << "diachron-synthetic-scene " << kSceneFileVersion << '\n';
  out << "# The truth of the scene; what each epoch's SfM knows is in ../<epoch>/ (COLMAP model, images, dsm.tif).\n";
  out << "# Frames: world metric, Z up; each epoch in its own frame, X_world = world_from_epoch(X_epoch).\n";
  out << "# Poses: R (cam_from_world, row-major) then centre C; X_cam = R (X - C). Pixels: (0, 0) = centre of the top-left pixel.\n";
  out << "seed " << scene.seed << '\n';
  out << "bounds " << scene.bounds.min_x << ' ' << scene.bounds.min_y << ' ' << scene.bounds.max_x << ' '
      << scene.bounds.max_y << '\n';
  out << "reference_height " << scene.reference_height_m << '\n';
  out << "epochs " << scene.epochs.size() << '\n';
  for (const SyntheticEpoch& epoch : scene.epochs) {
    const std::string epoch_dir = directory + "/" + epoch.name;
    make_folder(epoch_dir, "write_scene");
    if (!epoch.orthophoto) make_folder(epoch_dir + "/images", "write_scene");
    out << "epoch " << epoch.name << (epoch.orthophoto ? " orthophoto" : "") << '\n';
    out << "gsd " << epoch.gsd_m << '\n';
    out << "world_from_epoch " << epoch.world_from_epoch.scale;
    detail::write_scene_matrix(out, epoch.world_from_epoch.rotation);
    out << ' ' << epoch.world_from_epoch.translation.x() << ' ' << epoch.world_from_epoch.translation.y() << ' '
        << epoch.world_from_epoch.translation.z() << '\n';
    if (epoch.orthophoto) {
      // A delivered orthophoto and DSM: no camera, images nor tie points to record.
      const OrthoFrame& frame = epoch.orthophoto->frame;
      out << "orthophoto " << frame.width() << ' ' << frame.height();
      for (double c : frame.geo_transform().c) out << ' ' << c;
      out << '\n';
      detail::write_geotiff_u8(epoch.orthophoto->pixels, frame.geo_transform(), epoch_dir + "/ortho.tif");
      write_geotiff_dsm(epoch.dsm, epoch_dir + "/dsm.tif");
      write_geotiff_dsm(epoch.true_surface, truth + "/" + epoch.name + "_true_surface.tif");
      if (!epoch.albedo.values.empty())
        write_geotiff_dsm(detail::albedo_as_dsm(epoch.albedo), truth + "/" + epoch.name + "_albedo.tif");
      continue;
    }
    detail::write_scene_camera(out, "camera", epoch.camera);
    out << "images " << epoch.images.size() << '\n';
    for (std::size_t i = 0; i < epoch.images.size(); ++i) {
      const SyntheticImage& image = epoch.images[i];
      out << "image " << image.name << ' ' << image.row << ' ' << image.column << '\n';
      detail::write_scene_pose(out, "pose_world", image.pose_world);
      detail::write_scene_pose(out, "pose_epoch", image.pose_epoch);
      const std::string path = epoch_dir + "/images/" + image.name + ".png";
      if (options.write_image)
        options.write_image(static_cast<std::size_t>(&epoch - scene.epochs.data()), i, path);
      else
        write_image_u8(image.pixels, path);
    }
    // Tie points are the COLMAP model's 3D points (same order, ids from 1); the truth adds where
    // they are in the world.
    out << "tie_points " << epoch.tie_points.size() << '\n';
    for (std::size_t k = 0; k < epoch.tie_points.size(); ++k) {
      const TiePoint& tie = epoch.tie_points[k];
      out << "tie " << k + 1 << ' ' << tie.world.x() << ' ' << tie.world.y() << ' ' << tie.world.z() << '\n';
    }
    if (options.format == SceneEpochFormat::micmac)
      detail::write_micmac_epoch(epoch, epoch_dir);
    else
      write_colmap_text(detail::colmap_model_of_epoch(epoch), epoch_dir);
    write_geotiff_dsm(epoch.dsm, epoch_dir + "/dsm.tif");
    write_geotiff_dsm(epoch.true_surface, truth + "/" + epoch.name + "_true_surface.tif");
    if (!epoch.albedo.values.empty())
      write_geotiff_dsm(detail::albedo_as_dsm(epoch.albedo), truth + "/" + epoch.name + "_albedo.tif");
  }
  out << "check_points " << scene.check_points.size() << '\n';
  for (const CheckPoint& cp : scene.check_points) {
    out << "check " << cp.world.x() << ' ' << cp.world.y() << ' ' << cp.world.z() << ' ' << cp.observations.size();
    for (const CheckPoint::Observation& ob : cp.observations)
      out << ' ' << ob.epoch << ' ' << ob.image << ' ' << ob.pixel.x() << ' ' << ob.pixel.y();
    out << '\n';
  }
  out << "end\n";
  out.close();
  DIACHRON_CHECK(!out.fail(), "cannot write '" << text_path << "': write failed");
}

/// Reads a scene written by write_scene(): the truth from OUT/truth/, and from each epoch's
/// folder its images, its DSM, and from its COLMAP model the estimated camera and poses and the
/// tie points (epoch-frame position and observations); from an orthophoto epoch's folder its
/// orthophoto (SyntheticEpoch::orthophoto) and DSM, with no images. An epoch written as a MicMac
/// project (a folder with Ori-SfM/ and no cameras.txt) gives its estimated camera and poses from
/// Ori-SfM/ and its tie points without observations (Homol keeps pairs of observations, not tie
/// points), their epoch-frame position the truth's. The landscape is left empty. Throws
/// diachron::Error naming the file (and line) that is missing or cannot be parsed, or that
/// disagrees with the truth (an image or tie point missing from the COLMAP model, an image missing
/// from the Ori folder).
inline Scene read_scene(const std::string& directory) {
  const std::string text_path = detail::scene_file_name(directory);
  struct stat info {};
  DIACHRON_CHECK(::stat(text_path.c_str(), &info) == 0 || ::stat((directory + "/scene.txt").c_str(), &info) != 0,
                 "cannot read '" << text_path << "': '" << directory
                                 << "' holds a scene in the old single-folder layout (scene.txt at its top); write it again");
  detail::SceneTextReader in(text_path);
  Scene scene;
  in.expect("diachron-synthetic-scene");
  const int version = in.value<int>("the format version");
  in.check(version == kSceneFileVersion, "unsupported format version " + std::to_string(version));
  in.expect("seed");
  scene.seed = in.value<std::uint64_t>("the seed");
  in.expect("bounds");
  double b[4];
  in.read(b, 4, "the bounds");
  scene.bounds = WorldBounds{b[0], b[1], b[2], b[3]};
  in.expect("reference_height");
  scene.reference_height_m = in.value<double>("the reference height");
  in.expect("epochs");
  const auto n_epochs = in.value<long long>("the number of epochs");
  in.check(n_epochs >= 1 && n_epochs <= 1000, "the number of epochs must be in [1, 1000]");
  for (long long e = 0; e < n_epochs; ++e) {
    SyntheticEpoch epoch;
    in.expect("epoch");
    epoch.name = in.word("the epoch name");
    const std::optional<std::string> kind = in.optional_word();
    in.check(!kind || *kind == "orthophoto", "unknown kind of epoch '" + kind.value_or("") + "'");
    const std::string epoch_dir = directory + "/" + epoch.name;
    in.expect("gsd");
    epoch.gsd_m = in.value<double>("the GSD");
    in.expect("world_from_epoch");
    epoch.world_from_epoch.scale = in.value<double>("the Helmert scale");
    epoch.world_from_epoch.rotation = in.matrix("the Helmert rotation");
    double t[3];
    in.read(t, 3, "the Helmert translation");
    epoch.world_from_epoch.translation = Vec3(t[0], t[1], t[2]);
    const std::string truth = directory + "/" + kSceneTruthFolder + "/" + epoch.name;
    const auto read_truth_rasters = [&] {
      epoch.dsm = read_geotiff_dsm(epoch_dir + "/dsm.tif");
      epoch.true_surface = read_geotiff_dsm(truth + "_true_surface.tif");
      const std::string albedo_path = truth + "_albedo.tif";
      if (::stat(albedo_path.c_str(), &info) == 0) {
        const Dsm albedo = read_geotiff_dsm(albedo_path);
        epoch.albedo.values = albedo.heights();
        epoch.albedo.transform = albedo.transform();
      }
    };
    if (kind) {
      in.expect("orthophoto");
      int size[2];
      in.read(size, 2, "the orthophoto size");
      GeoTransform recorded;
      in.read(recorded.c.data(), 6, "the orthophoto geotransform");
      const std::string ortho_path = epoch_dir + "/ortho.tif";
      epoch.orthophoto = detail::read_scene_orthophoto(ortho_path);
      DIACHRON_CHECK(epoch.orthophoto->frame.width() == size[0] && epoch.orthophoto->frame.height() == size[1] &&
                         epoch.orthophoto->frame.geo_transform().c == recorded.c,
                     "'" << ortho_path << "' does not have the size and geotransform '" << text_path << "' records");
      read_truth_rasters();
      scene.epochs.push_back(std::move(epoch));
      continue;
    }
    epoch.camera = in.camera("camera");

    // A MicMac epoch (SceneEpochFormat::micmac) holds Ori-SfM/ and no COLMAP model.
    const std::string ori_dir = micmac_ori_folder(epoch_dir, kSceneMicmacOri);
    const bool micmac = !is_regular_file(epoch_dir + "/cameras.txt") && is_folder(ori_dir);
    ColmapModel model;
    std::map<std::string, MicmacOriImage> oriented;
    const std::string images_txt = epoch_dir + "/images.txt";
    const std::string camera_file = micmac ? ori_dir : epoch_dir + "/cameras.txt";
    if (micmac) {
      oriented = detail::read_micmac_epoch(epoch_dir, epoch);
    } else {
      model = read_colmap_text(epoch_dir);
      DIACHRON_CHECK(model.cameras.size() == 1, "'" << epoch_dir << "/cameras.txt' has " << model.cameras.size()
                                                    << " cameras, a synthetic epoch one");
      epoch.estimated_camera = camera_from_colmap(model.cameras.begin()->second).model;
    }
    DIACHRON_CHECK(epoch.estimated_camera.width() == epoch.camera.width() &&
                       epoch.estimated_camera.height() == epoch.camera.height(),
                   "'" << camera_file << "': the camera is " << epoch.estimated_camera.width() << " x "
                       << epoch.estimated_camera.height() << ", the true camera " << epoch.camera.width() << " x "
                       << epoch.camera.height());

    in.expect("images");
    const auto n_images = in.value<long long>("the number of images");
    in.check(n_images >= 0 && n_images <= 1000000, "bad number of images");
    std::map<std::uint32_t, int> index_of_colmap_image;
    for (long long i = 0; i < n_images; ++i) {
      SyntheticImage image;
      in.expect("image");
      image.name = in.word("the image name");
      image.row = in.value<int>("the image row");
      image.column = in.value<int>("the image column");
      image.pose_world = in.pose("pose_world");
      image.pose_epoch = in.pose("pose_epoch");
      if (micmac) {
        const auto it = oriented.find(image.name + ".png");
        DIACHRON_CHECK(it != oriented.end(), "'" << ori_dir << "' has no Orientation-" << image.name << ".png.xml (image "
                                                 << image.name << " is listed in '" << text_path << "')");
        image.estimated_pose = it->second.pose;
      } else {
        const std::optional<std::uint32_t> id = model.find_image(image.name + ".png");
        DIACHRON_CHECK(id, "'" << images_txt << "' has no image '" << image.name << ".png' (listed in '" << text_path
                               << "')");
        index_of_colmap_image[*id] = static_cast<int>(i);
        image.estimated_pose = model.images.at(*id).pose;
      }
      const std::string png = epoch_dir + "/images/" + image.name + ".png";
      image.pixels = detail::read_scene_image(png);
      DIACHRON_CHECK(image.pixels.width() == epoch.camera.width() && image.pixels.height() == epoch.camera.height(),
                     "'" << png << "' is " << image.pixels.width() << " x " << image.pixels.height() << ", the camera "
                         << epoch.camera.width() << " x " << epoch.camera.height());
      epoch.images.push_back(std::move(image));
    }
    const std::size_t delivered = micmac ? oriented.size() : model.images.size();
    DIACHRON_CHECK(delivered == epoch.images.size(),
                   "'" << (micmac ? ori_dir : images_txt) << "' has " << delivered << " images, '" << text_path << "' "
                       << epoch.images.size() << " for epoch " << epoch.name);

    in.expect("tie_points");
    const auto n_ties = in.value<long long>("the number of tie points");
    in.check(n_ties >= 0, "bad number of tie points");
    DIACHRON_CHECK(micmac || static_cast<std::size_t>(n_ties) == model.points3d.size(),
                   "'" << epoch_dir << "/points3D.txt' has " << model.points3d.size() << " points, '" << text_path
                       << "' " << n_ties << " tie points for epoch " << epoch.name);
    const Helmert3 epoch_from_world = epoch.epoch_from_world();
    for (long long k = 0; k < n_ties; ++k) {
      TiePoint tie;
      in.expect("tie");
      const auto id = in.value<long long>("the tie point's point3D id");
      in.read(tie.world.data(), 3, "the tie point's world position");
      if (micmac) {
        // Homol keeps pairs of observations, not tie points: the position is the truth's, as the
        // generator computes it, and the observations stay with the Homol files.
        tie.epoch = epoch_from_world(tie.world);
        epoch.tie_points.push_back(std::move(tie));
        continue;
      }
      const auto point = model.points3d.find(static_cast<std::uint64_t>(id));
      in.check(id >= 0 && point != model.points3d.end(),
               "tie point " + std::to_string(id) + " is not in '" + epoch_dir + "/points3D.txt'");
      tie.epoch = point->second.xyz;
      for (const ColmapTrackElement& element : point->second.track) {
        const ColmapImage& image = model.images.at(element.image_id);
        tie.observations.push_back({index_of_colmap_image.at(element.image_id),
                                    diachron_pixel_from_colmap(image.points2d[element.point2d_index].xy)});
      }
      epoch.tie_points.push_back(std::move(tie));
    }
    read_truth_rasters();
    scene.epochs.push_back(std::move(epoch));
  }
  in.expect("check_points");
  const auto n_checks = in.value<long long>("the number of check points");
  in.check(n_checks >= 0, "bad number of check points");
  for (long long k = 0; k < n_checks; ++k) {
    CheckPoint cp;
    in.expect("check");
    in.read(cp.world.data(), 3, "the check point coordinates");
    const auto n_obs = in.value<long long>("the number of observations");
    in.check(n_obs >= 0 && n_obs <= 100000000, "bad number of observations");
    for (long long o = 0; o < n_obs; ++o) {
      CheckPoint::Observation ob;
      ob.epoch = in.value<int>("an observation's epoch");
      ob.image = in.value<int>("an observation's image");
      in.check(ob.epoch >= 0 && ob.epoch < n_epochs &&
                   ob.image >= 0 && static_cast<std::size_t>(ob.image) < scene.epochs[static_cast<std::size_t>(ob.epoch)].images.size(),
               "check point observation of an unknown epoch or image");
      in.read(ob.pixel.data(), 2, "an observation's pixel");
      cp.observations.push_back(ob);
    }
    scene.check_points.push_back(std::move(cp));
  }
  in.expect("end");
  return scene;
}

}  // namespace diachron
