#pragma once
// match_epochs (examples/match_epochs/main.cpp): the epochs, their pairs, names and the output folder.

namespace match_epochs {

using namespace diachron;
using diachron::programs::Progress;

std::string quoted(const std::string& s) {
  std::string q = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') q += '\\';
    if (static_cast<unsigned char>(c) < 0x20) continue;
    q += c;
  }
  return q + "\"";
}

std::string json_number_or_null(double v) {
  if (!std::isfinite(v)) return "null";
  std::ostringstream o;
  o.precision(10);
  o << v;
  return o.str();
}

// A file name for a pair picture: the image names with '/' made safe.
std::string safe(std::string name) {
  for (char& c : name)
    if (c == '/' || c == '\\' || c == ' ') c = '_';
  return name;
}



// An epoch's name: its folder's name ("/data/1954/" -> "1954"), of the resolved path when the
// folder exists (so that "." and "../1954" are named too).
std::string folder_name(const std::string& given) {
  std::string dir = given;
  if (char* real = ::realpath(given.c_str(), nullptr)) {
    dir = real;
    std::free(real);
  }
  while (dir.size() > 1 && dir.back() == '/') dir.pop_back();
  const std::size_t slash = dir.find_last_of('/');
  return slash == std::string::npos ? dir : dir.substr(slash + 1);
}

// The absolute, resolved path of an existing file or folder (as given when it cannot be resolved).
std::string absolute_path(const std::string& path) {
  std::string out = path;
  if (char* real = ::realpath(path.c_str(), nullptr)) {
    out = real;
    std::free(real);
  }
  return out;
}

// Whether two paths are one existing file-system object.
bool same_folder(const std::string& a, const std::string& b) {
  struct stat sa {}, sb {};
  return ::stat(a.c_str(), &sa) == 0 && ::stat(b.c_str(), &sb) == 0 && sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
}

// One input epoch and what the run found for it.
struct Epoch {
  std::string dir;   // absolute (as the plan records it: jobs may run in other working folders)
  std::string name;  // its folder's name: rough_helmert_<name>.json, adjusted/<name>/
  EpochFolder folder;
  std::vector<EpochFrame> frames;
  std::vector<std::string> homol;  // each image's name in Homol/
  std::string rough_mode = "auto";  // --rough: auto, identity or a helmert.json
  std::optional<Helmert3> given;    // the transform --rough gave
  RoughCoregistrationReport rough;  // its co-registration (none for the reference)
  std::string via;                  // the free epoch a chained co-registration went through
  bool placed = false;              // reference_from_epoch known
  Helmert3 reference_from_epoch = Helmert3::identity();
  std::string rough_json;     // report.json's "rough_coregistration" of it ("null" for the reference)
  std::string input_check;    // report.json's "input_checks" entry of it
  std::string fingerprint;    // of its input files (io/input_fingerprint.hpp)
  bool loaded = false;        // `folder` and `frames` read
};

// Two epochs' overlapping image pairs and their matches; the master images are `master`'s.
struct EpochPair {
  std::size_t master = 0, secondary = 0;  // indices into the epochs
  Helmert3 secondary_from_master = Helmert3::identity();
  OverlappingPairsResult overlap;  // its `pairs` are the jobs first_job, first_job + 1, ...
  std::size_t first_job = 0;
  std::vector<PairJobRecord> records;  // the pair jobs' results, in the order of overlap.pairs
  PreciseMatchingReport precise;       // the same as precise matching reports them (without tentative lists)
};

// The names of the images in Homol/. MicMac names tie-point files after the images, without
// folders, and one name must mean one image. The names of images.txt are kept when they allow that;
// when a name has a folder ("1954/0001.tif", as COLMAP allows) or two epochs use the same name
// (numbered from 0001 each), every name becomes "e<k>_" (k the epoch's place, from 1) + the name
// with '/' turned into '_', and DIR/homol_names.txt says which is which. Decided before any work,
// so that a clash stops the run at once instead of after the matching.
bool set_homol_names(std::vector<Epoch>& epochs) {
  std::set<std::string> seen;
  bool plain = true;
  for (const Epoch& e : epochs)
    for (const EpochImage& image : e.folder.images)
      plain = plain && image.name.find('/') == std::string::npos && seen.insert(image.name).second;
  seen.clear();
  for (std::size_t k = 0; k < epochs.size(); ++k) {
    Epoch& e = epochs[k];
    e.homol.clear();
    for (const EpochImage& image : e.folder.images) {
      std::string name = image.name;
      if (!plain) {
        for (char& c : name)
          if (c == '/') c = '_';
        name = "e" + std::to_string(k + 1) + "_" + name;
      }
      DIACHRON_CHECK(seen.insert(name).second, "two images of epoch " << e.name << " would share the Homol name '"
                                                                       << name << "' (one is '" << image.name
                                                                       << "'): rename one of them");
      e.homol.push_back(name);
    }
  }
  return !plain;
}

void write_homol_names(const std::string& path, const std::vector<Epoch>& epochs) {
  std::ofstream out(path);
  DIACHRON_CHECK(out.good(), "cannot write " << path);
  out << "# epoch (place in report.json's epochs, from 1), image name in images.txt, its name in Homol/\n";
  for (std::size_t k = 0; k < epochs.size(); ++k)
    for (std::size_t i = 0; i < epochs[k].folder.images.size(); ++i)
      out << k + 1 << ' ' << epochs[k].folder.images[i].name << ' ' << epochs[k].homol[i] << '\n';
  DIACHRON_CHECK(out.good(), "cannot write " << path);
}

