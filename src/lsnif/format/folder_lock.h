// folder_lock.h -- an exclusive, non-blocking lock on a folder for one run of a program that writes
// several files into it (`lsnif convert`: models, sidecars, the scene): flock(2) on a lock file
// inside the folder. The lock goes with the process (a killed run leaves no lock behind, at most
// the empty lock file, which the next run reuses); a released lock removes its file.
#pragma once
#include <string>

#include "lsnif/format/status.h"

namespace lsnif {

class FolderLock {
 public:
  FolderLock() = default;
  FolderLock(const FolderLock&) = delete;
  FolderLock& operator=(const FolderLock&) = delete;
  FolderLock(FolderLock&& other) noexcept;
  FolderLock& operator=(FolderLock&& other) noexcept;
  ~FolderLock() { release(); }

  // Takes the lock file `name` in the existing folder `folder` (created if absent), without
  // waiting. `busy` is set when another holder has it (then the error says so, naming the lock
  // file); other errors name the file and the system's reason.
  Status acquire(const std::string& folder, const std::string& name, bool& busy);
  // Removes the lock file and releases the lock (nothing when not held).
  void release();
  bool held() const { return fd_ >= 0; }
  const std::string& path() const { return path_; }

 private:
  int fd_ = -1;
  std::string path_;
};

// Whether another holder has the lock file `name` in `folder` now. Creates and changes nothing (a
// missing folder or lock file: false).
bool folder_lock_busy(const std::string& folder, const std::string& name);

}  // namespace lsnif
