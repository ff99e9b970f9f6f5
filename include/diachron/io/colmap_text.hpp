#pragma once
/// @file
/// COLMAP text models (cameras.txt, images.txt, points3D.txt) read and written as they are on
/// disk, and the bridge from a COLMAP camera to a diachron Camera<FraserAffine>. Needs the
/// standard library and Eigen only (no GDAL, despite living in io/).
///
/// ColmapModel keeps COLMAP's conventions where the files have them, so that a model read and
/// written again is the same file:
/// - pixels (2D points, principal points in `params`): the centre of the top-left pixel is
///   (0.5, 0.5); diachron's pixel = COLMAP's - kColmapPixelShift (diachron_pixel_from_colmap());
/// - camera params in COLMAP's order for the model (e.g. OPENCV: fx fy cx cy k1 k2 p1 p2);
/// - the pose is a diachron Pose (X_cam = R (X - C)); the file stores QW QX QY QZ TX TY TZ of
///   X_cam = R X + t, read and written through Pose::from_cam_from_world() and
///   Pose::cam_from_world_translation(); the quaternion is written with QW >= 0.
/// Comments (`#` lines) and blank lines are accepted where COLMAP accepts them; the POINTS2D line
/// of an image is the line right after it (possibly empty), as COLMAP reads it.
/// Every malformed file is a diachron::Error that names the file and the line.

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <fstream>
#include <iomanip>
#include <limits>
#include <locale>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>


#include <Eigen/Core>
#include <Eigen/Geometry>

#include <diachron/camera/camera.hpp>
#include <diachron/camera/colmap_conversion.hpp>
#include <diachron/camera/conversion.hpp>
#include <diachron/camera/distortion.hpp>
#include <diachron/camera/pose.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/types.hpp>
#include <diachron/io/folders.hpp>

namespace diachron {

/// The point3D id of a 2D point that has none (COLMAP writes -1).
inline constexpr std::int64_t kColmapNoPoint3D = -1;

/// diachron pixel (centre of the top-left pixel at (0, 0)) of a COLMAP pixel.
inline Vec2 diachron_pixel_from_colmap(const Vec2& colmap_px) {
  return colmap_px - Vec2::Constant(kColmapPixelShift);
}
/// COLMAP pixel (centre of the top-left pixel at (0.5, 0.5)) of a diachron pixel.
inline Vec2 colmap_pixel_from_diachron(const Vec2& diachron_px) {
  return diachron_px + Vec2::Constant(kColmapPixelShift);
}

/// Number of parameters of a COLMAP (3.x) camera model, or nullopt for a name COLMAP does not know.
inline std::optional<int> colmap_camera_model_num_params(std::string_view model) {
  static constexpr std::pair<std::string_view, int> kModels[] = {
      {"SIMPLE_PINHOLE", 3}, {"PINHOLE", 4},          {"SIMPLE_RADIAL", 4},
      {"RADIAL", 5},         {"OPENCV", 8},           {"OPENCV_FISHEYE", 8},
      {"FULL_OPENCV", 12},   {"FOV", 5},              {"SIMPLE_RADIAL_FISHEYE", 4},
      {"RADIAL_FISHEYE", 5}, {"THIN_PRISM_FISHEYE", 12}};
  for (const auto& [name, n] : kModels)
    if (name == model) return n;
  return std::nullopt;
}

/// A camera of cameras.txt: `model` is COLMAP's name, `params` in COLMAP's order for it, principal
/// point in COLMAP's pixel convention; width and height in px.
struct ColmapCamera {
  std::uint32_t id = 0;
  std::string model;
  int width = 0;
  int height = 0;
  std::vector<double> params;
};

/// One 2D point of an image: `xy` in COLMAP's pixel convention (px), `point3d_id` the 3D point it
/// observes or kColmapNoPoint3D.
struct ColmapPoint2D {
  Eigen::Vector2d xy = Eigen::Vector2d::Zero();
  std::int64_t point3d_id = kColmapNoPoint3D;
};

/// An image of images.txt: its name (a path relative to the image folder), its camera, its pose in
/// the model's frame and its 2D points (indexed from 0 in file order, as tracks refer to them).
struct ColmapImage {
  std::uint32_t id = 0;
  std::string name;
  std::uint32_t camera_id = 0;
  Pose pose;
  std::vector<ColmapPoint2D> points2d;
};

/// One observation of a 3D point: an image and the index of the 2D point in it.
struct ColmapTrackElement {
  std::uint32_t image_id = 0;
  std::uint32_t point2d_index = 0;
  friend bool operator==(const ColmapTrackElement& a, const ColmapTrackElement& b) {
    return a.image_id == b.image_id && a.point2d_index == b.point2d_index;
  }
};

/// A 3D point of points3D.txt: position in the model's frame, colour, mean reprojection error (px,
/// as COLMAP computed it; -1 when unknown) and its track.
struct ColmapPoint3D {
  std::uint64_t id = 0;
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
  std::array<std::uint8_t, 3> rgb{{0, 0, 0}};
  double error = -1.0;
  std::vector<ColmapTrackElement> track;
};

/// A COLMAP sparse model as its three text files hold it, each table keyed by id.
struct ColmapModel {
  std::map<std::uint32_t, ColmapCamera> cameras;
  std::map<std::uint32_t, ColmapImage> images;
  std::map<std::uint64_t, ColmapPoint3D> points3d;

