#pragma once
/// @file
/// Files that appear whole or not at all, for outputs that several processes may write at once
/// (pair jobs on a cluster, a job run twice): the text goes to a temporary file beside the target,
/// named after the host and the process, which is then renamed onto the target. rename(2) within
/// one folder is atomic on POSIX file systems, NFS included: a reader sees the old file, the new one
/// or none, never a part. Two writers of the same content leave that content.
///
/// And an advisory lock on a file (fcntl record lock: released by the kernel when its process
/// ends, however it ends, and honoured over NFS v4), so that two jobs do not compute one pair at
/// the same time. POSIX calls only (see io/folders.hpp on <filesystem>).

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <optional>
#include <string>
#include <utility>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <diachron/core/error.hpp>

namespace diachron {

/// A name for a temporary file beside `path`: "<path>.part-<host>-<pid>", or, when `keep_extension`
/// is given (e.g. ".jpg", for writers that choose the format by the extension),
/// "<path without it>.part-<host>-<pid><extension>". Unique per process on a shared file system.
inline std::string temporary_sibling(const std::string& path, const std::string& keep_extension = "") {
  char host[256] = {0};
  if (::gethostname(host, sizeof host - 1) != 0) std::strcpy(host, "host");
  std::string stem = path;
  if (!keep_extension.empty() && stem.size() > keep_extension.size() &&
      stem.compare(stem.size() - keep_extension.size(), keep_extension.size(), keep_extension) == 0)
    stem.erase(stem.size() - keep_extension.size());
  return stem + ".part-" + host + "-" + std::to_string(::getpid()) + keep_extension;
}

/// Renames `temporary` onto `path` (atomically replacing it). Throws diachron::Error naming both,
/// after removing `temporary`, when that fails.
inline void rename_into_place(const std::string& temporary, const std::string& path) {
  if (::rename(temporary.c_str(), path.c_str()) != 0) {
    const int e = errno;
    ::unlink(temporary.c_str());
    DIACHRON_CHECK(false, "cannot move '" << temporary << "' to '" << path << "': " << std::strerror(e));
  }
}

/// Writes `text` to `path` through a temporary sibling and a rename. Throws diachron::Error naming
/// the file when it cannot be written (the temporary file is removed; `path` is left as it was).
inline void write_file_atomically(const std::string& path, const std::string& text) {
  const std::string temporary = temporary_sibling(path);
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    DIACHRON_CHECK(out.good(), "cannot write '" << temporary << "' (for '" << path << "')");
    out << text;
    out.flush();
    if (!out.good()) {
      out.close();
      ::unlink(temporary.c_str());
      DIACHRON_CHECK(false, "cannot write '" << temporary << "' (for '" << path << "'): disk full?");
    }
  }
  rename_into_place(temporary, path);
}

/// An exclusive advisory lock on a file, held while the object lives (and released by the kernel if
/// the process dies). Move-only.
class FileLock {
 public:
  /// Locks `path` (created when missing) without waiting: nullopt when another process holds it.
  /// Throws diachron::Error when the file cannot be created or locked for another reason.
  static std::optional<FileLock> try_lock(const std::string& path) {
    const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    DIACHRON_CHECK(fd >= 0, "cannot open the lock file '" << path << "': " << std::strerror(errno));
    struct flock lock {};
    lock.l_type = F_WRLCK;
    lock.l_whence = SEEK_SET;
    if (::fcntl(fd, F_SETLK, &lock) != 0) {
      const int e = errno;
      ::close(fd);
      if (e == EACCES || e == EAGAIN) return std::nullopt;
      DIACHRON_CHECK(false, "cannot lock '" << path << "': " << std::strerror(e));
    }
    return FileLock(path, fd);
  }
  FileLock(FileLock&& other) noexcept : path_(std::move(other.path_)), fd_(std::exchange(other.fd_, -1)) {}
  FileLock& operator=(FileLock&& other) noexcept {
    if (this != &other) {
      release();
      path_ = std::move(other.path_);
      fd_ = std::exchange(other.fd_, -1);
    }
    return *this;
  }
  FileLock(const FileLock&) = delete;
  FileLock& operator=(const FileLock&) = delete;
  ~FileLock() { release(); }

  const std::string& path() const { return path_; }

  /// Removes the lock file, then releases the lock. A process that opened the file before the
  /// removal may lock the removed file afterwards: callers check, once they hold a lock, whether
  /// the work is already done.
  void remove_and_release() {
    if (fd_ < 0) return;
    ::unlink(path_.c_str());
    release();
  }

 private:
  FileLock(std::string path, int fd) : path_(std::move(path)), fd_(fd) {}
  void release() {
    if (fd_ >= 0) ::close(fd_);  // closing drops the process's record locks on the file
    fd_ = -1;
  }
  std::string path_;
  int fd_ = -1;
};

}  // namespace diachron
