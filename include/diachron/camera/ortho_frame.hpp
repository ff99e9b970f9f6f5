#pragma once
/// @file
/// OrthoFrame: an orthophoto (or a tile of one) as a Frame: the orthographic projection through a
/// north-up GDAL geotransform. A world point's pixel is its X, Y through the inverse geotransform;
/// its height does not matter. A pixel's ray is vertical, from high above, so DsmLift,
/// DsmTransfer, local_affine, gsd_on_dsm and overlapping_pairs work on it unchanged.

#include <cmath>
#include <optional>

#include <Eigen/Core>

#include <diachron/core/error.hpp>
#include <diachron/core/geo_transform.hpp>
#include <diachron/geometry/helmert3.hpp>
#include <diachron/geometry/ray.hpp>

namespace diachron {

/// An orthophoto's pixel grid as a frame. `geo` maps the image's pixels (diachron convention) to
/// world X/Y in the frame's units; it must be north-up (no rotation terms: c[2] = c[4] = 0, c[1] > 0,
/// c[5] < 0), as orthophotos are delivered and as the DSM transfer's vertical rays need.
/// A value type; all const members are thread-safe.
class OrthoFrame {
 public:
  /// Height (frame units) from which a pixel's ray starts downwards. The ray-DSM intersection clips
  /// the ray to the DSM's height range first, so only "above every surface" matters; 1e7 keeps
  /// 1e-9 relative precision in double.
  static constexpr double kRayOriginZ = 1e7;

  OrthoFrame() = default;

  /// @throws diachron::Error for an empty size, a non-finite or rotated geotransform.
  OrthoFrame(const GeoTransform& geo, int width_px, int height_px) : geo_(geo), width_(width_px), height_(height_px) {
    check_north_up(geo);
    DIACHRON_CHECK(width_px > 0 && height_px > 0,
                   "OrthoFrame: the image must not be empty, got " << width_px << " x " << height_px);
  }

  /// Throws diachron::Error with the reason when `geo` is not a finite north-up geotransform.
  static void check_north_up(const GeoTransform& geo) {
    for (double v : geo.c) DIACHRON_CHECK(std::isfinite(v), "OrthoFrame: the geotransform has a non-finite coefficient");
    DIACHRON_CHECK(geo.c[2] == 0.0 && geo.c[4] == 0.0,
                   "OrthoFrame: the geotransform is rotated (row/column terms " << geo.c[2] << ", " << geo.c[4]
                                                                                 << "); resample it north-up first");
    DIACHRON_CHECK(geo.c[1] > 0.0 && geo.c[5] < 0.0,
                   "OrthoFrame: the geotransform is not north-up (pixel sizes " << geo.c[1] << ", " << geo.c[5]
                                                                                << "; want > 0 and < 0)");
  }

  const GeoTransform& geo_transform() const { return geo_; }
  int width() const { return width_; }
  int height() const { return height_; }
  /// Ground size of a pixel along x (frame units).
  double cell_size() const { return geo_.c[1]; }

  /// Pixel of a world point: its X, Y through the inverse geotransform (its Z is ignored);
  /// nullopt when the point is not finite. The pixel may fall outside the image (in_image()).
  std::optional<Eigen::Vector2d> project(const Eigen::Vector3d& world) const {
    if (!world.allFinite()) return std::nullopt;
    return geo_.world_to_pixel(world.head<2>());
  }

  /// The vertical ray through a pixel: origin at (X, Y, kRayOriginZ), direction (0, 0, -1);
  /// nullopt for a non-finite pixel.
  std::optional<Ray3> ray(const Eigen::Vector2d& pixel) const {
    if (!pixel.allFinite()) return std::nullopt;
    Ray3 out;
    const Eigen::Vector2d xy = geo_.pixel_to_world(pixel);
    out.origin = Eigen::Vector3d(xy.x(), xy.y(), kRayOriginZ);
    out.direction = Eigen::Vector3d(0.0, 0.0, -1.0);
    return out;
  }

  /// True when `pixel` lies on the image (pixel centres from 0 to size - 1, edges included), as
  /// Camera::in_image.
  bool in_image(const Eigen::Vector2d& pixel) const {
    return pixel.x() >= -0.5 && pixel.y() >= -0.5 && pixel.x() <= width_ - 0.5 && pixel.y() <= height_ - 0.5;
  }

  /// The tile of this orthophoto whose top-left pixel is (x0, y0) and size w x h: its pixel (0, 0)
  /// is this frame's (x0, y0).
  OrthoFrame tile(int x0, int y0, int w, int h) const {
    GeoTransform g = geo_;
    g.c[0] += x0 * geo_.c[1];
    g.c[3] += y0 * geo_.c[5];
    return OrthoFrame(g, w, h);
  }

  /// This frame moved into another world frame by a Helmert: only a similarity about the vertical
  /// keeps an orthophoto north-up, so anything else is refused (the orthophoto epoch is the
  /// reference; move the other epoch instead). Scale and translation apply to the geotransform.
  /// @throws diachron::Error when `helmert` rotates.
  OrthoFrame transformed(const Helmert3& helmert) const {
    DIACHRON_CHECK((helmert.rotation - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-12,
                   "OrthoFrame::transformed: an orthophoto can only be moved without rotation");
    GeoTransform g = geo_;
    g.c[0] = helmert.scale * geo_.c[0] + helmert.translation.x();
    g.c[3] = helmert.scale * geo_.c[3] + helmert.translation.y();
    g.c[1] *= helmert.scale;
    g.c[5] *= helmert.scale;
    return OrthoFrame(g, width_, height_);
  }

 private:
  GeoTransform geo_ = GeoTransform::north_up(0.0, 0.0, 1.0);
  int width_ = 1, height_ = 1;
};

}  // namespace diachron
