#pragma once
// A fresh folder for a test that writes files: <TMPDIR or /tmp>/diachron_<name>_<pid>, removed
// first so that a previous run leaves nothing behind.

#include <cstdlib>
#include <filesystem>
#include <string>

#include <unistd.h>

namespace diachron::test {

inline std::string fresh_temp_folder(const std::string& name) {
  const char* base = std::getenv("TMPDIR");
  const std::filesystem::path dir =
      std::filesystem::path(base ? base : "/tmp") / ("diachron_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir.string();
}

}  // namespace diachron::test
