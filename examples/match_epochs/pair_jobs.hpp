#pragma once
// match_epochs (examples/match_epochs/main.cpp): pair jobs. Job I matches image pair I of the plan
// (jobs.tsv) and writes DIR/jobs/<I>.json (io/pair_job_file.hpp) and, with pictures,
// DIR/jobs/<I>.jpg, each through a temporary file and a rename. A job whose result is there for
// this plan is skipped; a job another process holds (a lock on DIR/jobs/<I>.lock) is refused.

namespace match_epochs {

using namespace diachron;
using diachron::programs::Progress;

std::string job_stem(const std::string& plan_dir, std::size_t index) {
  char name[32];
  std::snprintf(name, sizeof name, "%06zu", index);
  return plan_dir + "/jobs/" + name;
}

// The result of job `index` when it is there, complete and of plan `plan_id`.
std::optional<PairJobRecord> finished_job(const std::string& plan_dir, std::size_t index, const std::string& plan_id) {
  const std::string path = job_stem(plan_dir, index) + ".json";
  if (!is_regular_file(path)) return std::nullopt;
  try {
    PairJobRecord r = read_pair_job(path);
    if (r.plan_id == plan_id && r.index == index) return r;
  } catch (const Error&) {
  }
  return std::nullopt;
}

// The images the jobs read, each read from disk when a job needs it and kept in a cache of at most
// `budget_bytes` (core/byte_budget_cache.hpp): consecutive jobs of one master image read it once,
// and memory does not grow with the number of images. A budget of 0 keeps nothing.
class JobImages {
 public:
  JobImages(const Run& run, std::size_t budget_bytes)
      : run_(run), cache_(ByteBudgetCacheOptions{std::max<std::size_t>(budget_bytes, 1)},
                          [](const Raster<std::uint8_t>& r) { return r.size() + sizeof(Raster<std::uint8_t>); }),
        keep_(budget_bytes > 0) {}
  Raster<std::uint8_t> load(std::size_t epoch, std::size_t image) const {
    if (!keep_) {
      ++uncached_reads_;
      return run_.epochs[epoch].folder.load_image(image);
    }
    const std::uint64_t key = (static_cast<std::uint64_t>(epoch) << 40) | image;
    return *cache_.get(key, [&] { return run_.epochs[epoch].folder.load_image(image); });
  }
  // The cache's counters; without a cache, `misses` counts the reads.
  ByteBudgetCacheStats stats() const {
    ByteBudgetCacheStats s = cache_.stats();
    s.misses += uncached_reads_;
    return s;
  }

