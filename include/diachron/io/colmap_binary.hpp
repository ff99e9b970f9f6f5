#pragma once
/// @file
/// COLMAP binary models (cameras.bin, images.bin, points3D.bin, COLMAP 3.8's layout, little endian)
/// read into and written from the ColmapModel of io/colmap_text.hpp, with the same conventions
/// (COLMAP pixels, a diachron Pose, params in COLMAP's order) and the same checks as the text
/// reader. Every malformed or truncated file is a diachron::Error naming the file, the byte offset
/// and the record. Needs the standard library and Eigen only (no GDAL, despite living in io/).
///
/// Layout (COLMAP 3.8, src/base/reconstruction.cc; all integers and doubles little endian):
/// ```
/// cameras.bin   u64 count, then per camera: u32 id, i32 model_id, u64 width, u64 height,
///               f64 params[n(model)]
/// images.bin    u64 count, then per image: u32 id, f64 qw qx qy qz tx ty tz, u32 camera_id,
///               name (bytes up to a '\0'), u64 num_points2D, then per point: f64 x, f64 y,
///               u64 point3D_id (2^64 - 1: no 3D point)
/// points3D.bin  u64 count, then per point: u64 id, f64 x y z, u8 r g b, f64 error,
///               u64 track_length, then per element: u32 image_id, u32 point2D_idx
/// ```

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <diachron/camera/pose.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/types.hpp>
#include <diachron/io/colmap_text.hpp>
#include <diachron/io/folders.hpp>

namespace diachron {

/// COLMAP's id of a camera model (its `CameraModelId`, the i32 of cameras.bin): SIMPLE_PINHOLE 0,
/// PINHOLE 1, SIMPLE_RADIAL 2, RADIAL 3, OPENCV 4, OPENCV_FISHEYE 5, FULL_OPENCV 6, FOV 7,
/// SIMPLE_RADIAL_FISHEYE 8, RADIAL_FISHEYE 9, THIN_PRISM_FISHEYE 10; nullopt for another name.
inline std::optional<int> colmap_camera_model_id(std::string_view model);

/// COLMAP's name of camera model id `model_id` (the inverse of colmap_camera_model_id()), nullopt
/// for an id COLMAP 3.8 does not have.
inline std::optional<std::string_view> colmap_camera_model_name(int model_id);

/// Reads the binary model in `directory` (cameras.bin, images.bin, points3D.bin) and checks that its
/// tables agree, as read_colmap_text() does. Throws diachron::Error naming the file, the byte offset
/// and the record for a missing or truncated file, a count that the file cannot hold, bytes after
/// the last record, an unknown camera model id, a size outside [1, INT_MAX], a number that is not
/// finite, an id out of range or given twice, a zero quaternion, an empty or unterminated name,
/// and a broken cross-reference (an image of an unknown camera, a track element whose image or 2D
/// point does not exist or observes another point, a 2D point that names a 3D point whose track
/// does not contain it).
inline ColmapModel read_colmap_binary(const std::string& directory);

/// Writes `model` as cameras.bin, images.bin and points3D.bin into `directory` (created if needed,
/// not its parents), byte for byte as COLMAP 3.8 lays them out (tables in id order). The other files
/// of the folder (a text model beside it) are left alone. Throws diachron::Error when the model is
/// inconsistent (ColmapModel::check()), holds a number that is not finite, an image name that is
/// empty or holds a '\0', or a file cannot be written.
inline void write_colmap_binary(const ColmapModel& model, const std::string& directory);

// Implementation ----------------------------------------------------------------------------------

namespace detail {

inline constexpr std::array<std::string_view, 11> kColmapModelNames = {
    "SIMPLE_PINHOLE", "PINHOLE",        "SIMPLE_RADIAL",         "RADIAL",         "OPENCV",           "OPENCV_FISHEYE",
    "FULL_OPENCV",    "FOV",            "SIMPLE_RADIAL_FISHEYE", "RADIAL_FISHEYE", "THIN_PRISM_FISHEYE"};

// COLMAP writes the id 2^64 - 1 (kInvalidPoint3DId) for a 2D point without a 3D point.
inline constexpr std::uint64_t kColmapBinaryNoPoint3D = std::numeric_limits<std::uint64_t>::max();

// One binary file read front to back. Every read names the file, the offset where the value
// starts and the record being read (set_record), so that a truncated or corrupt file says where.
class ColmapBinaryFile {
 public:
  explicit ColmapBinaryFile(std::string path) : path_(std::move(path)), in_(path_, std::ios::binary) {
    if (!in_.good()) throw Error("diachron: cannot read '" + path_ + "': the file cannot be opened");
    in_.seekg(0, std::ios::end);
    const std::streamoff end = in_.tellg();
    in_.seekg(0, std::ios::beg);
    if (end < 0 || !in_.good()) throw Error("diachron: cannot read '" + path_ + "': its size cannot be known");
    size_ = static_cast<std::uint64_t>(end);
  }

