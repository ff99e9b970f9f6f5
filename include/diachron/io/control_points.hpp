#pragma once
/// @file
/// Ground control points as a text file, for `match_epochs --adjust --gcps FILE` and
/// combined_adjustment (pipeline/combined_adjustment.hpp, CombinedControlPoint). One record per
/// line, fields separated by blanks, `#` starts a comment line:
///
///     point NAME X Y Z SIGMA     the position in the reference epoch's frame (epoch 2's, its
///                                units), its standard deviation per axis (same units, > 0)
///     obs NAME IMAGE X Y         an observation of point NAME in image IMAGE (a name of either
///                                epoch's images.txt), pixel in diachron's convention
///
/// Pixels: (0, 0) is the centre of the top-left pixel (docs/conventions.md), which is MicMac's
/// convention too; from COLMAP's (corner) subtract 0.5. Points and observations may come in any
/// order; names have no blanks. Needs the standard library and Eigen only. docs/adjustment.md.

#include <cstddef>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/io/colmap_text.hpp>

namespace diachron {

/// One ground control point of a control-point file.
struct ControlPointRecord {
  std::string name;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< reference frame, its units
  double sigma = 1.0;                                  ///< per axis, same units, > 0
  /// Observations: image name (as in images.txt) and pixel (diachron convention), in file order.
  std::vector<std::pair<std::string, Eigen::Vector2d>> observations;
};

/// Reads a control-point file (the file comment's layout). Points in file order.
/// Throws diachron::Error naming the file and line for an unknown record, a missing or unreadable
/// field, a sigma <= 0, a point defined twice, and (naming the point) an observation of a point
/// the file does not define or a point observed twice in one image.
inline std::vector<ControlPointRecord> read_control_points(const std::string& path) {
  // The line reader of COLMAP's text files: blank-separated fields, '#' comments.
  detail::ColmapTextFile file(path);
  std::vector<ControlPointRecord> points;
  std::map<std::string, std::size_t> index;
  struct PendingObservation {
    std::string point, image;
    Eigen::Vector2d pixel;
    int line;
  };
  std::vector<PendingObservation> observations;
  while (file.next_record()) {
    const std::string kind(file.field(0, "the record kind"));
    if (kind == "point") {
      if (file.fields().size() != 6) file.fail("a point line is 'point NAME X Y Z SIGMA'");
      ControlPointRecord p;
      p.name = std::string(file.field(1, "the point's name"));
      p.position = {file.number(2, "X"), file.number(3, "Y"), file.number(4, "Z")};
      p.sigma = file.number(5, "SIGMA");
      if (!(p.sigma > 0.0)) file.fail("point " + p.name + ": SIGMA must be > 0");
      if (!index.emplace(p.name, points.size()).second) file.fail("point " + p.name + " is defined twice");
      points.push_back(std::move(p));
    } else if (kind == "obs") {
      if (file.fields().size() != 5) file.fail("an observation line is 'obs NAME IMAGE X Y'");
      observations.push_back({std::string(file.field(1, "the point's name")), std::string(file.field(2, "the image name")),
                              Eigen::Vector2d(file.number(3, "X"), file.number(4, "Y")), file.line()});
    } else {
      file.fail("unknown record '" + kind + "' (expected 'point' or 'obs')");
    }
  }
  for (const PendingObservation& o : observations) {
    const auto it = index.find(o.point);
    if (it == index.end())
      detail::colmap_fail(path, o.line, "observation of point " + o.point + ", which the file does not define");
    ControlPointRecord& p = points[it->second];
    for (const auto& [image, pixel] : p.observations)
      if (image == o.image) detail::colmap_fail(path, o.line, "point " + o.point + " is observed twice in " + o.image);
    p.observations.emplace_back(o.image, o.pixel);
  }
  return points;
}

}  // namespace diachron
