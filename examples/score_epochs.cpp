// score_epochs: judges what `match_epochs --adjust` wrote for a scene that `make_scene` wrote, against
// the scene's truth, and prints the paper's table for every free epoch.
//
//   score_epochs SCENE_DIR OUT_DIR [--check] [--verbose]
//
// SCENE_DIR is make_scene's folder (the epoch folders and truth/), OUT_DIR match_epochs' --out, run
// with the scene's last epoch as the reference (match_epochs' default). Each free epoch's check
// points are triangulated from their true pixels twice, in the reference's frame:
//   rough only     the epoch as its SfM estimated it, moved by OUT_DIR/rough_helmert_<epoch>.json
//   full pipeline  the epoch as OUT_DIR/adjusted/cameras.json holds it
// and compared with their true position: mean, sigma, mean |e| and RMS per axis (metres), the 3D
// RMS in metres and the epoch's GSD. Then the epoch's camera as the SfM had it and as the
// adjustment recovered it, against the truth (eval/distortion_difference.hpp), and the distortion's
// 1-sigma the adjustment predicted without the truth (report.json, eval/distortion_precision.hpp).
//
// It also requires cameras.json to hold every image of every epoch, the reference's orientation
// unchanged (it is fixed) and each free epoch's images to share f, the principal point and K1-P2
// (one camera per epoch; B1 and B2 are per image). With --check it also requires the targets of
// docs/adjustment.md for every free epoch: the adjusted RMS at least 3 times smaller than the rough
// one and below 1.5 of the epoch's GSD.
// Exit status: 0 success (and PASS with --check), 1 when a requirement fails, 2 on unreadable input
// or bad options (errors without the library's internal condition unless --verbose).

#include <cmath>
#include <cstdio>
#include <exception>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>

#include "program_support.hpp"

#include <diachron/adjustment/triangulation.hpp>
#include <diachron/eval/check_points.hpp>
#include <diachron/eval/distortion_difference.hpp>
#include <diachron/eval/dod_map.hpp>
#include <diachron/eval/error_statistics.hpp>
#include <diachron/eval/scene_check_points.hpp>
#include <diachron/io/cameras_json.hpp>
#include <diachron/io/folders.hpp>
#include <diachron/io/helmert_json.hpp>
#include <diachron/io/json.hpp>
#include <diachron/synth/scene_io.hpp>

using namespace diachron;

namespace {

using Frames = std::vector<Frame<FraserAffine>>;

CheckPointReport check_points(const Scene& scene, std::size_t epoch, const Frames& frames) {
  return evaluate_scene_check_points(scene, epoch, scene.epochs.size() - 1, FrameTriangulator<FraserAffine>(frames));
}

void print_check_points(const char* name, const CheckPointReport& r) {
  const char* axis[3] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a)
    std::printf("| %-14s | %s    | %7.2f | %6.2f | %8.2f | %6.2f |\n", a == 0 ? name : "", axis[a], r.axes_m[a].mean,
                r.axes_m[a].sigma, r.axes_m[a].mean_abs, r.axes_m[a].rms);
}

int fail(const std::string& why) {
  std::printf("FAIL: %s\n", why.c_str());
  return 1;
}

// The "distortion_sigma" of the first free camera of `epoch` in report.json, or nullptr (no
// covariance, or an older report).
const JsonValue* distortion_sigma(const JsonValue& report, const std::string& epoch) {
  const JsonValue* adjustment = report.find("adjustment");
  const JsonValue* cameras = adjustment ? adjustment->find("cameras") : nullptr;
  if (!cameras || cameras->type != JsonValue::Type::array) return nullptr;
  for (const JsonValue& c : cameras->array) {
    const JsonValue* name = c.find("epoch");
    const JsonValue* sigma = c.find("distortion_sigma");
    if (name && name->type == JsonValue::Type::string && name->string == epoch && sigma &&
        sigma->type == JsonValue::Type::object)
      return sigma;
  }
  return nullptr;
}

// How far the DoD of `moving` placed by `placed` is from the DoD with the true placement: the
// median and RMS over the cells both maps have of |difference|, reference units. Only the placement
// differs between the two, so this is the DoD's error due to the co-registration alone.
std::pair<double, double> dod_placement_error(const Dsm& reference, const Dsm& moving, const Helmert3& placed,
                                              const Helmert3& truth) {
  const DodMap a = dod_map(reference, moving, placed), b = dod_map(reference, moving, truth);
  std::vector<double> d;
  if (a.success && b.success)
    for (int y = 0; y < a.dz.height(); ++y)
      for (int x = 0; x < a.dz.width(); ++x)
        if (a.dz.valid(x, y) && b.dz.valid(x, y)) d.push_back(std::abs(a.dz.heights()(x, y) - b.dz.heights()(x, y)));
  const ErrorStatistics s = error_statistics(d);  // NaN when empty
  return {s.median, s.rms};
}

