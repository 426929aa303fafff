// atomic_file.h -- the one way the program writes a file (models, loss curves, images, scenes,
// sidecars, reports). A file is written under a unique temporary name created exclusively in the
// target's folder (O_CREAT | O_EXCL | O_NOFOLLOW: never through a symbolic link, never over another
// file), every write is checked, the data is flushed to the disk (fsync) and the temporary file is
// renamed over the target, then the folder is flushed. So a reader sees the old file or the whole
// new one, never a partial file, whatever happens (full disk, a signal, a crash); a failure removes
// the temporary file and leaves the old file as it was. Targets that exist and are not regular
// files (symbolic links, devices, FIFOs, folders) are refused, not replaced.
#pragma once
#include <cstddef>
#include <functional>
#include <initializer_list>
#include <string>
#include <string_view>
#include <vector>

#include "lsnif/format/status.h"

namespace lsnif {

// Checks, before any work, that write_file_atomic(path, ...) can succeed as far as the file system
// tells now: `path` is not empty, does not exist or is a regular file, and its folder exists and
// accepts a new file (a temporary file is created there and removed). Errors name the path and
// the reason ("the folder 'out' does not exist", "'x' is a symbolic link; refusing to replace it",
// "cannot create a file in 'ro': Permission denied").
Status check_output_path(const std::string& path);

// Writes `size` bytes at `data` as the whole content of `path`, atomically (above). A new file gets
// the permissions 0666 less the umask, a replaced file keeps its permissions. Errors name the path
// and the system's reason (errno text).
Status write_file_atomic(const std::string& path, const void* data, size_t size);
inline Status write_file_atomic(const std::string& path, std::string_view bytes) {
  return write_file_atomic(path, bytes.data(), bytes.size());
}

// The target's name when `file_name` is the name of a temporary file write_file_atomic creates
// (".TARGET.tmp-" and 12 lowercase hex digits), else an empty string.
std::string atomic_temp_target(std::string_view file_name);

// Removes from `folder` (not its subfolders) the regular files named like write_file_atomic's
// temporary files whose target name `pick` accepts: what a writer killed before its rename left.
// Call it only while no writer can be at work on those targets. `removed` receives the paths
// removed; an error names the file that could not be listed or removed.
Status remove_stale_temp_files(const std::string& folder, const std::function<bool(const std::string&)>& pick,
                               std::vector<std::string>& removed);

// True when `a` and `b` both exist and are the same file (same device and inode: hard links and
// different spellings of one path included; symbolic links are followed).
bool same_file(const std::string& a, const std::string& b);

// An error when output `output` is the same file as one of `inputs` (the empty strings among them
// are skipped): writing it would destroy that input. `what` names the output in the message
// ("--csv", "-o").
Status check_not_an_input(const std::string& output, const char* what,
                          std::initializer_list<std::string> inputs);

}  // namespace lsnif
