// The adjusted export: cameras.json and per-epoch COLMAP models that COLMAP's own projection
// (written from its documentation) reproduces within the reported conversion error; the input
// model is never written into.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include <diachron/core/random.hpp>
#include <diachron/io/adjusted_export.hpp>
#include <diachron/io/cameras_json.hpp>
#include <diachron/io/colmap_model.hpp>
#include <diachron/io/colmap_text.hpp>

#include "support/colmap_binary.hpp"
#include "support/colmap_projection.hpp"
#include "support/temp_folder.hpp"

using namespace diachron;
using Catch::Matchers::Contains;

namespace {

namespace fs = std::filesystem;

std::string export_folder(const std::string& name) { return diachron::test::fresh_temp_folder("adjusted_" + name); }

// Epoch e1: two images sharing a camera with shear (B2 != 0: FULL_OPENCV, fitted) and one with its
// own camera; epoch e2: two images of a camera OPENCV holds exactly (K3 = B2 = 0).
std::vector<CamerasJsonImage> adjusted_images() {
  const Camera<FraserAffine> sheared(1000.0, 801.3, 598.2, 1600, 1200, {-0.08, 0.02, -0.004, 2e-4, -1e-4, 1.5, -0.8});
  const Camera<FraserAffine> other(1010.0, 799.0, 601.0, 1600, 1200, {-0.05, 0.01, 0.0, 1e-4, 1e-4, 0.5, 0.3});
  const Camera<FraserAffine> exact(700.0, 399.0, 301.0, 800, 600, {0.03, -0.01, 0.0, -3e-4, 2e-4, -0.7, 0.0});
  std::vector<CamerasJsonImage> out;
  const auto add = [&out](const std::string& name, const std::string& epoch, const Camera<FraserAffine>& c, double x) {
    const Pose pose = Pose::from_yaw_pitch_roll(Vec3(x, 50.0, 1500.0), 0.1 * x / 100.0, 0.02, -0.01);
    out.push_back(CamerasJsonImage::from_frame(name, epoch, Frame<FraserAffine>(c, pose)));
  };
  add("e1_a", "e1", sheared, 0.0);
  add("e2_a", "e2", exact, 20.0);
  add("e1_b", "e1", sheared, 400.0);
  add("e1_c", "e1", other, 800.0);
  add("e2_b", "e2", exact, 420.0);
  return out;
}

}  // namespace

TEST_CASE("write_adjusted_export: COLMAP models that project as the adjusted frames, within the reported error",
          "[io]") {
  const std::string dir = export_folder("models");
  const std::vector<CamerasJsonImage> images = adjusted_images();
  const AdjustedExportReport report = write_adjusted_export(images, dir);
  CHECK(report.cameras_json_path == dir + "/adjusted/cameras.json");
  REQUIRE(report.model_folders.size() == 2);
  CHECK(report.model_folders.at("e1") == dir + "/adjusted/e1");
  REQUIRE(report.cameras.size() == 3);
  CHECK(report.cameras[0].epoch == "e1");
  CHECK(report.cameras[0].model == "FULL_OPENCV");
  CHECK_FALSE(report.cameras[0].exact);
  CHECK(report.cameras[0].images == std::vector<std::string>{"e1_a", "e1_b"});
  CHECK(report.cameras[1].images == std::vector<std::string>{"e1_c"});
  CHECK(report.cameras[2].epoch == "e2");
  CHECK(report.cameras[2].model == "OPENCV");
  CHECK(report.cameras[2].exact);
  CHECK(report.cameras[2].max_error_px < 1e-6);
  CHECK(report.max_conversion_error_px == std::max(report.cameras[0].max_error_px, report.cameras[1].max_error_px));
  // Shear cannot be held by OpenCV's models: a real, measured, sub-pixel error.
  CHECK(report.max_conversion_error_px > 1e-3);
  CHECK(report.max_conversion_error_px < 1.0);

  // cameras.json holds the exact cameras.
  const std::vector<CamerasJsonImage> json = read_cameras_json(report.cameras_json_path);
  REQUIRE(json.size() == images.size());
  CHECK(json[3].camera.params() == images[3].camera.params());

  RandomStream rng(5, 0);
  // Named references, not structured bindings: C++17 lambdas cannot capture a binding (clang refuses).
  for (const auto& epoch_folder : report.model_folders) {
    const std::string& epoch = epoch_folder.first;
    const ColmapModel model = read_colmap_text(epoch_folder.second);
    for (const auto& id_image : model.images) {
      const auto& image = id_image.second;
      const CamerasJsonImage& source = *std::find_if(images.begin(), images.end(),
                                                     [&](const CamerasJsonImage& i) { return i.name == image.name; });
      CHECK(source.epoch == epoch);
      const ColmapCamera& camera = model.cameras.at(image.camera_id);
      const AdjustedCameraConversion& conversion =
          *std::find_if(report.cameras.begin(), report.cameras.end(), [&](const AdjustedCameraConversion& c) {
            return c.epoch == epoch && c.camera_id == image.camera_id;
          });
      const Frame<FraserAffine> frame = source.frame();
      const Eigen::Vector4d q = detail::colmap_qvec(image.pose);
      const Vec3 t = image.pose.cam_from_world_translation();
      int tested = 0;
      for (int k = 0; k < 200; ++k) {
        // A ground point seen inside the image.
        // One draw per statement, y before x (core/random.hpp, "Order of draws").
        const double y = rng.uniform(0.0, camera.height - 1.0);
        const Vec2 pixel(rng.uniform(0.0, camera.width - 1.0), y);
        const std::optional<Ray3> ray = frame.ray(pixel);
        REQUIRE(ray);
        const Vec3 world = ray->origin + rng.uniform(1300.0, 1600.0) * ray->direction;
        const Vec2 colmap = diachron_pixel_from_colmap(test::colmap_projection(camera.model, camera.params, q, t, world));
        CHECK((colmap - *frame.project(world)).norm() <= 1.5 * conversion.max_error_px + 1e-6);
        ++tested;
      }
      CHECK(tested == 200);
    }
  }
}

