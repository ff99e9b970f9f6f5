// Epoch folders with a binary COLMAP model (as COLMAP writes it): read as the text ones are, with
// the messages naming the .bin files; a text model beside it only when the two agree. MicMac
// projects (Ori-*/ and Homol/) read as the COLMAP model of the same synthetic epoch: the same
// frames, tracks triangulated near the model's points; the folders refused and why.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include <unistd.h>

#include <catch2/catch.hpp>

#include <diachron/core/raster.hpp>
#include <diachron/io/colmap_binary.hpp>
#include <diachron/io/colmap_text.hpp>
#include <diachron/io/epoch_folder.hpp>
#include <diachron/io/epoch_folder_check.hpp>
#include <diachron/io/geotiff.hpp>
#include <diachron/io/homol.hpp>
#include <diachron/synth/scene.hpp>
#include <diachron/synth/scene_io.hpp>

#include "support/scenes.hpp"
#include "support/temp_folder.hpp"

using namespace diachron;

namespace {

// One 40 x 30 px PINHOLE image "sub/a.png" (id 4) looking down from 100 units over a flat DSM at 0.
ColmapModel epochbin_model() {
  ColmapModel m;
  m.cameras[2] = ColmapCamera{2, "PINHOLE", 40, 30, {50.0, 52.0, 20.5, 15.0}};
  ColmapImage image;
  image.id = 4;
  image.name = "sub/a.png";
  image.camera_id = 2;
  image.pose = Pose::look_at(Vec3(10, 20, 100), Vec3(10, 20, 0));
  m.images[4] = image;
  return m;
}

// The epoch folder `name` with `model` in binary, its image and a flat DSM.
std::string epochbin_folder(const std::string& name, const ColmapModel& model) {
  const std::string dir = diachron::test::fresh_temp_folder("epochbin_" + name);
  write_colmap_binary(model, dir);
  make_folders(dir + "/images/sub", "epochbin_folder");
  Raster<std::uint8_t> pixels(40, 30);
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 40; ++x) pixels(x, y) = static_cast<std::uint8_t>(3 * x + 5 * y);
  write_image_u8(pixels, dir + "/images/sub/a.png");
  Raster<float> z(20, 20);
  for (float& v : z) v = 0.0f;
  write_geotiff_dsm(Dsm(z, GeoTransform::north_up(-40.0, 70.0, 5.0)), dir + "/dsm.tif");
  return dir;
}

}  // namespace

TEST_CASE("read_epoch_folder: a binary COLMAP model reads as the text one", "[io]") {
  const ColmapModel model = epochbin_model();
  const std::string dir = epochbin_folder("binary", model);
  const EpochFolder folder = read_epoch_folder(dir);
  CHECK(folder.model_format == ColmapFormat::binary);
  REQUIRE(folder.images.size() == 1);
  const EpochImage& image = folder.images[0];
  CHECK(image.id == 4);
  CHECK(image.name == "sub/a.png");
  CHECK(image.path == dir + "/images/sub/a.png");
  // PINHOLE: f = fy, B1 = fx - fy, principal point - 0.5 (diachron pixels).
  CHECK(image.frame.camera().focal() == 52.0);
  CHECK(image.frame.camera().cx() == 20.0);
  CHECK(image.frame.camera().cy() == 14.5);
  CHECK((image.frame.pose().centre() - Vec3(10, 20, 100)).norm() < 1e-12);
  CHECK(folder.load_image(0)(3, 2) == 3 * 3 + 5 * 2);

  // The same model as text beside it: read; a text model that differs: refused, naming both.
  write_colmap_text(model, dir);
  CHECK(read_epoch_folder(dir).model_format == ColmapFormat::binary);
  ColmapModel moved = model;
  moved.images.at(4).pose = Pose::look_at(Vec3(10, 20, 90), Vec3(10, 20, 0));
  write_colmap_text(moved, dir);
  CHECK_THROWS_WITH(read_epoch_folder(dir), Catch::Contains("holds a binary and a text COLMAP model that differ") &&
                                                Catch::Contains("image 4: pose"));
  for (const char* file : {"/cameras.txt", "/images.txt", "/points3D.txt"}) std::remove((dir + file).c_str());

  // Messages name the binary files.
  const std::string image_file = dir + "/images/sub/a.png";
  REQUIRE(std::rename(image_file.c_str(), (image_file + ".away").c_str()) == 0);
  CHECK_THROWS_WITH(read_epoch_folder(dir), Catch::Contains("image 'sub/a.png' (id 4 in images.bin) is missing from images/"));
  write_image_u8(Raster<std::uint8_t>(20, 30), image_file);
  const EpochFolder wrong = read_epoch_folder(dir);
  CHECK_THROWS_WITH(wrong.load_image(0), Catch::Contains("is 20 x 30 px but its camera in " + dir + "/cameras.bin is 40 x 30"));
  ColmapModel empty = model;
  empty.images.clear();
  write_colmap_binary(empty, dir);
  CHECK_THROWS_WITH(read_epoch_folder(dir), Catch::Contains("images.bin lists no image"));
  // A broken binary file stops the read with its name and byte.
  const std::string cut = epochbin_folder("cut", model);
  REQUIRE(::truncate((cut + "/images.bin").c_str(), 30) == 0);
  CHECK_THROWS_WITH(read_epoch_folder(cut), Catch::Contains("images.bin' byte 0: the number of images 1 needs at least"));
}

