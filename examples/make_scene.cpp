/// @file
/// make_scene: generates a synthetic multi-epoch scene and writes it to a folder as each epoch's
/// SfM would deliver it (per epoch: images, a COLMAP text model of the estimated orientation, or
/// with --micmac a MicMac project's Ori-SfM/ and Homol/, the DSM), with the truth apart in truth/
/// (docs/synthetic-scenes.md), then prints a summary.
///
///   make_scene OUT_DIR [--preset plain|decades] [--seed N] [--dem PATH] [--images-per-epoch RxC]
///              [--image-size WxH] [--epochs N] [--check-points N] [--dome M] [--offset X,Y]
///              [--scan-frame PX] [--control-points N] [--ortho-reference] [--model-offset NAME=DX,DY,DZ]
///              [--micmac] [--scan-px N] [--threads N]
///
/// `--preset decades` starts from SceneOptions::decades_apart(N) (`--epochs N`, 2 to 5, default 2)
/// and the other flags apply on top of it, so that `make_scene OUT --preset decades --seed S` writes
/// exactly the scene generate_scene() makes from decades_apart() with seed S. `--ortho-reference`
/// then delivers the last epoch as a true orthophoto and its true surface (synth/ortho_reference.hpp)
/// instead of images and a model. `--scan-px N` writes the film epochs as square N x N scans and every
/// epoch N / (film width) times larger than rendered (synth/full_size_scan.hpp), one image at a time.

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <chrono>
#include <cmath>
#include <ctime>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <optional>
#include <stdexcept>
#include <string>
#include <system_error>
#include <type_traits>
#include <utility>
#include <vector>

#include <diachron/io/colmap_text.hpp>
#include <diachron/io/dsm_reproject.hpp>
#include <diachron/io/folders.hpp>
#include <diachron/io/geotiff.hpp>
#include <diachron/synth/full_size_scan.hpp>
#include <diachron/synth/ortho_reference.hpp>
#include <diachron/synth/scan_frame.hpp>
#include <diachron/synth/scene.hpp>
#include <diachron/synth/scene_io.hpp>