  /// Id of the image called `name`, nullopt when there is none.
  std::optional<std::uint32_t> find_image(const std::string& name) const {
    for (const auto& [id, image] : images)
      if (image.name == name) return id;
    return std::nullopt;
  }

  /// Throws diachron::Error when the tables disagree: an image of an unknown camera, a camera with
  /// the wrong number of params, a track element that is not a 2D point observing that 3D point,
  /// or a 2D point that names a 3D point whose track does not contain it.
  void check() const;
};

/// Reads cameras.txt. Throws diachron::Error naming the file and line of anything malformed.
inline std::map<std::uint32_t, ColmapCamera> read_colmap_cameras_text(const std::string& path);
/// Reads images.txt (syntax only; read_colmap_text() also checks the references).
inline std::map<std::uint32_t, ColmapImage> read_colmap_images_text(const std::string& path);
/// Reads points3D.txt (syntax only; read_colmap_text() also checks the references).
inline std::map<std::uint64_t, ColmapPoint3D> read_colmap_points3d_text(const std::string& path);

/// Reads the model in `directory` (cameras.txt, images.txt, points3D.txt) and checks that its
/// tables agree; every error names the file and line.
inline ColmapModel read_colmap_text(const std::string& directory);

/// Writes `model` as cameras.txt, images.txt and points3D.txt into `directory` (created if needed,
/// not its parents), doubles with 17 significant digits. Throws diachron::Error when the model is
/// inconsistent (ColmapModel::check()) or a file cannot be written.
inline void write_colmap_text(const ColmapModel& model, const std::string& directory);

/// The diachron camera of a COLMAP camera: SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV
/// exactly; FULL_OPENCV exactly when k4 = k5 = k6 = 0, fitted otherwise (see
/// camera_from_colmap(const ColmapFullOpenCv&)). Principal point - 0.5 px; fx != fy becomes
/// B1 = fx - fy with f = fy; OpenCV's (p1, p2) become Fraser's (P2, P1) (docs/conventions.md).
/// Throws diachron::Error for another model or invalid params.
inline ConversionResult<Camera<FraserAffine>> camera_from_colmap(const ColmapCamera& colmap,
                                                                 const ConversionOptions& options = {});

/// The COLMAP camera (id `camera_id`) of a diachron camera: OPENCV when it is exact (K3 = 0 and
/// B2 = 0), else FULL_OPENCV (exact when B2 = 0, otherwise fitted: the result says how far).
template <class Distortion>
ConversionResult<ColmapCamera> colmap_camera_from_camera(const Camera<Distortion>& camera,
                                                         std::uint32_t camera_id,
                                                         const ConversionOptions& options = {});

// Implementation ----------------------------------------------------------------------------------

namespace detail {

[[noreturn]] inline void colmap_fail(const std::string& path, int line, const std::string& message) {
  std::ostringstream out;
  out << "diachron: '" << path << "' line " << line << ": " << message;
  throw Error(out.str());
}

// One COLMAP text file, line by line, split into whitespace-separated fields.
class ColmapTextFile {
 public:
  explicit ColmapTextFile(std::string path) : path_(std::move(path)), in_(path_) {
    if (!in_.good()) throw Error("diachron: cannot read '" + path_ + "': the file cannot be opened");
  }

