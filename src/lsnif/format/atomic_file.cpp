// atomic_file.cpp -- see atomic_file.h.
#include "lsnif/format/atomic_file.h"

#include <dirent.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <random>

namespace lsnif {
namespace {

// Temporary files are ".TARGET" + kTempTag + kTempDigits lowercase hex digits (48 random bits).
constexpr std::string_view kTempTag = ".tmp-";
constexpr size_t kTempDigits = 12;

// The folder part of `path` ("." for a bare file name, "/" for a file in the root).
std::string folder_of(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  if (slash == std::string::npos) return ".";
  if (slash == 0) return "/";
  return path.substr(0, slash);
}

std::string file_name_of(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

const char* kind_of(mode_t mode) {
  if (S_ISLNK(mode)) return "a symbolic link";
  if (S_ISDIR(mode)) return "a folder";
  if (S_ISCHR(mode) || S_ISBLK(mode)) return "a device";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

// The target must be absent or a regular file (lstat: a symbolic link is not followed). `mode`
// receives the permissions of an existing file, or 0.
Status check_target(const std::string& path, mode_t& mode) {
  mode = 0;
  if (path.empty()) return Status::error("empty output path");
  if (path.back() == '/') return Status::error("'%s' names a folder, not a file", path.c_str());
  struct stat st;
  if (::lstat(path.c_str(), &st) != 0) {
    if (errno == ENOENT) return Status::ok();
    return Status::error("'%s': %s", path.c_str(), std::strerror(errno));
  }
  if (!S_ISREG(st.st_mode))
    return Status::error("'%s' is %s; refusing to replace it with a file", path.c_str(), kind_of(st.st_mode));
  mode = st.st_mode & 07777;
  return Status::ok();
}

// The folder must exist and be a folder.
Status check_folder(const std::string& path, const std::string& dir) {
  struct stat st;
  if (::stat(dir.c_str(), &st) != 0) {
    if (errno == ENOENT) return Status::error("cannot write '%s': the folder '%s' does not exist", path.c_str(), dir.c_str());
    return Status::error("cannot write '%s': folder '%s': %s", path.c_str(), dir.c_str(), std::strerror(errno));
  }
  if (!S_ISDIR(st.st_mode))
    return Status::error("cannot write '%s': '%s' is not a folder", path.c_str(), dir.c_str());
  return Status::ok();
}

// Creates a new, empty temporary file ".NAME.tmp-XXXXXXXXXXXX" beside `path`, exclusively (no
// existing file or link is ever opened). Returns its descriptor, or -1 with `error` set.
int create_temp(const std::string& path, std::string& temp, Status& error) {
  const std::string dir = folder_of(path);
  const std::string prefix =
      (dir == "/" ? std::string("/") : dir + "/") + "." + file_name_of(path) + std::string(kTempTag);
  static thread_local std::mt19937_64 rng(
      std::random_device{}() ^ uint64_t(::getpid()) << 32 ^
      uint64_t(std::chrono::steady_clock::now().time_since_epoch().count()));
  for (int attempt = 0; attempt < 64; ++attempt) {
    const unsigned long long digits = rng() & ((1ull << (4 * kTempDigits)) - 1);
    temp = prefix + format("%0*llx", int(kTempDigits), digits);
    const int fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0666);
    if (fd >= 0) return fd;
    if (errno != EEXIST) {
      error = Status::error("cannot create a file in '%s' (to write '%s'): %s", dir.c_str(), path.c_str(),
                            std::strerror(errno));
      return -1;
    }
  }
  error = Status::error("cannot create a temporary file beside '%s': 64 names were taken", path.c_str());
  return -1;
}

// write(2) until everything is written; false with errno set on failure.
bool write_all(int fd, const void* data, size_t size) {
  const auto* p = static_cast<const unsigned char*>(data);
  while (size > 0) {
    const ssize_t n = ::write(fd, p, size);
    if (n < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    if (n == 0) {
      errno = EIO;
      return false;
    }
    p += n;
    size -= size_t(n);
  }
  return true;
}

// Checks that the folder (`dir`) of `path` exists and that the target is absent or a regular file
// (`mode`: its permissions, or 0), then creates the temporary file (`temp`). Its descriptor, or -1
// with `error` set.
int open_temp_beside(const std::string& path, std::string& dir, mode_t& mode, std::string& temp, Status& error) {
  error = path.empty() ? Status::error("empty output path") : Status::ok();
  if (error) error = check_folder(path, dir = folder_of(path));
  if (error) error = check_target(path, mode);
  return error ? create_temp(path, temp, error) : -1;
}

}  // namespace

Status check_output_path(const std::string& path) {
  std::string dir, temp;
  mode_t mode;
  Status error;
  const int fd = open_temp_beside(path, dir, mode, temp, error);
  if (fd < 0) return error;
  ::close(fd);
  ::unlink(temp.c_str());
  return Status::ok();
}

Status write_file_atomic(const std::string& path, const void* data, size_t size) {
  std::string dir, temp;
  mode_t mode = 0;
  Status error;
  const int fd = open_temp_beside(path, dir, mode, temp, error);
  if (fd < 0) return error;
  auto fail = [&](const char* what) {
    const int e = errno;
    ::close(fd);
    ::unlink(temp.c_str());
    return Status::error("cannot write '%s': %s: %s", path.c_str(), what, std::strerror(e));
  };
  if (mode != 0 && ::fchmod(fd, mode) != 0) return fail("keeping the file's permissions");
  if (!write_all(fd, data, size)) return fail(format("writing %zu bytes", size).c_str());
  if (::fsync(fd) != 0) return fail("flushing to the disk");
  if (::close(fd) != 0) {
    const int e = errno;
    ::unlink(temp.c_str());
    return Status::error("cannot write '%s': closing: %s", path.c_str(), std::strerror(e));
  }
  // The target may have been replaced by a link or a device meanwhile: check again just before.
  if (Status s = check_target(path, mode); !s) {
    ::unlink(temp.c_str());
    return s;
  }
  if (::rename(temp.c_str(), path.c_str()) != 0) {
    const int e = errno;
    ::unlink(temp.c_str());
    return Status::error("cannot write '%s': renaming the temporary file over it: %s", path.c_str(), std::strerror(e));
  }
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    // Some file systems cannot flush a folder (EINVAL); the file itself is on the disk already.
    const bool synced = ::fsync(dfd) == 0 || errno == EINVAL;
    const int e = errno;
    ::close(dfd);
    if (!synced) return Status::error("wrote '%s' but flushing its folder failed: %s", path.c_str(), std::strerror(e));
  }
  return Status::ok();
}

std::string atomic_temp_target(std::string_view name) {
  if (name.size() < 1 + 1 + kTempTag.size() + kTempDigits || name[0] != '.') return {};
  const std::string_view digits = name.substr(name.size() - kTempDigits);
  for (const char c : digits)
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return {};
  const std::string_view rest = name.substr(1, name.size() - 1 - kTempDigits);
  if (rest.size() <= kTempTag.size() || rest.substr(rest.size() - kTempTag.size()) != kTempTag) return {};
  return std::string(rest.substr(0, rest.size() - kTempTag.size()));
}

Status remove_stale_temp_files(const std::string& folder, const std::function<bool(const std::string&)>& pick,
                               std::vector<std::string>& removed) {
  const std::string dir = folder.empty() ? std::string(".") : folder;
  DIR* d = ::opendir(dir.c_str());
  if (!d) return Status::error("cannot list the folder '%s': %s", dir.c_str(), std::strerror(errno));
  Status result = Status::ok();
  while (const dirent* e = ::readdir(d)) {
    const std::string name = e->d_name, target = atomic_temp_target(name);
    if (target.empty() || !pick(target)) continue;
    const std::string path = dir + "/" + name;
    struct stat st;
    if (::lstat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) continue;
    if (::unlink(path.c_str()) != 0) {
      result = Status::error("cannot remove the stale temporary file '%s': %s", path.c_str(), std::strerror(errno));
      break;
    }
    removed.push_back(path);
  }
  ::closedir(d);
  return result;
}

bool same_file(const std::string& a, const std::string& b) {
  if (a.empty() || b.empty()) return false;
  struct stat sa, sb;
  if (::stat(a.c_str(), &sa) != 0 || ::stat(b.c_str(), &sb) != 0) return false;
  return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
}

Status check_not_an_input(const std::string& output, const char* what, std::initializer_list<std::string> inputs) {
  for (const std::string& in : inputs)
    if (same_file(output, in))
      return Status::error("%s '%s' is the input file '%s'; writing it would destroy the input", what, output.c_str(),
                           in.c_str());
  return Status::ok();
}

}  // namespace lsnif
