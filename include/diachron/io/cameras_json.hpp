#pragma once
/// @file
/// cameras.json: the adjusted orientation of every image with the exact Fraser + affine camera,
/// which no COLMAP camera model holds (docs/adjusted-export.md). Standard library and Eigen only.
/// @code
/// {
///   "images": [
///     {"name": "e1_r0_c0", "epoch": "e1",
///      "camera": {"model": "fraser_affine", "width": 1600, "height": 1200, "f": 1056.2, "cx": 799.5,
///                 "cy": 599.5, "k1": -0.05, "k2": 0.01, "k3": 0, "p1": 1e-4, "p2": -2e-4,
///                 "b1": 0.8, "b2": -0.3},
///      "pose": {"R": [[r00, r01, r02], [r10, r11, r12], [r20, r21, r22]], "C": [x, y, z]}},
///     ...
///   ]
/// }
/// @endcode
/// Camera: diachron's Fraser + affine (docs/conventions.md): normalised x = X/Z, y = Y/Z of the
/// camera frame (x right, y down, z forward), r^2 = x^2 + y^2,
///   x' = x (1 + k1 r^2 + k2 r^4 + k3 r^6) + p1 (r^2 + 2 x^2) + 2 p2 x y,
///   y' = y (1 + k1 r^2 + k2 r^4 + k3 r^6) + p2 (r^2 + 2 y^2) + 2 p1 x y,
///   u = cx + f x' + b1 x' + b2 y',  v = cy + f y';
/// f, cx, cy, b1, b2, width, height in pixels, (0, 0) the centre of the top-left pixel; k and p
/// dimensionless. Pose: R world-to-camera (rows = camera axes in the world frame), C the projection
/// centre in the world (epoch) frame, X_cam = R (X - C). Doubles are written with 17 significant
/// digits, so a file read back gives the same numbers.

#include <cmath>
#include <cstddef>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/LU>

#include <diachron/camera/camera.hpp>
#include <diachron/camera/distortion.hpp>
#include <diachron/camera/frame.hpp>
#include <diachron/camera/pose.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/types.hpp>
#include <diachron/io/json.hpp>

namespace diachron {

/// The value of "model" in cameras.json.
inline constexpr const char* kCamerasJsonModel = "fraser_affine";

/// One image of cameras.json. `rotation` and `centre` are kept as the file holds them (Pose would
/// re-orthonormalise R, changing the last bits), so a file read back compares equal to its source.
struct CamerasJsonImage {
  std::string name;   ///< image name (as in the COLMAP model, e.g. "e1_r0_c0")
  std::string epoch;  ///< epoch name (e.g. "e1"); the COLMAP model is DIR/adjusted/<epoch>/
  Camera<FraserAffine> camera{1.0, 0.0, 0.0, 1, 1};
  Mat3 rotation = Mat3::Identity();  ///< R, world -> camera
  Vec3 centre = Vec3::Zero();        ///< C, world (epoch) frame units

  /// The pose X_cam = R (X - C). Throws diachron::Error when R is not a rotation.
  Pose pose() const { return Pose(rotation, centre); }
  /// The oriented image.
  Frame<FraserAffine> frame() const { return Frame<FraserAffine>(camera, pose()); }

  /// An entry of a frame with any built-in distortion policy (held as Fraser + affine).
  template <class Distortion>
  static CamerasJsonImage from_frame(std::string name, std::string epoch, const Frame<Distortion>& frame) {
    CamerasJsonImage out;
    out.name = std::move(name);
    out.epoch = std::move(epoch);
    out.camera = as_fraser_affine(frame.camera());
    out.rotation = frame.pose().cam_from_world_rotation();
    out.centre = frame.pose().centre();
    return out;
  }
};

/// The text of cameras.json for `images` (see the file comment), one image per line group.
/// Precondition: non-empty names and epochs, finite R and C; else throws diachron::Error.
inline std::string cameras_json(const std::vector<CamerasJsonImage>& images);

/// Writes cameras_json(images) to `path` (replacing it). Throws diachron::Error naming the file
/// when it cannot be written.
inline void write_cameras_json(const std::vector<CamerasJsonImage>& images, const std::string& path);

/// Parses the text of a cameras.json; `where` names it in messages (a path).
/// Throws diachron::Error "<where>: images[i].camera.k1: ..." for a missing key, a value of the
/// wrong type, a non-finite number (e.g. 1e999), a model other than "fraser_affine", an invalid
/// camera (f <= 0, size <= 0) or an R that is not a rotation (1e-6 per entry), and names the
/// line and column of text that is not JSON. Unknown keys are ignored (room for later additions).
inline std::vector<CamerasJsonImage> parse_cameras_json(const std::string& text, const std::string& where);

/// Reads the cameras.json at `path` (parse_cameras_json() naming the file).
inline std::vector<CamerasJsonImage> read_cameras_json(const std::string& path);

// Implementation ----------------------------------------------------------------------------------

namespace detail {

// The key names of FraserAffine's params in cameras.json, in the policy's order [K1 K2 K3 P1 P2 B1 B2].
inline constexpr const char* kCamerasJsonParams[] = {"k1", "k2", "k3", "p1", "p2", "b1", "b2"};

class CamerasJsonReader {
 public:
  explicit CamerasJsonReader(const std::string& where) : where_(where) {}

