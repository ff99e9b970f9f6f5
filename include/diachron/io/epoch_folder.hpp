#pragma once
/// @file
/// Epoch folders, the exchange format of the pipeline (docs/architecture.md): a COLMAP model, text
/// (cameras.txt, images.txt, points3D.txt) or binary (cameras.bin, images.bin, points3D.bin, as
/// COLMAP writes it; io/colmap_model.hpp), the images under images/ and the epoch's DSM as
/// dsm.tif, in the model's frame; or an orthophoto epoch: `ortho.tif` (any GDAL raster, grey or
/// colour, with a north-up geotransform) and `dsm.tif` in the same CRS (any grid), the usual modern
/// reference (a national orthophoto and its DEM). An orthophoto is cut into tiles, each a
/// pseudo-image of the epoch with an OrthoFrame (camera/ortho_frame.hpp), read on demand.
/// read_epoch_folder() checks the whole folder up front, so a missing image or an unknown camera
/// stops the run before any work, with the file named. Images
/// are read on demand (EpochFolder::load_image): archives hold hundreds of large scans. Masks are
/// optional, 0 where a pixel must not be matched (the scan's frame, fiducial marks, clouds:
/// matching/image_mask.hpp), COLMAP's way (`masks/<image name>.png`) or MicMac's (`<image name
/// without its extension>_Masq.tif` beside the image); an image without one is used whole.
/// Needs GDAL (diachron::io).

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <diachron/camera/camera.hpp>
#include <diachron/camera/distortion.hpp>
#include <diachron/camera/epoch_frame.hpp>
#include <diachron/camera/frame.hpp>
#include <diachron/camera/ortho_frame.hpp>
#include <diachron/core/error.hpp>
#include <diachron/core/raster.hpp>
#include <diachron/io/colmap_model.hpp>
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
  /// For a tile of an orthophoto epoch: its frame (the orthophoto's geotransform moved to the tile),
  /// and `frame` above is unused; nullopt for a photo.
  std::optional<OrthoFrame> ortho;
  /// For a tile: its top-left pixel in the orthophoto (tile px + (tile_x, tile_y) = orthophoto px).
  int tile_x = 0, tile_y = 0;

  /// The image's frame whatever its kind: the photo's Frame, or the tile's OrthoFrame.
  EpochFrame epoch_frame() const { return ortho ? EpochFrame(*ortho) : EpochFrame(frame); }
  /// Its size, px.
  int width() const { return ortho ? ortho->width() : frame.camera().width(); }
  int height() const { return ortho ? ortho->height() : frame.camera().height(); }
};

/// How an orthophoto epoch is cut into tiles. Defaults: tiles about the size of the images
/// match_epochs is measured on (1600 x 1200 px, 53000 correlation cells of 6 px), so each tile's
/// pair costs what a photo pair costs, overlapping by a correlation window and a search so that no
/// point is lost at a seam.
struct OrthoTileOptions {
  /// Largest side of a tile, px (>= 64). An orthophoto at most this large (plus the overlap) on a
  /// side is one tile.
  int tile_px = 1536;
  /// Pixels two neighbouring tiles share (>= 0, < tile_px / 2): a 21 px window plus a 12 px search
  /// each side.
  int overlap_px = 64;

  void check() const {
    DIACHRON_CHECK(tile_px >= 64, "OrthoTileOptions::tile_px must be >= 64, got " << tile_px);
    DIACHRON_CHECK(overlap_px >= 0 && overlap_px < tile_px / 2,
                   "OrthoTileOptions::overlap_px must be in [0, tile_px / 2), got " << overlap_px);
  }
};