  // The next line that is neither blank nor a comment; false at the end of the file.
  bool next_record() {
    while (next_line()) {
      if (!fields_.empty() && fields_[0][0] != '#') return true;
    }
    return false;
  }

  // The next physical line, whatever it holds; false at the end of the file.
  bool next_line() {
    if (!std::getline(in_, line_)) return false;
    ++number_;
    fields_.clear();
    std::size_t i = 0;
    while (i < line_.size()) {
      while (i < line_.size() && is_space(line_[i])) ++i;
      const std::size_t start = i;
      while (i < line_.size() && !is_space(line_[i])) ++i;
      if (i > start) fields_.push_back(std::string_view(line_).substr(start, i - start));
    }
    return true;
  }

  const std::vector<std::string_view>& fields() const { return fields_; }
  int line() const { return number_; }
  const std::string& path() const { return path_; }

  [[noreturn]] void fail(const std::string& message) const { colmap_fail(path_, number_, message); }

  double number(std::size_t i, const char* what) const {
    const std::string_view s = field(i, what);
    double value = 0.0;
    const auto [end, error] = std::from_chars(s.data(), s.data() + s.size(), value);
    if (error != std::errc() || end != s.data() + s.size() || !std::isfinite(value))
      fail(std::string("cannot read ") + what + ": '" + std::string(s) + "' is not a finite number");
    return value;
  }

  long long integer(std::size_t i, const char* what, long long min, long long max) const {
    const std::string_view s = field(i, what);
    long long value = 0;
    const auto [end, error] = std::from_chars(s.data(), s.data() + s.size(), value);
    if (error != std::errc() || end != s.data() + s.size())
      fail(std::string("cannot read ") + what + ": '" + std::string(s) + "' is not an integer");
    if (value < min || value > max)
      fail(std::string(what) + " " + std::to_string(value) + " is outside [" + std::to_string(min) + ", " +
           std::to_string(max) + "]");
    return value;
  }

  std::string_view field(std::size_t i, const char* what) const {
    if (i >= fields_.size()) fail(std::string("cannot read ") + what + ": the line has only " +
                                  std::to_string(fields_.size()) + " fields");
    return fields_[i];
  }

 private:
  static bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f'; }

