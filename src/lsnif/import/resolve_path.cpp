// resolve_path.cpp -- see resolve_path.h.
#include "lsnif/import/resolve_path.h"

#include <filesystem>

namespace lsnif {

Status resolve_reference(const std::string& base_dir, const std::string& ref, bool allow_outside,
                         const std::string& what, std::string& out) {
  namespace fs = std::filesystem;
  if (ref.empty()) return Status::error("%s is empty", what.c_str());
  if (ref.find('\0') != std::string::npos) return Status::error("%s contains a NUL byte", what.c_str());
  const fs::path p(ref);
  const std::string folder = base_dir.empty() ? std::string(".") : base_dir;
  if (!allow_outside) {
    const char* why = nullptr;
    if (p.is_absolute()) {
      why = "it is an absolute path";
    } else {
      const fs::path normal = p.lexically_normal();
      if (!normal.empty() && *normal.begin() == "..") why = "its '..' leads out of that folder";
    }
    if (why)
      return Status::error("%s '%s' refers to a file outside the folder '%s' of the file that names it (%s); "
                           "pass --allow-outside-refs to allow that",
                           what.c_str(), ref.c_str(), folder.c_str(), why);
  }
  out = (p.is_absolute() ? p : fs::path(folder) / p).lexically_normal().string();
  return Status::ok();
}

}  // namespace lsnif