TEST_CASE("write_adjusted_export: never writes into the input model, checks before writing", "[io]") {
  const std::string dir = export_folder("refuse");
  const std::vector<CamerasJsonImage> images = adjusted_images();
  // The input model is DIR/adjusted/e1 itself, reached through a symbolic link.
  fs::create_directories(dir + "/adjusted/e1");
  fs::create_directory_symlink(dir + "/adjusted/e1", dir + "/input_e1");
  AdjustedExportOptions options;
  options.protected_folders = {dir + "/input_e1"};
  CHECK_THROWS_WITH(write_adjusted_export(images, dir, options), Contains("never overwritten"));
  CHECK_FALSE(fs::exists(dir + "/adjusted/cameras.json"));
  CHECK(fs::is_empty(dir + "/adjusted/e1"));
  // Another input folder is fine.
  fs::create_directories(dir + "/e1");
  options.protected_folders = {dir + "/e1"};
  CHECK_NOTHROW(write_adjusted_export(images, dir, options));
  CHECK(fs::is_empty(dir + "/e1"));

  std::vector<CamerasJsonImage> bad = images;
  bad[2].name = bad[0].name;
  const std::string dir2 = export_folder("bad");
  CHECK_THROWS_WITH(write_adjusted_export(bad, dir2), Contains("two images named 'e1_a'"));
  bad = images;
  bad[1].epoch = "..";
  CHECK_THROWS_WITH(write_adjusted_export(bad, dir2), Contains("not a plain folder name"));
  bad = images;
  bad[1].name = "with space";
  CHECK_THROWS_AS(write_adjusted_export(bad, dir2), Error);
  CHECK_FALSE(fs::exists(dir2 + "/adjusted"));
  CHECK_THROWS_AS(write_adjusted_export(images, ""), Error);
}