namespace {

// One epoch of the small test scene (2 images of 400 x 300 px, 300 tie points), generated once.
const Scene& micmacepoch_scene() {
  static const Scene scene = [] {
    SceneOptions options = diachron::test::small_scene_options(5, 300, 0);
    options.epochs.resize(1);
    return generate_scene(options);
  }();
  return scene;
}

// The scene written as `format` under a fresh folder `name`; returns its epoch folder.
std::string micmacepoch_write(const std::string& name, SceneEpochFormat format) {
  const std::string dir = diachron::test::temp_path("micmacepoch_" + name);
  SceneWriteOptions options;
  options.format = format;
  write_scene(micmacepoch_scene(), dir, options);
  return dir + "/" + micmacepoch_scene().epochs[0].name;
}

// The COLMAP points3D of `e` by their observations: (image name, pixel to 1e-4 px) -> position.
using MicmacepochKey = std::tuple<std::string, long long, long long>;
std::map<MicmacepochKey, Vec3> micmacepoch_points_by_observation(const EpochFolder& e) {
  std::map<MicmacepochKey, Vec3> out;
  for (const auto& [id, point] : e.model.points3d)
    for (const ColmapTrackElement& t : point.track) {
      const ColmapImage& image = e.model.images.at(t.image_id);
      const Vec2 px = diachron_pixel_from_colmap(image.points2d.at(t.point2d_index).xy);
      out[{image.name, std::llround(px.x() * 1e4), std::llround(px.y() * 1e4)}] = point.xyz;
    }
  return out;
}

}  // namespace