const char* kDescription =
    "score_epochs: judges what match_epochs --adjust wrote (OUT_DIR) for the epoch folders of a scene that\n"
    "make_scene wrote (SCENE_DIR), the scene's last epoch the reference, against the scene's truth. Prints\n"
    "each free epoch's check points (rough only, full pipeline) and camera against the truth. Epochs of the\n"
    "scene that OUT_DIR does not hold (a run on some of them) are skipped.\n"
    "Exit status: 0 success (and PASS with --check), 1 when a requirement fails, 2 on unreadable input or\n"
    "bad options.\n";

}  // namespace

int main(int argc, char** argv) {
  std::string scene_dir, out_dir;
  bool check = false, verbose = false;
  CLI::App app{kDescription, "score_epochs"};
  app.get_formatter()->column_width(34);
  app.add_option("SCENE_DIR", scene_dir, "what make_scene wrote")->required();
  app.add_option("OUT_DIR", out_dir, "what match_epochs --adjust wrote for its epoch folders")->required();
  app.add_flag("--check", check,
               "also require every free epoch's adjusted check points 3 times closer than the rough ones and "
               "within 1.5 of its GSD (exit 1 otherwise)");
  app.add_flag("--verbose", verbose, "errors with the library's internal condition (for bug reports)");
  if (const std::optional<int> status = diachron::programs::parse_options(app, argc, argv, 2)) return *status;
  try {
    const Scene scene = read_scene(scene_dir);
    if (scene.epochs.size() < 2) return fail("the scene has " + std::to_string(scene.epochs.size()) + " epoch(s)");
    const std::size_t reference = scene.epochs.size() - 1;
    const std::vector<CamerasJsonImage> adjusted = read_cameras_json(out_dir + "/adjusted/cameras.json");
    // What the adjustment itself said, without the truth (match_epochs' report.json), if there.
    std::optional<JsonValue> report;
    if (std::ifstream in{out_dir + "/report.json"}) {
      std::ostringstream text;
      text << in.rdbuf();
      report = parse_json(text.str(), out_dir + "/report.json");
    }

    // cameras.json names images as images.txt does: the scene's name and ".png" (read_scene's lookup).
    std::map<std::string, const CamerasJsonImage*> by_name;
    for (const CamerasJsonImage& image : adjusted) by_name[image.epoch + "/" + image.name] = &image;
    const auto entry = [&by_name](const SyntheticEpoch& e, std::size_t i) {
      const auto it = by_name.find(e.name + "/" + e.images[i].name + ".png");
      return it == by_name.end() ? nullptr : it->second;
    };
    // The epochs the run had: the reference and every free epoch with a rough transform.
    std::vector<bool> present(scene.epochs.size(), false);
    std::size_t images = 0;
    for (std::size_t k = 0; k < scene.epochs.size(); ++k) {
      present[k] = k == reference || is_regular_file(out_dir + "/rough_helmert_" + scene.epochs[k].name + ".json");
      if (present[k]) images += scene.epochs[k].images.size();
      else std::printf("%s: not in this run (no rough_helmert_%s.json), skipped\n", scene.epochs[k].name.c_str(),
                       scene.epochs[k].name.c_str());
    }
    if (adjusted.size() != images)
      return fail("cameras.json has " + std::to_string(adjusted.size()) + " images, the run's epochs " +
                  std::to_string(images));
    const SyntheticEpoch& ref = scene.epochs[reference];
    const Frames ref_input = ref.estimated_frames();
    for (std::size_t i = 0; i < ref.images.size(); ++i) {
      const CamerasJsonImage* image = entry(ref, i);
      if (!image) return fail("cameras.json has no image " + ref.name + "/" + ref.images[i].name);
      const Frame<FraserAffine> f = image->frame();
      // The reference is fixed: its orientation comes out as it went in (to the printed digits).
      const double moved = (f.pose().centre() - ref_input[i].pose().centre()).norm();
      const double scale = ref_input[i].pose().centre().norm();
      if (!(moved <= 1e-6 * std::max(1.0, scale)))
        return fail("the reference's image " + ref.images[i].name + " moved by " + std::to_string(moved));
    }

    std::vector<std::string> failures;
    for (std::size_t k = 0; k < reference; ++k) {
      if (!present[k]) continue;
      const SyntheticEpoch& e = scene.epochs[k];
      const Helmert3 helmert = read_helmert_json(out_dir + "/rough_helmert_" + e.name + ".json");
      Frames rough, after;
      for (std::size_t i = 0; i < e.images.size(); ++i) {
        const CamerasJsonImage* image = entry(e, i);
        if (!image) return fail("cameras.json has no image " + e.name + "/" + e.images[i].name);
        rough.push_back(e.estimated_frame(i).transformed(helmert));
        after.push_back(image->frame());
        const auto shared = [](const Camera<FraserAffine>& c) {
          const auto q = c.intrinsics();
          return std::vector<double>(q.begin(), q.end() - 2);  // all but B1, B2
        };
        if (i > 0 && shared(after[i].camera()) != shared(after[0].camera()))
          return fail(e.name + "'s images do not share f, the principal point and K1-P2 in cameras.json");
      }
      const CheckPointReport before = check_points(scene, k, rough), now = check_points(scene, k, after);
      if (!before.success || !now.success)
        return fail("no check point of " + e.name + " could be triangulated: " + now.reason + before.reason);
      std::printf("%sCheck points of %s in the world frame, metres (GSD of %s: %.2f m):\n", k ? "\n" : "",
                  e.name.c_str(), e.name.c_str(), e.gsd_m);
      std::printf("| method         | axis |    mean |  sigma | mean |e| |    RMS |\n");
      std::printf("|----------------|------|---------|--------|----------|--------|\n");
      print_check_points("rough only", before);
      print_check_points("full pipeline", now);
      std::printf("3D RMS of %s: rough only %.2f m (%.2f GSD, %zu points), full pipeline %.2f m (%.2f GSD, %zu points): "
                  "%.1f x smaller\n",
                  e.name.c_str(), before.rms_3d_m, before.rms_3d_gsd, before.num_used, now.rms_3d_m, now.rms_3d_gsd,
                  now.num_used, before.rms_3d_m / now.rms_3d_m);

      const Camera<FraserAffine>& truth = e.camera;
      const Camera<FraserAffine>& sfm = e.estimated_camera;
      const Camera<FraserAffine>& recovered = after.front().camera();
      std::printf("\n%s's camera against the truth (px):\n", e.name.c_str());
      // Worst over the image: the distortion alone; the whole camera with the focal length and
      // principal point refitted; what no change of pose absorbs (eval/distortion_difference.hpp).
      std::printf("| camera             | focal error | principal point error | distortion, worst | f, pp refitted, worst "
                  "| beyond a pose, worst |\n");
      std::printf("|--------------------|-------------|-----------------------|-------------------|---------------------"
                  "--|----------------------|\n");
      for (const auto& [name, c] : {std::pair<const char*, const Camera<FraserAffine>*>{"as the SfM had it", &sfm},
                                    std::pair<const char*, const Camera<FraserAffine>*>{"after adjustment", &recovered}}) {
        const DistortionDifference d = distortion_difference(*c, truth);
        std::printf("| %-18s | %11.2f | %21.2f | %17.2f | %21.2f | %20.2f |\n", name, c->focal() - truth.focal(),
                    (c->principal_point() - truth.principal_point()).norm(), d.max_px, d.refit_max_px,
                    d.beyond_pose_max_px);
      }
      const JsonValue* sigma = report ? distortion_sigma(*report, e.name) : nullptr;
      const JsonValue* worst = sigma ? sigma->find("worst_px") : nullptr;
      const JsonValue* rms = sigma ? sigma->find("rms_px") : nullptr;
      if (worst && rms && worst->type == JsonValue::Type::number && rms->type == JsonValue::Type::number)
        std::printf("Predicted by the adjustment (covariance): distortion 1-sigma %.2f px at worst, %.2f px RMS\n",
                    worst->number, rms->number);
      // The DoD's error due to the placement of the epoch's DSM (match_epochs' dod/), against the
      // DoD with the true placement.
      const Helmert3 true_placement = scene.transform(reference, k);
      const auto [rough_median, rough_rms] = dod_placement_error(ref.dsm, e.dsm, helmert, true_placement);
      std::printf("DoD of %s, error of the placement against the true one (reference units): rough median %.3f, "
                  "RMS %.3f",
                  e.name.c_str(), rough_median, rough_rms);
      const std::string adjusted_helmert = out_dir + "/dod/" + e.name + "_helmert.json";
      if (is_regular_file(adjusted_helmert)) {
        const auto [median, rms] = dod_placement_error(ref.dsm, e.dsm, read_helmert_json(adjusted_helmert), true_placement);
        std::printf("; adjusted median %.3f, RMS %.3f", median, rms);
      }
      std::printf("\n");
      if (now.num_used < before.num_used) failures.push_back(e.name + ": fewer check points triangulate after the adjustment");
      if (!(now.rms_3d_m * 3.0 <= before.rms_3d_m))
        failures.push_back(e.name + ": the adjusted RMS is not 3 times smaller than the rough one");
      if (!(now.rms_3d_gsd < 1.5)) failures.push_back(e.name + ": the adjusted RMS is not below 1.5 GSD");
    }
    if (check) {
      if (!failures.empty()) {
        std::string all;
        for (const std::string& f : failures) all += (all.empty() ? "" : "; ") + f;
        return fail(all);
      }
      std::printf("PASS\n");
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "score_epochs: %s\n", diachron::programs::error_text(e, verbose).c_str());
    return 2;
  }
}