 private:
  const Run& run_;
  mutable ByteBudgetCache<std::uint64_t, Raster<std::uint8_t>> cache_;
  bool keep_ = true;
  mutable std::atomic<std::size_t> uncached_reads_{0};
};

struct JobsOutcome {
  std::size_t done = 0, skipped = 0;
  std::vector<std::string> errors;  // one per failed job
  ByteBudgetCacheStats images;      // the image cache's
};

// Runs the jobs `indices` of the plan in `plan_dir` (whose epochs they need are loaded here),
// `threads` at a time (or one at a time with `threads` each when there are fewer jobs than threads).
JobsOutcome run_jobs(Run& run, const std::string& plan_dir, const std::string& plan_path,
                     const std::vector<std::size_t>& indices, std::size_t threads, std::size_t memory_budget,
                     const ProgressCallback& progress, bool quiet) {
  const Settings& s = run.settings;
  const std::vector<Job> all = job_list(run);
  for (std::size_t i : indices)
    DIACHRON_CHECK(i < all.size(), "job " << i << " is not in the plan '" << plan_path << "' (it has jobs 0 to "
                                          << (all.empty() ? 0 : all.size() - 1) << ")");
  std::vector<std::uint8_t> needed(run.epochs.size(), 0);
  for (std::size_t i : indices) needed[run.pairs[all[i].pair].master] = needed[run.pairs[all[i].pair].secondary] = 1;
  for (std::size_t k = 0; k < run.epochs.size(); ++k)
    if (needed[k]) load_epoch(run, k, plan_path);
  make_folder(plan_dir + "/jobs", "match_epochs");
  const JobImages images(run, memory_budget);
  std::vector<PreciseEpoch<EpochFrame>> precise(run.epochs.size());
  for (std::size_t k = 0; k < run.epochs.size(); ++k) {
    if (!needed[k]) continue;
    const Epoch& e = run.epochs[k];
    precise[k] = {e.frames, [&images, k](std::size_t i) { return images.load(k, i); }, &e.folder.dsm,
                  [&e](std::size_t i) { return e.folder.load_mask(i); }};
  }
  PreciseMatchingOptions options = s.options;
  options.threads = indices.size() >= resolve_threads(threads) ? 1 : threads;
  options.progress = nullptr;
  SiftOptions sift_options;
  sift_options.root_sift = s.matcher_name == "rootsift";
  JobsOutcome out;
  std::vector<std::string> errors(indices.size());
  std::vector<std::uint8_t> skipped(indices.size(), 0);
  // The jobs one image's pairs after another (each epoch pair's by master image, then secondary), so
  // that the cache serves an image to its next pairs; results go by index whatever the order.
  std::vector<std::size_t> order(indices.size());
  for (std::size_t n = 0; n < order.size(); ++n) order[n] = n;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) {
    const Job& a = all[indices[x]];
    const Job& b = all[indices[y]];
    const ImagePairOverlap& pa = run.pairs[a.pair].overlap.pairs[a.k];
    const ImagePairOverlap& pb = run.pairs[b.pair].overlap.pairs[b.k];
    return std::tie(a.pair, pa.master, pa.secondary) < std::tie(b.pair, pb.master, pb.secondary);
  });
  ProgressReporter reporter(quiet ? ProgressCallback() : progress, "precise matching (pairs)", indices.size());
  parallel_for(indices.size(), threads, [&](std::size_t m) {
    const std::size_t n = order[m];
    const std::size_t index = indices[n];
    try {
      const Job job = all[index];
      const EpochPair& ep = run.pairs[job.pair];
      const std::string stem = job_stem(plan_dir, index);
      std::optional<FileLock> lock = FileLock::try_lock(stem + ".lock");
      DIACHRON_CHECK(lock, "pair job " << index << " is being run by another process now (it holds " << stem
                                       << ".lock): let it finish; if it died, run this job again");
      if (finished_job(plan_dir, index, run.plan_id)) {
        skipped[n] = 1;
        lock->remove_and_release();
        reporter.advance();
        return;
      }
      const std::vector<ImagePairOverlap> pair = {ep.overlap.pairs[job.k]};
      const PreciseEpoch<EpochFrame>& p1 = precise[ep.master];
      const PreciseEpoch<EpochFrame>& p2 = precise[ep.secondary];
      const Helmert3& h = ep.secondary_from_master;
      PreciseMatchingReport r;
      if (s.method == "correlation") {
        r = precise_matching_correlation(p1, p2, h, pair, options);
      } else if (s.method == "patch") {
        if (s.matcher_name == "akaze")
          r = precise_matching_patch(p1, p2, h, pair, ExtractorPairMatcher<AkazeExtractor>(AkazeExtractor{}), options);
        else if (s.matcher_name == "xfeat")
          r = precise_matching_patch(p1, p2, h, pair, XFeatPairMatcher(s.model_path), options);
        else
          r = precise_matching_patch(p1, p2, h, pair, ExtractorPairMatcher<SiftExtractor>(SiftExtractor(sift_options)),
                                     options);
      } else if (s.matcher_name == "xfeat") {
        PreciseMatchingOptions cosine = options;
        cosine.guided.metric = DescriptorDistance::Cosine;
        r = precise_matching_guided(p1, p2, h, pair, XFeatExtractor(s.model_path), cosine);
      } else {
        r = precise_matching_guided(p1, p2, h, pair, SiftExtractor(sift_options), options);
      }
      const PrecisePairReport& p = r.pairs.at(0);
      const Epoch& ea = run.epochs[ep.master];
      const Epoch& eb = run.epochs[ep.secondary];
      PairJobRecord record = pair_job_record(p, run.plan_id, index);
      record.master_epoch = ea.name;
      record.secondary_epoch = eb.name;
      record.master_image = ea.folder.images[p.master].name;
      record.secondary_image = eb.folder.images[p.secondary].name;
      // Guided matching extracts the two images' features inside the job: they count in its time.
      record.seconds.total = std::max(record.seconds.total, r.seconds_total);
      if (s.pictures && !p.matches.empty()) {
        const std::string jpg = stem + ".jpg", temporary = temporary_sibling(jpg, ".jpg");
        ::unlink(jpg.c_str());  // an earlier picture of this job must not outlive its result
        write_pair_picture(temporary, picture_of(images.load(ep.master, p.master)),
                           picture_of(images.load(ep.secondary, p.secondary)), p.matches, s.method == "correlation",
                           record.master_image + " (" + ea.name + ") -- " + record.secondary_image + " (" + eb.name +
                               ")");
        if (is_regular_file(temporary)) rename_into_place(temporary, jpg);
      }
      write_pair_job(stem + ".json", record);
      lock->remove_and_release();
    } catch (const std::exception& e) {
      errors[n] = "pair job " + std::to_string(index) + ": " + programs::error_text(e, false);
    }
    reporter.advance();
  });
  out.images = images.stats();
  for (std::size_t n = 0; n < indices.size(); ++n) {
    if (!errors[n].empty()) out.errors.push_back(errors[n]);
    else if (skipped[n]) ++out.skipped;
    else ++out.done;
  }
  return out;
}

}  // namespace match_epochs