namespace {

// The export's input: the images above named as match_epochs names them in the combined model
// ("<epoch>/<name>.png": a sub-folder per epoch), a placeholder file for each (the links only need
// a file to point to), and tie points seen exactly, a skipped one of each kind and one observed
// 5 px off.
struct ColmapallInput {
  std::vector<CamerasJsonImage> images;
  std::vector<std::string> paths;
  std::vector<ExportTrack> tracks;
  std::size_t exact_tracks = 0;
  std::size_t observations = 0;
};

ColmapallInput colmapall_input(const std::string& inputs) {
  ColmapallInput in;
  in.images = adjusted_images();
  for (CamerasJsonImage& im : in.images) {
    im.name = im.epoch + "/" + im.name + ".png";
    fs::create_directories(inputs + "/" + im.epoch + "/images");
    in.paths.push_back(inputs + "/" + im.epoch + "/images/../images/" + fs::path(im.name).filename().string());
    std::ofstream(in.paths.back()) << "placeholder " << im.name;
  }
  RandomStream rng(9, 0);
  for (int k = 0; k < 40; ++k) {
    // A ground point under image k % 5, observed where every image that sees it projects it.
    const std::size_t source = static_cast<std::size_t>(k % 5);
    const Frame<FraserAffine> frame = in.images[source].frame();
    // One draw per statement, y before x (core/random.hpp, "Order of draws").
    const double y = rng.uniform(100.0, frame.camera().height() - 100.0);
    const Vec2 pixel(rng.uniform(100.0, frame.camera().width() - 100.0), y);
    ExportTrack track;
    track.xyz = frame.ray(pixel)->origin + rng.uniform(1400.0, 1500.0) * frame.ray(pixel)->direction;
    for (std::size_t i = 0; i < in.images.size(); ++i) {
      const std::optional<Vec2> px = in.images[i].frame().project(track.xyz);
      if (px && px->x() > -0.5 && px->y() > -0.5 && px->x() < in.images[i].camera.width() - 0.5 &&
          px->y() < in.images[i].camera.height() - 0.5)
        track.observations.push_back({i, *px});
    }
    in.observations += track.observations.size();
    in.tracks.push_back(track);
  }
  in.exact_tracks = in.tracks.size();
  // Left out: no position, no observation.
  in.tracks.push_back({Vec3(0.0, std::numeric_limits<double>::quiet_NaN(), 0.0), {{0, Vec2(10, 10)}}});
  in.tracks.push_back({Vec3(1, 2, 3), {}});
  // Two observations, the second 3 px right and 4 px down of its projection: error (0 + 5) / 2.
  ExportTrack off = in.tracks[0];
  off.observations.resize(2);
  off.observations[1].pixel += Vec2(3.0, 4.0);
  in.tracks.push_back(off);
  in.observations += 2;
  return in;
}

std::string colmapall_read(const std::string& path) {
  std::ifstream in(path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

}  // namespace

TEST_CASE("write_adjusted_colmap: one COLMAP model of every epoch with the tie points, and linked images", "[io]") {
  const std::string dir = export_folder("colmap_all");
  const ColmapallInput in = colmapall_input(dir + "/inputs");
  REQUIRE(in.exact_tracks == 40);
  const AdjustedColmapReport report = write_adjusted_colmap(in.images, in.paths, in.tracks, dir);
  CHECK(report.folder == dir + "/adjusted/colmap");
  CHECK(report.model_folder == dir + "/adjusted/colmap/sparse");
  CHECK(report.images_folder == dir + "/adjusted/colmap/images");
  CHECK(report.format == ColmapFormat::text);
  CHECK(report.images == 5);
  CHECK(report.points == 41);
  CHECK(report.skipped_tracks == 2);
  CHECK(report.observations == in.observations);
  CHECK(report.unprojected_observations == 0);
  CHECK(report.max_reprojection_error_px == Approx(5.0).margin(1e-6));
  // Camera ids in order of first use over all epochs: e1's sheared camera, e2's, e1's other one.
  REQUIRE(report.cameras.size() == 3);
  CHECK(report.cameras[0].camera_id == 1);
  CHECK(report.cameras[0].images == std::vector<std::string>{"e1/e1_a.png", "e1/e1_b.png"});
  CHECK(report.cameras[1].camera_id == 2);
  CHECK(report.cameras[1].images == std::vector<std::string>{"e2/e2_a.png", "e2/e2_b.png"});
  CHECK(report.cameras[1].model == "OPENCV");
  CHECK(report.cameras[2].images == std::vector<std::string>{"e1/e1_c.png"});
  CHECK(report.cameras[2].epoch.empty());  // one model of every epoch
  CHECK(report.max_conversion_error_px > 1e-3);  // the shear, as in the per-epoch models

  ColmapFormat format = ColmapFormat::binary;
  const ColmapModel model = read_colmap_model(report.model_folder, &format);  // checks the tracks' consistency
  CHECK(format == ColmapFormat::text);
  CHECK_NOTHROW(model.check());
  // Image ids 1.. in input order, every camera id used and distinct.
  REQUIRE(model.images.size() == 5);
  std::uint32_t expected = 1;
  for (const auto& [id, image] : model.images) {
    CHECK(id == expected);
    CHECK(image.name == in.images[expected - 1].name);
    CHECK(model.cameras.count(image.camera_id));
    CHECK((image.pose.centre() - in.images[expected - 1].centre).norm() < 1e-9);
    ++expected;
  }
  CHECK(model.cameras.size() == 3);
  // Point ids 1.., each observation a 2D point in COLMAP's convention, errors in the adjusted frames.
  REQUIRE(model.points3d.size() == 41);
  std::uint64_t point_id = 1;
  std::size_t kept = 0;
  for (std::size_t t = 0; t < in.tracks.size(); ++t) {
    const ExportTrack& track = in.tracks[t];
    if (!track.xyz.allFinite() || track.observations.empty()) continue;
    const ColmapPoint3D& p = model.points3d.at(point_id);
    CHECK(p.xyz == track.xyz);
    CHECK(p.rgb == std::array<std::uint8_t, 3>{{128, 128, 128}});
    REQUIRE(p.track.size() == track.observations.size());
    for (std::size_t o = 0; o < track.observations.size(); ++o) {
      const ColmapImage& image = model.images.at(p.track[o].image_id);
      CHECK(p.track[o].image_id == track.observations[o].image + 1);
      const ColmapPoint2D& xy = image.points2d.at(p.track[o].point2d_index);
      CHECK(xy.xy == track.observations[o].pixel + Vec2(0.5, 0.5));
      CHECK(xy.point3d_id == static_cast<std::int64_t>(point_id));
      if (t < in.exact_tracks) {
        // COLMAP's own projection of the point with the exported camera lands on the 2D point,
        // within the camera's conversion error.
        const ColmapCamera& camera = model.cameras.at(image.camera_id);
        const Vec2 colmap = test::colmap_projection(camera.model, camera.params, detail::colmap_qvec(image.pose),
                                                    image.pose.cam_from_world_translation(), p.xyz);
        CHECK((colmap - xy.xy).norm() <= 1.5 * report.max_conversion_error_px + 1e-6);
      }
    }
    CHECK(p.error == Approx(t < in.exact_tracks ? 0.0 : 2.5).margin(1e-6));
    ++point_id;
    ++kept;
  }
  CHECK(kept == 41);

  // images/: one link per image, named as in the model, to the file's absolute canonical path.
  for (std::size_t i = 0; i < in.images.size(); ++i) {
    const fs::path link = report.images_folder + "/" + in.images[i].name;
    REQUIRE(fs::is_symlink(link));
    const fs::path target = fs::read_symlink(link);
    CHECK(target.is_absolute());
    CHECK(target == fs::canonical(in.paths[i]));
    CHECK(colmapall_read(link.string()) == "placeholder " + in.images[i].name);
  }

  // Binary on request, into the same folder: the text files of the first run go, the model stays.
  AdjustedColmapOptions binary;
  binary.format = ColmapFormat::binary;
  binary.rgb = {{10, 20, 30}};
  const AdjustedColmapReport again = write_adjusted_colmap(in.images, in.paths, in.tracks, dir, binary);
  CHECK(again.format == ColmapFormat::binary);
  CHECK_FALSE(has_colmap_model(again.model_folder, ColmapFormat::text));
  const ColmapModel read_binary = read_colmap_model(again.model_folder, &format);
  CHECK(format == ColmapFormat::binary);
  CHECK(read_binary.points3d.at(7).rgb == std::array<std::uint8_t, 3>{{10, 20, 30}});
  ColmapModel recoloured = model;
  for (auto& entry : recoloured.points3d) entry.second.rgb = {{10, 20, 30}};
  CHECK(colmap_model_difference(read_binary, recoloured).value_or("none") == "none");
}

TEST_CASE("write_adjusted_colmap: refuses colliding names, missing files and bad observations before writing",
          "[io]") {
  const std::string dir = export_folder("colmap_all_refused");
  const ColmapallInput in = colmapall_input(dir + "/inputs");
  const auto refused = [&](const std::vector<CamerasJsonImage>& images, const std::vector<std::string>& paths,
                           const std::vector<ExportTrack>& tracks, const std::string& what,
                           const AdjustedColmapOptions& options = {}) {
    INFO(what);
    CHECK_THROWS_WITH(write_adjusted_colmap(images, paths, tracks, dir, options), Contains(what));
    CHECK_FALSE(fs::exists(dir + "/adjusted"));
  };
  std::vector<CamerasJsonImage> images = in.images;
  images[3].name = "e2/e2_a.png";  // e1's image named as e2's
  refused(images, in.paths, in.tracks, "images 1 (epoch 'e2') and 3 (epoch 'e1') are both named 'e2/e2_a.png'");
  images = in.images;
  images[0].name = "../e1_a.png";
  refused(images, in.paths, in.tracks, "is not a relative path inside images/");
  images[0].name = "/e1_a.png";
  refused(images, in.paths, in.tracks, "is not a relative path inside images/");
  images[0].name = "e1 a.png";
  refused(images, in.paths, in.tracks, "white space");
  images = in.images;
  images[4].epoch = "colmap";
  refused(images, in.paths, in.tracks, "epoch named 'colmap'");
  std::vector<std::string> paths = in.paths;
  paths[2] = dir + "/inputs/e1/images/nothing.png";
  refused(in.images, paths, in.tracks, "'" + paths[2] + "', does not exist");
  paths.pop_back();
  refused(in.images, paths, in.tracks, "4 image paths for 5 images");
  std::vector<ExportTrack> tracks = in.tracks;
  tracks[3].observations[0].image = 5;
  refused(in.images, in.paths, tracks, "track 3 observes image 5, but there are 5");
  tracks = in.tracks;
  tracks[1].observations[0].pixel.x() = std::numeric_limits<double>::infinity();
  refused(in.images, in.paths, tracks, "track 1 has a non-finite pixel");
  AdjustedColmapOptions options;
  options.protected_folders = {dir + "/inputs/e1"};
  fs::create_directories(dir + "/adjusted/colmap");
  fs::create_directory_symlink(dir + "/adjusted/colmap", dir + "/inputs/e1/model");
  options.protected_folders = {dir + "/inputs/e1/model"};
  CHECK_THROWS_WITH(write_adjusted_colmap(in.images, in.paths, in.tracks, dir, options), Contains("never overwritten"));
  CHECK(fs::is_empty(dir + "/adjusted/colmap"));
  // An entry of images/ that is not a link is never replaced.
  fs::create_directories(dir + "/adjusted/colmap/images/e2");
  std::ofstream(dir + "/adjusted/colmap/images/e2/e2_b.png") << "a real file";
  CHECK_THROWS_WITH(write_adjusted_colmap(in.images, in.paths, in.tracks, dir),
                    Contains("exists and is not a symbolic link"));
  CHECK_FALSE(fs::exists(dir + "/adjusted/colmap/sparse"));
  CHECK(colmapall_read(dir + "/adjusted/colmap/images/e2/e2_b.png") == "a real file");
}

TEST_CASE("write_adjusted_colmap: COLMAP's model_analyzer reads the model, every image and point", "[io]") {
  const std::optional<std::string> colmap = test::colmap_binary();
  if (!colmap) {
    WARN("skipped: the colmap binary is not installed (scripts/install_deps.sh installs it; DIACHRON_COLMAP names it)");
    return;
  }
  const std::string dir = export_folder("colmap_all_analyzer");
  const ColmapallInput in = colmapall_input(dir + "/inputs");
  for (const ColmapFormat format : {ColmapFormat::text, ColmapFormat::binary}) {
    AdjustedColmapOptions options;
    options.format = format;
    const AdjustedColmapReport report = write_adjusted_colmap(in.images, in.paths, in.tracks, dir, options);
    const std::string log = dir + "/model_analyzer.log";
    const std::string command = "'" + *colmap + "' model_analyzer --path '" + report.model_folder + "' > '" + log + "' 2>&1";
    const int status = std::system(command.c_str());
    const std::string output = colmapall_read(log);
    INFO(command << "\n" << output);
    REQUIRE(status == 0);
    CHECK_THAT(output, Contains("Cameras: 3"));
    CHECK_THAT(output, Contains("Images: 5"));
    CHECK_THAT(output, Contains("Registered images: 5"));
    CHECK_THAT(output, Contains("Points: 41"));
    CHECK_THAT(output, Contains("Observations: " + std::to_string(in.observations)));
  }
}