  std::string path_;
  std::ifstream in_;
  std::string line_;
  std::vector<std::string_view> fields_;
  int number_ = 0;
};

inline constexpr long long kColmapMaxId32 = static_cast<long long>(std::numeric_limits<std::uint32_t>::max()) - 1;

// COLMAP's qvec (QW QX QY QZ of cam_from_world) with QW >= 0.
inline Eigen::Vector4d colmap_qvec(const Pose& pose) {
  Eigen::Quaterniond q(pose.cam_from_world_rotation());
  q.normalize();
  Eigen::Vector4d out(q.w(), q.x(), q.y(), q.z());
  if (out[0] < 0.0) out = -out;
  return out;
}

struct ColmapImageLines {
  int record = 0;  // line of the image record
  int points = 0;  // line of its POINTS2D
};

inline std::map<std::uint32_t, ColmapImage> read_images(const std::string& path,
                                                         std::map<std::uint32_t, ColmapImageLines>* lines) {
  ColmapTextFile file(path);
  std::map<std::uint32_t, ColmapImage> images;
  while (file.next_record()) {
    ColmapImage image;
    if (file.fields().size() != 10)
      file.fail("an image line needs 10 fields (IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME), found " +
                std::to_string(file.fields().size()));
    image.id = static_cast<std::uint32_t>(file.integer(0, "the image id", 0, kColmapMaxId32));
    const Eigen::Quaterniond q(file.number(1, "QW"), file.number(2, "QX"), file.number(3, "QY"), file.number(4, "QZ"));
    const Vec3 t(file.number(5, "TX"), file.number(6, "TY"), file.number(7, "TZ"));
    if (!(q.norm() > 1e-12)) file.fail("the quaternion QW QX QY QZ is zero");
    image.pose = Pose::from_cam_from_world(q.normalized().toRotationMatrix(), t);
    image.camera_id = static_cast<std::uint32_t>(file.integer(8, "the camera id", 0, kColmapMaxId32));
    image.name = std::string(file.field(9, "the image name"));
    if (images.count(image.id)) file.fail("image id " + std::to_string(image.id) + " appears twice");
    ColmapImageLines where;
    where.record = file.line();
    // COLMAP reads the POINTS2D line as the very next line; at the end of the file it has none.
    if (file.next_line()) {
      where.points = file.line();
      const auto& f = file.fields();
      if (f.size() % 3 != 0)
        file.fail("POINTS2D of image " + std::to_string(image.id) + " needs triples (X Y POINT3D_ID), found " +
                  std::to_string(f.size()) + " fields");
      image.points2d.resize(f.size() / 3);
      for (std::size_t k = 0; k < image.points2d.size(); ++k) {
        ColmapPoint2D& p = image.points2d[k];
        p.xy = Vec2(file.number(3 * k, "a 2D point's X"), file.number(3 * k + 1, "a 2D point's Y"));
        p.point3d_id = file.integer(3 * k + 2, "a 2D point's POINT3D_ID", -1, std::numeric_limits<long long>::max());
      }
    }
    if (lines) (*lines)[image.id] = where;
    images.emplace(image.id, std::move(image));
  }
  return images;
}

inline std::map<std::uint64_t, ColmapPoint3D> read_points3d(const std::string& path, std::map<std::uint64_t, int>* lines) {
  ColmapTextFile file(path);
  std::map<std::uint64_t, ColmapPoint3D> points;
  while (file.next_record()) {
    const auto& f = file.fields();
    if (f.size() < 8 || (f.size() - 8) % 2 != 0)
      file.fail("a 3D point line needs POINT3D_ID X Y Z R G B ERROR then (IMAGE_ID POINT2D_IDX) pairs, found " +
                std::to_string(f.size()) + " fields");
    ColmapPoint3D p;
    p.id = static_cast<std::uint64_t>(file.integer(0, "the point3D id", 0, std::numeric_limits<long long>::max()));
    p.xyz = Vec3(file.number(1, "X"), file.number(2, "Y"), file.number(3, "Z"));
    for (int c = 0; c < 3; ++c)
      p.rgb[static_cast<std::size_t>(c)] =
          static_cast<std::uint8_t>(file.integer(4 + static_cast<std::size_t>(c), "a colour component", 0, 255));
    p.error = file.number(7, "ERROR");
    for (std::size_t k = 8; k < f.size(); k += 2) {
      ColmapTrackElement e;
      e.image_id = static_cast<std::uint32_t>(file.integer(k, "a track's IMAGE_ID", 0, kColmapMaxId32));
      e.point2d_index = static_cast<std::uint32_t>(
          file.integer(k + 1, "a track's POINT2D_IDX", 0, std::numeric_limits<std::uint32_t>::max()));
      p.track.push_back(e);
    }
    if (points.count(p.id)) file.fail("point3D id " + std::to_string(p.id) + " appears twice");
    if (lines) (*lines)[p.id] = file.line();
    points.emplace(p.id, std::move(p));
  }
  return points;
}

// Cross-references of a model; `where` names the file and line of a broken reference, or nullptr
// for a model in memory (the message then names the ids).
struct ColmapCheckContext {
  std::string images_path;
  std::string points_path;
  const std::map<std::uint32_t, ColmapImageLines>* image_lines = nullptr;
  const std::map<std::uint64_t, int>* point_lines = nullptr;
};

inline void check_colmap_model(const ColmapModel& model, const ColmapCheckContext* context) {
  const auto image_fail = [&](std::uint32_t id, bool points_line, const std::string& message) {
    if (context) {
      const ColmapImageLines& l = context->image_lines->at(id);
      colmap_fail(context->images_path, points_line ? l.points : l.record, message);
    }
    throw Error("diachron: ColmapModel: " + message);
  };
  const auto point_fail = [&](std::uint64_t id, const std::string& message) {
    if (context) colmap_fail(context->points_path, context->point_lines->at(id), message);
    throw Error("diachron: ColmapModel: " + message);
  };
  for (const auto& [id, camera] : model.cameras) {
    DIACHRON_CHECK(id == camera.id, "ColmapModel: camera " << camera.id << " is stored under id " << id);
    const std::optional<int> n = colmap_camera_model_num_params(camera.model);
    DIACHRON_CHECK(n && static_cast<std::size_t>(*n) == camera.params.size(),
                   "ColmapModel: camera " << id << " of model '" << camera.model << "' has " << camera.params.size()
                                          << " params");
    DIACHRON_CHECK(camera.width > 0 && camera.height > 0, "ColmapModel: camera " << id << " has no size");
  }
  for (const auto& [id, image] : model.images) {
    if (id != image.id) image_fail(id, false, "image " + std::to_string(image.id) + " is stored under id " + std::to_string(id));
    if (!model.cameras.count(image.camera_id))
      image_fail(id, false, "image " + std::to_string(id) + " refers to camera " + std::to_string(image.camera_id) +
                                ", which cameras.txt does not have");
  }
  std::set<std::pair<std::uint32_t, std::uint32_t>> observed;
  for (const auto& [pid, point] : model.points3d) {
    if (pid != point.id) point_fail(pid, "point3D " + std::to_string(point.id) + " is stored under id " + std::to_string(pid));
    for (const ColmapTrackElement& e : point.track) {
      const auto image = model.images.find(e.image_id);
      const std::string element = "track element (" + std::to_string(e.image_id) + ", " +
                                  std::to_string(e.point2d_index) + ") of point3D " + std::to_string(pid);
      if (image == model.images.end()) point_fail(pid, element + ": no image " + std::to_string(e.image_id));
      if (e.point2d_index >= image->second.points2d.size())
        point_fail(pid, element + ": image " + std::to_string(e.image_id) + " has " +
                            std::to_string(image->second.points2d.size()) + " 2D points");
      const std::int64_t named = image->second.points2d[e.point2d_index].point3d_id;
      if (named != static_cast<std::int64_t>(pid))
        point_fail(pid, element + ": that 2D point observes point3D " + std::to_string(named));
      if (!observed.emplace(e.image_id, e.point2d_index).second) point_fail(pid, element + " appears twice");
    }
  }
  for (const auto& [id, image] : model.images) {
    for (std::size_t k = 0; k < image.points2d.size(); ++k) {
      const std::int64_t p = image.points2d[k].point3d_id;
      if (p == kColmapNoPoint3D) continue;
      if (!observed.count({id, static_cast<std::uint32_t>(k)}))
        image_fail(id, true, "2D point " + std::to_string(k) + " of image " + std::to_string(id) + " observes point3D " +
                                 std::to_string(p) + ", whose track does not contain it");
    }
  }
}

inline std::ofstream open_colmap_output(const std::string& path) {
  std::ofstream out(path);
  DIACHRON_CHECK(out.good(), "cannot write '" << path << "': the file cannot be created");
  out.imbue(std::locale::classic());
  out << std::setprecision(std::numeric_limits<double>::max_digits10);
  return out;
}

inline void close_colmap_output(std::ofstream& out, const std::string& path) {
  out.close();
  DIACHRON_CHECK(!out.fail(), "cannot write '" << path << "': write failed");
}

}  // namespace detail

inline void ColmapModel::check() const { detail::check_colmap_model(*this, nullptr); }

inline std::map<std::uint32_t, ColmapCamera> read_colmap_cameras_text(const std::string& path) {
  detail::ColmapTextFile file(path);
  std::map<std::uint32_t, ColmapCamera> cameras;
  while (file.next_record()) {
    ColmapCamera camera;
    camera.id = static_cast<std::uint32_t>(file.integer(0, "the camera id", 0, detail::kColmapMaxId32));
    camera.model = std::string(file.field(1, "the camera model"));
    const std::optional<int> n = colmap_camera_model_num_params(camera.model);
    if (!n) file.fail("unknown camera model '" + camera.model + "'");
    camera.width = static_cast<int>(file.integer(2, "the width", 1, std::numeric_limits<int>::max()));
    camera.height = static_cast<int>(file.integer(3, "the height", 1, std::numeric_limits<int>::max()));
    if (file.fields().size() != 4 + static_cast<std::size_t>(*n))
      file.fail("camera model " + camera.model + " needs " + std::to_string(*n) + " params, found " +
                std::to_string(file.fields().size() - 4));
    for (int k = 0; k < *n; ++k) camera.params.push_back(file.number(4 + static_cast<std::size_t>(k), "a camera param"));
    if (cameras.count(camera.id)) file.fail("camera id " + std::to_string(camera.id) + " appears twice");
    cameras.emplace(camera.id, std::move(camera));
  }
  return cameras;
}

inline std::map<std::uint32_t, ColmapImage> read_colmap_images_text(const std::string& path) {
  return detail::read_images(path, nullptr);
}

inline std::map<std::uint64_t, ColmapPoint3D> read_colmap_points3d_text(const std::string& path) {
  return detail::read_points3d(path, nullptr);
}

inline ColmapModel read_colmap_text(const std::string& directory) {
  ColmapModel model;
  detail::ColmapCheckContext context;
  context.images_path = directory + "/images.txt";
  context.points_path = directory + "/points3D.txt";
  std::map<std::uint32_t, detail::ColmapImageLines> image_lines;
  std::map<std::uint64_t, int> point_lines;
  model.cameras = read_colmap_cameras_text(directory + "/cameras.txt");
  model.images = detail::read_images(context.images_path, &image_lines);
  model.points3d = detail::read_points3d(context.points_path, &point_lines);
  context.image_lines = &image_lines;
  context.point_lines = &point_lines;
  detail::check_colmap_model(model, &context);
  return model;
}

inline void write_colmap_text(const ColmapModel& model, const std::string& directory) {
  DIACHRON_CHECK(!directory.empty(), "write_colmap_text: empty folder name");
  model.check();
  make_folder(directory, "write_colmap_text");
  {
    const std::string path = directory + "/cameras.txt";
    std::ofstream out = detail::open_colmap_output(path);
    out << "# Camera list with one line of data per camera:\n"
        << "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
        << "# Number of cameras: " << model.cameras.size() << '\n';
    for (const auto& [id, camera] : model.cameras) {
      out << id << ' ' << camera.model << ' ' << camera.width << ' ' << camera.height;
      for (double p : camera.params) out << ' ' << p;
      out << '\n';
    }
    detail::close_colmap_output(out, path);
  }
  {
    const std::string path = directory + "/images.txt";
    std::ofstream out = detail::open_colmap_output(path);
    std::size_t observations = 0;
    for (const auto& entry : model.images)
      for (const ColmapPoint2D& p : entry.second.points2d) observations += p.point3d_id != kColmapNoPoint3D;
    out << "# Image list with two lines of data per image:\n"
        << "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
        << "#   POINTS2D[] as (X, Y, POINT3D_ID)\n"
        << "# Number of images: " << model.images.size() << ", mean observations per image: "
        << (model.images.empty() ? 0.0 : static_cast<double>(observations) / static_cast<double>(model.images.size()))
        << '\n';
    for (const auto& [id, image] : model.images) {
      DIACHRON_CHECK(!image.name.empty() && image.name.find_first_of(" \t\r\n") == std::string::npos,
                     "write_colmap_text: image " << id << " has an empty name or one with white space: '"
                                                 << image.name << "'");
      const Eigen::Vector4d q = detail::colmap_qvec(image.pose);
      const Vec3 t = image.pose.cam_from_world_translation();
      out << id << ' ' << q[0] << ' ' << q[1] << ' ' << q[2] << ' ' << q[3] << ' ' << t.x() << ' ' << t.y() << ' '
          << t.z() << ' ' << image.camera_id << ' ' << image.name << '\n';
      for (std::size_t k = 0; k < image.points2d.size(); ++k) {
        const ColmapPoint2D& p = image.points2d[k];
        DIACHRON_CHECK(p.xy.allFinite(), "write_colmap_text: 2D point " << k << " of image " << id << " is not finite");
        out << (k ? " " : "") << p.xy.x() << ' ' << p.xy.y() << ' ' << p.point3d_id;
      }
      out << '\n';
    }
    detail::close_colmap_output(out, path);
  }
  {
    const std::string path = directory + "/points3D.txt";
    std::ofstream out = detail::open_colmap_output(path);
    std::size_t elements = 0;
    for (const auto& entry : model.points3d) elements += entry.second.track.size();
    out << "# 3D point list with one line of data per point:\n"
        << "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n"
        << "# Number of points: " << model.points3d.size() << ", mean track length: "
        << (model.points3d.empty() ? 0.0 : static_cast<double>(elements) / static_cast<double>(model.points3d.size()))
        << '\n';
    for (const auto& [id, p] : model.points3d) {
      DIACHRON_CHECK(p.xyz.allFinite() && std::isfinite(p.error),
                     "write_colmap_text: point3D " << id << " has a non-finite position or error");
      out << id << ' ' << p.xyz.x() << ' ' << p.xyz.y() << ' ' << p.xyz.z() << ' ' << int{p.rgb[0]} << ' '
          << int{p.rgb[1]} << ' ' << int{p.rgb[2]} << ' ' << p.error;
      for (const ColmapTrackElement& e : p.track) out << ' ' << e.image_id << ' ' << e.point2d_index;
      out << '\n';
    }
    detail::close_colmap_output(out, path);
  }
}

inline ConversionResult<Camera<FraserAffine>> camera_from_colmap(const ColmapCamera& colmap,
                                                                 const ConversionOptions& options) {
  const std::optional<int> n = colmap_camera_model_num_params(colmap.model);
  DIACHRON_CHECK(n && static_cast<std::size_t>(*n) == colmap.params.size(),
                 "camera_from_colmap: camera " << colmap.id << " of model '" << colmap.model << "' has "
                                               << colmap.params.size() << " params");
  const std::vector<double>& p = colmap.params;
  if (colmap.model == ColmapFullOpenCv::kModelName)
    return camera_from_colmap(ColmapFullOpenCv::from_params(colmap.width, colmap.height, p), options);
  // Every other supported model is OPENCV with some params fixed at 0 (and fx = fy for the SIMPLE_ ones).
  std::vector<double> opencv;
  if (colmap.model == "SIMPLE_PINHOLE") {
    opencv = {p[0], p[0], p[1], p[2], 0.0, 0.0, 0.0, 0.0};
  } else if (colmap.model == "PINHOLE") {
    opencv = {p[0], p[1], p[2], p[3], 0.0, 0.0, 0.0, 0.0};
  } else if (colmap.model == "SIMPLE_RADIAL") {
    opencv = {p[0], p[0], p[1], p[2], p[3], 0.0, 0.0, 0.0};
  } else if (colmap.model == "RADIAL") {
    opencv = {p[0], p[0], p[1], p[2], p[3], p[4], 0.0, 0.0};
  } else if (colmap.model == ColmapOpenCv::kModelName) {
    opencv = p;
  } else {
    throw Error("diachron: camera_from_colmap: COLMAP camera model '" + colmap.model + "' (camera " +
                std::to_string(colmap.id) +
                ") has no diachron counterpart; supported: SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV, "
                "FULL_OPENCV");
  }
  return camera_from_colmap(ColmapOpenCv::from_params(colmap.width, colmap.height, opencv), options);
}

template <class Distortion>
ConversionResult<ColmapCamera> colmap_camera_from_camera(const Camera<Distortion>& camera, std::uint32_t camera_id,
                                                         const ConversionOptions& options) {
  const Camera<FraserAffine> fraser = as_fraser_affine(camera);
  ConversionResult<ColmapCamera> out;
  out.model.id = camera_id;
  out.model.width = camera.width();
  out.model.height = camera.height();
  // OPENCV holds the camera when K3 and the shear B2 are zero; FULL_OPENCV otherwise.
  const auto take = [&out](const auto& r, const char* name) {
    out.model.model = name;
    out.model.params = r.model.params();
    out.exact = r.exact;
    out.max_error_px = r.max_error_px;
    out.rms_error_px = r.rms_error_px;
    out.num_samples = r.num_samples;
  };
  if (fraser.params()[2] == 0.0 && fraser.params()[6] == 0.0)
    take(colmap_opencv_from_camera(fraser, options), ColmapOpenCv::kModelName);
  else
    take(colmap_full_opencv_from_camera(fraser, options), ColmapFullOpenCv::kModelName);
  return out;
}

}  // namespace diachron
