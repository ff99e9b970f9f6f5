// match_epochs: inter-epoch tie points between two or more epochs of aerial images (paper section
// 3.2, Algorithm 1): rough co-registration of every epoch with the reference from the DSMs,
// overlapping image pairs of every two epochs, precise matching per pair, and optionally one
// combined adjustment of all epochs.
//
//   match_epochs EPOCH_DIR EPOCH_DIR [EPOCH_DIR ...] --out DIR [options]
//
// or the same in stages, for a cluster (docs/scaling.md; the same outputs byte for byte):
//
//   match_epochs plan EPOCH_DIR... --out DIR [options] [--emit slurm]   DIR/plan.json, jobs.tsv
//   match_epochs run-pair --plan DIR/plan.json --index I | --range A-B   DIR/jobs/<I>.json, .jpg
//   match_epochs merge --plan DIR/plan.json                              the outputs below
//
// The program's parts: settings.hpp (the options that decide the results), plan.hpp and
// plan_stage.hpp (the plan), pair_jobs.hpp, merge.hpp, report.hpp / reporter.hpp (report.json),
// dod.hpp, adjustment.hpp, pictures.hpp, slurm.hpp, epochs.hpp (the epochs and the output folder).
//
// Each epoch folder holds a COLMAP model (text: cameras.txt, images.txt, points3D.txt; or COLMAP's
// binary .bin files), images/ and dsm.tif in the model's frame (what make_scene writes), and
// optionally masks/<image name>.png (COLMAP's masks) or images/<stem>_Masq.tif (MicMac's): 0 where
// no match may be, e.g. the scan's frame and fiducial marks; or it is an orthophoto epoch: ortho.tif
// (north-up geotransform) and dsm.tif in the same CRS, cut into tiles (io/epoch_folder.hpp). An
// epoch is named by its folder ("/data/1954" -> 1954). The reference is the last epoch given, or
// --reference NAME; every other epoch is free, taken in name order.
//
// Before any work, every option is parsed strictly (CLI11) and each epoch's model, DSM and image
// files are checked against each other (io/epoch_folder_check.hpp): a model that disagrees grossly
// with its DSM, or images that are unreadable or not of their camera's size, refuse the run (exit
// 1, with the figures and a remedy); a mild disagreement is a warning that lowers the trust.
// Each free epoch is co-registered with the reference from the DSMs (--rough auto), or through
// another free epoch already placed when that fails, or by a given transform (--rough
// identity|FILE, per epoch with NAME=). Every two epochs' overlapping image pairs are matched.
//
// The outputs are written into a fresh folder inside --out and moved into place when the run ends
// (exit 0 or 2): a rerun never leaves an earlier run's tie points beside its report; a run stopped
// by an error leaves --out as it was. --out must be new or empty, or --overwrite replaces an earlier
// run's outputs. Writes
//   DIR/rough_helmert_<epoch>.json  per free epoch, its rough co-registration, X_ref = scale R X + t
//   DIR/Homol/              final inter-epoch tie points of every pair, MicMac Homol (both directions;
//                           names as in images.txt, unless a name has a folder or two epochs use it: then
//                           every name is prefixed e<k>_, and DIR/homol_names.txt lists them)
//   DIR/plan.json, DIR/jobs.tsv, DIR/jobs/  the plan and each pair job's result (docs/scaling.md)
//   DIR/report.json         the run (command line, version, threads, time per stage), the trust of the
//                           results and why, warnings, the input checks, per epoch and epoch pair
//   DIR/pairs/<a>__<b>.jpg  each pair: the secondary warped onto the master, the matches as dots
//   DIR/dod/<epoch>_rough.tif, .png  each free epoch's DoD with the reference after the rough
//                           co-registration (eval/dod_map.hpp), report.json's "dod"
// and with --adjust (the combined adjustment, pipeline/combined_epochs.hpp, in the reference's frame):
//   DIR/adjusted/cameras.json, DIR/adjusted/<epoch>/  the adjusted orientation (io/adjusted_export.hpp)
//   DIR/adjusted/colmap/    all epochs in one COLMAP model with the tie points as points3D, images/
//                           links (--colmap-format text|binary)
//   DIR/adjusted/micmac/Ori-diachron/  the same as MicMac orientations (io/micmac_orientation.hpp)
//   DIR/adjusted/residuals/<image>.png  reprojection residuals of the free epochs' tie points
//   DIR/dod/<epoch>.tif, .png, <epoch>_helmert.json  each free epoch's DoD after the adjustment
//   the "adjustment" section of report.json, and its grade (adjustment/adjustment_grade.hpp) in "trust"
// Progress on stderr (lines when it is not a terminal). Exit status: 0 success, 2 no co-registration,
// no overlap, no match or no adjustment (reason printed), 1 bad input. The input folders are never
// written to.

