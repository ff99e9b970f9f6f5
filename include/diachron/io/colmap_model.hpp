#pragma once
/// @file
/// A COLMAP sparse model in either of COLMAP's forms: read_colmap_model() takes what the folder
/// holds (text, io/colmap_text.hpp, or binary, io/colmap_binary.hpp), write_colmap_model() writes
/// the form asked for. Needs the standard library and Eigen only (no GDAL, despite living in io/).
///
/// A folder that holds both forms is read only when they are the same model: COLMAP itself
/// silently prefers the binary files, but a text model beside a binary one is usually a conversion
/// someone may have edited since, and taking either silently could use stale orientations.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <sstream>
#include <string>

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/io/colmap_binary.hpp>
#include <diachron/io/colmap_text.hpp>
#include <diachron/io/folders.hpp>

namespace diachron {

/// The two forms of a COLMAP model on disk: `text` (cameras.txt, images.txt, points3D.txt) and
/// `binary` (cameras.bin, images.bin, points3D.bin).
enum class ColmapFormat { text, binary };

/// "text" or "binary".
inline const char* colmap_format_name(ColmapFormat format) { return format == ColmapFormat::text ? "text" : "binary"; }

/// The file name of table `table` ("cameras", "images" or "points3D") in `format`, e.g. "images.bin".
inline std::string colmap_file_name(const std::string& table, ColmapFormat format) {
  return table + (format == ColmapFormat::text ? ".txt" : ".bin");
}

/// Whether `directory` holds (any file of) a COLMAP model in `format`: one of its three files is a
/// regular file (symbolic links followed). A partial model counts, so that reading it names the
/// missing file.
inline bool has_colmap_model(const std::string& directory, ColmapFormat format) {
  for (const char* table : {"cameras", "images", "points3D"})
    if (is_regular_file(directory + "/" + colmap_file_name(table, format))) return true;
  return false;
}

/// The first difference between two models, or nullopt when they are the same: same ids, names,
/// camera models, sizes, params, 2D points, points3D, colours, errors and tracks, compared exactly,
/// and poses within 1e-12 (rotation entries; centres relative to 1 + |C|), since a pose goes
/// through a quaternion on its way to a file. E.g. "image 3: name 'a.png' against 'b.png'".
inline std::optional<std::string> colmap_model_difference(const ColmapModel& a, const ColmapModel& b);

/// Reads the COLMAP model in `directory`, text or binary as the folder holds it. When it holds both,
/// both are read and must be the same model (colmap_model_difference()); otherwise throws
/// diachron::Error saying where they differ and to remove the stale one. `format_read`, when given,
/// receives the form read (`binary` when both were, and agreed). Throws diachron::Error as
/// read_colmap_text() and read_colmap_binary() do, naming the file, and for a folder with no model
/// file at all.
inline ColmapModel read_colmap_model(const std::string& directory, ColmapFormat* format_read = nullptr);

/// Writes `model` into `directory` (created if needed, not its parents) in `format`, through
/// write_colmap_text() or write_colmap_binary(). Only that form's three files are written: a model
/// of the other form in the folder is left alone (read_colmap_model() then reads the folder only if
/// the two agree). Throws as those writers do.
inline void write_colmap_model(const ColmapModel& model, const std::string& directory,
                               ColmapFormat format = ColmapFormat::text);

// Implementation ----------------------------------------------------------------------------------

inline std::optional<std::string> colmap_model_difference(const ColmapModel& a, const ColmapModel& b) {
  std::ostringstream d;
  d.precision(17);
  if (a.cameras.size() != b.cameras.size()) {
    d << a.cameras.size() << " cameras against " << b.cameras.size();
    return d.str();
  }
  for (auto i = a.cameras.begin(), j = b.cameras.begin(); i != a.cameras.end(); ++i, ++j) {
    const ColmapCamera &x = i->second, &y = j->second;
    if (i->first != j->first) d << "camera ids " << i->first << " against " << j->first;
    else if (x.model != y.model || x.width != y.width || x.height != y.height || x.params != y.params)
      d << "camera " << i->first << ": model, size or params differ";
    if (!d.str().empty()) return d.str();
  }
  if (a.images.size() != b.images.size()) {
    d << a.images.size() << " images against " << b.images.size();
    return d.str();
  }
  for (auto i = a.images.begin(), j = b.images.begin(); i != a.images.end(); ++i, ++j) {
    const ColmapImage &x = i->second, &y = j->second;
    if (i->first != j->first) d << "image ids " << i->first << " against " << j->first;
    else if (x.name != y.name) d << "image " << i->first << ": name '" << x.name << "' against '" << y.name << "'";
    else if (x.camera_id != y.camera_id)
      d << "image " << i->first << ": camera " << x.camera_id << " against " << y.camera_id;
    else if ((x.pose.cam_from_world_rotation() - y.pose.cam_from_world_rotation()).cwiseAbs().maxCoeff() > 1e-12 ||
             (x.pose.centre() - y.pose.centre()).norm() > 1e-12 * (1.0 + x.pose.centre().norm()))
      d << "image " << i->first << ": pose (centre " << x.pose.centre().transpose() << " against "
        << y.pose.centre().transpose() << ")";
    else if (x.points2d.size() != y.points2d.size())
      d << "image " << i->first << ": " << x.points2d.size() << " 2D points against " << y.points2d.size();
    else
      for (std::size_t k = 0; k < x.points2d.size() && d.str().empty(); ++k)
        if (x.points2d[k].xy != y.points2d[k].xy || x.points2d[k].point3d_id != y.points2d[k].point3d_id)
          d << "image " << i->first << ": 2D point " << k << " differs";
    if (!d.str().empty()) return d.str();
  }
  if (a.points3d.size() != b.points3d.size()) {
    d << a.points3d.size() << " points3D against " << b.points3d.size();
    return d.str();
  }
  for (auto i = a.points3d.begin(), j = b.points3d.begin(); i != a.points3d.end(); ++i, ++j) {
    const ColmapPoint3D &x = i->second, &y = j->second;
    if (i->first != j->first) d << "point3D ids " << i->first << " against " << j->first;
    else if (x.xyz != y.xyz || x.rgb != y.rgb || x.error != y.error)
      d << "point3D " << i->first << ": position, colour or error differ";
    else if (!(x.track == y.track)) d << "point3D " << i->first << ": track differs";
    if (!d.str().empty()) return d.str();
  }
  return std::nullopt;
}

inline ColmapModel read_colmap_model(const std::string& directory, ColmapFormat* format_read) {
  const bool text = has_colmap_model(directory, ColmapFormat::text);
  const bool binary = has_colmap_model(directory, ColmapFormat::binary);
  DIACHRON_CHECK(text || binary, "'" << directory
                                     << "' holds no COLMAP model: neither cameras.txt, images.txt, points3D.txt nor "
                                        "cameras.bin, images.bin, points3D.bin");
  if (format_read) *format_read = binary ? ColmapFormat::binary : ColmapFormat::text;
  if (!binary) return read_colmap_text(directory);
  ColmapModel model = read_colmap_binary(directory);
  if (text) {
    const std::optional<std::string> difference = colmap_model_difference(model, read_colmap_text(directory));
    DIACHRON_CHECK(!difference, "'" << directory
                                    << "' holds a binary and a text COLMAP model that differ (binary against text: "
                                    << *difference
                                    << "); remove the stale one (or convert one into the other with colmap "
                                       "model_converter)");
  }
  return model;
}

inline void write_colmap_model(const ColmapModel& model, const std::string& directory, ColmapFormat format) {
  if (format == ColmapFormat::text)
    write_colmap_text(model, directory);
  else
    write_colmap_binary(model, directory);
}

}  // namespace diachron
