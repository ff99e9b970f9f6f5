#pragma once
/// @file
/// A fingerprint of input files, to tell whether the inputs of a plan are still those it was made
/// for (match_epochs plan / run-pair / merge, docs/scaling.md). Each file counts with its path, its
/// size and its modification time (nanoseconds): what `make` trusts, without reading thousands of
/// scans of hundreds of megabytes. A file replaced, rewritten, grown, removed or added under the
/// files listed changes the fingerprint; a file rewritten with the same bytes within the same
/// nanosecond does not. 64-bit FNV-1a, written as 16 hexadecimal digits. POSIX calls only.

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include <sys/stat.h>

#include <diachron/io/epoch_folder.hpp>
#include <diachron/io/folders.hpp>

namespace diachron {

/// One file as the fingerprint sees it: size -1 when it does not exist (a missing file is part
/// of the fingerprint: it appearing later changes it).
struct FileStamp {
  std::string path;
  long long size = -1;
  long long mtime_ns = 0;
};

/// The stamp of `path` now.
inline FileStamp file_stamp(const std::string& path) {
  FileStamp s{path, -1, 0};
  struct stat info {};
  if (::stat(path.c_str(), &info) == 0) {
    s.size = static_cast<long long>(info.st_size);
    s.mtime_ns = static_cast<long long>(info.st_mtim.tv_sec) * 1000000000LL + info.st_mtim.tv_nsec;
  }
  return s;
}

namespace detail {

inline void fnv1a(std::uint64_t& h, const void* data, std::size_t n) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < n; ++i) {
    h ^= p[i];
    h *= 1099511628211ULL;
  }
}

}  // namespace detail

/// 64-bit FNV-1a of `text`, as 16 lower-case hexadecimal digits.
inline std::string fingerprint_text(const std::string& text, std::uint64_t seed = 14695981039346656037ULL) {
  std::uint64_t h = seed;
  detail::fnv1a(h, text.data(), text.size());
  char out[17];
  std::snprintf(out, sizeof out, "%016llx", static_cast<unsigned long long>(h));
  return out;
}

/// The fingerprint of the stamps of `paths` (in the order given: callers sort them).
inline std::string files_fingerprint(const std::vector<std::string>& paths) {
  std::string text;
  for (const std::string& p : paths) {
    const FileStamp s = file_stamp(p);
    text += p + '\n' + std::to_string(s.size) + ' ' + std::to_string(s.mtime_ns) + '\n';
  }
  return fingerprint_text(text);
}

/// The files an epoch folder's results depend on: every regular file directly in its folder (the
/// model, dsm.tif, ortho.tif), its images and masks, and a MicMac epoch's Ori- files. Sorted.
inline std::vector<std::string> epoch_input_files(const EpochFolder& epoch) {
  std::vector<std::string> files;
  const std::string& dir = epoch.directory;
  for (const std::string& e : folder_entries(dir))
    if (is_regular_file(dir + "/" + e)) files.push_back(dir + "/" + e);
  for (const EpochImage& im : epoch.images) {
    if (!im.path.empty()) files.push_back(im.path);
    if (!im.mask_path.empty()) files.push_back(im.mask_path);
  }
  if (epoch.is_micmac()) {
    const std::string& ori = epoch.micmac_ori;  // the Ori- folder's path
    for (const std::string& e : folder_entries(ori))
      if (is_regular_file(ori + "/" + e)) files.push_back(ori + "/" + e);
  }
  std::sort(files.begin(), files.end());
  files.erase(std::unique(files.begin(), files.end()), files.end());
  return files;
}

/// The fingerprint of an epoch folder's input files (epoch_input_files) now.
inline std::string epoch_fingerprint(const EpochFolder& epoch) { return files_fingerprint(epoch_input_files(epoch)); }

}  // namespace diachron
