#pragma once
/// @file
/// EpochFrame: one image of an epoch whatever its kind: an oriented photo (Frame<FraserAffine>, as
/// an SfM model gives it) or a tile of an orthophoto (OrthoFrame). It forwards the members the
/// transfer, the footprints, the GSD and the ground filter use (project, ray, in_image, size), so a
/// program can hold photo epochs and orthophoto epochs in one type and pass either as master or
/// secondary. For a photo it computes exactly what the Frame computes.

#include <optional>
#include <variant>

#include <Eigen/Core>

#include <diachron/camera/distortion.hpp>
#include <diachron/camera/frame.hpp>
#include <diachron/camera/ortho_frame.hpp>
#include <diachron/core/error.hpp>
#include <diachron/geometry/ray.hpp>

namespace diachron {

/// An oriented photo or an orthophoto tile. A value type; all const members are thread-safe.
class EpochFrame {
 public:
  using Photo = Frame<FraserAffine>;

  EpochFrame(const Photo& photo) : frame_(photo) {}        // NOLINT: implicit, a photo is an epoch frame
  EpochFrame(const OrthoFrame& ortho) : frame_(ortho) {}  // NOLINT: likewise an orthophoto tile

  bool is_ortho() const { return std::holds_alternative<OrthoFrame>(frame_); }
  /// The photo's frame, or nullptr for an orthophoto tile.
  const Photo* photo() const { return std::get_if<Photo>(&frame_); }
  /// The orthophoto tile's frame, or nullptr for a photo.
  const OrthoFrame* ortho() const { return std::get_if<OrthoFrame>(&frame_); }

  /// Pixel of a world point (Frame::project or OrthoFrame::project).
  std::optional<Eigen::Vector2d> project(const Eigen::Vector3d& world) const {
    if (const Photo* p = photo()) return p->project(world);
    return std::get<OrthoFrame>(frame_).project(world);
  }

  /// World ray through a pixel (Frame::ray or OrthoFrame::ray).
  std::optional<Ray3> ray(const Eigen::Vector2d& pixel) const {
    if (const Photo* p = photo()) return p->ray(pixel);
    return std::get<OrthoFrame>(frame_).ray(pixel);
  }

  bool in_image(const Eigen::Vector2d& pixel) const {
    if (const Photo* p = photo()) return p->in_image(pixel);
    return std::get<OrthoFrame>(frame_).in_image(pixel);
  }

  /// Image size, px.
  int width() const { return photo() ? photo()->camera().width() : std::get<OrthoFrame>(frame_).width(); }
  int height() const { return photo() ? photo()->camera().height() : std::get<OrthoFrame>(frame_).height(); }

 private:
  std::variant<Photo, OrthoFrame> frame_;
};

}  // namespace diachron
