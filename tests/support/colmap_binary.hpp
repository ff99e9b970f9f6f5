#pragma once
// Where tests find the colmap binary (Debian's package installs /usr/bin/colmap): the environment
// variable DIACHRON_COLMAP, else the first `colmap` on PATH. Tests that need it WARN and return when
// it is absent (scripts/install_deps.sh --peers installs it).

#include <cstdlib>
#include <optional>
#include <sstream>
#include <string>

#include <unistd.h>

namespace diachron::test {

inline std::optional<std::string> colmap_binary() {
  if (const char* env = std::getenv("DIACHRON_COLMAP")) return std::string(env);
  const char* path = std::getenv("PATH");
  std::istringstream dirs(path ? path : "/usr/bin");
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    const std::string candidate = dir + "/colmap";
    if (::access(candidate.c_str(), X_OK) == 0) return candidate;
  }
  return std::nullopt;
}

}  // namespace diachron::test