/// The tiles' origins along one side of `size` px: one tile when it fits in tile_px + overlap_px,
/// else evenly spaced tiles of at most tile_px sharing at least overlap_px. Returns (start, length).
inline std::vector<std::pair<int, int>> ortho_tile_spans(int size, const OrthoTileOptions& options) {
  options.check();
  DIACHRON_CHECK(size > 0, "ortho_tile_spans: an empty side (" << size << " px)");
  if (size <= options.tile_px + options.overlap_px) return {{0, size}};
  const int step = options.tile_px - options.overlap_px;
  const int n = 1 + (size - options.tile_px + step - 1) / step;  // tiles so that the last one reaches the end
  std::vector<std::pair<int, int>> out;
  for (int k = 0; k < n; ++k) {
    // Spread the tiles evenly: the k-th starts at round(k (size - tile) / (n - 1)).
    const int start = static_cast<int>((static_cast<long long>(k) * (size - options.tile_px)) / (n - 1));
    out.emplace_back(start, options.tile_px);
  }
  return out;
}

/// An epoch folder as read: the model, its images in images.txt order (by id), and the DSM; or,
/// for an orthophoto epoch, no model, the orthophoto's tiles as images (row by row) and the DSM.
struct EpochFolder {
  std::string directory;
  ColmapModel model;
  /// The form the model was read in (binary when the folder holds both and they agree).
  ColmapFormat model_format = ColmapFormat::text;
  std::vector<EpochImage> images;
  Dsm dsm;
  /// The orthophoto of an orthophoto epoch (`<directory>/ortho.tif`), empty for a photo epoch.
  std::string ortho_path;
  /// The whole orthophoto's frame (its tiles' frames are tiles of it); meaningful when is_ortho().
  OrthoFrame ortho;

  bool is_ortho() const { return !ortho_path.empty(); }

  /// Index of the image called `name` in `images`, or images.size() when there is none.
  std::size_t find(const std::string& name) const {
    for (std::size_t i = 0; i < images.size(); ++i)
      if (images[i].name == name) return i;
    return images.size();
  }

  /// Reads image `i` as 8-bit grey (RGB becomes luma, 16-bit scans are stretched: read_image_grey8).
  /// Throws diachron::Error naming the file when it cannot be read or its size is not its camera's.
  /// An orthophoto's tile is read as its window of the orthophoto.
  Raster<std::uint8_t> load_image(std::size_t i) const {
    DIACHRON_CHECK(i < images.size(), "EpochFolder::load_image: image " << i << " of " << images.size());
    if (images[i].ortho) {
      GreyImageReadOptions window;
      window.window_x = images[i].tile_x;
      window.window_y = images[i].tile_y;
      window.window_width = images[i].ortho->width();
      window.window_height = images[i].ortho->height();
      return read_image_grey8(ortho_path, window);
    }
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
                        << whose << " in " << directory << "/" << colmap_file_name("cameras", model_format) << " is "
                        << camera.width() << " x "
                        << camera.height());
    return raster;
  }
};

namespace detail {

// The orthophoto epoch of `directory` (ortho.tif + dsm.tif): its georeference checked against its
// DSM's, its tiles.
inline EpochFolder read_ortho_epoch_folder(const std::string& directory, const GeoTiffReadOptions& dsm_options,
                                           const OrthoTileOptions& tiles) {
  EpochFolder out;
  out.directory = directory;
  out.ortho_path = directory + "/ortho.tif";
  const RasterGeoreference geo = read_raster_georeference(out.ortho_path);
  DIACHRON_CHECK(geo.has_geotransform, "epoch folder '" << directory
                                                        << "': ortho.tif has no geotransform; an orthophoto epoch "
                                                           "needs one (georeference it, e.g. with gdal_translate -a_ullr)");
  try {
    out.ortho = OrthoFrame(geo.transform, geo.width, geo.height);
  } catch (const Error& e) {
    DIACHRON_CHECK(false, "epoch folder '" << directory << "': ortho.tif: " << e.what());
  }
  out.dsm = read_geotiff_dsm(directory + "/dsm.tif", dsm_options);
  DIACHRON_CHECK(out.dsm.statistics().count > 0, "epoch folder '" << directory << "': dsm.tif has no valid cell");
  DIACHRON_CHECK(same_crs(geo.crs, out.dsm.crs()),
                 "epoch folder '" << directory << "': ortho.tif and dsm.tif are in different CRS ("
                                  << (geo.crs.empty() ? std::string("none") : geo.crs.substr(0, 60)) << " / "
                                  << (out.dsm.crs().empty() ? std::string("none") : out.dsm.crs().substr(0, 60))
                                  << "); reproject one onto the other (gdalwarp -t_srs)");
  const std::vector<std::pair<int, int>> xs = ortho_tile_spans(geo.width, tiles), ys = ortho_tile_spans(geo.height, tiles);
  for (const auto& [y0, h] : ys)
    for (const auto& [x0, w] : xs) {
      EpochImage tile;
      tile.id = static_cast<std::uint32_t>(out.images.size() + 1);
      tile.name = "ortho_x" + std::to_string(x0) + "_y" + std::to_string(y0) + ".tif";
      tile.path = out.ortho_path;
      tile.ortho = out.ortho.tile(x0, y0, w, h);
      tile.tile_x = x0;
      tile.tile_y = y0;
      out.images.push_back(std::move(tile));
    }
  return out;
}

}  // namespace detail

