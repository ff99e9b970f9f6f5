// score_adjusted_epochs SCENE_DIR OUT_DIR: judges what `match_epochs --adjust` wrote to OUT_DIR for a
// scene that make_scene wrote to SCENE_DIR, against the scene's truth (SCENE_DIR/truth/).
//
// Epoch 1's check points are triangulated from their true pixels twice, in epoch 2's frame:
//   rough      epoch 1 as its SfM estimated it, moved by OUT_DIR/rough_helmert.json
//   adjusted   epoch 1 as OUT_DIR/adjusted/cameras.json holds it
// and compared with their true position. Prints both RMS (metres and epoch-1 GSD) and exits 0 when
// the adjusted RMS meets the targets of docs/adjustment.md (at least 3 times smaller than the rough
// one and below 1.5 epoch-1 GSD), 1 when it does not, 2 on unreadable input. It also requires
// cameras.json to hold every image of both epochs, epoch 2's orientation unchanged (the reference is
// fixed), and epoch 1's images to share f, the principal point and K1-P2 (one camera per epoch; B1
// and B2 are per image).

#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <diachron/adjustment/triangulation.hpp>
#include <diachron/eval/check_points.hpp>
#include <diachron/eval/scene_check_points.hpp>
#include <diachron/io/cameras_json.hpp>
#include <diachron/io/helmert_json.hpp>
#include <diachron/synth/scene_io.hpp>

using namespace diachron;

namespace {

using Frames = std::vector<Frame<FraserAffine>>;

CheckPointReport check_points(const Scene& scene, const Frames& epoch1) {
  return evaluate_scene_check_points(scene, 0, 1, FrameTriangulator<FraserAffine>(epoch1));
}

int fail(const std::string& why) {
  std::printf("FAIL: %s\n", why.c_str());
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: score_adjusted_epochs SCENE_DIR OUT_DIR\n");
    return 2;
  }
  const std::string scene_dir = argv[1], out_dir = argv[2];
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
    std::printf("check points (%zu): rough RMS %.3f m (%.2f GSD), adjusted RMS %.3f m (%.2f GSD), %.1f x smaller\n",
                now.num_used, before.rms_3d_m, before.rms_3d_gsd, now.rms_3d_m, now.rms_3d_gsd,
                before.rms_3d_m / now.rms_3d_m);
    if (now.num_used < before.num_used) return fail("fewer check points triangulate after the adjustment");
    if (!(now.rms_3d_m * 3.0 <= before.rms_3d_m)) return fail("the adjusted RMS is not 3 times smaller than the rough one");
    if (!(now.rms_3d_gsd < 1.5)) return fail("the adjusted RMS is not below 1.5 GSD");
    std::printf("PASS\n");
    return 0;
  } catch (const std::exception& e) {
    std::printf("ERROR: %s\n", e.what());
    return 2;
  }
}