TEST_CASE("read_epoch_folder: a MicMac project reads as the COLMAP model of the same epoch", "[io][micmac]") {
  const SyntheticEpoch& truth = micmacepoch_scene().epochs[0];
  const EpochFolder colmap = read_epoch_folder(micmacepoch_write("colmap", SceneEpochFormat::colmap));
  const std::string dir = micmacepoch_write("micmac", SceneEpochFormat::micmac);
  const EpochFolder micmac = read_epoch_folder(dir);
  CHECK(colmap.source() == EpochSource::colmap_text);
  CHECK(micmac.source() == EpochSource::micmac);
  CHECK(std::string(epoch_source_name(micmac.source())) == "micmac");
  CHECK(micmac.micmac_ori == dir + "/Ori-SfM");

  // The same images and frames: poses to 1e-6, the cameras projecting alike (MicMac's Fraser holds
  // the estimated camera exactly: B1 = B2 = 0).
  REQUIRE(micmac.images.size() == colmap.images.size());
  REQUIRE(micmac.model.cameras.size() == 1);
  for (std::size_t i = 0; i < micmac.images.size(); ++i) {
    const EpochImage& m = micmac.images[i];
    CHECK(m.id == i + 1);
    CHECK(m.path == dir + "/images/" + m.name);
    CHECK(m.mask_path.empty());
    CHECK(m.conversion_error_px == 0.0);
    const std::size_t k = colmap.find(m.name);
    REQUIRE(k < colmap.images.size());
    const Frame<FraserAffine>& c = colmap.images[k].frame;
    CHECK((m.frame.pose().cam_from_world_rotation() - c.pose().cam_from_world_rotation()).cwiseAbs().maxCoeff() < 1e-6);
    CHECK((m.frame.pose().centre() - c.pose().centre()).norm() < 1e-6);
    CHECK(m.frame.camera().width() == c.camera().width());
    double worst = 0.0;
    for (const TiePoint& tie : truth.tie_points) {
      const std::optional<Vec2> a = m.frame.project(tie.epoch), b = c.project(tie.epoch);
      if (a && b) worst = std::max(worst, (*a - *b).norm());
    }
    CHECK(worst < 1e-6 + m.conversion_error_px + colmap.images[k].conversion_error_px);
    CHECK(micmac.model.images.at(m.id).name == m.name);
    CHECK(micmac.model.images.at(m.id).pose.centre() == m.frame.pose().centre());
  }
  CHECK(micmac.load_image(0).width() == truth.camera.width());

  // The tracks: one Homol file per pair read (the other direction skipped), nearly every tie point
  // kept, each near the COLMAP model's point of the same observations. That point is the true one;
  // the MicMac one is triangulated from pixels with 0.3 px noise over a base of 0.4 image widths,
  // which puts it a median 0.4 GSD off across and 0.6 GSD along the rays (measured), without bias.
  const MicmacTiePointReport& r = micmac.micmac_ties;
  CHECK(r.homol_dir == dir + "/Homol");
  CHECK(r.files == 1);
  CHECK(r.skipped_files == 0);
  CHECK(r.tie_points == truth.tie_points.size());
  CHECK(r.tracks.dropped_conflicting == 0);
  CHECK(r.points == micmac.model.points3d.size());
  CHECK(r.points + r.failed_triangulation + r.large_reprojection == r.tracks.tracks);
  CHECK(r.points >= colmap.model.points3d.size() * 95 / 100);
  const std::map<MicmacepochKey, Vec3> colmap_points = micmacepoch_points_by_observation(colmap);
  std::vector<double> distances, across;
  double mean_dz = 0.0;
  for (const auto& [id, point] : micmac.model.points3d) {
    REQUIRE(point.track.size() == 2);
    CHECK(point.error >= 0.0);
    CHECK(point.error <= 3.0);
    const ColmapImage& image = micmac.model.images.at(point.track[0].image_id);
    const ColmapPoint2D& p2 = image.points2d.at(point.track[0].point2d_index);
    CHECK(p2.point3d_id == static_cast<std::int64_t>(id));
    const Vec2 px = diachron_pixel_from_colmap(p2.xy);
    const auto it = colmap_points.find({image.name, std::llround(px.x() * 1e4), std::llround(px.y() * 1e4)});
    REQUIRE(it != colmap_points.end());
    const Vec3 d = point.xyz - it->second;
    distances.push_back(d.norm());
    across.push_back(d.head<2>().norm());
    mean_dz += d.z();
  }
  REQUIRE(!distances.empty());
  mean_dz /= static_cast<double>(distances.size());
  std::sort(distances.begin(), distances.end());
  std::sort(across.begin(), across.end());
  const double gsd = truth.gsd_m / truth.world_from_epoch.scale;  // epoch-frame units per px
  INFO("median distance " << distances[distances.size() / 2] << ", horizontal " << across[across.size() / 2]
                          << ", mean dz " << mean_dz << ", GSD " << gsd << " epoch units");
  CHECK(distances[distances.size() / 2] < 1.0 * gsd);
  CHECK(across[across.size() / 2] < 0.5 * gsd);
  CHECK(std::abs(mean_dz) < 0.2 * gsd);

  // Downstream: the model-against-DSM check sees the triangulated points on the DSM.
  const EpochFolderCheck check = check_epoch_folder(micmac);
  CHECK_FALSE(check.refused());
  CHECK(check.agreement.verdict == ModelDsmVerdict::agree);

  // read_scene (score_epochs) takes the MicMac epoch's estimated camera and poses from Ori-SfM, and
  // its tie points' positions from the truth, without observations (Homol holds pairs).
  const Scene back = read_scene(dir.substr(0, dir.rfind('/')));
  const SyntheticEpoch& e = back.epochs.at(0);
  REQUIRE(e.images.size() == truth.images.size());
  REQUIRE(e.tie_points.size() == truth.tie_points.size());
  for (std::size_t i = 0; i < e.images.size(); ++i) {
    double worst = 0.0;
    for (const TiePoint& tie : truth.tie_points) {
      const std::optional<Vec2> a = e.estimated_frame(i).project(tie.epoch);
      const std::optional<Vec2> b = truth.estimated_frame(i).project(tie.epoch);
      if (a && b) worst = std::max(worst, (*a - *b).norm());
    }
    CHECK(worst < 1e-6);
  }
  for (std::size_t k = 0; k < e.tie_points.size(); ++k) {
    CHECK((e.tie_points[k].epoch - truth.tie_points[k].epoch).norm() < 1e-9 * (1.0 + truth.tie_points[k].epoch.norm()));
    CHECK(e.tie_points[k].observations.empty());
  }
}