namespace {

constexpr const char* kUsage =
    "usage: make_scene OUT_DIR [options]\n"
    "  --preset NAME            plain (default: the small test scene) or decades (SceneOptions::decades_apart(N)\n"
    "                           with N = --epochs; the options below apply on top of it)\n"
    "  --seed N                 random seed (default 0)\n"
    "  --dem PATH               real DEM (GeoTIFF) as terrain instead of procedural relief (one in\n"
    "                           degrees is first reprojected to its UTM zone)\n"
    "  --images-per-epoch RxC   flight lines x images per line of every epoch (plain default 2x3)\n"
    "  --image-size WxH         image size in pixels (plain default 400x300; focal length scales with W)\n"
    "  --epochs N               number of epochs, oldest first (default 2; plain: 1 to 100, the last one\n"
    "                           recent; decades: 2 to 5, film flights of the 1950s to 1980s and a recent one)\n"
    "  --check-points N         check points wanted (plain default 100)\n"
    "  --dome M                 dome bending of every epoch DSM, metres (plain default 0)\n"
    "  --offset X,Y             world X, Y of the scene centre, metres (default 0,0; procedural only)\n"
    "  --flying-height M        flying height of every epoch above the mean ground, metres\n"
    "  --scan-frame PX          draw a scan's film frame (a dark band of PX px with fiducial marks and a\n"
    "                           data strip) over the images of every epoch but the last, and write their\n"
    "                           masks as OUT/<epoch>/masks/<image>.png (0 on the frame; default 0: none)\n"
    "  --control-points N       also write OUT/control_points.txt and OUT/check_points.txt (io/\n"
    "                           control_points.hpp): of the check points seen in 2 or more images of the\n"
    "                           first epoch, the first N and the others, positions in the last epoch's\n"
    "                           frame (sigma 0.1 m), their true pixels; for match_epochs --gcps and\n"
    "                           --check-points. score_epochs still scores all (default 0: none)\n"
    "  --ortho-reference        deliver the last epoch as a national reference is: OUT/<epoch>/ortho.tif, a\n"
    "                           true orthophoto (8-bit grey GeoTIFF rendered straight down at that epoch's\n"
    "                           GSD, north-up in its frame, over its images' footprints) and dsm.tif, its\n"
    "                           true surface in that frame; no images nor COLMAP model (older epochs as\n"
    "                           without the flag)\n"
    "  --model-offset NAME=DX,DY,DZ  move epoch NAME's SfM model (its cameras' centres in images.txt and its\n"
    "                           points in points3D.txt) by DX, DY, DZ epoch units and leave its DSM where\n"
    "                           it is: a model and a DSM that disagree, as a COLMAP model poorly aligned\n"
    "                           with model_aligner is (match_epochs must refuse it); the truth is not\n"
    "                           moved (default: none)\n"
    "  --micmac                 write each photo epoch as a MicMac project instead of a COLMAP model:\n"
    "                           OUT/<epoch>/Ori-SfM/ (the estimated camera and poses, Orientation-<image>.xml\n"
    "                           and AutoCal-<epoch>-0.xml) and OUT/<epoch>/Homol/ (every pair of observations\n"
    "                           of each tie point, both directions); images/, dsm.tif and the truth as\n"
    "                           without it (not with --model-offset)\n"
    "  --scan-px N              full-size scans: the film epochs (all but the last) become square, rendered\n"
    "                           W x W (W their width, 1600 with the decades preset, or --image-size's) and\n"
    "                           written N x N; every epoch is written k = N / W times larger than rendered\n"
    "                           (cameras, truth pixels scaled; the recent epoch keeps its finer GSD), each\n"
    "                           image rebuilt from the ground position of its rendered pixels with a fine\n"
    "                           ground texture and the film's look at full size (synth/full_size_scan.hpp);\n"
    "                           N >= W, k W and k H whole (not with --scan-frame nor --ortho-reference)\n"
    "  --threads N              worker threads, 0 = all cores (default 0)\n";

// Flags that are not given leave the preset's value alone.
struct Arguments {
  std::string out_dir;
  std::string preset = "plain";
  std::uint64_t seed = 0;
  std::optional<std::string> dem;
  std::optional<std::pair<int, int>> block, size;
  std::optional<int> epochs, check_points;
  std::optional<double> dome, flying_height;
  std::optional<std::pair<double, double>> offset;
  int scan_frame_px = 0;
  int control_points = 0;
  int scan_px = 0;
  bool ortho_reference = false;
  bool micmac = false;
  std::optional<std::pair<std::string, diachron::Vec3>> model_offset;  // --model-offset NAME=DX,DY,DZ
  std::size_t threads = 0;
};

[[noreturn]] void usage_error(const std::string& message) {
  std::cerr << "make_scene: " << message << "\n" << kUsage;
  std::exit(1);
}

// A whole number of T or a finite double: the whole text, no sign for an unsigned type, no white
// space, within T's range (std::stoll would take "-1" as 2^64 - 1 for a count, std::stod "nan").
template <class T>
T parse_number(const std::string& text, const std::string& option) {
  T value{};
  bool parsed = false;
  if constexpr (std::is_floating_point_v<T>) {
    char* end = nullptr;
    errno = 0;
    value = std::strtod(text.c_str(), &end);
    parsed = !text.empty() && !std::isspace(static_cast<unsigned char>(text[0])) &&
             end == text.c_str() + text.size() && errno == 0 && std::isfinite(value);
  } else {
    const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    parsed = ec == std::errc() && ptr == text.data() + text.size();
  }
  if (!parsed) usage_error("bad value '" + text + "' for " + option + " (a finite number" +
                           (std::is_floating_point_v<T> ? ")" : ", whole, in range)"));
  return value;
}

std::pair<std::string, std::string> split(const std::string& text, char separator, const std::string& option) {
  const auto at = text.find(separator);
  if (at == std::string::npos) usage_error("bad value '" + text + "' for " + option);
  return {text.substr(0, at), text.substr(at + 1)};
}

Arguments parse(int argc, char** argv) {
  Arguments a;
  std::vector<std::string> args(argv + 1, argv + argc);
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    if (arg == "-h" || arg == "--help") {
      std::cout << kUsage;
      std::exit(0);
    }
    if (arg == "--ortho-reference") {
      a.ortho_reference = true;
      continue;
    }
    if (arg == "--micmac") {
      a.micmac = true;
      continue;
    }
    if (arg.rfind("--", 0) == 0) {
      if (i + 1 >= args.size()) usage_error("missing value for " + arg);
      const std::string value = args[++i];
      if (arg == "--preset") {
        if (value != "plain" && value != "decades") usage_error("unknown preset '" + value + "' (plain or decades)");
        a.preset = value;
      } else if (arg == "--seed") {
        a.seed = parse_number<std::uint64_t>(value, arg);
      } else if (arg == "--dem") {
        a.dem = value;
      } else if (arg == "--images-per-epoch") {
        const auto [r, c] = split(value, 'x', arg);
        a.block = std::make_pair(parse_number<int>(r, arg), parse_number<int>(c, arg));
        if (a.block->first < 1 || a.block->second < 1) usage_error("--images-per-epoch needs positive RxC");
      } else if (arg == "--image-size") {
        const auto [w, h] = split(value, 'x', arg);
        a.size = std::make_pair(parse_number<int>(w, arg), parse_number<int>(h, arg));
        if (a.size->first < 16 || a.size->second < 16) usage_error("--image-size needs at least 16x16");
      } else if (arg == "--epochs") {
        a.epochs = parse_number<int>(value, arg);  // its range depends on the preset, checked below
      } else if (arg == "--check-points") {
        a.check_points = parse_number<int>(value, arg);
        if (*a.check_points < 0) usage_error("--check-points must be >= 0");
      } else if (arg == "--dome") {
        a.dome = parse_number<double>(value, arg);
      } else if (arg == "--offset") {
        const auto [x, y] = split(value, ',', arg);
        a.offset = std::make_pair(parse_number<double>(x, arg), parse_number<double>(y, arg));
      } else if (arg == "--flying-height") {
        a.flying_height = parse_number<double>(value, arg);
        if (!(*a.flying_height > 0.0)) usage_error("--flying-height must be > 0");
      } else if (arg == "--scan-frame") {
        a.scan_frame_px = parse_number<int>(value, arg);
        if (a.scan_frame_px < 0) usage_error("--scan-frame must be >= 0");
      } else if (arg == "--scan-px") {
        a.scan_px = parse_number<int>(value, arg);
        if (a.scan_px < 16 || a.scan_px > 100000) usage_error("--scan-px must be in [16, 100000]");
      } else if (arg == "--control-points") {
        a.control_points = parse_number<int>(value, arg);
        if (a.control_points < 0) usage_error("--control-points must be >= 0");
      } else if (arg == "--model-offset") {
        const auto [name, rest] = split(value, '=', arg);
        const auto [dx, yz] = split(rest, ',', arg);
        const auto [dy, dz] = split(yz, ',', arg);
        const diachron::Vec3 d(parse_number<double>(dx, arg), parse_number<double>(dy, arg), parse_number<double>(dz, arg));
        if (name.empty() || !d.allFinite()) usage_error("--model-offset wants NAME=DX,DY,DZ, finite numbers");
        a.model_offset = std::make_pair(name, d);
      } else if (arg == "--threads") {
        a.threads = static_cast<std::size_t>(parse_number<std::uint64_t>(value, arg));
        if (a.threads > 4096) usage_error("--threads must be in [0, 4096]");
      } else {
        usage_error("unknown option " + arg);
      }
    } else if (a.out_dir.empty()) {
      a.out_dir = arg;
    } else {
      usage_error("more than one output folder given");
    }
  }
  if (a.out_dir.empty()) usage_error("missing OUT_DIR");
  if (a.epochs && a.preset == "decades" && (*a.epochs < 2 || *a.epochs > 5))
    usage_error("--epochs must be in [2, 5] with --preset decades");
  if (a.epochs && a.preset == "plain" && (*a.epochs < 1 || *a.epochs > 100)) usage_error("--epochs must be in [1, 100]");
  if (a.ortho_reference && a.epochs && *a.epochs < 2) usage_error("--ortho-reference needs at least two epochs");
  // --model-offset edits the written COLMAP model, which a MicMac epoch does not have.
  if (a.micmac && a.model_offset) usage_error("--model-offset moves a COLMAP model: not with --micmac");
  if (a.scan_px > 0 && (a.scan_frame_px > 0 || a.ortho_reference))
    usage_error("--scan-px is not available with --scan-frame nor --ortho-reference");
  return a;
}

