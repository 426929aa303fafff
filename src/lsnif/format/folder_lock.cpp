// folder_lock.cpp -- see folder_lock.h.
#include "lsnif/format/folder_lock.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <utility>

namespace lsnif {

namespace {

std::string lock_path(const std::string& folder, const std::string& name) {
  return (folder.empty() ? std::string(".") : folder) + "/" + name;
}

// Whether `fd` is still the file at `path` (a releasing holder removes the file: a lock taken on
// the removed file locks nothing that the next run sees).
bool still_linked(int fd, const std::string& path) {
  struct stat open_st, path_st;
  return ::fstat(fd, &open_st) == 0 && ::lstat(path.c_str(), &path_st) == 0 && open_st.st_dev == path_st.st_dev &&
         open_st.st_ino == path_st.st_ino;
}

}  // namespace

FolderLock::FolderLock(FolderLock&& other) noexcept
    : fd_(std::exchange(other.fd_, -1)), path_(std::move(other.path_)) {}

FolderLock& FolderLock::operator=(FolderLock&& other) noexcept {
  if (this != &other) {
    release();
    fd_ = std::exchange(other.fd_, -1);
    path_ = std::move(other.path_);
  }
  return *this;
}

Status FolderLock::acquire(const std::string& folder, const std::string& name, bool& busy) {
  release();
  busy = false;
  const std::string path = lock_path(folder, name);
  // A few rounds at most: each retry means a holder released (and removed) the file meanwhile.
  for (int attempt = 0; attempt < 16; ++attempt) {
    const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_NOFOLLOW | O_CLOEXEC, 0666);
    if (fd < 0) return Status::error("cannot open the lock file '%s': %s", path.c_str(), std::strerror(errno));
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const int e = errno;
      ::close(fd);
      if (e == EWOULDBLOCK) {
        busy = true;
        return Status::error("'%s' is held by another process", path.c_str());
      }
      return Status::error("cannot lock '%s': %s", path.c_str(), std::strerror(e));
    }
    if (still_linked(fd, path)) {
      fd_ = fd;
      path_ = path;
      return Status::ok();
    }
    ::close(fd);
  }
  return Status::error("cannot lock '%s': it keeps being replaced", path.c_str());
}

void FolderLock::release() {
  if (fd_ < 0) return;
  // Removed while still locked: whoever opened it meanwhile finds it unlinked and opens a new one.
  ::unlink(path_.c_str());
  ::close(fd_);
  fd_ = -1;
  path_.clear();
}

bool folder_lock_busy(const std::string& folder, const std::string& name) {
  const int fd = ::open(lock_path(folder, name).c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0) return false;
  const bool busy = ::flock(fd, LOCK_SH | LOCK_NB) != 0 && errno == EWOULDBLOCK;
  ::close(fd);
  return busy;
}

}  // namespace lsnif
