#pragma once
// match_epochs (examples/match_epochs/main.cpp): report.json as the run goes: what the run was
// (command line, version, threads, time per stage), the trust of its results and why, the warnings,
// the notes, the input checks, then the sections of the stages.

namespace match_epochs {

using namespace diachron;

struct Reporter {
  const Run* run = nullptr;
  RunClock clock;
  std::string command_line;  // quoted arguments, comma-separated
  std::size_t threads = 0;
  std::string trust = "none";  // "high" or "low" once the run has an answer
  std::vector<std::string> trust_reasons;

  Reporter(const Run& r, int argc, char** argv, std::size_t thread_count) : run(&r), threads(thread_count) {
    for (int i = 0; i < argc; ++i) command_line += (i ? ", " : "") + quoted(argv[i]);
  }

  // Writes `dir`/report.json with `sections` (further top-level members, each "  \"key\": ...,\n").
  void write(const std::string& dir, const std::string& sections) const {
    const Run& r = *run;
    std::ostringstream o;
    o.precision(6);
    o << "  \"run\": {\"command_line\": [" << command_line << "], \"version\": " << quoted(DIACHRON_VERSION)
      << ", \"threads\": " << (threads ? threads : std::max(1u, std::thread::hardware_concurrency()))
      << ", \"started\": " << quoted(clock.started()) << ", \"plan_id\": " << quoted(r.plan_id)
      << ", \"inputs\": {\"epochs\": [";
    for (std::size_t k = 0; k < r.epochs.size(); ++k) o << (k ? ", " : "") << quoted(r.epochs[k].dir);
    o << "], \"gcps\": "
      << (r.settings.gcps.empty() ? std::string("null") : quoted(absolute_path(r.settings.gcps)))
      << ", \"check_points\": "
      << (r.settings.checks.empty() ? std::string("null") : quoted(absolute_path(r.settings.checks)))
      << "}, \"seconds\": " << clock.json() << ", \"peak_memory_bytes\": "
      << (peak_resident_bytes() ? std::to_string(*peak_resident_bytes()) : std::string("null")) << "},\n"
      << "  \"trust\": {\"level\": " << quoted(trust) << ", \"reasons\": [";
    for (std::size_t k = 0; k < trust_reasons.size(); ++k) o << (k ? ", " : "") << quoted(trust_reasons[k]);
    o << "]},\n  \"warnings\": [";
    for (std::size_t k = 0; k < r.warnings.size(); ++k) o << (k ? ",\n    " : "\n    ") << quoted(r.warnings[k]);
    o << "],\n  \"notes\": [";
    for (std::size_t k = 0; k < r.notes.size(); ++k) o << (k ? ",\n    " : "\n    ") << quoted(r.notes[k]);
    o << "],\n  \"input_checks\": {";
    for (std::size_t k = 0; k < r.epochs.size(); ++k)
      o << (k ? ",\n    " : "\n    ") << quoted(r.epochs[k].name) << ": " << r.epochs[k].input_check;
    o << "},\n";
    write_report(dir + "/report.json", r.epochs, r.reference, r.pairs, r.settings.options, r.settings.method,
                 r.settings.matcher_name, o.str() + sections);
  }
};

}  // namespace match_epochs