// The plain preset: the small test scene, with as many epochs as asked (the last one recent).
diachron::SceneOptions plain_options(int epochs) {
  diachron::SceneOptions options;
  options.epochs.clear();
  for (int e = 0; e < epochs; ++e) {
    // The last epoch is the recent one; older ones are historical with their own headings.
    const std::string name = "e" + std::to_string(e + 1);
    diachron::EpochOptions epoch =
        e + 1 == epochs && epochs > 1 ? diachron::EpochOptions::recent(name) : diachron::EpochOptions::historical(name);
    if (e + 1 < epochs) epoch.heading_deg = -25.0 * e;
    options.epochs.push_back(epoch);
  }
  return options;
}

diachron::SceneOptions scene_options(const Arguments& args) {
  diachron::SceneOptions options =
      args.preset == "decades" ? diachron::SceneOptions::decades_apart(args.epochs.value_or(2))
                               : plain_options(args.epochs.value_or(2));
  options.seed = args.seed;
  options.threads = args.threads;
  if (args.check_points) options.check_points = *args.check_points;
  if (args.offset) {
    options.terrain.centre_x_m = args.offset->first;
    options.terrain.centre_y_m = args.offset->second;
  }
  for (diachron::EpochOptions& epoch : options.epochs) {
    if (args.block) {
      epoch.rows = args.block->first;
      epoch.columns = args.block->second;
    }
    if (args.size) {
      epoch.focal_px *= static_cast<double>(args.size->first) / epoch.image_width_px;
      epoch.image_width_px = args.size->first;
      epoch.image_height_px = args.size->second;
    }
    if (args.dome) epoch.dsm.dome_m = *args.dome;
    if (args.flying_height) epoch.set_flying_height_keeping_gsd(*args.flying_height);
  }
  // Film frames are square (23 x 23 cm): the film epochs are rendered W x W.
  if (args.scan_px > 0)
    for (std::size_t e = 0; e + 1 < std::max<std::size_t>(options.epochs.size(), 2); ++e)
      options.epochs[e].image_height_px = options.epochs[e].image_width_px;
  return options;
}