TEST_CASE("read_epoch_folder: MicMac images at the project's top, a Homol suffix, filtered tie points",
          "[io][micmac]") {
  const std::string dir = micmacepoch_write("variants", SceneEpochFormat::micmac);
  const std::size_t all = read_epoch_folder(dir).model.points3d.size();
  REQUIRE(all > 100);
  const std::vector<std::string> names = {micmacepoch_scene().epochs[0].images[0].name + ".png",
                                          micmacepoch_scene().epochs[0].images[1].name + ".png"};

  // MicMac keeps the images beside Ori-*/: read there when images/ does not hold them.
  std::filesystem::rename(dir + "/images/" + names[0], dir + "/" + names[0]);
  const EpochFolder top = read_epoch_folder(dir);
  CHECK(top.images[0].path == dir + "/" + names[0]);
  CHECK(top.images[1].path == dir + "/images/" + names[1]);
  std::filesystem::remove(dir + "/" + names[0]);
  CHECK_THROWS_WITH(read_epoch_folder(dir), Catch::Contains("image '" + names[0] + "' (") &&
                                                Catch::Contains("Orientation-" + names[0] + ".xml") &&
                                                Catch::Contains("is in neither images/ nor the folder itself"));
  std::filesystem::copy_file(dir + "/images/" + names[1], dir + "/images/" + names[0]);

  // Only the backward file of the pair: read, swapped.
  const std::string forward = homol_file_path(dir + "/Homol", names[0], names[1]);
  const PointMatches matches = read_homol(forward);
  std::filesystem::remove(forward);
  CHECK(read_epoch_folder(dir).model.points3d.size() == all);
  write_homol(dir + "/Homol", names[0], names[1], matches);

  // A wrong tie point, 20 px off across the flight line: its track is dropped for its reprojection.
  PointMatches wrong = matches;
  wrong[0].b.y() += 20.0;
  write_homol(dir + "/Homol", names[0], names[1], wrong);
  const EpochFolder filtered = read_epoch_folder(dir);
  CHECK(filtered.micmac_ties.large_reprojection == 1);
  CHECK(filtered.model.points3d.size() == all - 1);
  write_homol(dir + "/Homol", names[0], names[1], matches);

  // A pair with an image the orientation does not hold is skipped and counted.
  write_homol(dir + "/Homol", names[0], "unoriented.tif", PointMatches(matches.begin(), matches.begin() + 3));
  const EpochFolder skipped = read_epoch_folder(dir);
  CHECK(skipped.micmac_ties.skipped_files == 1);
  CHECK(skipped.model.points3d.size() == all);

  // Homol<SH>: MicmacEpochOptions::homol names it; without it the model has no points, and the
  // check warns that it cannot compare the model with the DSM.
  std::filesystem::rename(dir + "/Homol", dir + "/Homol-Guided");
  const EpochFolder none = read_epoch_folder(dir);
  CHECK(none.model.points3d.empty());
  CHECK(none.micmac_ties.homol_dir.empty());
  CHECK(none.model.images.size() == 2);
  const EpochFolderCheck check = check_epoch_folder(none);
  CHECK(std::any_of(check.issues.begin(), check.issues.end(), [](const EpochCheckIssue& i) {
    return i.check == "model_dsm" && i.severity == EpochCheckSeverity::warning;
  }));
  MicmacEpochOptions guided;
  guided.homol = "Homol-Guided";
  CHECK(read_epoch_folder(dir, {}, {}, guided).model.points3d.size() == all);
}