  const std::string& path() const { return path_; }
  std::uint64_t offset() const { return offset_; }
  void set_record(std::string record) { record_ = std::move(record); }

  [[noreturn]] void fail_at(std::uint64_t offset, const std::string& message) const {
    throw Error("diachron: '" + path_ + "' byte " + std::to_string(offset) + (record_.empty() ? "" : ", " + record_) +
                ": " + message);
  }

  std::uint64_t u64(const char* what) { return unsigned_value<8>(what); }
  std::uint32_t u32(const char* what) { return static_cast<std::uint32_t>(unsigned_value<4>(what)); }
  std::uint8_t u8(const char* what) { return static_cast<std::uint8_t>(unsigned_value<1>(what)); }
  std::int32_t i32(const char* what) {
    const auto bits = static_cast<std::uint32_t>(unsigned_value<4>(what));
    std::int32_t value = 0;
    std::memcpy(&value, &bits, sizeof value);  // two's complement, as COLMAP wrote it
    return value;
  }
  double f64(const char* what) {
    const std::uint64_t start = offset_;
    const std::uint64_t bits = unsigned_value<8>(what);
    double value = 0.0;
    std::memcpy(&value, &bits, sizeof value);
    if (!std::isfinite(value)) fail_at(start, std::string(what) + " is not a finite number");
    return value;
  }

  // An id that fits COLMAP's 32-bit ids but is not their "invalid" value (2^32 - 1).
  std::uint32_t id32(const char* what) {
    const std::uint64_t start = offset_;
    const std::uint32_t id = u32(what);
    if (id == std::numeric_limits<std::uint32_t>::max())
      fail_at(start, std::string(what) + " " + std::to_string(id) + " is COLMAP's invalid id");
    return id;
  }

  // A count of records of at least `min_bytes` each: more than the rest of the file can hold is a
  // corrupt count, refused before anything is allocated for it.
  std::uint64_t count(const char* what, std::uint64_t min_bytes) {
    const std::uint64_t start = offset_;
    const std::uint64_t n = u64(what);
    if (n > (size_ - offset_) / min_bytes)
      fail_at(start, std::string(what) + " " + std::to_string(n) + " needs at least " + std::to_string(min_bytes) +
                         " bytes each, but only " + std::to_string(size_ - offset_) + " bytes follow");
    return n;
  }

  // A name: bytes up to a '\0'.
  std::string name(const char* what) {
    const std::uint64_t start = offset_;
    std::string out;
    for (;;) {
      char c = 0;
      if (!in_.get(c))
        fail_at(start, std::string("truncated: ") + what + " has no terminating '\\0' before the end of the file");
      ++offset_;
      if (c == '\0') break;
      out.push_back(c);
    }
    if (out.empty()) fail_at(start, std::string(what) + " is empty");
    return out;
  }

  // After the last record: a longer file is not what its counts say.
  void finish() const {
    if (offset_ != size_)
      fail_at(offset_, std::to_string(size_ - offset_) + " bytes follow the last record (a wrong count?)");
  }

