// file_io.h -- the one way the program reads a whole file (models, settings files, meshes and their
// material libraries, scenes and the buffers they refer to, shaders, sidecars, cache keys), beside
// atomic_file.h, the one way it writes one. The file must be a regular file (symbolic links are
// followed) of at most the number of bytes the caller accepts, so no input can make a reader
// allocate more than its caller chose. The size is taken before the read and checked after it: a
// file that grows or shrinks meanwhile is an error, never a cut or padded result.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "lsnif/format/status.h"

namespace lsnif {

// Why read_file failed, for callers that word the error in their own terms.
enum class ReadProblem : uint8_t {
  None,
  Missing,       // no such file (or a folder on its way is missing)
  CannotAccess,  // its status cannot be read (no permission on a folder on its way, a name too long, ...)
  Directory,     // a folder
  NotRegular,    // a device, FIFO or socket
  SizeUnknown,   // its size cannot be read
  TooLarge,      // more bytes than the caller accepts
  OutOfMemory,   // no memory for its bytes
  CannotOpen,    // it cannot be opened for reading
  ReadError,     // reading it failed
  ChangedSize,   // it grew or shrank while it was read
};

// What went wrong in a failed read_file.
struct ReadFailure {
  ReadProblem problem = ReadProblem::None;
  uint64_t size = 0;   // the file's size, when it was taken (TooLarge and the problems after it)
  uint64_t got = 0;    // bytes read before the failure, at most `size` (ReadError, ChangedSize)
  std::string reason;  // the system's words (CannotAccess, SizeUnknown, CannotOpen, ReadError), else empty
};

// Reads the whole file at `path` into `out`: replaced on success, left as it was on failure. A file
// of more than `max_bytes` bytes is refused before anything is allocated. Errors name the file and
// the problem ("'m.obj': no such file", "'big.bin' has 5000 bytes, more than the 4096 accepted");
// `failure`, when not null, receives the problem for a caller that words its own message.
Status read_file(const std::string& path, std::string& out, uint64_t max_bytes, ReadFailure* failure = nullptr);
Status read_file(const std::string& path, std::vector<uint8_t>& out, uint64_t max_bytes,
                 ReadFailure* failure = nullptr);

}  // namespace lsnif