#include <algorithm>
#include <atomic>
#include <charconv>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <thread>
#include <tuple>
#include <type_traits>
#include <cstdlib>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <sys/stat.h>
#include <unistd.h>
#include <iterator>

#include <CLI/CLI.hpp>

#include "../program_support.hpp"

#include <diachron/core/byte_budget_cache.hpp>
#include <diachron/core/index_ranges.hpp>
#include <diachron/core/memory_usage.hpp>
#include <diachron/core/progress.hpp>
#include <diachron/eval/dod_map.hpp>
#include <diachron/io/control_points.hpp>
#include <diachron/io/epoch_folder.hpp>
#include <diachron/io/epoch_folder_check.hpp>
#include <diachron/io/folders.hpp>
#include <diachron/io/geotiff.hpp>
#include <diachron/io/helmert_json.hpp>
#include <diachron/io/homol.hpp>
#include <diachron/io/atomic_file.hpp>
#include <diachron/io/input_fingerprint.hpp>
#include <diachron/io/json.hpp>
#include <diachron/io/pair_job_file.hpp>
#include <diachron/pipeline/epoch_placement.hpp>
#include <diachron/pipeline/overlapping_pairs.hpp>
#include <diachron/pipeline/precise_matching.hpp>
#include <diachron/pipeline/rough_coregistration.hpp>
#include <diachron/terrain/ray_dsm_intersection.hpp>
#include <diachron/vision/akaze.hpp>
#include <diachron/vision/draw_dod.hpp>
#include <diachron/geometry/homography.hpp>
#include <diachron/vision/draw_pair_overlay.hpp>
#include <diachron/vision/extractor_pair_matcher.hpp>
#include <diachron/vision/sift.hpp>
#include <diachron/vision/xfeat.hpp>

#include <opencv2/imgproc.hpp>
#if DIACHRON_MATCH_EPOCHS_ADJUST
#include <diachron/adjustment/adjustment_grade.hpp>
#include <diachron/adjustment/triangulation.hpp>
#include <diachron/eval/check_points.hpp>
#include <diachron/eval/distortion_precision.hpp>
#include <diachron/eval/dsm_reintersection.hpp>
#include <diachron/io/adjusted_export.hpp>
#include <diachron/io/micmac_orientation.hpp>
#include <diachron/pipeline/combined_epochs.hpp>
#include <diachron/pipeline/orthophoto_reference.hpp>
#include <diachron/vision/draw_residuals.hpp>
#include <glog/logging.h>
#endif

#include "epochs.hpp"
#include "pictures.hpp"
#include "report.hpp"
#include "settings.hpp"
#include "dod.hpp"
#include "adjustment.hpp"
#include "plan.hpp"
#include "reporter.hpp"
#include "plan_stage.hpp"
#include "pair_jobs.hpp"
#include "merge.hpp"
#include "slurm.hpp"