  [[noreturn]] void fail(const std::string& key, const std::string& what) const {
    throw Error("diachron: " + where_ + ": " + key + ": " + what);
  }

  const JsonValue& member(const JsonValue& object, const std::string& path, const char* key) const {
    const JsonValue* v = object.find(key);
    if (!v) fail(path.empty() ? std::string(key) : path + "." + key, "missing");
    return *v;
  }

  const JsonValue& typed(const JsonValue& v, const std::string& key, JsonValue::Type type) const {
    if (v.type != type)
      fail(key, std::string("is of type ") + json_type_name(v.type) + ", expected " + json_type_name(type));
    return v;
  }

  double number(const JsonValue& v, const std::string& key) const {
    typed(v, key, JsonValue::Type::number);
    if (!std::isfinite(v.number)) fail(key, "is not a finite number");
    return v.number;
  }

  double number_member(const JsonValue& object, const std::string& path, const char* key) const {
    return number(member(object, path, key), path + "." + key);
  }

  int size_member(const JsonValue& object, const std::string& path, const char* key) const {
    const double v = number_member(object, path, key);
    if (!(v >= 1.0 && v <= 1e9 && v == std::floor(v))) fail(path + "." + key, "must be a positive integer (px)");
    return static_cast<int>(v);
  }

  std::string string_member(const JsonValue& object, const std::string& path, const char* key) const {
    const std::string k = path + "." + key;
    const std::string& s = typed(member(object, path, key), k, JsonValue::Type::string).string;
    if (s.empty()) fail(k, "is empty");
    return s;
  }

  // An array of `n` finite numbers (or, with `rows`, of `rows` arrays of n / rows).
  std::vector<double> numbers(const JsonValue& v, const std::string& key, std::size_t n, std::size_t rows) const {
    typed(v, key, JsonValue::Type::array);
    std::vector<double> out;
    if (rows == 1) {
      if (v.array.size() != n) fail(key, "needs " + std::to_string(n) + " numbers, has " + std::to_string(v.array.size()));
      for (std::size_t i = 0; i < n; ++i) out.push_back(number(v.array[i], key + "[" + std::to_string(i) + "]"));
      return out;
    }
    if (v.array.size() != rows)
      fail(key, "needs " + std::to_string(rows) + " rows, has " + std::to_string(v.array.size()));
    for (std::size_t r = 0; r < rows; ++r) {
      const std::vector<double> row = numbers(v.array[r], key + "[" + std::to_string(r) + "]", n / rows, 1);
      out.insert(out.end(), row.begin(), row.end());
    }
    return out;
  }