 private:
  template <int N>
  std::uint64_t unsigned_value(const char* what) {
    std::array<unsigned char, N> bytes{};
    in_.read(reinterpret_cast<char*>(bytes.data()), N);
    if (in_.gcount() != N)
      fail_at(offset_, std::string("truncated: ") + what + " needs " + std::to_string(N) +
                           " bytes, the file ends at byte " + std::to_string(size_));
    offset_ += N;
    // Assembled byte by byte: the file is little endian whatever the machine is.
    std::uint64_t value = 0;
    for (int k = N - 1; k >= 0; --k) value = (value << 8) | bytes[static_cast<std::size_t>(k)];
    return value;
  }

  std::string path_;
  std::ifstream in_;
  std::uint64_t size_ = 0;
  std::uint64_t offset_ = 0;
  std::string record_;
};

// One binary file written front to back, little endian whatever the machine is.
class ColmapBinaryOutput {
 public:
  explicit ColmapBinaryOutput(std::string path)
      : path_(std::move(path)), out_(path_, std::ios::binary | std::ios::trunc) {
    DIACHRON_CHECK(out_.good(), "cannot write '" << path_ << "': the file cannot be created");
  }
  void u64(std::uint64_t v) { put<8>(v); }
  void u32(std::uint32_t v) { put<4>(v); }
  void u8(std::uint8_t v) { put<1>(v); }
  void i32(std::int32_t v) {
    std::uint32_t bits = 0;
    std::memcpy(&bits, &v, sizeof bits);
    put<4>(bits);
  }
  void f64(double v) {
    std::uint64_t bits = 0;
    std::memcpy(&bits, &v, sizeof bits);
    put<8>(bits);
  }
  void name(const std::string& s) { out_.write(s.c_str(), static_cast<std::streamsize>(s.size() + 1)); }
  void close() {
    out_.close();
    DIACHRON_CHECK(!out_.fail(), "cannot write '" << path_ << "': write failed");
  }

 private:
  template <int N>
  void put(std::uint64_t v) {
    std::array<char, N> bytes{};
    for (int k = 0; k < N; ++k) bytes[static_cast<std::size_t>(k)] = static_cast<char>((v >> (8 * k)) & 0xffu);
    out_.write(bytes.data(), N);
  }