TEST_CASE("read_epoch_folder: MicMac folders it refuses, and how to choose an orientation", "[io][micmac]") {
  const std::string dir = micmacepoch_write("refusals", SceneEpochFormat::micmac);
  const EpochFolder one = read_epoch_folder(dir);

  // Two orientations, none named: refused, listing both and saying how to choose.
  std::filesystem::copy(dir + "/Ori-SfM", dir + "/Ori-Other");
  CHECK_THROWS_WITH(read_epoch_folder(dir), Catch::Contains("several MicMac orientations (Ori-Other, Ori-SfM)") &&
                                                Catch::Contains("MicmacEpochOptions::ori"));
  MicmacEpochOptions named;
  for (const char* ori : {"Other", "Ori-Other"}) {
    named.ori = ori;
    const EpochFolder other = read_epoch_folder(dir, {}, {}, named);
    CHECK(other.micmac_ori == dir + "/Ori-Other");
    CHECK(other.model.points3d.size() == one.model.points3d.size());
  }
  named.ori = "Missing";
  CHECK_THROWS_WITH(read_epoch_folder(dir, {}, {}, named), Catch::Contains("Ori-Missing' is not a folder"));
  named.ori = "a/b";
  CHECK_THROWS_WITH(read_epoch_folder(dir, {}, {}, named), Catch::Contains("must contain no '/'"));

  // An Ori folder without Orientation files does not count; alone, it is refused.
  std::filesystem::remove_all(dir + "/Ori-Other");
  std::filesystem::create_directories(dir + "/Ori-Empty");
  CHECK(read_epoch_folder(dir).micmac_ori == dir + "/Ori-SfM");
  std::filesystem::rename(dir + "/Ori-SfM", dir + "/Ori-Away");
  for (const auto& entry : std::filesystem::directory_iterator(dir + "/Ori-Away"))
    if (entry.path().filename().string().rfind("Orientation-", 0) == 0) std::filesystem::remove(entry.path());
  CHECK_THROWS_WITH(read_epoch_folder(dir), Catch::Contains("holds no COLMAP model and its MicMac orientation folders "
                                                            "(Ori-Away, Ori-Empty) hold no Orientation-<image>.xml"));
  named.ori = "Away";
  CHECK_THROWS_WITH(read_epoch_folder(dir, {}, {}, named), Catch::Contains("no Orientation-<image>.xml in"));

  // MicMac's binary tie points are refused rather than silently left out.
  const std::string binary = micmacepoch_write("binary", SceneEpochFormat::micmac);
  std::filesystem::remove_all(binary + "/Homol");
  std::filesystem::create_directories(binary + "/Homol/Pastisa.tif");
  std::FILE* dat = std::fopen((binary + "/Homol/Pastisa.tif/b.tif.dat").c_str(), "wb");
  REQUIRE(dat != nullptr);
  std::fclose(dat);
  CHECK_THROWS_WITH(read_epoch_folder(binary), Catch::Contains("Homol/Pastisa.tif/b.tif.dat is MicMac's binary "
                                                               "tie-point form, which is not read"));

  // A COLMAP model beside the orientation is read first unless the orientation is named.
  const std::string both = micmacepoch_write("both", SceneEpochFormat::micmac);
  write_colmap_text(one.model, both);
  CHECK(read_epoch_folder(both).source() == EpochSource::colmap_text);
  named.ori = "SfM";
  CHECK(read_epoch_folder(both, {}, {}, named).source() == EpochSource::micmac);
}
