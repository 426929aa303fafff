// file_io.cpp -- see file_io.h.
#include "lsnif/format/file_io.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <new>
#include <stdexcept>
#include <system_error>
#include <utility>

namespace lsnif {
namespace {

using ull = unsigned long long;

// The message of a failed read of `path`.
Status describe(const std::string& path, const ReadFailure& f, uint64_t max_bytes) {
  const std::string shown = printable(path);  // a name may hold anything but '\0'
  const char* p = shown.c_str();
  switch (f.problem) {
    case ReadProblem::None: return Status::ok();
    case ReadProblem::Missing: return Status::error("'%s': no such file", p);
    case ReadProblem::CannotAccess: return Status::error("cannot access '%s': %s", p, f.reason.c_str());
    case ReadProblem::Directory: return Status::error("'%s' is a folder, not a file", p);
    case ReadProblem::NotRegular: return Status::error("'%s' is not a regular file", p);
    case ReadProblem::SizeUnknown: return Status::error("cannot read the size of '%s': %s", p, f.reason.c_str());
    case ReadProblem::TooLarge:
      return Status::error("'%s' has %llu bytes, more than the %llu accepted", p, ull(f.size), ull(max_bytes));
    case ReadProblem::OutOfMemory: return Status::error("no memory for the %llu bytes of '%s'", ull(f.size), p);
    case ReadProblem::CannotOpen: return Status::error("cannot open '%s': %s", p, f.reason.c_str());
    case ReadProblem::ReadError: return Status::error("cannot read '%s': %s", p, f.reason.c_str());
    case ReadProblem::ChangedSize: return Status::error("'%s' changed size while it was read", p);
  }
  return Status::error("cannot read '%s'", p);
}

// Reads the file at `path` into `bytes` (empty on entry), or says in `f` (fresh on entry) why not.
template <typename Bytes>
void read_into(const std::string& path, uint64_t max_bytes, Bytes& bytes, ReadFailure& f) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (st.type() == fs::file_type::not_found) {
    f.problem = ReadProblem::Missing;
    return;
  }
  if (ec) {
    f.problem = ReadProblem::CannotAccess;
    f.reason = ec.message();
    return;
  }
  if (fs::is_directory(st) || !fs::is_regular_file(st)) {
    f.problem = fs::is_directory(st) ? ReadProblem::Directory : ReadProblem::NotRegular;
    return;
  }
  const uintmax_t size = fs::file_size(path, ec);
  if (ec) {
    f.problem = ReadProblem::SizeUnknown;
    f.reason = ec.message();
    return;
  }
  f.size = size;
  if (size > max_bytes) {
    f.problem = ReadProblem::TooLarge;
    return;
  }
  std::FILE* file = std::fopen(path.c_str(), "rb");
  if (!file) {
    f.problem = ReadProblem::CannotOpen;
    f.reason = std::strerror(errno);
    return;
  }
  bool allocated = size <= bytes.max_size();
  if (allocated) {
    try {
      bytes.resize(static_cast<size_t>(size));
    } catch (const std::bad_alloc&) {
      allocated = false;
    } catch (const std::length_error&) {
      allocated = false;
    }
  }
  if (!allocated) {
    std::fclose(file);
    f.problem = ReadProblem::OutOfMemory;
    return;
  }
  f.got = bytes.empty() ? 0 : std::fread(bytes.data(), 1, bytes.size(), file);
  // One more byte must not be there: the file may have grown since its size was taken.
  unsigned char extra;
  const bool longer = std::fread(&extra, 1, 1, file) == 1;
  const bool failed = std::ferror(file) != 0;
  const int error = errno;
  std::fclose(file);
  if (failed) {
    f.problem = ReadProblem::ReadError;
    f.reason = error ? std::strerror(error) : "read error";
  } else if (f.got != size || longer) {
    f.problem = ReadProblem::ChangedSize;
  }
}

template <typename Bytes>
Status read_whole(const std::string& path, Bytes& out, uint64_t max_bytes, ReadFailure* failure) {
  Bytes bytes;
  ReadFailure f;
  read_into(path, max_bytes, bytes, f);
  if (failure) *failure = f;
  if (f.problem != ReadProblem::None) return describe(path, f, max_bytes);
  out = std::move(bytes);
  return Status::ok();
}

}  // namespace

Status read_file(const std::string& path, std::string& out, uint64_t max_bytes, ReadFailure* failure) {
  return read_whole(path, out, max_bytes, failure);
}

Status read_file(const std::string& path, std::vector<uint8_t>& out, uint64_t max_bytes, ReadFailure* failure) {
  return read_whole(path, out, max_bytes, failure);
}

}  // namespace lsnif