  std::string path_;
  std::ofstream out_;
};

// Where each record of a binary model starts, for the cross-reference errors.
struct ColmapBinaryOffsets {
  std::map<std::uint32_t, std::uint64_t> image_record, image_points;  // the image's id, its num_points2D
  std::map<std::uint64_t, std::uint64_t> point_record;
};

inline std::map<std::uint32_t, ColmapCamera> read_cameras_binary(const std::string& path) {
  ColmapBinaryFile file(path);
  std::map<std::uint32_t, ColmapCamera> cameras;
  // The smallest camera: SIMPLE_PINHOLE, 4 + 4 + 8 + 8 + 3 x 8 bytes.
  const std::uint64_t n = file.count("the number of cameras", 48);
  for (std::uint64_t r = 0; r < n; ++r) {
    const std::uint64_t start = file.offset();
    file.set_record("camera record " + std::to_string(r + 1) + " of " + std::to_string(n));
    ColmapCamera camera;
    camera.id = file.id32("the camera id");
    file.set_record("camera record " + std::to_string(r + 1) + " of " + std::to_string(n) + " (id " +
                    std::to_string(camera.id) + ")");
    const std::uint64_t model_at = file.offset();
    const std::int32_t model_id = file.i32("the camera model id");
    const std::optional<std::string_view> name = colmap_camera_model_name(model_id);
    if (!name)
      file.fail_at(model_at, "unknown camera model id " + std::to_string(model_id) + " (COLMAP 3.8 has 0 to 10)");
    camera.model = std::string(*name);
    for (int* side : {&camera.width, &camera.height}) {
      const std::uint64_t at = file.offset();
      const char* what = side == &camera.width ? "the width" : "the height";
      const std::uint64_t v = file.u64(what);
      if (v < 1 || v > static_cast<std::uint64_t>(std::numeric_limits<int>::max()))
        file.fail_at(at, std::string(what) + " " + std::to_string(v) + " is outside [1, " +
                             std::to_string(std::numeric_limits<int>::max()) + "]");
      *side = static_cast<int>(v);
    }
    const int num_params = *colmap_camera_model_num_params(camera.model);
    for (int k = 0; k < num_params; ++k) camera.params.push_back(file.f64("a camera param"));
    if (cameras.count(camera.id)) file.fail_at(start, "camera id " + std::to_string(camera.id) + " appears twice");
    cameras.emplace(camera.id, std::move(camera));
  }
  file.set_record("");
  file.finish();
  return cameras;
}

inline std::map<std::uint32_t, ColmapImage> read_images_binary(const std::string& path, ColmapBinaryOffsets& offsets) {
  ColmapBinaryFile file(path);
  std::map<std::uint32_t, ColmapImage> images;
  // The smallest image: id, 7 doubles, camera id, a one-letter name and its '\0', no 2D point.
  const std::uint64_t n = file.count("the number of images", 4 + 56 + 4 + 2 + 8);
  for (std::uint64_t r = 0; r < n; ++r) {
    const std::uint64_t start = file.offset();
    const std::string record = "image record " + std::to_string(r + 1) + " of " + std::to_string(n);
    file.set_record(record);
    ColmapImage image;
    image.id = file.id32("the image id");
    file.set_record(record + " (id " + std::to_string(image.id) + ")");
    if (images.count(image.id)) file.fail_at(start, "image id " + std::to_string(image.id) + " appears twice");
    const std::uint64_t q_at = file.offset();
    const double qw = file.f64("QW"), qx = file.f64("QX"), qy = file.f64("QY"), qz = file.f64("QZ");
    const Eigen::Quaterniond q(qw, qx, qy, qz);
    const double tx = file.f64("TX"), ty = file.f64("TY"), tz = file.f64("TZ");
    if (!(q.norm() > 1e-12)) file.fail_at(q_at, "the quaternion QW QX QY QZ is zero");
    image.pose = Pose::from_cam_from_world(q.normalized().toRotationMatrix(), Vec3(tx, ty, tz));
    image.camera_id = file.id32("the camera id");
    image.name = file.name("the image name");
    offsets.image_record[image.id] = start;
    offsets.image_points[image.id] = file.offset();
    const std::uint64_t num_points = file.count("num_points2D", 24);
    image.points2d.resize(static_cast<std::size_t>(num_points));
    for (ColmapPoint2D& p : image.points2d) {
      const double x = file.f64("a 2D point's X"), y = file.f64("a 2D point's Y");
      p.xy = Vec2(x, y);
      const std::uint64_t id_at = file.offset();
      const std::uint64_t id = file.u64("a 2D point's point3D id");
      if (id == kColmapBinaryNoPoint3D) {
        p.point3d_id = kColmapNoPoint3D;
      } else if (id > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max())) {
        file.fail_at(id_at, "a 2D point's point3D id " + std::to_string(id) + " is out of range");
      } else {
        p.point3d_id = static_cast<std::int64_t>(id);
      }
    }
    images.emplace(image.id, std::move(image));
  }
  file.set_record("");
  file.finish();
  return images;
}

inline std::map<std::uint64_t, ColmapPoint3D> read_points3d_binary(const std::string& path,
                                                                  ColmapBinaryOffsets& offsets) {
  ColmapBinaryFile file(path);
  std::map<std::uint64_t, ColmapPoint3D> points;
  // The smallest point: id, xyz, rgb, error, an empty track.
  const std::uint64_t n = file.count("the number of points3D", 8 + 24 + 3 + 8 + 8);
  for (std::uint64_t r = 0; r < n; ++r) {
    const std::uint64_t start = file.offset();
    const std::string record = "point3D record " + std::to_string(r + 1) + " of " + std::to_string(n);
    file.set_record(record);
    ColmapPoint3D p;
    p.id = file.u64("the point3D id");
    // 2D points name their 3D point with a signed 64-bit id (kColmapNoPoint3D = -1).
    if (p.id > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max()))
      file.fail_at(start, "the point3D id " + std::to_string(p.id) + " is out of range");
    file.set_record(record + " (id " + std::to_string(p.id) + ")");
    if (points.count(p.id)) file.fail_at(start, "point3D id " + std::to_string(p.id) + " appears twice");
    const double x = file.f64("X"), y = file.f64("Y"), z = file.f64("Z");
    p.xyz = Vec3(x, y, z);
    for (std::uint8_t& c : p.rgb) c = file.u8("a colour component");
    p.error = file.f64("ERROR");
    const std::uint64_t length = file.count("the track length", 8);
    p.track.resize(static_cast<std::size_t>(length));
    for (ColmapTrackElement& e : p.track) {
      e.image_id = file.id32("a track's IMAGE_ID");
      e.point2d_index = file.u32("a track's POINT2D_IDX");
    }
    offsets.point_record[p.id] = start;
    points.emplace(p.id, std::move(p));
  }
  file.set_record("");
  file.finish();
  return points;
}