  CamerasJsonImage image(const JsonValue& v, const std::string& path) const {
    typed(v, path, JsonValue::Type::object);
    CamerasJsonImage out;
    out.name = string_member(v, path, "name");
    out.epoch = string_member(v, path, "epoch");

    const std::string cpath = path + ".camera";
    const JsonValue& c = typed(member(v, path, "camera"), cpath, JsonValue::Type::object);
    const std::string model = string_member(c, cpath, "model");
    if (model != kCamerasJsonModel)
      fail(cpath + ".model", "is \"" + model + "\", expected \"" + kCamerasJsonModel + "\"");
    const int width = size_member(c, cpath, "width");
    const int height = size_member(c, cpath, "height");
    const double f = number_member(c, cpath, "f");
    const double cx = number_member(c, cpath, "cx");
    const double cy = number_member(c, cpath, "cy");
    Camera<FraserAffine>::Params params{};
    for (std::size_t i = 0; i < params.size(); ++i) params[i] = number_member(c, cpath, kCamerasJsonParams[i]);
    try {
      out.camera = Camera<FraserAffine>(f, cx, cy, width, height, params);
    } catch (const Error& e) {
      fail(cpath, std::string("is not a valid camera: ") + e.what());
    }

    const std::string ppath = path + ".pose";
    const JsonValue& p = typed(member(v, path, "pose"), ppath, JsonValue::Type::object);
    const std::vector<double> r = numbers(member(p, ppath, "R"), ppath + ".R", 9, 3);
    const std::vector<double> centre = numbers(member(p, ppath, "C"), ppath + ".C", 3, 1);
    for (int i = 0; i < 9; ++i) out.rotation(i / 3, i % 3) = r[static_cast<std::size_t>(i)];
    out.centre = Vec3(centre[0], centre[1], centre[2]);
    const double error = (out.rotation.transpose() * out.rotation - Mat3::Identity()).cwiseAbs().maxCoeff();
    if (!(error <= 1e-6 && out.rotation.determinant() > 0.0)) {
      std::ostringstream what;
      what << "is not a rotation (|R^T R - I|max = " << error << ", det = " << out.rotation.determinant() << ")";
      fail(ppath + ".R", what.str());
    }
    return out;
  }

 private:
  const std::string& where_;
};

}  // namespace detail

inline std::string cameras_json(const std::vector<CamerasJsonImage>& images) {
  std::string out = "{\n  \"images\": [";
  for (std::size_t i = 0; i < images.size(); ++i) {
    const CamerasJsonImage& im = images[i];
    DIACHRON_CHECK(!im.name.empty() && !im.epoch.empty(), "cameras_json: image " << i << " has an empty name or epoch");
    DIACHRON_CHECK(im.rotation.allFinite() && im.centre.allFinite(),
                   "cameras_json: image " << i << " ('" << im.name << "') has a non-finite pose");
    const Camera<FraserAffine>& c = im.camera;
    out += i ? ",\n    {" : "\n    {";
    out += "\"name\": " + json_quoted(im.name) + ", \"epoch\": " + json_quoted(im.epoch) + ",\n     ";
    out += "\"camera\": {\"model\": " + json_quoted(kCamerasJsonModel) + ", \"width\": " + std::to_string(c.width()) +
           ", \"height\": " + std::to_string(c.height()) + ", \"f\": " + json_number(c.focal()) +
           ", \"cx\": " + json_number(c.cx()) + ", \"cy\": " + json_number(c.cy());
    for (std::size_t k = 0; k < c.params().size(); ++k)
      out += std::string(", \"") + detail::kCamerasJsonParams[k] + "\": " + json_number(c.params()[k]);
    out += "},\n     \"pose\": {\"R\": [";
    for (int r = 0; r < 3; ++r)
      out += std::string(r ? ", " : "") + "[" + json_number(im.rotation(r, 0)) + ", " + json_number(im.rotation(r, 1)) +
             ", " + json_number(im.rotation(r, 2)) + "]";
    out += "], \"C\": [" + json_number(im.centre.x()) + ", " + json_number(im.centre.y()) + ", " +
           json_number(im.centre.z()) + "]}}";
  }
  out += images.empty() ? "]\n}\n" : "\n  ]\n}\n";
  return out;
}

inline void write_cameras_json(const std::vector<CamerasJsonImage>& images, const std::string& path) {
  const std::string text = cameras_json(images);  // checks before the file is touched
  std::ofstream out(path);
  DIACHRON_CHECK(out.good(), "cannot write '" << path << "': the file cannot be created");
  out << text;
  out.close();
  DIACHRON_CHECK(!out.fail(), "cannot write '" << path << "': write failed");
}

inline std::vector<CamerasJsonImage> parse_cameras_json(const std::string& text, const std::string& where) {
  const JsonValue root = parse_json(text, where);
  const detail::CamerasJsonReader reader(where);
  reader.typed(root, "the top level", JsonValue::Type::object);
  const JsonValue& images = reader.typed(reader.member(root, "", "images"), "images", JsonValue::Type::array);
  std::vector<CamerasJsonImage> out;
  out.reserve(images.array.size());
  for (std::size_t i = 0; i < images.array.size(); ++i)
    out.push_back(reader.image(images.array[i], "images[" + std::to_string(i) + "]"));
  return out;
}

inline std::vector<CamerasJsonImage> read_cameras_json(const std::string& path) {
  std::ifstream in(path);
  DIACHRON_CHECK(in.good(), "cannot read '" << path << "': the file cannot be opened");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return parse_cameras_json(text, "'" + path + "'");
}

}  // namespace diachron
