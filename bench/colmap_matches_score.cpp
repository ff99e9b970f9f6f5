// Scores COLMAP's matches on a synthetic scene against its truth (bench/peers/colmap_timesift.sh
// runs COLMAP and exports its database as text, then this). Regenerates nothing: the scene is read
// with read_scene, every match scored with MatchTruthScorer.
//
// Usage: colmap_matches_score SCENE_DIR WORK_DIR [--json PATH]
// WORK_DIR holds db_images.txt (image_id camera_id name), db_keypoints.txt (image_id rows cols hex),
// db_matches.txt (pair_id rows cols hex), db_two_view_geometries.txt (pair_id rows cols config hex),
// and sparse_txt/<model>/ (COLMAP text models). Image names are <epoch>/<image>.png.
// Prints which images each model registered, then per pair kind (inter-/intra-epoch; raw matches and
// verified two-view geometries) the pairs, the matches, how many could be scored, how many of the
// scored are within 1/3/6/10 px, and the unscored by reason (for off_image: how many are more than
// 10 px from their true position, which lies outside the image: wrong matches); the same as JSON.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <iterator>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <diachron/eval/match_truth.hpp>
#include <diachron/io/colmap_text.hpp>
#include <diachron/io/folders.hpp>
#include <diachron/synth/scene_io.hpp>

using namespace diachron;

