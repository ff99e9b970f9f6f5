#pragma once
// match_epochs (examples/match_epochs/main.cpp): `plan --emit slurm`. DIR/slurm/ gets one sbatch
// array script per chunk of at most --slurm-max-array tasks (Slurm refuses arrays beyond its
// MaxArraySize, 1001 by default), a merge script, and submit.sh, which submits the arrays and then
// the merge with --dependency=afterok on all of them: the merge runs only when every pair job
// succeeded. docs/scaling.md.

namespace match_epochs {

using namespace diachron;
using diachron::programs::strict_number;

struct SlurmOptions {
  std::size_t max_array = 1000;     // tasks per array (Slurm's MaxArraySize - 1 by default)
  std::size_t pairs_per_task = 1;   // jobs each array task runs (run-pair --range)
  std::size_t cpus_per_task = 1;    // --cpus-per-task of the pair tasks (run-pair's threads)
  std::size_t merge_cpus = 1;       // --cpus-per-task of the merge
  std::vector<std::string> sbatch;  // further #SBATCH lines, e.g. --partition=main, --time=2:00:00
};

void add_slurm_options(CLI::App& app, SlurmOptions& o) {
  app.add_option("--slurm-max-array", o.max_array, "with --emit slurm: tasks per array, below MaxArraySize (default 1000)")
      ->check(strict_number<std::size_t>(1, 4000000, "a task count >= 1"));
  app.add_option("--slurm-pairs-per-task", o.pairs_per_task, "with --emit slurm: pair jobs per array task (default 1)")
      ->check(strict_number<std::size_t>(1, 1000000, "a job count >= 1"));
  app.add_option("--slurm-cpus", o.cpus_per_task, "with --emit slurm: CPUs per pair task (default 1)")
      ->check(strict_number<std::size_t>(1, 4096, "a CPU count in [1, 4096]"));
  app.add_option("--slurm-merge-cpus", o.merge_cpus, "with --emit slurm: CPUs of the merge (default 1)")
      ->check(strict_number<std::size_t>(1, 4096, "a CPU count in [1, 4096]"));
  app.add_option("--sbatch", o.sbatch, "with --emit slurm: an sbatch option for every job, e.g. --sbatch=--time=2:00:00 "
                                        "(repeatable)");
}

// `s` quoted for sh.
std::string shell_quoted(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

// The path of this program (for the scripts: jobs run with another working folder).
std::string program_path(const char* argv0) {
  if (char* real = ::realpath("/proc/self/exe", nullptr)) {
    std::string out = real;
    std::free(real);
    return out;
  }
  return absolute_path(argv0);
}

void write_slurm_scripts(const Run& run, const std::string& work, const std::string& final_plan, const char* argv0,
                         const SlurmOptions& o) {
  DIACHRON_CHECK(run.jobs > 0, "--emit slurm: the plan has no pair job");
  const std::string dir = work + "/slurm";
  make_folder(dir, "match_epochs");
  make_folder(dir + "/logs", "match_epochs");
  const std::string final_dir = final_plan.substr(0, final_plan.find_last_of('/'));
  const std::string program = shell_quoted(program_path(argv0)), plan = shell_quoted(final_plan);
  const std::string logs = final_dir + "/slurm/logs";
  std::string extra;
  for (const std::string& s : o.sbatch) {
    DIACHRON_CHECK(s.rfind("--", 0) == 0 && s.find('\n') == std::string::npos,
                   "--sbatch '" << s << "': an sbatch option, e.g. --partition=main");
    extra += "#SBATCH " + s + "\n";
  }
  const std::size_t tasks = (run.jobs + o.pairs_per_task - 1) / o.pairs_per_task;
  const std::vector<IndexRange> chunks = index_chunks(tasks, o.max_array);
  std::ostringstream submit;
  submit << "#!/bin/sh\n# Submits the pair jobs of " << final_plan << " (" << run.jobs << " jobs in " << chunks.size()
         << " array(s)), then the merge once all of them succeeded.\n# Prints the merge's job id last.\nset -eu\n"
         << "cd " << shell_quoted(final_dir + "/slurm") << "\ndepend=afterok\n";
  for (std::size_t c = 0; c < chunks.size(); ++c) {
    const std::size_t first_task = chunks[c].first, n = chunks[c].size();
    std::ostringstream a;
    a << "#!/bin/sh\n#SBATCH --job-name=match_epochs-pairs-" << c << "\n#SBATCH --array=0-" << n - 1
      << "\n#SBATCH --cpus-per-task=" << o.cpus_per_task << "\n#SBATCH --output=" << logs << "/pairs-" << c
      << "-%a.out\n" << extra << "# Task t runs the pair jobs from (" << first_task << " + t) * " << o.pairs_per_task
      << ", " << o.pairs_per_task << " of them (the last ones may be fewer).\n"
      << "first=$(( (" << first_task << " + SLURM_ARRAY_TASK_ID) * " << o.pairs_per_task << " ))\n"
      << "last=$(( first + " << o.pairs_per_task - 1 << " ))\n"
      << "[ \"$last\" -lt " << run.jobs << " ] || last=" << run.jobs - 1 << "\n"
      << "exec " << program << " run-pair --plan " << plan << " --range \"$first-$last\" --threads "
      << o.cpus_per_task << " --quiet\n";
    const std::string name = "pairs_" + std::to_string(c) + ".sbatch";
    write_file_atomically(dir + "/" + name, a.str());
    submit << "id=$(sbatch --parsable " << name << ")\necho \"pairs " << c << ": job ${id%%;*}\"\n"
           << "depend=\"$depend:${id%%;*}\"\n";
  }
  std::ostringstream m;
  m << "#!/bin/sh\n#SBATCH --job-name=match_epochs-merge\n#SBATCH --cpus-per-task=" << o.merge_cpus
    << "\n#SBATCH --output=" << logs << "/merge.out\n" << extra << "exec " << program << " merge --plan " << plan
    << " --threads " << o.merge_cpus << " --quiet\n";
  write_file_atomically(dir + "/merge.sbatch", m.str());
  submit << "id=$(sbatch --parsable --dependency=\"$depend\" --kill-on-invalid-dep=yes merge.sbatch)\n"
         << "echo \"merge: job ${id%%;*}\"\n";
  write_file_atomically(dir + "/submit.sh", submit.str());
  ::chmod((dir + "/submit.sh").c_str(), 0755);
}

}  // namespace match_epochs
