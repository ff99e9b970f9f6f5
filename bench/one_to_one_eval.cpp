// one_to_one_eval: one-to-one transfer-guided tiling on decades-apart synthetic scenes, per warp
// kind, scored with the truth (docs/one-to-one-tiling.md).
//
//   one_to_one_eval [--seeds N] [--first-seed S] [--max-pairs N] [--max-features N] [--threads N]
//                   [--layouts precise,small] [--plain]
//
// --plain runs the plain SceneOptions{} (no decades effects) instead, as a check that the tiling
// finds correct matches when the images allow it.
// For every seed of SceneOptions::decades_apart(): the overlapping epoch-1 x epoch-2 image pairs
// from overlapping_pairs() (estimated frames, the epochs' SfM DSMs, the true Helmert), the
// --max-pairs largest overlaps kept. For each pair the DsmTransfer is built from the *estimated*
// frames, the epoch-1 DSM and the *true* Helmert between the epoch frames: the co-registration is
// taken as solved, so what is measured is the tiling and its warp, not the Helmert. Then
// match_one_to_one with SIFT (ratio 0.8, mutual; masked extraction) for each warp kind and tile
// layout; matches are scored with MatchTruthScorer (share correct within 1 / 3 / 6 / 10 px among the
// decidable ones, correct matches per pair, time per pair). Per tile: the relief under it (height
// range of the epoch-1 DSM points seen at a 9 x 9 grid of the tile) and the warp's error against the
// truth (|warp(p) - true pixel| at a 6 x 6 grid between the warp's nodes), so the kinds can be
// compared where relief is strong. Deterministic; times are wall-clock of this machine.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <diachron/eval/match_truth.hpp>
#include <diachron/pipeline/overlapping_pairs.hpp>
#include <diachron/synth/scene.hpp>
#include <diachron/terrain/transfer.hpp>
#include <diachron/tiling/one_to_one.hpp>
#include <diachron/tiling/patch_warp.hpp>
#include <diachron/vision/extractor_pair_matcher.hpp>
#include <diachron/vision/sift.hpp>

#include "match_scoring.hpp"

using namespace diachron;

using diachron::bench::median;
using diachron::bench::Scored;
using diachron::bench::seconds_since;

namespace {

struct Arguments {
  int seeds = 3;
  std::uint64_t first_seed = 0;
  int max_pairs = 3;
  int max_features = 4000;
  std::size_t threads = 0;
  std::vector<std::string> layouts = {"precise", "small"};
  bool plain = false;  // the plain SceneOptions{} (every effect off): a sanity check that matching works
};

[[noreturn]] void usage(const std::string& message) {
  std::fprintf(stderr,
               "one_to_one_eval: %s\nusage: one_to_one_eval [--seeds N] [--first-seed S] [--max-pairs N] "
               "[--max-features N] [--threads N] [--layouts precise,small] [--plain]\n",
               message.c_str());
  std::exit(1);
}

Arguments parse(int argc, char** argv) {
  Arguments a;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--plain") {
      a.plain = true;
      continue;
    }
    if (i + 1 >= argc) usage("missing value for " + arg);
    const std::string v = argv[++i];
    try {
      if (arg == "--seeds") a.seeds = std::stoi(v);
      else if (arg == "--first-seed") a.first_seed = std::stoull(v);
      else if (arg == "--max-pairs") a.max_pairs = std::stoi(v);
      else if (arg == "--max-features") a.max_features = std::stoi(v);
      else if (arg == "--threads") a.threads = static_cast<std::size_t>(std::stoul(v));
      else if (arg == "--layouts") {
        a.layouts.clear();
        std::stringstream in(v);
        for (std::string item; std::getline(in, item, ',');) a.layouts.push_back(item);
      } else usage("unknown option " + arg);
    } catch (const std::logic_error&) {
      usage("bad value '" + v + "' for " + arg);
    }
  }
  for (const std::string& l : a.layouts)
    if (l != "precise" && l != "small") usage("unknown layout " + l);
  if (a.seeds < 1 || a.max_pairs < 1) usage("--seeds and --max-pairs must be >= 1");
  return a;
}