namespace {

constexpr std::uint64_t kPairIdFactor = 2147483647;  // COLMAP's pair_id = id1 * this + id2
const double kThresholds[] = {1.0, 3.0, 6.0, 10.0};

std::vector<std::uint8_t> from_hex(const std::string& hex, const std::string& where) {
  DIACHRON_CHECK(hex.size() % 2 == 0, where << ": odd hex blob");
  std::vector<std::uint8_t> out(hex.size() / 2);
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = static_cast<std::uint8_t>(std::stoul(hex.substr(2 * i, 2), nullptr, 16));
  return out;
}

template <class T>
std::vector<T> blob_values(const std::string& hex, std::size_t count, const std::string& where) {
  const std::vector<std::uint8_t> bytes = from_hex(hex, where);
  DIACHRON_CHECK(bytes.size() == count * sizeof(T), where << ": blob of " << bytes.size() << " bytes, expected "
                                                          << count * sizeof(T));
  std::vector<T> out(count);
  std::memcpy(out.data(), bytes.data(), bytes.size());  // COLMAP writes the host's (little-endian) layout
  return out;
}

std::ifstream open(const std::string& path) {
  std::ifstream in(path);
  DIACHRON_CHECK(in.good(), "cannot read '" << path << "'");
  return in;
}

struct Tally {
  std::size_t pairs = 0, matches = 0;
  // off_image matches whose true position (outside image b) is more than 10 px from pixel_b: wrong.
  std::size_t off_image_wrong = 0;
  std::map<MatchTruthStatus, std::size_t> by_status;
  std::vector<MatchTruth> truths;
};

const char* status_name(MatchTruthStatus s) {
  switch (s) {
    case MatchTruthStatus::scored: return "scored";
    case MatchTruthStatus::no_surface: return "no_surface";
    case MatchTruthStatus::off_image: return "off_image";
    case MatchTruthStatus::occluded: return "occluded";
    case MatchTruthStatus::changed_surface: return "changed_surface";
  }
  return "?";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3 && !(argc == 5 && std::string(argv[3]) == "--json")) {
    std::cerr << "usage: colmap_matches_score SCENE_DIR WORK_DIR [--json PATH]\n";
    return 1;
  }
  try {
    const std::string scene_dir = argv[1], work = argv[2];
    const Scene scene = read_scene(scene_dir);
    const MatchTruthScorer scorer(scene);

    // COLMAP image id -> (epoch, image) of the scene, by name "<epoch>/<image>.png".
    std::map<std::uint32_t, ImageRef> ref_of;
    std::map<std::uint32_t, std::string> name_of;
    {
      std::ifstream in = open(work + "/db_images.txt");
      std::uint32_t id = 0, camera = 0;
      std::string name;
      while (in >> id >> camera >> name) {
        name_of[id] = name;
        for (std::size_t e = 0; e < scene.epochs.size(); ++e)
          for (std::size_t i = 0; i < scene.epochs[e].images.size(); ++i)
            if (name == scene.epochs[e].name + "/" + scene.epochs[e].images[i].name + ".png")
              ref_of[id] = ImageRef{static_cast<int>(e), static_cast<int>(i)};
        DIACHRON_CHECK(ref_of.count(id), "db_images.txt: image '" << name << "' is not in the scene");
      }
    }
    // Keypoints, diachron pixels.
    std::map<std::uint32_t, std::vector<Vec2>> keypoints;
    {
      std::ifstream in = open(work + "/db_keypoints.txt");
      std::uint32_t id = 0;
      std::size_t rows = 0, cols = 0;
      std::string hex;
      while (in >> id >> rows >> cols >> hex) {
        const std::vector<float> v = blob_values<float>(hex, rows * cols, "keypoints of image " + std::to_string(id));
        std::vector<Vec2>& k = keypoints[id];
        for (std::size_t r = 0; r < rows; ++r)
          k.push_back(diachron_pixel_from_colmap(Vec2(v[r * cols], v[r * cols + 1])));
      }
    }
    // Matches of a table, scored, split into inter- and intra-epoch.
    const auto score_table = [&](const std::string& file, bool has_config, Tally& inter, Tally& intra) {
      std::ifstream in = open(work + "/" + file);
      std::string line;
      while (std::getline(in, line)) {
        std::istringstream fields(line);
        std::uint64_t pair_id = 0;
        std::size_t rows = 0, cols = 0;
        int config = 0;
        std::string hex;
        fields >> pair_id >> rows >> cols;
        if (has_config) fields >> config;
        fields >> hex;
        DIACHRON_CHECK(fields && cols == 2, file << ": bad line for pair " << pair_id);
        const auto id2 = static_cast<std::uint32_t>(pair_id % kPairIdFactor);
        const auto id1 = static_cast<std::uint32_t>(pair_id / kPairIdFactor);
        const ImageRef a = ref_of.at(id1), b = ref_of.at(id2);
        Tally& t = a.epoch != b.epoch ? inter : intra;
        ++t.pairs;
        const std::vector<std::uint32_t> m = blob_values<std::uint32_t>(hex, rows * 2, file);
        const std::vector<Vec2>& ka = keypoints.at(id1);
        const std::vector<Vec2>& kb = keypoints.at(id2);
        for (std::size_t r = 0; r < rows; ++r) {
          const MatchTruth truth = scorer.score(a, b, ka.at(m[2 * r]), kb.at(m[2 * r + 1]));
          ++t.matches;
          if (truth.status == MatchTruthStatus::off_image &&
              !((truth.true_pixel - kb.at(m[2 * r + 1])).norm() <= 10.0))
            ++t.off_image_wrong;
          ++t.by_status[truth.status];
          t.truths.push_back(truth);
        }
      }
    };
    Tally raw_inter, raw_intra, verified_inter, verified_intra;
    score_table("db_matches.txt", false, raw_inter, raw_intra);
    score_table("db_two_view_geometries.txt", true, verified_inter, verified_intra);

    std::ostringstream json;
    json << "{\"scene\": \"" << scene_dir << "\", \"models\": [";
    std::printf("COLMAP on %s: %zu images\n", scene_dir.c_str(), name_of.size());
    const std::vector<std::string> models = folder_entries(work + "/sparse_txt");
    if (models.empty()) std::printf("the mapper made no model\n");
    for (std::size_t k = 0; k < models.size(); ++k) {
      const ColmapModel model = read_colmap_text(work + "/sparse_txt/" + models[k]);
      std::map<int, std::vector<std::string>> per_epoch;
      for (const auto& [id, image] : model.images) per_epoch[ref_of.at(id).epoch].push_back(image.name);
      std::printf("model %s: %zu images registered, %zu points;", models[k].c_str(), model.images.size(),
                  model.points3d.size());
      json << (k ? ", " : "") << "{\"name\": \"" << models[k] << "\", \"points\": " << model.points3d.size()
           << ", \"images\": {";
      bool first = true;
      for (const auto& [e, names] : per_epoch) {
        std::printf(" %s: %zu of %zu", scene.epochs[static_cast<std::size_t>(e)].name.c_str(), names.size(),
                    scene.epochs[static_cast<std::size_t>(e)].images.size());
        json << (first ? "" : ", ") << "\"" << scene.epochs[static_cast<std::size_t>(e)].name << "\": [";
        for (std::size_t i = 0; i < names.size(); ++i) json << (i ? ", " : "") << "\"" << names[i] << "\"";
        json << "]";
        first = false;
      }
      json << "}}";
      std::printf("%s\n", per_epoch.size() > 1 ? "  (epochs merged)" : "");
    }
    json << "], \"matches\": {";

    std::printf("\n%-26s %6s %8s %8s %8s %8s %8s %8s   unscored by reason\n", "matches", "pairs", "matches", "scored",
                "<=1px", "<=3px", "<=6px", "<=10px");
    const std::pair<const char*, const Tally*> rows[] = {{"inter-epoch verified", &verified_inter},
                                                         {"inter-epoch raw", &raw_inter},
                                                         {"intra-epoch verified", &verified_intra},
                                                         {"intra-epoch raw", &raw_intra}};
    for (std::size_t r = 0; r < std::size(rows); ++r) {
      const auto& [label, tally] = rows[r];
      const AccuracyCurve curve = accuracy_curve(tally->truths, 10);
      std::printf("%-26s %6zu %8zu %8zu", label, tally->pairs, tally->matches, curve.scored);
      json << (r ? ", " : "") << "\"" << label << "\": {\"pairs\": " << tally->pairs << ", \"matches\": " << tally->matches
           << ", \"scored\": " << curve.scored;
      for (double t : kThresholds) {
        const auto within = static_cast<std::size_t>(std::llround(curve.share_within(t) * static_cast<double>(curve.scored)));
        std::printf(" %8zu", curve.scored ? within : std::size_t{0});
        json << ", \"within_" << t << "px\": " << (curve.scored ? within : 0);
      }
      std::printf("  ");
      json << ", \"unscored\": {";
      bool first = true;
      for (const auto& [status, n] : tally->by_status) {
        if (status == MatchTruthStatus::scored) continue;
        std::printf(" %s %zu", status_name(status), n);
        json << (first ? "" : ", ") << "\"" << status_name(status) << "\": " << n;
        first = false;
        if (status == MatchTruthStatus::off_image) {
          std::printf(" (%zu > 10 px off)", tally->off_image_wrong);
          json << ", \"off_image_more_than_10px\": " << tally->off_image_wrong;
        }
      }
      json << "}}";
      std::printf("\n");
    }
    json << "}}";
    std::printf("\n%s\n", json.str().c_str());
    if (argc == 5) {
      std::ofstream out(argv[4]);
      out << json.str() << '\n';
      DIACHRON_CHECK(out.good(), "cannot write '" << argv[4] << "'");
    }
  } catch (const std::exception& e) {
    std::cerr << "colmap_matches_score: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