// The cross-references read_colmap_text() checks (check_colmap_model), each error naming the file
// and the offset of the record at fault.
inline void check_colmap_binary_model(const ColmapModel& model, const std::string& directory,
                                      const ColmapBinaryOffsets& offsets) {
  const auto fail = [&](const char* file, std::uint64_t offset, const std::string& message) {
    throw Error("diachron: '" + directory + "/" + file + "' byte " + std::to_string(offset) + ": " + message);
  };
  for (const auto& [id, image] : model.images)
    if (!model.cameras.count(image.camera_id))
      fail("images.bin", offsets.image_record.at(id),
           "image " + std::to_string(id) + " refers to camera " + std::to_string(image.camera_id) +
               ", which cameras.bin does not have");
  std::set<std::pair<std::uint32_t, std::uint32_t>> observed;
  for (const auto& [pid, point] : model.points3d) {
    const std::uint64_t at = offsets.point_record.at(pid);
    for (const ColmapTrackElement& e : point.track) {
      const std::string element = "track element (" + std::to_string(e.image_id) + ", " +
                                  std::to_string(e.point2d_index) + ") of point3D " + std::to_string(pid);
      const auto image = model.images.find(e.image_id);
      if (image == model.images.end()) fail("points3D.bin", at, element + ": no image " + std::to_string(e.image_id));
      if (e.point2d_index >= image->second.points2d.size())
        fail("points3D.bin", at,
             element + ": image " + std::to_string(e.image_id) + " has " +
                 std::to_string(image->second.points2d.size()) + " 2D points");
      const std::int64_t named = image->second.points2d[e.point2d_index].point3d_id;
      if (named != static_cast<std::int64_t>(pid))
        fail("points3D.bin", at, element + ": that 2D point observes point3D " + std::to_string(named));
      if (!observed.emplace(e.image_id, e.point2d_index).second) fail("points3D.bin", at, element + " appears twice");
    }
  }
  for (const auto& [id, image] : model.images)
    for (std::size_t k = 0; k < image.points2d.size(); ++k) {
      const std::int64_t p = image.points2d[k].point3d_id;
      if (p != kColmapNoPoint3D && !observed.count({id, static_cast<std::uint32_t>(k)}))
        fail("images.bin", offsets.image_points.at(id),
             "2D point " + std::to_string(k) + " of image " + std::to_string(id) + " observes point3D " +
                 std::to_string(p) + ", whose track does not contain it");
    }
}

}  // namespace detail

inline std::optional<int> colmap_camera_model_id(std::string_view model) {
  for (std::size_t k = 0; k < detail::kColmapModelNames.size(); ++k)
    if (detail::kColmapModelNames[k] == model) return static_cast<int>(k);
  return std::nullopt;
}

inline std::optional<std::string_view> colmap_camera_model_name(int model_id) {
  if (model_id < 0 || static_cast<std::size_t>(model_id) >= detail::kColmapModelNames.size()) return std::nullopt;
  return detail::kColmapModelNames[static_cast<std::size_t>(model_id)];
}

inline ColmapModel read_colmap_binary(const std::string& directory) {
  ColmapModel model;
  detail::ColmapBinaryOffsets offsets;
  model.cameras = detail::read_cameras_binary(directory + "/cameras.bin");
  model.images = detail::read_images_binary(directory + "/images.bin", offsets);
  model.points3d = detail::read_points3d_binary(directory + "/points3D.bin", offsets);
  detail::check_colmap_binary_model(model, directory, offsets);
  return model;
}