GridTilerOptions layout(const std::string& name) {
  // small: the paper era's 640 x 480 tiles with MicMac's 10 % buffer per side.
  return name == "precise" ? GridTilerOptions::micmac_precise() : GridTilerOptions{640, 480, 64, 48};
}

struct TileRecord {
  double relief_m = std::nan("");  // height range of the epoch-1 DSM under the tile
  double warp_error_px = std::nan("");  // median |warp - truth| in the tile
  bool matched = false;
  Scored scored;
};

struct KindResult {
  Scored all;
  std::vector<double> correct3_per_pair, kept_per_pair, seconds_per_pair, warp_error_px;
  std::size_t pairs = 0, tiles = 0, skipped = 0, raw = 0, outside_core = 0, displaced = 0, off_patch = 0;
  std::vector<TileRecord> tiles_records;
};

}  // namespace

int main(int argc, char** argv) {
  const Arguments args = parse(argc, argv);
  try {
    const PatchWarpKind kinds[3] = {PatchWarpKind::homography_corners, PatchWarpKind::homography_grid,
                                    PatchWarpKind::piecewise_affine};
    std::printf("one_to_one_eval: %d seeds from %llu, %d largest-overlap pairs per seed, SIFT at most %d features per tile\n",
                args.seeds, static_cast<unsigned long long>(args.first_seed), args.max_pairs, args.max_features);
    SiftOptions sift_options;
    sift_options.max_features = args.max_features;
    const ExtractorPairMatcher<SiftExtractor> sift{SiftExtractor{sift_options}};

    std::map<std::string, std::map<PatchWarpKind, KindResult>> results;  // layout -> kind
    std::vector<double> generation_seconds;
    std::size_t footprints_invalid = 0, candidate_pairs = 0, overlapping = 0;
    for (int s = 0; s < args.seeds; ++s) {
      SceneOptions options = args.plain ? SceneOptions{} : SceneOptions::decades_apart();
      options.seed = args.first_seed + static_cast<std::uint64_t>(s);
      options.threads = args.threads;
      const auto t0 = std::chrono::steady_clock::now();
      const Scene scene = generate_scene(options);
      generation_seconds.push_back(seconds_since(t0));
      const SyntheticEpoch& e1 = scene.epochs[0];
      const SyntheticEpoch& e2 = scene.epochs[1];
      const Helmert3 helmert = scene.epoch2_from_epoch1();
      const MatchTruthScorer truth(scene);

      OverlappingPairsOptions pair_options;
      pair_options.min_overlap_fraction = 0.1;
      pair_options.threads = args.threads;
      // The SfM DSMs cover the multi-view part of each block only; the footprints' plane fallback
      // (FootprintOptions::plane_fallback, on) keeps the images at the blocks' edges.
      const OverlappingPairsResult pairs =
          overlapping_pairs(make_footprint_images(e1.estimated_frames()), e1.dsm,
                            make_footprint_images(e2.estimated_frames()), e2.dsm, helmert, pair_options);
      footprints_invalid += pairs.invalid_master_footprints + pairs.invalid_secondary_footprints;
      candidate_pairs += pairs.candidate_pairs;
      overlapping += pairs.overlapping_pairs;
      std::fprintf(stderr, "seed %llu: scene in %.1f s; %s\n", static_cast<unsigned long long>(options.seed),
                   generation_seconds.back(), pairs.message.c_str());

      const std::size_t n_pairs = std::min<std::size_t>(pairs.pairs.size(), static_cast<std::size_t>(args.max_pairs));
      for (std::size_t p = 0; p < n_pairs; ++p) {
        const ImagePairOverlap& pair = pairs.pairs[p];
        const int i = static_cast<int>(pair.master), j = static_cast<int>(pair.secondary);
        const auto transfer = make_dsm_transfer(e1.estimated_frame(pair.master), e1.dsm,
                                                e2.estimated_frame(pair.secondary), helmert);
        const Raster<std::uint8_t>& master = e1.images[pair.master].pixels;
        const Raster<std::uint8_t>& secondary = e2.images[pair.secondary].pixels;
        for (const std::string& layout_name : args.layouts) {
          // Relief per tile, from the DSM points the master sees (the same for every kind).
          const std::vector<Tile> tiles = GridTiler(layout(layout_name)).tiles(master.width(), master.height());
          std::vector<double> relief(tiles.size(), std::nan(""));
          for (std::size_t t = 0; t < tiles.size(); ++t) {
            double lo = 1e300, hi = -1e300;
            const PixelRect& r = tiles[t].buffered;
            for (int gy = 0; gy < 9; ++gy)
              for (int gx = 0; gx < 9; ++gx) {
                const auto q = transfer.master_point(Vec2(r.x + (r.width - 1) * gx / 8.0, r.y + (r.height - 1) * gy / 8.0));
                if (!q) continue;
                lo = std::min(lo, q->z());
                hi = std::max(hi, q->z());
              }
            if (hi >= lo) relief[t] = hi - lo;
          }
          for (const PatchWarpKind kind : kinds) {
            OneToOneOptions o;
            o.tiles = layout(layout_name);
            o.warp.kind = kind;
            o.threads = args.threads;
            const auto t1 = std::chrono::steady_clock::now();
            const OneToOneResult r = match_one_to_one(master, secondary, transfer, sift, o);
            const double seconds = seconds_since(t1);
            KindResult& out = results[layout_name][kind];
            Scored pair_scored;
            std::vector<TileRecord> records(r.tiles.size());
            for (std::size_t k = 0; k < r.matches.size(); ++k) {
              const MatchTruth t = truth.score({0, i}, {1, j}, r.matches[k].a, r.matches[k].b);
              pair_scored.add(t);
              records[r.match_tile[k]].scored.add(t);
            }
            for (std::size_t t = 0; t < r.tiles.size(); ++t) {
              const OneToOneTileReport& tr = r.tiles[t];
              records[t].relief_m = relief[t];
              records[t].matched = tr.matched();
              if (!tr.matched()) continue;
              // The warp against the truth, between its nodes.
              const PatchWarpFit fit = fit_patch_warp(transfer, tr.tile.buffered, o.warp);
              std::vector<double> errors;
              const PixelRect& b = tr.tile.buffered;
              for (int gy = 0; gy < 6; ++gy)
                for (int gx = 0; gx < 6; ++gx) {
                  const Vec2 px(b.x + (b.width - 1) * (gx + 0.37) / 6.0, b.y + (b.height - 1) * (gy + 0.61) / 6.0);
                  const MatchTruth t = truth.transfer({0, i}, {1, j}, px);
                  const auto w = fit.warp(px);
                  if (t.scored() && w) errors.push_back((*w - t.true_pixel).norm());
                }
              records[t].warp_error_px = median(errors);
              out.warp_error_px.insert(out.warp_error_px.end(), errors.begin(), errors.end());
            }
            out.all.add(pair_scored);
            out.correct3_per_pair.push_back(static_cast<double>(pair_scored.within[1]));
            out.kept_per_pair.push_back(static_cast<double>(r.kept));
            out.seconds_per_pair.push_back(seconds);
            ++out.pairs;
            out.tiles += r.tiles.size();
            out.skipped += r.tiles_skipped;
            out.raw += r.raw;
            out.outside_core += r.outside_core;
            out.displaced += r.displaced;
            out.off_patch += r.off_patch;
            out.tiles_records.insert(out.tiles_records.end(), records.begin(), records.end());
            std::fprintf(stderr, "  pair (%d, %d) overlap %.0f %%, %s tiles, %s: %zu kept, %zu correct < 3 px, %.1f s\n", i,
                         j, 100.0 * pair.fraction_of_smaller, layout_name.c_str(), to_string(kind), r.kept,
                         pair_scored.within[1], seconds);
          }
        }
      }
    }

    std::printf("\nscenes: median %.1f s to generate; footprints: %zu invalid; %zu candidate pairs, %zu overlapping\n",
                median(generation_seconds), footprints_invalid, candidate_pairs, overlapping);
    for (const std::string& layout_name : args.layouts) {
      const GridTilerOptions l = layout(layout_name);
      std::printf("\n## %s tiles (%d x %d, buffer %d x %d)\n\n", layout_name.c_str(), l.tile_width, l.tile_height,
                  l.buffer_x, l.buffer_y);
      std::printf("| warp | pairs | tiles (skipped) | raw / pair | kept / pair | correct < 1 / 3 / 6 / 10 px | correct < 3 px / pair (median) | displaced, off patch, outside core | warp error vs truth, median / p90 px | s / pair |\n");
      std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
      for (const PatchWarpKind kind : kinds) {
        const KindResult& r = results[layout_name][kind];
        std::vector<double> e = r.warp_error_px;
        std::sort(e.begin(), e.end());
        const double p90 = e.empty() ? std::nan("") : e[static_cast<std::size_t>(0.9 * static_cast<double>(e.size() - 1))];
        std::printf("| %s | %zu | %zu (%zu) | %.0f | %.0f | %.1f / %.1f / %.1f / %.1f %% | %.0f | %zu, %zu, %zu | %.2f / %.2f | %.2f |\n",
                    to_string(kind), r.pairs, r.tiles, r.skipped,
                    r.pairs ? static_cast<double>(r.raw) / static_cast<double>(r.pairs) : 0.0, median(r.kept_per_pair),
                    r.all.share(0), r.all.share(1), r.all.share(2), r.all.share(3), median(r.correct3_per_pair),
                    r.displaced, r.off_patch, r.outside_core, median(e), p90, median(r.seconds_per_pair));
      }
      // Relief split: terciles of the matched tiles' relief (the same tiles for every kind).
      std::vector<double> reliefs;
      for (const TileRecord& t : results[layout_name][kinds[0]].tiles_records)
        if (std::isfinite(t.relief_m)) reliefs.push_back(t.relief_m);
      std::sort(reliefs.begin(), reliefs.end());
      if (reliefs.size() < 3) continue;
      const double c1 = reliefs[reliefs.size() / 3], c2 = reliefs[2 * reliefs.size() / 3];
      std::printf("\nBy relief under the tile (height range of the epoch-1 DSM; terciles at %.1f and %.1f m):\n\n", c1, c2);
      std::printf("| warp | relief | tiles | correct < 3 px / tile (mean) | correct < 3 / 10 px | warp error vs truth, median of tile medians, px |\n|---|---|---|---|---|---|\n");
      const char* names[3] = {"low", "middle", "high"};
      for (int band = 0; band < 3; ++band)
        for (const PatchWarpKind kind : kinds) {
          Scored s;
          std::size_t n = 0;
          std::vector<double> warp_errors;
          for (const TileRecord& t : results[layout_name][kind].tiles_records) {
            if (!std::isfinite(t.relief_m)) continue;
            const int b = t.relief_m < c1 ? 0 : (t.relief_m < c2 ? 1 : 2);
            if (b != band) continue;
            ++n;
            s.add(t.scored);
            if (std::isfinite(t.warp_error_px)) warp_errors.push_back(t.warp_error_px);
          }
          std::printf("| %s | %s | %zu | %.1f | %.1f / %.1f %% | %.2f |\n", to_string(kind), names[band], n,
                      n ? static_cast<double>(s.within[1]) / static_cast<double>(n) : 0.0, s.share(1), s.share(3),
                      median(warp_errors));
        }
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "one_to_one_eval: %s\n", e.what());
    return 1;
  }
}
