#pragma once
/// @file
/// Epoch folders, the exchange format of the pipeline (docs/architecture.md): a COLMAP text model
/// (cameras.txt, images.txt, points3D.txt), the images under images/ and the epoch's DSM as
/// dsm.tif, in the model's frame. read_epoch_folder() checks the whole folder up front, so a
/// missing image or an unknown camera stops the run before any work, with the file named. Images
/// are read on demand (EpochFolder::load_image): archives hold hundreds of large scans. Masks are
/// optional, 0 where a pixel must not be matched (the scan's frame, fiducial marks, clouds:
/// matching/image_mask.hpp), COLMAP's way (`masks/<image name>.png`) or MicMac's (`<image name
/// without its extension>_Masq.tif` beside the image); an image without one is used whole.
/// Needs GDAL (diachron::io).

#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <diachron/camera/camera.hpp>
#include <diachron/camera/distortion.hpp>
#include <diachron/camera/frame.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/io/colmap_text.hpp>
#include <diachron/io/folders.hpp>
#include <diachron/io/geotiff.hpp>
#include <diachron/io/grey_image.hpp>
#include <diachron/terrain/dsm.hpp>

namespace diachron {

/// One image of an epoch folder: its COLMAP id and name (relative to images/), the file it is read
/// from, and its orientation as a diachron Frame (camera converted from the COLMAP model, pose in
/// the model's frame, diachron pixel convention).
struct EpochImage {
  std::uint32_t id = 0;
  std::string name;
  std::string path;
  /// Its mask, `masks/<name>.png` (COLMAP) or else `images/<name stem>_Masq.tif` (MicMac), or empty
  /// when the folder has neither.
  std::string mask_path;
  Frame<FraserAffine> frame{Camera<FraserAffine>(1.0, 0.0, 0.0, 1, 1), Pose{}};
  /// Largest difference (px) between COLMAP's projection and the converted camera's over the
  /// image; 0 for models diachron holds exactly (every model it reads but FULL_OPENCV with K4-K6).
  double conversion_error_px = 0.0;
};

/// An epoch folder as read: the model, its images in images.txt order (by id), and the DSM.
struct EpochFolder {
  std::string directory;
  ColmapModel model;
  std::vector<EpochImage> images;
  Dsm dsm;

  /// Index of the image called `name` in `images`, or images.size() when there is none.
  std::size_t find(const std::string& name) const {
    for (std::size_t i = 0; i < images.size(); ++i)
      if (images[i].name == name) return i;
    return images.size();
  }

  /// Reads image `i` as 8-bit grey (RGB becomes luma, 16-bit scans are stretched: read_image_grey8).
  /// Throws diachron::Error naming the file when it cannot be read or its size is not its camera's.
  Raster<std::uint8_t> load_image(std::size_t i) const {
    DIACHRON_CHECK(i < images.size(), "EpochFolder::load_image: image " << i << " of " << images.size());
    return read_camera_sized(images[i].path, i, "image", "its camera");
  }

  /// Images with a mask.
  std::size_t masks() const {
    std::size_t n = 0;
    for (const EpochImage& image : images) n += !image.mask_path.empty();
    return n;
  }

  /// Reads image `i`'s mask as 8-bit grey (0 = ignore the pixel), or an empty raster when it has
  /// none. Throws diachron::Error naming the file when it cannot be read or its size is not its
  /// camera's.
  Raster<std::uint8_t> load_mask(std::size_t i) const {
    DIACHRON_CHECK(i < images.size(), "EpochFolder::load_mask: image " << i << " of " << images.size());
    if (images[i].mask_path.empty()) return {};
    return read_camera_sized(images[i].mask_path, i, "mask", "its image's camera");
  }

 private:
  // Reads `path` (an image or a mask, `what`) as 8-bit grey and checks that it is image i's camera's
  // size; `whose` names that camera in the message.
  Raster<std::uint8_t> read_camera_sized(const std::string& path, std::size_t i, const char* what,
                                         const char* whose) const {
    Raster<std::uint8_t> raster = read_image_grey8(path);
    const Camera<FraserAffine>& camera = images[i].frame.camera();
    DIACHRON_CHECK(raster.width() == camera.width() && raster.height() == camera.height(),
                   what << " '" << path << "' is " << raster.width() << " x " << raster.height() << " px but "
                        << whose << " in " << directory << "/cameras.txt is " << camera.width() << " x "
                        << camera.height());
    return raster;
  }
};

/// Reads the epoch folder `directory`: `cameras.txt`, `images.txt`, `points3D.txt`, `dsm.tif`, and
/// checks that every image of images.txt exists under `images/`; notes each image's mask where it
/// exists (EpochImage::mask_path, read on demand by EpochFolder::load_mask). Throws
/// diachron::Error naming the file (and line) when the folder, a file or an image is missing, a file
/// cannot be parsed, a camera model has no diachron counterpart, or the DSM has no valid cell.
inline EpochFolder read_epoch_folder(const std::string& directory, const GeoTiffReadOptions& dsm_options = {}) {
  DIACHRON_CHECK(!directory.empty() && is_folder(directory),
                 "epoch folder '" << directory << "' does not exist or is not a folder");
  EpochFolder out;
  out.directory = directory;
  out.model = read_colmap_text(directory);
  DIACHRON_CHECK(!out.model.images.empty(), "epoch folder '" << directory << "': images.txt lists no image");
  out.dsm = read_geotiff_dsm(directory + "/dsm.tif", dsm_options);
  DIACHRON_CHECK(out.dsm.statistics().count > 0, "epoch folder '" << directory << "': dsm.tif has no valid cell");
  for (const auto& [id, colmap_image] : out.model.images) {
    EpochImage image;
    image.id = id;
    image.name = colmap_image.name;
    image.path = directory + "/images/" + colmap_image.name;
    DIACHRON_CHECK(is_regular_file(image.path),
                   "epoch folder '" << directory << "': image '" << colmap_image.name << "' (id " << id
                                    << " in images.txt) is missing from images/");
    const std::string colmap_mask = directory + "/masks/" + colmap_image.name + ".png";
    const std::size_t dot = image.path.find_last_of('.');
    const std::size_t slash = image.path.find_last_of('/');
    const std::string micmac_mask =
        (dot != std::string::npos && dot > slash ? image.path.substr(0, dot) : image.path) + "_Masq.tif";
    for (const std::string& candidate : {colmap_mask, micmac_mask})
      if (image.mask_path.empty() && is_regular_file(candidate))
        image.mask_path = candidate;
    const ColmapCamera& colmap_camera = out.model.cameras.at(colmap_image.camera_id);  // check()ed by the reader
    const ConversionResult<Camera<FraserAffine>> camera = camera_from_colmap(colmap_camera);
    image.frame = Frame<FraserAffine>(camera.model, colmap_image.pose);
    image.conversion_error_px = camera.exact ? 0.0 : camera.max_error_px;
    out.images.push_back(std::move(image));
  }
  return out;
}

}  // namespace diachron
