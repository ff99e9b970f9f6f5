// score_epochs: judges what `match_epochs --adjust` wrote for a scene that `make_scene` wrote, against
// the scene's truth, and prints the paper's table.
//
//   score_epochs SCENE_DIR OUT_DIR [--check]
//
// SCENE_DIR is make_scene's folder (two epoch folders and truth/), OUT_DIR match_epochs' --out.
// Epoch 1's check points are triangulated from their true pixels twice, in epoch 2's frame:
//   rough only     epoch 1 as its SfM estimated it, moved by OUT_DIR/rough_helmert.json
//   full pipeline  epoch 1 as OUT_DIR/adjusted/cameras.json holds it
// and compared with their true position: mean, sigma, mean |e| and RMS per axis (metres), the 3D
// RMS in metres and epoch-1 GSD. Then epoch 1's camera as the SfM had it and as the adjustment
// recovered it, against the truth (eval/distortion_difference.hpp), and the distortion's 1-sigma
// the adjustment predicted without the truth (report.json, eval/distortion_precision.hpp).
//
// It also requires cameras.json to hold every image of both epochs, epoch 2's orientation unchanged
// (the reference is fixed) and epoch 1's images to share f, the principal point and K1-P2 (one
// camera per epoch; B1 and B2 are per image). With --check it also requires the targets of
// docs/adjustment.md: the adjusted RMS at least 3 times smaller than the rough one and below 1.5
// epoch-1 GSD.
// Exit status: 0 success (and PASS with --check), 1 when a requirement fails, 2 on unreadable input.

#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <diachron/adjustment/triangulation.hpp>
#include <diachron/eval/check_points.hpp>
#include <diachron/eval/distortion_difference.hpp>
#include <diachron/eval/scene_check_points.hpp>
#include <diachron/io/cameras_json.hpp>
#include <diachron/io/helmert_json.hpp>
#include <diachron/io/json.hpp>
#include <diachron/synth/scene_io.hpp>

using namespace diachron;