namespace {

using namespace diachron;
using namespace match_epochs;
using diachron::programs::Progress;
using diachron::programs::strict_number;

const char* kDescription =
    "match_epochs: inter-epoch tie points between two or more epochs of aerial images (rough\n"
    "co-registration from the DSMs, overlapping pairs, precise matching), and with --adjust one\n"
    "combined adjustment of all epochs. Each EPOCH_DIR, named by its folder: a COLMAP model (text\n"
    "cameras.txt images.txt points3D.txt, or COLMAP's .bin) or a MicMac project (Ori-NAME/, Homol/),\n"
    "images/, dsm.tif in the model's frame,\n"
    "optionally masks/<image name>.png or images/<stem>_Masq.tif (0 where no match may be); or an\n"
    "orthophoto epoch: ortho.tif and dsm.tif in one CRS. The last epoch given is the reference\n"
    "(--reference); the others are taken in name order. Each epoch's model, DSM and images are\n"
    "checked against each other before any work. Outputs go to --out (docs/precise-matching.md).\n"
    "The run in stages, for a cluster (docs/scaling.md): match_epochs plan EPOCH_DIR... --out DIR,\n"
    "then match_epochs run-pair --plan DIR/plan.json --index I (every job of DIR/jobs.tsv), then\n"
    "match_epochs merge --plan DIR/plan.json; the same outputs as one run.\n"
    "Exit status: 0 success (report.json's \"trust\" grades it), 2 no answer (no co-registration,\n"
    "overlap, match or adjustment: the reason is printed), 1 bad input or options.\n";

// The options of the stages that do not change the results.
struct StageOptions {
  std::string out_dir, plan_path, index, range, emit;
  std::string memory_budget = "1G";  // the image cache of the pair jobs
  bool overwrite = false, quiet = false, verbose = false;
  std::size_t threads = 0;
  SlurmOptions slurm;
};

void add_common_options(CLI::App& app, StageOptions& o) {
  app.add_option("--memory-budget", o.memory_budget,
                 "bytes of images the pair jobs keep between pairs, e.g. 4G, 500M, 0 (default 1G); each running "
                 "pair holds its two images and its work on top (docs/scaling.md)");
  app.add_option("--threads", o.threads, "worker threads, 0 = all cores (default 0)")
      ->check(strict_number<std::size_t>(0, 4096, "a thread count in [0, 4096]"));
  app.add_flag("--quiet", o.quiet, "no progress on stderr");
  app.add_flag("--verbose", o.verbose, "errors with the library's internal condition (for bug reports)");
}

void add_out_options(CLI::App& app, StageOptions& o) {
  app.add_option("--out", o.out_dir, "output folder (created; it must be new or empty unless --overwrite)")->required();
  app.add_flag("--overwrite", o.overwrite,
               "replace the outputs of an earlier run in --out (they are removed only when this run ends, "
               "so a failed run leaves them as they were)");
}

// The plan's folder and path from --plan (DIR/plan.json or DIR).
void resolve_plan_path(StageOptions& o, std::string& plan_dir) {
  if (is_folder(o.plan_path)) o.plan_path += "/plan.json";
  o.plan_path = absolute_path(o.plan_path);
  const std::size_t slash = o.plan_path.find_last_of('/');
  plan_dir = slash == std::string::npos ? std::string(".") : o.plan_path.substr(0, slash);
}

// The jobs of run-pair: --index, --range, or the Slurm array task's index.
std::vector<std::size_t> job_indices(const StageOptions& o, std::size_t jobs, const std::string& plan_path) {
  IndexRange range;
  if (!o.range.empty()) {
    range = parse_index_range(o.range);
  } else if (!o.index.empty()) {
    range = parse_index_range(o.index);
    DIACHRON_CHECK(range.first == range.last, "--index takes one job (" << o.index << "): --range A-B for several");
  } else {
    const char* task = std::getenv("SLURM_ARRAY_TASK_ID");
    DIACHRON_CHECK(task != nullptr, "run-pair needs --index I or --range A-B (or SLURM_ARRAY_TASK_ID in a Slurm array)");
    range = parse_index_range(task);
  }
  DIACHRON_CHECK(range.last < jobs, "job " << range.last << " is not in the plan '" << plan_path << "' (it has jobs 0 to "
                                          << (jobs == 0 ? 0 : jobs - 1) << ")");
  std::vector<std::size_t> out;
  for (std::size_t i = range.first; i <= range.last; ++i) out.push_back(i);
  return out;
}

// Threads of a job: --threads, else the CPUs Slurm gave the task, else all.
std::size_t job_threads(const CLI::App& app, const StageOptions& o) {
  if (app.count("--threads") > 0) return o.threads;
  if (const char* cpus = std::getenv("SLURM_CPUS_PER_TASK")) {
    std::size_t n = 0;
    if (diachron::programs::detail::parse_strict(std::string(cpus), n) && n >= 1 && n <= 4096) return n;
  }
  return o.threads;
}

// The image reads and the memory of the jobs, for people.
std::string memory_summary(const JobsOutcome& outcome) {
  const ByteBudgetCacheStats& c = outcome.images;
  std::ostringstream o;
  o << "images read " << c.misses << " times, " << c.hits << " from the cache (at most "
    << format_bytes(c.peak_resident_bytes) << " kept)";
  if (const std::optional<std::size_t> peak = peak_resident_bytes()) o << ", peak memory " << format_bytes(*peak);
  return o.str();
}

void print_job_errors(const JobsOutcome& outcome) {
  for (const std::string& e : outcome.errors) {
    Progress::break_line();
    std::fprintf(stderr, "match_epochs: %s\n", e.c_str());
  }
}

int main_stages(int argc, char** argv) {
  const std::string stage = argc > 1 ? argv[1] : "";
  const bool staged = stage == "plan" || stage == "run-pair" || stage == "merge";
  Settings settings;
  StageOptions o;
  CLI::App app{kDescription, staged ? "match_epochs " + stage : "match_epochs"};
  app.get_formatter()->column_width(34);
  if (!staged || stage == "plan") {
    add_run_options(app, settings);
    add_out_options(app, o);
  }
  if (stage == "plan") {
    app.add_option("--emit", o.emit, "also write job scripts: slurm (DIR/slurm/: an sbatch array and a merge job)")
        ->check(CLI::IsMember({"slurm"}));
    add_slurm_options(app, o.slurm);
  }
  if (stage == "run-pair" || stage == "merge") {
    app.add_option("--plan", o.plan_path, "the plan: DIR/plan.json (or DIR) written by match_epochs plan")->required();
  }
  if (stage == "run-pair") {
    app.add_option("--index", o.index, "the job (a line of DIR/jobs.tsv; default: SLURM_ARRAY_TASK_ID)");
    app.add_option("--range", o.range, "the jobs A to B, both included");
  }
  add_common_options(app, o);
  // The stage's name is not an option of its own parser.
  std::vector<char*> args(argv, argv + argc);
  if (staged) args.erase(args.begin() + 1);
  if (const std::optional<int> status =
          diachron::programs::parse_options(app, static_cast<int>(args.size()), args.data(), 1))
    return *status;
  std::optional<OutputFolder> output;
  try {
    const ProgressCallback progress = o.quiet ? ProgressCallback() : Progress::callback();
    std::size_t budget = 0;
    try {
      budget = parse_byte_size(o.memory_budget);
    } catch (const Error& e) {
      DIACHRON_CHECK(false, "--memory-budget: " << e.message());
    }
    if (stage == "run-pair") {
      DIACHRON_CHECK(o.index.empty() || o.range.empty(), "--index and --range both name jobs: give one of them");
      std::string plan_dir;
      resolve_plan_path(o, plan_dir);
      Run run = read_plan(o.plan_path);
      const std::vector<std::size_t> indices = job_indices(o, run.jobs, o.plan_path);
      const JobsOutcome outcome =
          run_jobs(run, plan_dir, o.plan_path, indices, job_threads(app, o), budget, progress, o.quiet);
      print_job_errors(outcome);
      std::printf("pair jobs %s of %s: %zu run, %zu already done, %zu failed; %s\n",
                  index_ranges_text(index_ranges(indices)).c_str(), o.plan_path.c_str(), outcome.done, outcome.skipped,
                  outcome.errors.size(), memory_summary(outcome).c_str());
      return outcome.errors.empty() ? 0 : 1;
    }
    if (stage == "merge") {
      std::string plan_dir;
      resolve_plan_path(o, plan_dir);
      Run run = read_plan(o.plan_path);
      Reporter reporter(run, argc, argv, o.threads);
      output.emplace(plan_dir, true, true);
      const int status = merge_stage(run, plan_dir, o.plan_path, output->work(), plan_dir, reporter, o.threads);
      output->commit();
      return status;
    }
    // plan, or the whole run: the plan, every job, the merge.
    prepare(settings);
#if DIACHRON_MATCH_EPOCHS_ADJUST
    // The adjustment's options are used by the merge; a typo fails here, before any work.
    parse_intrinsics(settings.hold);
    parse_priors(settings.prior);
#endif
    Run run;
    run.settings = settings;
    run.arguments = canonical_arguments(app, settings);
    name_epochs(run);
    Reporter reporter(run, argc, argv, o.threads);
    // Every option is checked; the output folder next (a full --out refuses before any work).
    output.emplace(o.out_dir, o.overwrite);
    const std::string work = output->work();
    const int planned = plan_stage(run, work, reporter, progress, o.quiet, o.threads);
    if (planned == 1) return 1;  // refused: --out as it was
    if (planned == 2) {
      output->commit();
      return 2;
    }
    if (stage == "plan") {
      const std::string final_plan = absolute_path(o.out_dir) + "/plan.json";
      if (o.emit == "slurm") write_slurm_scripts(run, work, final_plan, argv[0], o.slurm);
      output->commit();
      std::printf("plan: %zu pair jobs in %s (%s/jobs.tsv lists them); run each with match_epochs run-pair --plan %s "
                  "--index I%s, then match_epochs merge --plan %s\n",
                  run.jobs, final_plan.c_str(), o.out_dir.c_str(), final_plan.c_str(),
                  o.emit == "slurm" ? (" (or sh " + o.out_dir + "/slurm/submit.sh)").c_str() : "", final_plan.c_str());
      return 0;
    }
    // The one-process run goes through the plan as written, as the stages do.
    const std::string plan_path = work + "/plan.json";
    Run planned_run = read_plan(plan_path);
    for (std::size_t k = 0; k < run.epochs.size(); ++k) {  // read once: the same folders
      planned_run.epochs[k].folder = std::move(run.epochs[k].folder);
      planned_run.epochs[k].frames = std::move(run.epochs[k].frames);
      planned_run.epochs[k].loaded = true;
    }
    std::vector<std::size_t> all(planned_run.jobs);
    for (std::size_t i = 0; i < all.size(); ++i) all[i] = i;
    const JobsOutcome outcome = run_jobs(planned_run, work, plan_path, all, o.threads, budget, progress, o.quiet);
    print_job_errors(outcome);
    if (!o.quiet) std::fprintf(stderr, "pair jobs: %s\n", memory_summary(outcome).c_str());
    DIACHRON_CHECK(outcome.errors.empty(), outcome.errors.size() << " pair job(s) failed");
    reporter.run = &planned_run;
    reporter.clock.stage("precise matching");
    const int status = merge_stage(planned_run, work, plan_path, work, o.out_dir, reporter, o.threads);
    output->commit();
    return status;
  } catch (const std::exception& e) {
    Progress::break_line();
    std::fprintf(stderr, "match_epochs: %s\n", diachron::programs::error_text(e, o.verbose).c_str());
    return 1;
  }
}

}  // namespace

int main(int argc, char** argv) {
#if DIACHRON_MATCH_EPOCHS_ADJUST
  // Ceres logs through glog on stderr (e.g. a trust-region step it rejected); the adjustment's
  // report and report.json say what matters, so only fatal messages are let through.
  FLAGS_minloglevel = google::GLOG_FATAL;
#endif
  // Whole lines on stdout even into a file, so that they keep their order with stderr's progress.
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  return main_stages(argc, argv);
}