// The factor of --scan-px: written pixels per rendered pixel, from the first (film) epoch's width.
double scan_scale(const Arguments& args, const diachron::SceneOptions& options) {
  const double k = static_cast<double>(args.scan_px) / options.epochs.front().image_width_px;
  if (k < 1.0)
    usage_error("--scan-px " + std::to_string(args.scan_px) + " is below the rendered width " +
                std::to_string(options.epochs.front().image_width_px) + " px");
  for (const diachron::EpochOptions& e : options.epochs) {
    const double w = k * e.image_width_px, h = k * e.image_height_px;
    if (std::abs(w - std::round(w)) > 1e-9 * w || std::abs(h - std::round(h)) > 1e-9 * h)
      usage_error("--scan-px " + std::to_string(args.scan_px) + ": epoch " + e.name + "'s " +
                  std::to_string(e.image_width_px) + " x " + std::to_string(e.image_height_px) + " px times " +
                  std::to_string(k) + " is not whole; choose N so that it is");
  }
  return k;
}

// Writes full-size scans band by band into a GDAL memory image, then as PNG (fast deflate): one
// image at a time, so the scene never holds its full-size images. Caches the current epoch's renderer.
class ScanWriter {
 public:
  ScanWriter(const diachron::Scene& scene, const diachron::SceneOptions& options, double scale)
      : scene_(scene), options_(options) {
    scan_.scale = scale;
    scan_.threads = options.threads;
  }