inline void write_colmap_binary(const ColmapModel& model, const std::string& directory) {
  DIACHRON_CHECK(!directory.empty(), "write_colmap_binary: empty folder name");
  model.check();
  // Everything is checked before the first byte, so a refused model leaves no half-written file.
  // 2^32 - 1 is COLMAP's invalid camera and image id: the reader would refuse it.
  constexpr std::uint32_t invalid_id = std::numeric_limits<std::uint32_t>::max();
  for (const auto& [id, camera] : model.cameras) {
    DIACHRON_CHECK(id != invalid_id, "write_colmap_binary: camera id " << id << " is COLMAP's invalid id");
    for (double p : camera.params)
      DIACHRON_CHECK(std::isfinite(p), "write_colmap_binary: camera " << id << " has a non-finite param");
  }
  for (const auto& [id, image] : model.images) {
    DIACHRON_CHECK(id != invalid_id, "write_colmap_binary: image id " << id << " is COLMAP's invalid id");
    DIACHRON_CHECK(!image.name.empty() && image.name.find('\0') == std::string::npos,
                   "write_colmap_binary: image " << id << " has an empty name or one with a '\\0'");
    DIACHRON_CHECK(image.pose.centre().allFinite() && image.pose.cam_from_world_rotation().allFinite(),
                   "write_colmap_binary: image " << id << " has a non-finite pose");
    for (std::size_t k = 0; k < image.points2d.size(); ++k)
      DIACHRON_CHECK(image.points2d[k].xy.allFinite(),
                     "write_colmap_binary: 2D point " << k << " of image " << id << " is not finite");
  }
  for (const auto& [id, p] : model.points3d)
    DIACHRON_CHECK(p.xyz.allFinite() && std::isfinite(p.error),
                   "write_colmap_binary: point3D " << id << " has a non-finite position or error");
  make_folder(directory, "write_colmap_binary");
  {
    detail::ColmapBinaryOutput out(directory + "/cameras.bin");
    out.u64(model.cameras.size());
    for (const auto& [id, camera] : model.cameras) {
      out.u32(id);
      out.i32(*colmap_camera_model_id(camera.model));  // check() refused unknown models
      out.u64(static_cast<std::uint64_t>(camera.width));
      out.u64(static_cast<std::uint64_t>(camera.height));
      for (double p : camera.params) out.f64(p);
    }
    out.close();
  }
  {
    detail::ColmapBinaryOutput out(directory + "/images.bin");
    out.u64(model.images.size());
    for (const auto& [id, image] : model.images) {
      out.u32(id);
      const Eigen::Vector4d q = detail::colmap_qvec(image.pose);
      const Vec3 t = image.pose.cam_from_world_translation();
      for (int k = 0; k < 4; ++k) out.f64(q[k]);
      for (int k = 0; k < 3; ++k) out.f64(t[k]);
      out.u32(image.camera_id);
      out.name(image.name);
      out.u64(image.points2d.size());
      for (const ColmapPoint2D& p : image.points2d) {
        out.f64(p.xy.x());
        out.f64(p.xy.y());
        out.u64(p.point3d_id == kColmapNoPoint3D ? detail::kColmapBinaryNoPoint3D
                                                 : static_cast<std::uint64_t>(p.point3d_id));
      }
    }
    out.close();
  }
  {
    detail::ColmapBinaryOutput out(directory + "/points3D.bin");
    out.u64(model.points3d.size());
    for (const auto& [id, p] : model.points3d) {
      out.u64(id);
      for (int k = 0; k < 3; ++k) out.f64(p.xyz[k]);
      for (std::uint8_t c : p.rgb) out.u8(c);
      out.f64(p.error);
      out.u64(p.track.size());
      for (const ColmapTrackElement& e : p.track) {
        out.u32(e.image_id);
        out.u32(e.point2d_index);
      }
    }
    out.close();
  }
}

}  // namespace diachron
