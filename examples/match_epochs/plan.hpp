#pragma once
// match_epochs (examples/match_epochs/main.cpp): the plan. `plan` writes DIR/plan.json (the
// settings, the epochs with their rough co-registration, every overlapping pair of every two
// epochs, one job per image pair) and DIR/jobs.tsv; run-pair and merge read it back. Doubles are
// written with 17 significant digits, so a plan read back is the plan written, and the one-process
// run (which goes through the same file) gives byte for byte what plan / run-pair / merge give.

namespace match_epochs {

using namespace diachron;

constexpr const char* kPlanFormat = "diachron match_epochs plan 1";

// Everything the stages share: the settings, the epochs, the pairs, what the checks said.
struct Run {
  Settings settings;
  std::vector<std::string> arguments;  // canonical_arguments(): what the plan's id hashes
  std::vector<Epoch> epochs;
  std::size_t reference = 0;
  std::vector<EpochPair> pairs;
  std::vector<std::string> warnings, notes;  // the input checks' (and the DSMs')
  std::string plan_id;
  std::size_t jobs = 0;
};

// One job: image pair `k` of epoch pair `pair` (Run::pairs).
struct Job {
  std::size_t pair = 0, k = 0;
};

std::vector<Job> job_list(const Run& run) {
  std::vector<Job> jobs;
  for (std::size_t q = 0; q < run.pairs.size(); ++q)
    for (std::size_t k = 0; k < run.pairs[q].overlap.pairs.size(); ++k) jobs.push_back({q, k});
  return jobs;
}

// The plan's id: the version, the settings and every epoch's input files. A job or a merge
// refuses a plan whose inputs changed since, and a merge refuses results of another plan.
std::string plan_id(const Run& run) {
  std::string text = std::string(DIACHRON_VERSION) + '\n';
  for (const std::string& a : run.arguments) text += a + '\n';
  for (const Epoch& e : run.epochs) text += e.name + ' ' + e.fingerprint + '\n';
  return fingerprint_text(text);
}

std::string helmert_numbers(const Helmert3& h) {
  std::string o = "[" + json_number(h.scale);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) o += ", " + json_number(h.rotation(r, c));
  for (int i = 0; i < 3; ++i) o += ", " + json_number(h.translation(i));
  return o + "]";
}

std::string plan_json(const Run& run) {
  std::ostringstream o;
  o << "{\n  \"format\": " << json_quoted(kPlanFormat) << ",\n  \"version\": " << json_quoted(DIACHRON_VERSION)
    << ",\n  \"plan_id\": " << json_quoted(run.plan_id) << ",\n  \"arguments\": [";
  for (std::size_t k = 0; k < run.arguments.size(); ++k) o << (k ? ", " : "") << json_quoted(run.arguments[k]);
  o << "],\n  \"reference\": " << run.reference << ",\n  \"epochs\": [";
  for (std::size_t k = 0; k < run.epochs.size(); ++k) {
    const Epoch& e = run.epochs[k];
    o << (k ? ",\n    " : "\n    ") << "{\"name\": " << json_quoted(e.name) << ", \"dir\": " << json_quoted(e.dir)
      << ", \"fingerprint\": " << json_quoted(e.fingerprint) << ", \"rough_mode\": " << json_quoted(e.rough_mode)
      << ", \"placed\": " << (e.placed ? "true" : "false") << ", \"via\": " << json_quoted(e.via)
      << ",\n     \"reference_from_epoch\": " << helmert_numbers(e.reference_from_epoch)
      << ",\n     \"rough_coregistration\": " << json_quoted(e.rough_json) << ",\n     \"input_check\": "
      << json_quoted(e.input_check) << "}";
  }
  o << "],\n  \"warnings\": [";
  for (std::size_t k = 0; k < run.warnings.size(); ++k) o << (k ? ", " : "") << json_quoted(run.warnings[k]);
  o << "],\n  \"notes\": [";
  for (std::size_t k = 0; k < run.notes.size(); ++k) o << (k ? ", " : "") << json_quoted(run.notes[k]);
  o << "],\n  \"epoch_pairs\": [";
  for (std::size_t q = 0; q < run.pairs.size(); ++q) {
    const EpochPair& p = run.pairs[q];
    const OverlappingPairsResult& v = p.overlap;
    o << (q ? ",\n    " : "\n    ") << "{\"master\": " << p.master << ", \"secondary\": " << p.secondary
      << ", \"first_job\": " << p.first_job << ",\n     \"secondary_from_master\": "
      << helmert_numbers(p.secondary_from_master) << ",\n     \"overlap\": {\"success\": "
      << (v.success ? "true" : "false") << ", \"message\": " << json_quoted(v.message)
      << ", \"candidates\": " << v.candidate_pairs << ", \"overlapping\": " << v.overlapping_pairs
      << ", \"filtered\": " << v.filtered_pairs << ", \"invalid\": [" << v.invalid_master_footprints << ", "
      << v.invalid_secondary_footprints << "],\n      \"pairs\": [";
    for (std::size_t k = 0; k < v.pairs.size(); ++k) {
      const ImagePairOverlap& i = v.pairs[k];
      o << (k ? ", " : "") << "[" << i.master << ", " << i.secondary << ", " << json_number(i.area) << ", "
        << json_number(i.fraction_of_smaller) << ", " << json_number(i.fraction_of_master) << "]";
    }
    o << "]}}";
  }
  o << "],\n  \"jobs\": " << run.jobs << "\n}\n";
  return o.str();
}