  void operator()(std::size_t epoch, std::size_t image, const std::string& path) {
    if (!renderer_ || epoch_ != epoch) {
      renderer_.reset();
      renderer_.emplace(scene_, epoch, options_.epochs.at(epoch).look, scan_);
      epoch_ = epoch;
    }
    const auto t0 = std::chrono::steady_clock::now();
    diachron::detail::gdal_register_once();
    const diachron::detail::QuietGdalErrors quiet;
    GDALDriver* mem = GetGDALDriverManager()->GetDriverByName("MEM");
    GDALDriver* png = GetGDALDriverManager()->GetDriverByName("PNG");
    if (!mem || !png) throw diachron::Error("cannot write '" + path + "': GDAL has no MEM or PNG driver");
    const int w = renderer_->width(), h = renderer_->height();
    diachron::detail::GdalDatasetPtr tmp(mem->Create("", w, h, 1, GDT_Byte, nullptr));
    if (!tmp) throw diachron::Error("cannot write '" + path + "': cannot allocate " + std::to_string(w) + " x " +
                                    std::to_string(h) + " px");
    renderer_->render(image, [&](int first_row, const diachron::Raster<std::uint8_t>& band) {
      const CPLErr err = tmp->GetRasterBand(1)->RasterIO(GF_Write, 0, first_row, w, band.height(),
                                                         const_cast<std::uint8_t*>(band.data()), w, band.height(),
                                                         GDT_Byte, 0, 0, nullptr);
      if (err != CE_None) throw diachron::Error("cannot write '" + path + "': copy failed");
    });
    const auto t1 = std::chrono::steady_clock::now();
    char** create = CSLSetNameValue(nullptr, "ZLEVEL", "1");
    diachron::detail::GdalDatasetPtr out(png->CreateCopy(path.c_str(), tmp.get(), FALSE, create, nullptr, nullptr));
    CSLDestroy(create);
    if (!out) throw diachron::Error("cannot write '" + path + "'" + diachron::detail::QuietGdalErrors::last_message());
    diachron::detail::close_written(out, path);
    const auto t2 = std::chrono::steady_clock::now();
    std::fprintf(stderr, "make_scene: %s %dx%d px: rendered in %.1f s, PNG in %.1f s\n", path.c_str(), w, h,
                 std::chrono::duration<double>(t1 - t0).count(), std::chrono::duration<double>(t2 - t1).count());
  }

 private:
  const diachron::Scene& scene_;
  const diachron::SceneOptions& options_;
  diachron::FullSizeScanOptions scan_;
  std::optional<diachron::FullSizeEpochRenderer> renderer_;
  std::size_t epoch_ = 0;
};

// Writes the check points seen in 2 or more images of the first epoch as two files of
// io/control_points.hpp's layout: the first `count` to `control_path`, the others to `check_path`.
// Positions in the last epoch's frame (its units; sigma 0.1 m), the true pixels in the first
// epoch's images (named as write_scene names them: <name>.png). Returns how many control points
// and check points it wrote.
std::pair<int, int> write_point_files(const diachron::Scene& scene, int count, const std::string& control_path,
                                      const std::string& check_path) {
  const diachron::SyntheticEpoch& first = scene.epochs.front();
  const diachron::Helmert3 reference_from_world = scene.epochs.back().epoch_from_world();
  std::FILE* files[2] = {std::fopen(control_path.c_str(), "w"), std::fopen(check_path.c_str(), "w")};
  if (!files[0] || !files[1]) {
    for (std::FILE* f : files)
      if (f) std::fclose(f);
    throw diachron::Error("cannot write " + control_path + " or " + check_path);
  }
  const char* kinds[2] = {"control", "check"};
  for (int f = 0; f < 2; ++f)
    std::fprintf(files[f], "# make_scene: check points of the scene as %s points of %s against %s (positions in %s's\n"
                           "# frame, its units; true pixels, diachron convention). io/control_points.hpp\n",
                 kinds[f], first.name.c_str(), scene.epochs.back().name.c_str(), scene.epochs.back().name.c_str());
  int written[2] = {0, 0};
  for (std::size_t k = 0; k < scene.check_points.size(); ++k) {
    const diachron::CheckPoint& cp = scene.check_points[k];
    std::vector<const diachron::CheckPoint::Observation*> seen;
    for (const auto& o : cp.observations)
      if (o.epoch == 0) seen.push_back(&o);
    if (seen.size() < 2) continue;
    const int which = written[0] < count ? 0 : 1;
    const diachron::Vec3 p = reference_from_world(cp.world);
    std::fprintf(files[which], "point cp%zu %.6f %.6f %.6f %.6f\n", k, p.x(), p.y(), p.z(),
                 0.1 * reference_from_world.scale);
    for (const auto* o : seen)
      std::fprintf(files[which], "obs cp%zu %s.png %.4f %.4f\n", k,
                   first.images[static_cast<std::size_t>(o->image)].name.c_str(), o->pixel.x(), o->pixel.y());
    ++written[which];
  }
  const bool ok = std::fclose(files[0]) == 0 && std::fclose(files[1]) == 0;
  if (!ok) throw diachron::Error("cannot write " + control_path + " or " + check_path);
  return {written[0], written[1]};
}

}  // namespace

