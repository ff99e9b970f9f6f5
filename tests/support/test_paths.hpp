#pragma once
// Where tests find real data outside the repository (../shared/data and ../shared/models).
// The environment variables DIACHRON_DATA_DIR / DIACHRON_MODELS_DIR override the CMake defaults.
// A test that needs a file calls require_data_file(); when it is absent the test is skipped with a
// message (Catch2 2.13 has no SKIP, so it WARNs and returns).

#include <cstdlib>
#include <optional>
#include <string>
#include <sys/stat.h>

namespace diachron::test {

inline bool file_exists(const std::string& path) {
  struct stat info {};
  return ::stat(path.c_str(), &info) == 0;
}

inline std::string data_dir() {
  if (const char* env = std::getenv("DIACHRON_DATA_DIR")) return env;
  return DIACHRON_TEST_DATA_DIR;
}

inline std::string models_dir() {
  if (const char* env = std::getenv("DIACHRON_MODELS_DIR")) return env;
  return DIACHRON_TEST_MODELS_DIR;
}

/// Full path of `relative` under the data folder, or nullopt when it is not there.
inline std::optional<std::string> data_file(const std::string& relative) {
  const std::string path = data_dir() + "/" + relative;
  if (!file_exists(path)) return std::nullopt;
  return path;
}

/// Full path of `relative` under the models folder, or nullopt when it is not there.
inline std::optional<std::string> model_file(const std::string& relative) {
  const std::string path = models_dir() + "/" + relative;
  if (!file_exists(path)) return std::nullopt;
  return path;
}

}  // namespace diachron::test

/// Skips the rest of the current test case, with a message, when `opt_path` is empty.
#define DIACHRON_REQUIRE_FILE_OR_SKIP(opt_path, what)                                   \
  do {                                                                                  \
    if (!(opt_path)) {                                                                  \
      WARN("skipped: " << (what) << " not found (set DIACHRON_DATA_DIR / DIACHRON_MODELS_DIR)"); \
      return;                                                                           \
    }                                                                                   \
  } while (false)