namespace {

using Frames = std::vector<Frame<FraserAffine>>;

CheckPointReport check_points(const Scene& scene, const Frames& epoch1) {
  return evaluate_scene_check_points(scene, 0, 1, FrameTriangulator<FraserAffine>(epoch1));
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

// Camera 0's (epoch 1's) "distortion_sigma" in report.json, or nullptr (no covariance, or an
// older report).
const JsonValue* epoch1_distortion_sigma(const JsonValue& report) {
  const JsonValue* adjustment = report.find("adjustment");
  const JsonValue* cameras = adjustment ? adjustment->find("cameras") : nullptr;
  if (!cameras || cameras->type != JsonValue::Type::array) return nullptr;
  for (const JsonValue& c : cameras->array) {
    const JsonValue* index = c.find("camera");
    const JsonValue* sigma = c.find("distortion_sigma");
    if (index && index->type == JsonValue::Type::number && index->number == 0.0 && sigma &&
        sigma->type == JsonValue::Type::object)
      return sigma;
  }
  return nullptr;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> positional;
  bool check = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--check") check = true;
    else positional.push_back(a);
  }
  if (positional.size() != 2) {
    std::fprintf(stderr, "usage: score_epochs SCENE_DIR OUT_DIR [--check]\n");
    return 2;
  }
  const std::string scene_dir = positional[0], out_dir = positional[1];
  try {
    const Scene scene = read_scene(scene_dir);
    if (scene.epochs.size() != 2) return fail("the scene has " + std::to_string(scene.epochs.size()) + " epochs, not 2");
    const SyntheticEpoch& e1 = scene.epochs[0];
    const SyntheticEpoch& e2 = scene.epochs[1];
    const Helmert3 helmert = read_helmert_json(out_dir + "/rough_helmert.json");
    const std::vector<CamerasJsonImage> adjusted = read_cameras_json(out_dir + "/adjusted/cameras.json");

    // cameras.json names images as images.txt does: the scene's name and ".png" (read_scene's lookup).
    std::map<std::string, const CamerasJsonImage*> by_name;
    for (const CamerasJsonImage& image : adjusted) by_name[image.epoch + "/" + image.name] = &image;
    const auto entry = [&by_name](const SyntheticEpoch& e, std::size_t i) {
      const auto it = by_name.find(e.name + "/" + e.images[i].name + ".png");
      return it == by_name.end() ? nullptr : it->second;
    };
    Frames rough, after;
    for (std::size_t i = 0; i < e1.images.size(); ++i) {
      const CamerasJsonImage* image = entry(e1, i);
      if (!image) return fail("cameras.json has no image " + e1.name + "/" + e1.images[i].name);
      rough.push_back(e1.estimated_frame(i).transformed(helmert));
      after.push_back(image->frame());
      const auto shared = [](const Camera<FraserAffine>& c) {
        const auto k = c.intrinsics();
        return std::vector<double>(k.begin(), k.end() - 2);  // all but B1, B2
      };
      if (i > 0 && shared(after[i].camera()) != shared(after[0].camera()))
        return fail("epoch 1's images do not share f, the principal point and K1-P2 in cameras.json");
    }
    const Frames e2_input = e2.estimated_frames();
    for (std::size_t i = 0; i < e2.images.size(); ++i) {
      const CamerasJsonImage* image = entry(e2, i);
      if (!image) return fail("cameras.json has no image " + e2.name + "/" + e2.images[i].name);
      const Frame<FraserAffine> f = image->frame();
      // The reference is fixed: its orientation comes out as it went in (to the printed digits).
      const double moved = (f.pose().centre() - e2_input[i].pose().centre()).norm();
      const double scale = e2_input[i].pose().centre().norm();
      if (!(moved <= 1e-6 * std::max(1.0, scale)))
        return fail("epoch 2's image " + e2.images[i].name + " moved by " + std::to_string(moved));
    }
    if (adjusted.size() != e1.images.size() + e2.images.size())
      return fail("cameras.json has " + std::to_string(adjusted.size()) + " images, the scene " +
                  std::to_string(e1.images.size() + e2.images.size()));

    const CheckPointReport before = check_points(scene, rough), now = check_points(scene, after);
    if (!before.success || !now.success) return fail("no check point could be triangulated: " + now.reason + before.reason);
    std::printf("Check points of epoch 1 in the world frame, metres (GSD of epoch 1: %.1f m):\n", e1.gsd_m);
    std::printf("| method         | axis |    mean |  sigma | mean |e| |    RMS |\n");
    std::printf("|----------------|------|---------|--------|----------|--------|\n");
    print_check_points("rough only", before);
    print_check_points("full pipeline", now);
    std::printf("3D RMS: rough only %.2f m (%.2f GSD, %zu points), full pipeline %.2f m (%.2f GSD, %zu points): "
                "%.1f x smaller\n",
                before.rms_3d_m, before.rms_3d_gsd, before.num_used, now.rms_3d_m, now.rms_3d_gsd, now.num_used,
                before.rms_3d_m / now.rms_3d_m);

    const Camera<FraserAffine>& truth = e1.camera;
    const Camera<FraserAffine>& sfm = e1.estimated_camera;
    const Camera<FraserAffine>& recovered = after.front().camera();
    std::printf("\nEpoch 1's camera against the truth (px):\n");
    // Worst over the image: the distortion alone; the whole camera with the focal length and
    // principal point refitted; what no change of pose absorbs (eval/distortion_difference.hpp).
    std::printf("| camera             | focal error | principal point error | distortion, worst | f, pp refitted, worst "
                "| beyond a pose, worst |\n");
    std::printf("|--------------------|-------------|-----------------------|-------------------|-----------------------"
                "|----------------------|\n");
    for (const auto& [name, c] : {std::pair<const char*, const Camera<FraserAffine>*>{"as the SfM had it", &sfm},
                                  std::pair<const char*, const Camera<FraserAffine>*>{"after adjustment", &recovered}}) {
      const DistortionDifference d = distortion_difference(*c, truth);
      std::printf("| %-18s | %11.2f | %21.2f | %17.2f | %21.2f | %20.2f |\n", name, c->focal() - truth.focal(),
                  (c->principal_point() - truth.principal_point()).norm(), d.max_px, d.refit_max_px,
                  d.beyond_pose_max_px);
    }
    // What the adjustment itself said, without the truth (match_epochs' report.json).
    std::ifstream in(out_dir + "/report.json");
    if (in) {
      std::ostringstream text;
      text << in.rdbuf();
      const JsonValue report = parse_json(text.str(), out_dir + "/report.json");
      const JsonValue* sigma = epoch1_distortion_sigma(report);
      const JsonValue* worst = sigma ? sigma->find("worst_px") : nullptr;
      const JsonValue* rms = sigma ? sigma->find("rms_px") : nullptr;
      if (worst && rms && worst->type == JsonValue::Type::number && rms->type == JsonValue::Type::number)
        std::printf("Predicted by the adjustment (covariance): distortion 1-sigma %.2f px at worst, %.2f px RMS\n",
                    worst->number, rms->number);
    }

    if (check) {
      if (now.num_used < before.num_used) return fail("fewer check points triangulate after the adjustment");
      if (!(now.rms_3d_m * 3.0 <= before.rms_3d_m))
        return fail("the adjusted RMS is not 3 times smaller than the rough one");
      if (!(now.rms_3d_gsd < 1.5)) return fail("the adjusted RMS is not below 1.5 GSD");
      std::printf("PASS\n");
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "score_epochs: %s\n", e.what());
    return 2;
  }
}
