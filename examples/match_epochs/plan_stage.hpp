#pragma once
// match_epochs (examples/match_epochs/main.cpp): the plan stage. The epochs read and checked, every
// free epoch co-registered with the reference, the overlapping pairs of every two epochs; then
// plan.json, jobs.tsv and an empty jobs/ in `work`.

namespace match_epochs {

using namespace diachron;
using diachron::programs::Progress;

// The epochs of the settings, named by their folders, the reference last and the free ones in name
// order after it (outputs do not depend on the order they were given in), each with its --rough.
void name_epochs(Run& run) {
  Settings& s = run.settings;
  std::vector<Epoch>& epochs = run.epochs;
  epochs.clear();
  epochs.resize(s.dirs.size());
  for (std::size_t k = 0; k < s.dirs.size(); ++k) {
    epochs[k].dir = absolute_path(s.dirs[k]);
    epochs[k].name = folder_name(s.dirs[k]);
    DIACHRON_CHECK(!epochs[k].name.empty() && epochs[k].name != "/" && epochs[k].name != "residuals" &&
                       epochs[k].name != "colmap" && epochs[k].name != "micmac",
                   "epoch folder '" << s.dirs[k] << "' has no name usable for outputs ('" << epochs[k].name
                                    << "'; residuals, colmap and micmac are taken by adjusted/): give it a folder of its "
                                       "own, e.g. a link named after its year");
    for (std::size_t j = 0; j < k; ++j) {
      DIACHRON_CHECK(s.dirs[j] != s.dirs[k] && !same_folder(s.dirs[j], s.dirs[k]),
                     "the folder '" << s.dirs[k] << "' is given twice (as '" << s.dirs[j] << "')");
      DIACHRON_CHECK(epochs[j].name != epochs[k].name,
                     "two epochs are named '" << epochs[k].name << "' ('" << s.dirs[j] << "' and '" << s.dirs[k]
                                              << "'): epochs are named by their folders; link one under another name");
    }
  }
  std::string reference_name = s.reference_name.empty() ? epochs.back().name : s.reference_name;
  {
    const auto it =
        std::find_if(epochs.begin(), epochs.end(), [&](const Epoch& e) { return e.name == reference_name; });
    std::string known;
    for (const Epoch& e : epochs) known += (known.empty() ? "" : ", ") + e.name;
    DIACHRON_CHECK(it != epochs.end(), "--reference: no epoch is named '" << reference_name << "' (" << known << ")");
    std::rotate(it, it + 1, epochs.end());
    std::sort(epochs.begin(), epochs.end() - 1, [](const Epoch& a, const Epoch& b) { return a.name < b.name; });
  }
  run.reference = epochs.size() - 1;
  // --rough: one mode for every free epoch, or NAME=MODE for one; read before any work, so that a
  // missing or malformed file fails fast.
  for (const std::string& spec : s.rough_specs) {
    const std::size_t eq = spec.find('=');
    std::string name, mode = spec;
    if (eq != std::string::npos &&
        std::any_of(epochs.begin(), epochs.end(), [&](const Epoch& e) { return e.name == spec.substr(0, eq); })) {
      name = spec.substr(0, eq);
      mode = spec.substr(eq + 1);
      DIACHRON_CHECK(name != epochs[run.reference].name,
                     "--rough " << spec << ": '" << name << "' is the reference; it is not moved");
    }
    std::optional<Helmert3> given;
    if (mode == "identity") given = Helmert3::identity();
    else if (mode != "auto") {
      DIACHRON_CHECK(!mode.empty(), "--rough wants [NAME=]auto, identity or a helmert.json file");
      DIACHRON_CHECK(is_regular_file(mode), "--rough: '" << mode << "' is neither auto, identity nor a file");
      given = read_helmert_json(mode);
    }
    for (std::size_t k = 0; k < run.reference; ++k)
      if (name.empty() || epochs[k].name == name) {
        epochs[k].rough_mode = mode;
        epochs[k].given = given;
      }
  }
}

// Reads every epoch and checks its model, DSM and image files against each other. False when a
// check refuses the run (said on stderr, with the remedy).
bool read_and_check_epochs(Run& run, bool quiet) {
  bool refused = false;
  for (Epoch& e : run.epochs) {
    load_epoch(run, static_cast<std::size_t>(&e - run.epochs.data()), "");
    e.fingerprint = epoch_fingerprint(e.folder);
    const EpochFolderCheck check = check_epoch_folder(e.folder);
    std::ostringstream o;
    o.precision(6);
    input_check_json(o, check);
    e.input_check = o.str();
    for (const EpochCheckIssue& issue : check.issues) {
      if (issue.severity == EpochCheckSeverity::note) {
        run.notes.push_back(issue.what + " (" + issue.remedy + ")");
        if (!quiet) {
          Progress::break_line();
          std::fprintf(stderr, "note: %s\n", run.notes.back().c_str());
        }
        continue;
      }
      if (issue.severity == EpochCheckSeverity::warning) {
        warn(run.warnings, issue.what + " (" + issue.remedy + ")");
        continue;
      }
      Progress::break_line();
      std::fprintf(stderr, "match_epochs: %s\n  remedy: %s\n", issue.what.c_str(), issue.remedy.c_str());
      refused = true;
    }
  }
  return !refused;
}

// The plan: 0 when made (plan.json, jobs.tsv, jobs/ in `work`), 1 when the input checks refuse the
// run (nothing written), 2 when there is no answer (no co-registration or no overlap: report.json
// says why).
int plan_stage(Run& run, const std::string& work, Reporter& reporter, const ProgressCallback& progress, bool quiet,
               std::size_t threads) {
  Settings& s = run.settings;
  std::vector<Epoch>& epochs = run.epochs;
  const std::size_t reference = run.reference;
  if (!read_and_check_epochs(run, quiet)) {
    std::fprintf(stderr, "match_epochs: refused before any matching; --out is left as it was\n");
    return 1;
  }
  reporter.clock.stage("reading and checking the inputs");
  for (std::size_t k = 0; k < reference; ++k)
    DIACHRON_CHECK(!s.adjust || !epochs[k].folder.is_ortho(),
                   "epoch " << epochs[k].name << " ('" << epochs[k].dir
                            << "') is an orthophoto epoch: with --adjust an orthophoto can only be the reference "
                               "(--reference "
                            << epochs[k].name << ")");
  for (const Epoch& e : epochs)
    if (const std::optional<double> v = suspected_untagged_nodata(e.folder.dsm); v && !s.dsm_read.assume_untagged_nodata) {
      std::ostringstream m;
      m << "'" << e.dir << "/dsm.tif' has heights of " << *v
        << " far below all others and no nodata tag for them: if they are holes, pass --nodata " << *v;
      warn(run.warnings, m.str());
    }
#if DIACHRON_MATCH_EPOCHS_ADJUST
  // The control and check points' image names, before any work.
  epochs_control_points(s.control, epochs, "control point");
  epochs_control_points(s.check_records, epochs, "check point");
#endif
  if (set_homol_names(epochs) && !quiet)
    std::fprintf(stderr, "image names with a folder or shared by two epochs: Homol/ uses e<k>_ names "
                         "(DIR/homol_names.txt)\n");
  if (!quiet)
    for (const Epoch& e : epochs)
      std::fprintf(stderr, "epoch %s%s: %zu %s (%zu masked), DSM %d x %d\n", e.name.c_str(),
                   &e == &epochs[reference] ? " (reference)" : "", e.folder.images.size(),
                   e.folder.is_ortho() ? "orthophoto tiles" : "images", e.folder.masks(), e.folder.dsm.width(),
                   e.folder.dsm.height());

  // 1. Rough co-registration of every free epoch with the reference: from the DSMs (its defaults:
  // SIFT on slope images), or given. An epoch that fails goes through another free epoch already
  // placed, the best-trusted first; the chain may grow as epochs are placed.
  std::vector<std::optional<Helmert3>> given;
  for (const Epoch& e : epochs) given.push_back(e.given);
  const std::vector<EpochPlacement> placements = place_epochs(
      epochs.size(), reference, given,
      [&](std::size_t from, std::size_t to) {
        RoughCoregistrationOptions rough_options;
        rough_options.threads = threads;
        rough_options.progress = progress;
        rough_options.correlation_fallback = s.use_fallback;
        return rough_coregistration(epochs[from].folder.dsm, epochs[to].folder.dsm,
                                    ExtractorPairMatcher<SiftExtractor>(SiftExtractor{}), rough_options);
      },
      [&](std::size_t from, std::size_t to, const RoughCoregistrationReport& r) {
        std::printf("rough co-registration %s -> %s: %s\n", epochs[from].name.c_str(), epochs[to].name.c_str(),
                    r.message.c_str());
      });
  for (std::size_t k = 0; k < reference; ++k) {
    Epoch& e = epochs[k];
    const EpochPlacement& p = placements[k];
    e.placed = p.placed;
    e.reference_from_epoch = p.reference_from_epoch;
    e.rough = p.report;
    if (p.given) {
      e.rough.success = true;
      e.rough.epoch2_from_epoch1 = p.reference_from_epoch;
      e.rough.message = e.rough_mode == "identity" ? "given: the identity (--rough identity)"
                                                   : "given: " + e.rough_mode + " (--rough FILE)";
    }
    if (p.via) {
      e.via = epochs[*p.via].name;
      e.rough.message = "through " + e.via + ": " + e.rough.message;
    }
    std::ostringstream o;
    o.precision(10);  // write_report's
    write_rough_json(o, e);
    e.rough_json = o.str();
  }
  reporter.clock.stage("rough co-registration");
  for (std::size_t k = 0; k < reference; ++k) {
    if (epochs[k].placed) continue;
    reporter.write(work, "");
    std::printf("no co-registration of %s with %s: %s\n", epochs[k].name.c_str(), epochs[reference].name.c_str(),
                epochs[k].rough.message.c_str());
    return 2;
  }
  for (std::size_t k = 0; k < reference; ++k)
    write_helmert_json(epochs[k].reference_from_epoch, work + "/rough_helmert_" + epochs[k].name + ".json");

  // 2. Overlapping pairs of every two epochs through the DSMs, the master's footprints moved by
  // the transform between them. Photos and orthophoto tiles alike, through EpochFrame.
  OverlappingPairsOptions overlap_options = s.overlap_options;
  overlap_options.threads = threads;
  for (std::size_t a = 0; a < epochs.size(); ++a)
    for (std::size_t b = a + 1; b < epochs.size(); ++b) {
      EpochPair p;
      p.master = a;
      p.secondary = b;
      // Into the reference: its rough transform as it is (bit for bit what two epochs always used).
      p.secondary_from_master = b == reference ? epochs[a].reference_from_epoch
                                               : epochs[b].reference_from_epoch.inverse() * epochs[a].reference_from_epoch;
      std::vector<FootprintImage<EpochFrame>> fa, fb;
      for (const EpochFrame& f : epochs[a].frames) fa.push_back({f, f.width(), f.height()});
      for (const EpochFrame& f : epochs[b].frames) fb.push_back({f, f.width(), f.height()});
      p.overlap = overlapping_pairs(fa, epochs[a].folder.dsm, fb, epochs[b].folder.dsm, p.secondary_from_master,
                                    overlap_options);
      // The jobs by master image, then secondary (overlapping_pairs gives the largest overlap first):
      // consecutive jobs share their master, so a task of several jobs (--range, a Slurm task with
      // --slurm-pairs-per-task) reads it once through the image cache.
      std::stable_sort(p.overlap.pairs.begin(), p.overlap.pairs.end(),
                       [](const ImagePairOverlap& x, const ImagePairOverlap& y) {
                         return std::tie(x.master, x.secondary) < std::tie(y.master, y.secondary);
                       });
      p.first_job = run.jobs;
      run.jobs += p.overlap.pairs.size();
      std::printf("overlapping pairs %s -- %s: %zu of %zu candidates (%s)\n", epochs[a].name.c_str(),
                  epochs[b].name.c_str(), p.overlap.pairs.size(), p.overlap.candidate_pairs, p.overlap.message.c_str());
      run.pairs.push_back(std::move(p));
    }
  reporter.clock.stage("overlapping pairs");
  for (std::size_t k = 0; k < epochs.size(); ++k) {
    if (std::any_of(run.pairs.begin(), run.pairs.end(), [&](const EpochPair& p) {
          return (p.master == k || p.secondary == k) && !p.overlap.pairs.empty();
        }))
      continue;
    reporter.write(work, "");
    std::printf("no overlapping pair: epoch %s overlaps no other epoch (least overlap %g of the smaller footprint; "
                "check its DSM and rough co-registration)\n",
                epochs[k].name.c_str(), s.min_overlap);
    return 2;
  }
  run.plan_id = plan_id(run);
  write_file_atomically(work + "/plan.json", plan_json(run));
  write_file_atomically(work + "/jobs.tsv", jobs_tsv(run));
  make_folder(work + "/jobs", "match_epochs");
  return 0;
}

}  // namespace match_epochs