// DIR/jobs.tsv: one line per job, for people and for job engines (Snakemake, GNU parallel).
std::string jobs_tsv(const Run& run) {
  std::ostringstream o;
  o << "index\tmaster_epoch\tmaster_image\tsecondary_epoch\tsecondary_image\toverlap\n";
  for (const EpochPair& p : run.pairs)
    for (std::size_t k = 0; k < p.overlap.pairs.size(); ++k) {
      const ImagePairOverlap& i = p.overlap.pairs[k];
      const Epoch& a = run.epochs[p.master];
      const Epoch& b = run.epochs[p.secondary];
      o << p.first_job + k << '\t' << a.name << '\t' << a.folder.images[i.master].name << '\t' << b.name << '\t'
        << b.folder.images[i.secondary].name << '\t' << i.fraction_of_smaller << '\n';
    }
  return o.str();
}

namespace plan_detail {

const JsonValue& member(const JsonValue& v, const char* key, JsonValue::Type type, const std::string& path) {
  const JsonValue* m = v.find(key);
  DIACHRON_CHECK(m != nullptr && m->type == type,
                 "'" << path << "' is not a plan of this version (\"" << key << "\" missing or not a "
                     << json_type_name(type) << "): run match_epochs plan again");
  return *m;
}

std::size_t count(const JsonValue& v, const char* key, const std::string& path) {
  const double x = member(v, key, JsonValue::Type::number, path).number;
  DIACHRON_CHECK(x >= 0.0 && x < 9e15 && x == std::floor(x), "'" << path << "': \"" << key << "\" is not a count");
  return static_cast<std::size_t>(x);
}

std::size_t count_of(const JsonValue& v, const std::string& path) {
  DIACHRON_CHECK(v.type == JsonValue::Type::number && v.number >= 0.0 && v.number < 9e15 && v.number == std::floor(v.number),
                 "'" << path << "': an index is not a count");
  return static_cast<std::size_t>(v.number);
}

Helmert3 helmert(const JsonValue& v, const char* key, const std::string& path) {
  const JsonValue& a = member(v, key, JsonValue::Type::array, path);
  DIACHRON_CHECK(a.array.size() == 13, "'" << path << "': \"" << key << "\" is not 13 numbers");
  double x[13];
  for (int i = 0; i < 13; ++i) {
    DIACHRON_CHECK(a.array[i].type == JsonValue::Type::number, "'" << path << "': \"" << key << "\" is not 13 numbers");
    x[i] = a.array[i].number;
  }
  Helmert3 h;
  h.scale = x[0];
  for (int i = 0; i < 9; ++i) h.rotation(i / 3, i % 3) = x[1 + i];
  h.translation = Eigen::Vector3d(x[10], x[11], x[12]);
  return h;
}

std::vector<std::string> strings(const JsonValue& v, const char* key, const std::string& path) {
  std::vector<std::string> out;
  for (const JsonValue& s : member(v, key, JsonValue::Type::array, path).array) {
    DIACHRON_CHECK(s.type == JsonValue::Type::string, "'" << path << "': \"" << key << "\" holds a non-string");
    out.push_back(s.string);
  }
  return out;
}

}  // namespace plan_detail

// Parses the canonical arguments into `s` (the same option definitions as the command line).
void parse_arguments(const std::vector<std::string>& arguments, Settings& s, const std::string& path) {
  CLI::App app{"match_epochs plan arguments"};
  add_run_options(app, s);
  std::vector<std::string> reversed(arguments.rbegin(), arguments.rend());  // CLI11 takes them last first
  try {
    app.parse(reversed);
  } catch (const CLI::ParseError& e) {
    DIACHRON_CHECK(false, "'" << path << "': its arguments do not parse with this match_epochs (" << e.what()
                              << "): run match_epochs plan again");
  }
  prepare(s);
}

