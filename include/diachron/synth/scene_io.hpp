#pragma once
/// @file
/// Writes a synthetic scene to a plain folder and reads it back: 8-bit PNG images, GeoTIFF DSMs
/// (the SfM DSM of each epoch in its own frame, the true surface and the albedo in the world
/// frame), and one text file with cameras, poses, Helmerts, tie points and check points.
/// Needs GDAL (diachron::io); the generator itself does not.
///
/// Folder layout (docs/synthetic-scenes.md describes the text format line by line):
/// @code
/// OUT/scene.txt                       truth: cameras, poses, Helmerts, tie and check points
/// OUT/images/<image name>.png         8-bit grey images
/// OUT/<epoch>_dsm.tif                 the epoch's DSM as its SfM delivers it (epoch frame)
/// OUT/<epoch>_true_surface.tif        the epoch's true surface (world frame)
/// OUT/<epoch>_albedo.tif              the epoch's ground albedo (world frame, 0..1)
/// @endcode

#include <cerrno>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <fstream>
#include <iomanip>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <sys/stat.h>
#include <sys/types.h>

#include <Eigen/Core>

#include <diachron/camera/camera.hpp>
#include <diachron/camera/distortion.hpp>
#include <diachron/camera/pose.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/geometry/helmert3.hpp>
#include <diachron/io/geotiff.hpp>
#include <diachron/synth/scene.hpp>
#include <diachron/terrain/dsm.hpp>