int main(int argc, char** argv) {
  const Arguments args = parse(argc, argv);
  try {
    diachron::SceneOptions options = scene_options(args);
    if (args.dem) {
      diachron::GeoTiffReadOptions read;
      read.assume_untagged_nodata = true;
      // Cells in degrees under heights in metres would make a flat, stretched world: the terrain
      // goes to metres first.
      std::string utm;
      options.real_dem = diachron::dsm_in_metres(diachron::read_geotiff_dsm(*args.dem, read), &utm);
      if (!utm.empty())
        std::fprintf(stderr, "make_scene: %s is in degrees; reprojected to %s\n", args.dem->c_str(), utm.c_str());
    }

    const double scale = args.scan_px > 0 ? scan_scale(args, options) : 1.0;
    const auto t0 = std::chrono::steady_clock::now();
    const std::clock_t c0 = std::clock();
    diachron::Scene scene = diachron::generate_scene(options);
    if (args.scan_px > 0) diachron::scale_scene_images(scene, scale);
    if (args.ortho_reference) {
      diachron::OrthoReferenceOptions ortho;
      ortho.threads = args.threads;
      diachron::make_ortho_reference(scene, options, scene.epochs.size() - 1, ortho);
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const double cpu_seconds = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
    // The film epochs' scans keep their frame; the masks say where it is (COLMAP's names).
    std::vector<std::pair<std::string, diachron::Raster<std::uint8_t>>> masks;
    if (args.scan_frame_px > 0)
      for (std::size_t e = 0; e + 1 < scene.epochs.size(); ++e)
        for (std::size_t i = 0; i < scene.epochs[e].images.size(); ++i) {
          diachron::SyntheticImage& image = scene.epochs[e].images[i];
          diachron::ScanFrameOptions frame;
          frame.band_px = args.scan_frame_px;
          frame.seed = scene.seed * 1000 + e * 100 + i;
          masks.emplace_back(scene.epochs[e].name + "/masks/" + image.name + ".png.png",
                             diachron::draw_scan_frame(image.pixels, frame));
        }
    if (args.model_offset) {
      const bool known = std::any_of(scene.epochs.begin(), scene.epochs.end(), [&](const diachron::SyntheticEpoch& e) {
        return e.name == args.model_offset->first && !e.orthophoto;
      });
      if (!known) usage_error("--model-offset: no epoch with a model is named '" + args.model_offset->first + "'");
    }
    diachron::SceneWriteOptions write;
    if (args.micmac) write.format = diachron::SceneEpochFormat::micmac;
    std::optional<ScanWriter> scans;
    if (args.scan_px > 0) {
      scans.emplace(scene, options, scale);
      write.write_image = [&scans](std::size_t e, std::size_t i, const std::string& path) { (*scans)(e, i, path); };
    }
    const auto w0 = std::chrono::steady_clock::now();
    diachron::write_scene(scene, args.out_dir, write);
    scans.reset();
    const double write_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count();
    if (args.model_offset) {
      // The written model is moved, not the scene: the truth keeps the epoch where it is.
      const std::string dir = args.out_dir + "/" + args.model_offset->first;
      diachron::ColmapModel model = diachron::read_colmap_text(dir);
      const diachron::Vec3& d = args.model_offset->second;
      for (auto& [id, image] : model.images)
        image.pose = diachron::Pose(image.pose.cam_from_world_rotation(), image.pose.centre() + d);
      for (auto& [id, point] : model.points3d) point.xyz += d;
      diachron::write_colmap_text(model, dir);
      std::printf("model of %s moved by (%g, %g, %g) against its DSM (--model-offset)\n",
                  args.model_offset->first.c_str(), d.x(), d.y(), d.z());
    }
    for (const auto& [name, mask] : masks) {
      const std::string path = args.out_dir + "/" + name;
      diachron::make_folders(path.substr(0, path.rfind('/')), "make_scene");
      diachron::write_image_u8(mask, path);
    }

    if (args.control_points > 0) {
      const auto [control, check] = write_point_files(scene, args.control_points, args.out_dir + "/control_points.txt",
                                                      args.out_dir + "/check_points.txt");
      std::printf("%d control points written to %s/control_points.txt, %d check points to %s/check_points.txt\n",
                  control, args.out_dir.c_str(), check, args.out_dir.c_str());
    }
    std::printf("scene written to %s (preset %s, seed %llu, generated in %.2f s, %.2f s of CPU)\n",
                args.out_dir.c_str(), args.preset.c_str(), static_cast<unsigned long long>(scene.seed), seconds,
                cpu_seconds);
    if (args.scan_px > 0)
      std::printf("full-size scans: %g x the rendered size, scene written in %.1f s\n", scale, write_seconds);
    std::printf("world: X [%.1f, %.1f] Y [%.1f, %.1f] m, reference height %.1f m, %zu buildings and %zu trees "
                "over all epochs\n",
                scene.bounds.min_x, scene.bounds.max_x, scene.bounds.min_y, scene.bounds.max_y, scene.reference_height_m,
                scene.landscape.buildings.size(), scene.landscape.trees.size());
    for (const diachron::SyntheticEpoch& epoch : scene.epochs) {
      const diachron::Helmert3& h = epoch.world_from_epoch;
      if (epoch.orthophoto) {
        std::printf("%s: true orthophoto %dx%d px, GSD %.2f m, DSM (true surface) %dx%d (%zu valid), "
                    "world_from_epoch scale %.4f rotation %.2f deg\n",
                    epoch.name.c_str(), epoch.orthophoto->frame.width(), epoch.orthophoto->frame.height(), epoch.gsd_m,
                    epoch.dsm.width(), epoch.dsm.height(), epoch.dsm.statistics().count, h.scale,
                    diachron::rad_to_deg(diachron::rotation_angle(h.rotation)));
        continue;
      }
      std::printf("%s: %zu images %dx%d px, f %.1f px, GSD %.2f m, DSM %dx%d (%zu valid), %zu tie points, "
                  "world_from_epoch scale %.4f rotation %.2f deg\n",
                  epoch.name.c_str(), epoch.images.size(), epoch.camera.width(), epoch.camera.height(),
                  epoch.camera.focal(), epoch.gsd_m, epoch.dsm.width(), epoch.dsm.height(), epoch.dsm.statistics().count,
                  epoch.tie_points.size(), h.scale, diachron::rad_to_deg(diachron::rotation_angle(h.rotation)));
    }
    std::printf("%zu check points seen in every epoch\n", scene.check_points.size());
    if (scene.epochs.size() >= 2) {
      const diachron::Helmert3 h = scene.epoch2_from_epoch1();
      std::printf("true epoch2_from_epoch1: scale %.6f, rotation %.4f deg, translation (%.3f, %.3f, %.3f)\n", h.scale,
                  diachron::rad_to_deg(diachron::rotation_angle(h.rotation)), h.translation.x(), h.translation.y(),
                  h.translation.z());
    }
  } catch (const diachron::Error& e) {
    std::cerr << "make_scene: " << e.message() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "make_scene: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