// A warning: on stderr on its own line, and kept for report.json.
void warn(std::vector<std::string>& warnings, const std::string& text) {
  Progress::break_line();
  std::fprintf(stderr, "warning: %s\n", text.c_str());
  warnings.push_back(text);
}

// The wall-clock time of each stage of the run and in total, for report.json.
class RunClock {
 public:
  RunClock() : start_(std::chrono::steady_clock::now()), last_(start_), started_(std::time(nullptr)) {}
  // Ends the stage under way (its time goes to `name`, added up when a stage comes again).
  void stage(const std::string& name) {
    const auto now = std::chrono::steady_clock::now();
    const double seconds = std::chrono::duration<double>(now - last_).count();
    last_ = now;
    for (auto& [n, s] : stages_)
      if (n == name) {
        s += seconds;
        return;
      }
    stages_.emplace_back(name, seconds);
  }
  std::string json() const {
    std::ostringstream o;
    o.precision(4);
    o << "{";
    for (const auto& [name, seconds] : stages_) o << quoted(name) << ": " << seconds << ", ";
    o << "\"total\": " << std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count() << "}";
    return o.str();
  }
  std::string started() const {
    char text[32];
    std::tm utc{};
    ::gmtime_r(&started_, &utc);
    std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &utc);
    return text;
  }

 private:
  std::chrono::steady_clock::time_point start_, last_;
  std::time_t started_;
  std::vector<std::pair<std::string, double>> stages_;
};

// What the merge writes into --out (the tie points and everything after them): replaced as a whole
// by a rerun, never mixed with its outputs.
bool is_merge_output(const std::string& name) {
  static const std::set<std::string> kOutputs = {"Homol", "adjusted", "pairs", "dod", "report.json", "homol_names.txt"};
  return kOutputs.count(name) > 0 || (name.rfind("rough_helmert_", 0) == 0 && name.size() > 19 &&
                                      name.compare(name.size() - 5, 5, ".json") == 0);
}

// What the plan writes (plan.json, the job list, the pair jobs' results, the Slurm scripts).
bool is_plan_output(const std::string& name) {
  return name == "plan.json" || name == "jobs.tsv" || name == "jobs" || name == "slurm";
}

// Everything match_epochs writes into --out.
bool is_match_epochs_output(const std::string& name) { return is_merge_output(name) || is_plan_output(name); }

// The run's outputs are written into a fresh folder inside --out and moved into place when the run
// ends (commit()), after the outputs of an earlier run are removed: a rerun that finds fewer pairs
// or fails never leaves earlier tie points beside its report. A run stopped by an error (exit 1)
// leaves --out as it was. --out must be new or empty unless `overwrite`. A merge (`merge`) writes
// into the plan's folder: it replaces an earlier merge's outputs and keeps the plan's.
class OutputFolder {
 public:
  OutputFolder(const std::string& final_dir, bool overwrite, bool merge = false) : final_(final_dir), merge_(merge) {
    std::vector<std::string> entries;
    if (is_folder(final_))
      for (const std::string& e : folder_entries(final_))
        if (e.rfind(kPartial, 0) != 0) entries.push_back(e);
    if (!entries.empty() && !overwrite && !merge) {
      std::string some;
      for (std::size_t k = 0; k < entries.size() && k < 4; ++k) some += (k ? ", " : "") + entries[k];
      DIACHRON_CHECK(false, "--out '" << final_ << "' is not empty (it holds " << some
                                      << (entries.size() > 4 ? ", ..." : "")
                                      << "): give a new or empty folder, or --overwrite to replace the outputs of "
                                         "an earlier run in it");
    }
    created_ = !is_folder(final_);
    make_folders(final_, "--out");
    work_ = final_ + "/" + kPartial + std::to_string(::getpid());
    std::filesystem::remove_all(work_);
    make_folder(work_, "--out");
  }
  OutputFolder(const OutputFolder&) = delete;
  OutputFolder& operator=(const OutputFolder&) = delete;
  ~OutputFolder() {
    std::error_code ignored;
    if (committed_) return;
    std::filesystem::remove_all(work_, ignored);
    if (created_) std::filesystem::remove(final_, ignored);  // only when empty: as it was, absent
  }
  const std::string& work() const { return work_; }
  const std::string& final_dir() const { return final_; }
  // Moves the run's outputs into --out, after removing an earlier run's.
  void commit() {
    if (committed_) return;
    for (const std::string& e : folder_entries(final_))
      if (merge_ ? is_merge_output(e) : is_match_epochs_output(e)) std::filesystem::remove_all(final_ + "/" + e);
    for (const std::string& e : folder_entries(work_)) std::filesystem::rename(work_ + "/" + e, final_ + "/" + e);
    std::filesystem::remove(work_);
    committed_ = true;
  }

 private:
  static constexpr const char* kPartial = ".match_epochs-partial-";
  std::string final_, work_;
  bool created_ = false;  // --out did not exist before the run
  bool merge_ = false;
  bool committed_ = false;
};

}  // namespace match_epochs