namespace diachron {

/// Version written on the first line of scene.txt.
inline constexpr int kSceneFileVersion = 1;

namespace detail {

inline void make_scene_directory(const std::string& path) {
  if (::mkdir(path.c_str(), 0755) != 0 && errno != EEXIST)
    throw Error("diachron: cannot create the folder '" + path + "'");
  struct stat info {};
  DIACHRON_CHECK(::stat(path.c_str(), &info) == 0 && S_ISDIR(info.st_mode), "'" << path << "' is not a folder");
}

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

}  // namespace detail

/// Writes `scene` into the folder `directory` (created if needed; files in it are overwritten).
/// The landscape description (roads, buildings) is not written: its effect is in the true
/// surfaces and albedo rasters. Throws diachron::Error naming the file that cannot be written.
inline void write_scene(const Scene& scene, const std::string& directory) {
  DIACHRON_CHECK(!directory.empty(), "write_scene: empty folder name");
  detail::make_scene_directory(directory);
  detail::make_scene_directory(directory + "/images");
  const std::string text_path = directory + "/scene.txt";
  std::ofstream out(text_path);
  DIACHRON_CHECK(out.good(), "cannot write '" << text_path << "': the file cannot be created");
  out << std::setprecision(std::numeric_limits<double>::max_digits10);
  out << "diachron-synthetic-scene " << kSceneFileVersion << '\n';
  out << "# Frames: world metric, Z up; each epoch in its own frame, X_world = world_from_epoch(X_epoch).\n";
  out << "# Poses: R (cam_from_world, row-major) then centre C; X_cam = R (X - C). Pixels: (0, 0) = centre of the top-left pixel.\n";
  out << "seed " << scene.seed << '\n';
  out << "bounds " << scene.bounds.min_x << ' ' << scene.bounds.min_y << ' ' << scene.bounds.max_x << ' '
      << scene.bounds.max_y << '\n';
  out << "reference_height " << scene.reference_height_m << '\n';
  out << "epochs " << scene.epochs.size() << '\n';
  for (const SyntheticEpoch& epoch : scene.epochs) {
    out << "epoch " << epoch.name << '\n';
    out << "gsd " << epoch.gsd_m << '\n';
    out << "world_from_epoch " << epoch.world_from_epoch.scale;
    detail::write_scene_matrix(out, epoch.world_from_epoch.rotation);
    out << ' ' << epoch.world_from_epoch.translation.x() << ' ' << epoch.world_from_epoch.translation.y() << ' '
        << epoch.world_from_epoch.translation.z() << '\n';
    detail::write_scene_camera(out, "camera", epoch.camera);
    detail::write_scene_camera(out, "estimated_camera", epoch.estimated_camera);
    out << "images " << epoch.images.size() << '\n';
    for (const SyntheticImage& image : epoch.images) {
      out << "image " << image.name << ' ' << image.row << ' ' << image.column << '\n';
      detail::write_scene_pose(out, "pose_world", image.pose_world);
      detail::write_scene_pose(out, "pose_epoch", image.pose_epoch);
      detail::write_scene_pose(out, "estimated_pose", image.estimated_pose);
      write_image_u8(image.pixels, directory + "/images/" + image.name + ".png");
    }
    out << "tie_points " << epoch.tie_points.size() << '\n';
    for (const TiePoint& tie : epoch.tie_points) {
      out << "tie " << tie.world.x() << ' ' << tie.world.y() << ' ' << tie.world.z() << ' ' << tie.epoch.x() << ' '
          << tie.epoch.y() << ' ' << tie.epoch.z() << ' ' << tie.observations.size();
      for (const ImageObservation& ob : tie.observations) out << ' ' << ob.image << ' ' << ob.pixel.x() << ' ' << ob.pixel.y();
      out << '\n';
    }
    write_geotiff_dsm(epoch.dsm, directory + "/" + epoch.name + "_dsm.tif");
    write_geotiff_dsm(epoch.true_surface, directory + "/" + epoch.name + "_true_surface.tif");
    if (!epoch.albedo.values.empty())
      write_geotiff_dsm(detail::albedo_as_dsm(epoch.albedo), directory + "/" + epoch.name + "_albedo.tif");
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

/// Reads a scene written by write_scene(). The landscape is left empty. Throws diachron::Error
/// naming the file (and line) that is missing or cannot be parsed.
inline Scene read_scene(const std::string& directory) {
  const std::string text_path = directory + "/scene.txt";
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
    in.expect("gsd");
    epoch.gsd_m = in.value<double>("the GSD");
    in.expect("world_from_epoch");
    epoch.world_from_epoch.scale = in.value<double>("the Helmert scale");
    epoch.world_from_epoch.rotation = in.matrix("the Helmert rotation");
    double t[3];
    in.read(t, 3, "the Helmert translation");
    epoch.world_from_epoch.translation = Vec3(t[0], t[1], t[2]);
    epoch.camera = in.camera("camera");
    epoch.estimated_camera = in.camera("estimated_camera");
    in.expect("images");
    const auto n_images = in.value<long long>("the number of images");
    in.check(n_images >= 0 && n_images <= 1000000, "bad number of images");
    for (long long i = 0; i < n_images; ++i) {
      SyntheticImage image;
      in.expect("image");
      image.name = in.word("the image name");
      image.row = in.value<int>("the image row");
      image.column = in.value<int>("the image column");
      image.pose_world = in.pose("pose_world");
      image.pose_epoch = in.pose("pose_epoch");
      image.estimated_pose = in.pose("estimated_pose");
      image.pixels = detail::read_scene_image(directory + "/images/" + image.name + ".png");
      DIACHRON_CHECK(image.pixels.width() == epoch.camera.width() && image.pixels.height() == epoch.camera.height(),
                     "'" << directory << "/images/" << image.name << ".png' is " << image.pixels.width() << " x "
                         << image.pixels.height() << ", the camera " << epoch.camera.width() << " x "
                         << epoch.camera.height());
      epoch.images.push_back(std::move(image));
    }
    in.expect("tie_points");
    const auto n_ties = in.value<long long>("the number of tie points");
    in.check(n_ties >= 0, "bad number of tie points");
    for (long long k = 0; k < n_ties; ++k) {
      TiePoint tie;
      in.expect("tie");
      double p[6];
      in.read(p, 6, "the tie point coordinates");
      tie.world = Vec3(p[0], p[1], p[2]);
      tie.epoch = Vec3(p[3], p[4], p[5]);
      const auto n_obs = in.value<long long>("the number of observations");
      in.check(n_obs >= 0 && n_obs <= n_images, "bad number of observations");
      for (long long o = 0; o < n_obs; ++o) {
        ImageObservation ob;
        ob.image = in.value<int>("an observation's image");
        in.check(ob.image >= 0 && ob.image < n_images, "observation of image " + std::to_string(ob.image) +
                                                          " outside the epoch's " + std::to_string(n_images));
        in.read(ob.pixel.data(), 2, "an observation's pixel");
        tie.observations.push_back(ob);
      }
      epoch.tie_points.push_back(std::move(tie));
    }
    epoch.dsm = read_geotiff_dsm(directory + "/" + epoch.name + "_dsm.tif");
    epoch.true_surface = read_geotiff_dsm(directory + "/" + epoch.name + "_true_surface.tif");
    const std::string albedo_path = directory + "/" + epoch.name + "_albedo.tif";
    struct stat info {};
    if (::stat(albedo_path.c_str(), &info) == 0) {
      const Dsm albedo = read_geotiff_dsm(albedo_path);
      epoch.albedo.values = albedo.heights();
      epoch.albedo.transform = albedo.transform();
    }
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
