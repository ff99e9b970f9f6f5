#pragma once
/// @file
/// Folders for the writers of io/ (Homol, COLMAP models, adjusted exports, scenes): tests, one
/// mkdir, mkdir -p, and a folder's entries, with diachron::Error naming the folder.
///
/// POSIX calls rather than std::filesystem: GCC's <filesystem> inline functions refer to
/// libstdc++ internals that a program cannot link when every inline function is emitted, which
/// the headers/alone test does.

#include <algorithm>
#include <cerrno>
#include <string>
#include <vector>

#include <dirent.h>
#include <sys/stat.h>
#include <sys/types.h>

#include <diachron/core/error.hpp>

namespace diachron {

/// True when `path` is an existing folder (symbolic links followed).
inline bool is_folder(const std::string& path) {
  struct stat info {};
  return ::stat(path.c_str(), &info) == 0 && S_ISDIR(info.st_mode);
}

/// True when `path` is an existing regular file (symbolic links followed).
inline bool is_regular_file(const std::string& path) {
  struct stat info {};
  return ::stat(path.c_str(), &info) == 0 && S_ISREG(info.st_mode);
}

/// Creates the folder `path` when it is not there (its parent must exist). Throws diachron::Error,
/// prefixed by `who` (the calling function, for the message), when it cannot be created or
/// exists and is not a folder.
inline void make_folder(const std::string& path, const char* who) {
  if (::mkdir(path.c_str(), 0755) != 0 && errno != EEXIST)
    throw Error(std::string("diachron: ") + who + ": cannot create the folder '" + path + "'");
  DIACHRON_CHECK(is_folder(path), who << ": '" << path << "' is not a folder");
}

/// mkdir -p: creates every missing folder of `path`. Throws as make_folder().
inline void make_folders(const std::string& path, const char* who) {
  for (std::size_t slash = path.find('/', 1);; slash = path.find('/', slash + 1)) {
    const std::string prefix = slash == std::string::npos ? path : path.substr(0, slash);
    if (!prefix.empty() && !is_folder(prefix)) make_folder(prefix, who);
    if (slash == std::string::npos) break;
  }
  DIACHRON_CHECK(is_folder(path), who << ": '" << path << "' is not a folder");
}

/// The entries of a folder except . and .., sorted; empty when it cannot be read.
inline std::vector<std::string> folder_entries(const std::string& path) {
  std::vector<std::string> out;
  if (DIR* dir = ::opendir(path.c_str())) {
    while (const dirent* entry = ::readdir(dir)) {
      const std::string name = entry->d_name;
      if (name != "." && name != "..") out.push_back(name);
    }
    ::closedir(dir);
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace diachron