// Reads DIR/plan.json: the settings, the epochs (their folders not read yet: load_epoch()), the
// pairs. Throws diachron::Error, with the remedy, for a file of another format or version.
Run read_plan(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  DIACHRON_CHECK(in.good(), "cannot read the plan '" << path << "': run match_epochs plan EPOCH_DIR... --out DIR first");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const JsonValue v = parse_json(text, path);
  using T = JsonValue::Type;
  using namespace plan_detail;
  DIACHRON_CHECK(v.type == T::object && v.find("format") && v.find("format")->type == T::string &&
                     v.find("format")->string == kPlanFormat,
                 "'" << path << "' is not a match_epochs plan (of this format, \"" << kPlanFormat << "\")");
  const std::string version = member(v, "version", T::string, path).string;
  DIACHRON_CHECK(version == DIACHRON_VERSION, "'" << path << "' was made by diachron " << version << "; this is "
                                                  << DIACHRON_VERSION << ": run match_epochs plan again with this version");
  Run run;
  run.plan_id = member(v, "plan_id", T::string, path).string;
  run.arguments = strings(v, "arguments", path);
  parse_arguments(run.arguments, run.settings, path);
  run.reference = count(v, "reference", path);
  for (const JsonValue& ev : member(v, "epochs", T::array, path).array) {
    Epoch e;
    e.name = member(ev, "name", T::string, path).string;
    e.dir = member(ev, "dir", T::string, path).string;
    e.fingerprint = member(ev, "fingerprint", T::string, path).string;
    e.rough_mode = member(ev, "rough_mode", T::string, path).string;
    e.placed = member(ev, "placed", T::boolean, path).boolean;
    e.via = member(ev, "via", T::string, path).string;
    e.reference_from_epoch = helmert(ev, "reference_from_epoch", path);
    e.rough_json = member(ev, "rough_coregistration", T::string, path).string;
    e.input_check = member(ev, "input_check", T::string, path).string;
    run.epochs.push_back(std::move(e));
  }
  DIACHRON_CHECK(run.epochs.size() >= 2 && run.reference < run.epochs.size(), "'" << path << "': no reference epoch");
  run.warnings = strings(v, "warnings", path);
  run.notes = strings(v, "notes", path);
  for (const JsonValue& pv : member(v, "epoch_pairs", T::array, path).array) {
    EpochPair p;
    p.master = count(pv, "master", path);
    p.secondary = count(pv, "secondary", path);
    DIACHRON_CHECK(p.master < run.epochs.size() && p.secondary < run.epochs.size(), "'" << path << "': a pair of unknown epochs");
    p.first_job = count(pv, "first_job", path);
    p.secondary_from_master = helmert(pv, "secondary_from_master", path);
    const JsonValue& ov = member(pv, "overlap", T::object, path);
    OverlappingPairsResult& o = p.overlap;
    o.success = member(ov, "success", T::boolean, path).boolean;
    o.message = member(ov, "message", T::string, path).string;
    o.candidate_pairs = count(ov, "candidates", path);
    o.overlapping_pairs = count(ov, "overlapping", path);
    o.filtered_pairs = count(ov, "filtered", path);
    const JsonValue& invalid = member(ov, "invalid", T::array, path);
    DIACHRON_CHECK(invalid.array.size() == 2, "'" << path << "': \"invalid\" is not two counts");
    o.invalid_master_footprints = count_of(invalid.array[0], path);
    o.invalid_secondary_footprints = count_of(invalid.array[1], path);
    for (const JsonValue& iv : member(ov, "pairs", T::array, path).array) {
      DIACHRON_CHECK(iv.type == T::array && iv.array.size() == 5, "'" << path << "': an image pair is not 5 numbers");
      ImagePairOverlap i;
      i.master = count_of(iv.array[0], path);
      i.secondary = count_of(iv.array[1], path);
      i.area = iv.array[2].number;
      i.fraction_of_smaller = iv.array[3].number;
      i.fraction_of_master = iv.array[4].number;
      o.pairs.push_back(i);
    }
    run.pairs.push_back(std::move(p));
  }
  run.jobs = count(v, "jobs", path);
  std::size_t jobs = 0;
  for (const EpochPair& p : run.pairs) {
    DIACHRON_CHECK(p.first_job == jobs, "'" << path << "': the pairs' jobs are not numbered in order");
    jobs += p.overlap.pairs.size();
  }
  DIACHRON_CHECK(jobs == run.jobs, "'" << path << "' counts " << run.jobs << " jobs, its pairs " << jobs);
  DIACHRON_CHECK(run.settings.dirs.size() == run.epochs.size(), "'" << path << "': its arguments and its epochs disagree");
  return run;
}

// Reads epoch k's folder (model, DSM; images stay on disk) and checks that its input files are
// those the plan was made for.
void load_epoch(Run& run, std::size_t k, const std::string& plan_path) {
  Epoch& e = run.epochs[k];
  if (e.loaded) return;
  e.folder = read_epoch_folder(e.dir, run.settings.dsm_read, {}, run.settings.micmac_epochs);
  for (const EpochImage& im : e.folder.images) e.frames.push_back(im.epoch_frame());
  const std::string now = epoch_fingerprint(e.folder);
  DIACHRON_CHECK(plan_path.empty() || now == e.fingerprint,
                 "the input files of epoch " << e.name << " ('" << e.dir << "': its model, DSM, images or masks) changed "
                                             << "since the plan '" << plan_path
                                             << "' was made (sizes or times differ): run match_epochs plan again");
  e.loaded = true;
}

}  // namespace match_epochs
