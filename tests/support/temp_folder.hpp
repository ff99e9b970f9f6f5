#pragma once
// Temporary folders for tests that write files. Every folder of one test process lives under
// <TMPDIR or /tmp>/diachron_test_<pid>, which is removed when the process exits normally, so that
// repeated test runs do not pile folders up in /tmp (each run has a new pid). Set
// DIACHRON_KEEP_TEST_FILES=1 to keep them for inspection.

#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>

#include <unistd.h>

namespace diachron::test {

namespace detail {

class TempRoot {
 public:
  TempRoot() {
    const char* base = std::getenv("TMPDIR");
    path_ = std::filesystem::path(base && *base ? base : "/tmp") / ("diachron_test_" + std::to_string(::getpid()));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  TempRoot(const TempRoot&) = delete;
  TempRoot& operator=(const TempRoot&) = delete;
  ~TempRoot() {
    const char* keep = std::getenv("DIACHRON_KEEP_TEST_FILES");
    if (keep && *keep && std::string(keep) != "0") return;
    std::error_code ignored;  // a destructor at exit has no one to report to
    std::filesystem::remove_all(path_, ignored);
  }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

}  // namespace detail

/// The process's root of temporary folders (created on first use, removed at exit).
inline const std::filesystem::path& temp_root() {
  static const detail::TempRoot root;
  return root.path();
}

/// `temp_root()/name`, removed first; not created (for writers that must create their folder).
inline std::string temp_path(const std::string& name) {
  const std::filesystem::path dir = temp_root() / name;
  std::filesystem::remove_all(dir);
  return dir.string();
}

/// `temp_root()/name`, fresh and empty.
inline std::string fresh_temp_folder(const std::string& name) {
  const std::string dir = temp_path(name);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace diachron::test