/// Reads the epoch folder `directory`: its COLMAP model (`cameras.txt`, `images.txt`, `points3D.txt`,
/// or the `.bin` files; both only when they agree: read_colmap_model()), `dsm.tif`, and checks that
/// every image of the model exists under `images/`; notes each image's mask where it
/// exists (EpochImage::mask_path, read on demand by EpochFolder::load_mask). A folder with
/// `ortho.tif` and no model is an orthophoto epoch: its tiles (`tiles`) become its images, named
/// `ortho_x<X>_y<Y>.tif` after their top-left pixel in the orthophoto. Throws diachron::Error
/// naming the file (and line, or byte for a binary model) when the folder, a file or an image is
/// missing, a file cannot be parsed, a camera model has no diachron counterpart, the DSM has no
/// valid cell, the folder holds both a model and an orthophoto, or a text and a binary model that
/// differ, or the orthophoto has no geotransform, a rotated one, or another CRS than its DSM.
inline EpochFolder read_epoch_folder(const std::string& directory, const GeoTiffReadOptions& dsm_options = {},
                                     const OrthoTileOptions& tiles = {}) {
  DIACHRON_CHECK(!directory.empty() && is_folder(directory),
                 "epoch folder '" << directory << "' does not exist or is not a folder");
  tiles.check();
  const bool has_ortho = is_regular_file(directory + "/ortho.tif");
  const bool has_model = is_regular_file(directory + "/images.txt") || is_regular_file(directory + "/cameras.txt") ||
                         has_colmap_model(directory, ColmapFormat::binary);
  DIACHRON_CHECK(!(has_ortho && has_model), "epoch folder '" << directory
                                                             << "' holds both a COLMAP model and ortho.tif; an epoch "
                                                                "is one or the other: move one of them away");
  if (has_ortho) return detail::read_ortho_epoch_folder(directory, dsm_options, tiles);
  EpochFolder out;
  out.directory = directory;
  // A folder with no model file at all keeps the text reader's message (cameras.txt cannot be opened).
  if (has_colmap_model(directory, ColmapFormat::binary))
    out.model = read_colmap_model(directory, &out.model_format);
  else
    out.model = read_colmap_text(directory);
  const std::string images_file = colmap_file_name("images", out.model_format);
  DIACHRON_CHECK(!out.model.images.empty(), "epoch folder '" << directory << "': " << images_file << " lists no image");
  out.dsm = read_geotiff_dsm(directory + "/dsm.tif", dsm_options);
  DIACHRON_CHECK(out.dsm.statistics().count > 0, "epoch folder '" << directory << "': dsm.tif has no valid cell");
  for (const auto& [id, colmap_image] : out.model.images) {
    EpochImage image;
    image.id = id;
    image.name = colmap_image.name;
    image.path = directory + "/images/" + colmap_image.name;
    DIACHRON_CHECK(is_regular_file(image.path),
                   "epoch folder '" << directory << "': image '" << colmap_image.name << "' (id " << id << " in "
                                    << images_file << ") is missing from images/");
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
