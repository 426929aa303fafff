// output_folder.cpp -- see output_folder.h.
#include "lsnif/format/output_folder.h"

#include <filesystem>
#include <vector>

#include "lsnif/format/atomic_file.h"
#include "lsnif/format/file_io.h"

namespace lsnif {
namespace fs = std::filesystem;

namespace {

bool plain_name(const std::string& name) {
  return !name.empty() && name != "." && name != ".." && name.find('/') == std::string::npos &&
         name.find('\0') == std::string::npos && name.find('\n') == std::string::npos;
}

// The record's lines: the tool's name, then the names (each plain). False when it is not a record.
bool parse_record(const std::string& text, std::string& tool, std::set<std::string>& names) {
  size_t at = 0;
  bool first = true;
  while (at < text.size()) {
    const size_t end = text.find('\n', at);
    if (end == std::string::npos) return false;  // every line ends with a newline
    const std::string line = text.substr(at, end - at);
    at = end + 1;
    if (first) {
      tool = line;
      first = false;
    } else if (plain_name(line) && line != kOutputRecord) {
      names.insert(line);
    } else {
      return false;
    }
  }
  return !first && !tool.empty();
}

}  // namespace

Status OutputFolder::claim(const std::string& folder, const std::string& tool, OutputFolder& out) {
  out = OutputFolder();
  out.folder_ = folder;
  out.tool_ = tool;
  std::error_code ec;
  if (!fs::exists(fs::symlink_status(folder, ec))) {
    fs::create_directories(folder, ec);
    if (ec) return Status::error("%s: cannot create the output folder: %s", printable(folder).c_str(), ec.message().c_str());
    return out.write_record();
  }
  if (!fs::is_directory(folder, ec)) return Status::error("%s: not a folder", printable(folder).c_str());
  const fs::path record = fs::path(folder) / kOutputRecord;
  std::set<std::string> listed;
  std::string text;
  const bool has_record = fs::exists(fs::symlink_status(record, ec));
  if (has_record) {
    std::string recorded_tool;
    if (!read_file(record.string(), text, 1 << 20) || !parse_record(text, recorded_tool, listed))
      return Status::error("%s: its %s is not a record of written files: the folder is someone else's; give an "
                           "empty or new output folder", printable(folder).c_str(), kOutputRecord);
    if (recorded_tool != tool)
      return Status::error("%s: it holds the outputs of %s, not of %s; give an empty or new output folder",
                           printable(folder).c_str(), printable(recorded_tool).c_str(), printable(tool).c_str());
  }
  std::vector<std::string> foreign;
  size_t foreign_count = 0;
  for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name == kOutputRecord || listed.count(name)) continue;
    if (foreign.size() < 5) foreign.push_back(printable(name));
    ++foreign_count;
  }
  if (ec) return Status::error("%s: cannot list the output folder: %s", printable(folder).c_str(), ec.message().c_str());
  if (foreign_count) {
    std::string names;
    for (const std::string& n : foreign) names += (names.empty() ? "" : ", ") + n;
    if (foreign_count > foreign.size()) names += format(" and %zu more", foreign_count - foreign.size());
    return Status::error("%s holds files that %s did not write (%s): it removes and replaces only its own outputs; "
                         "give an empty or new output folder",
                         printable(folder).c_str(), printable(tool).c_str(), names.c_str());
  }
  // Every entry is the tool's own: the earlier results go (no stale result is kept).
  for (const std::string& name : listed) {
    fs::remove_all(fs::path(folder) / name, ec);
    if (ec)
      return Status::error("%s: cannot remove the earlier output %s: %s", printable(folder).c_str(),
                           printable(name).c_str(), ec.message().c_str());
  }
  return out.write_record();
}

Status OutputFolder::will_write(const std::string& name) {
  if (!plain_name(name) || name == kOutputRecord)
    return Status::error("%s: '%s' is not a plain file name in the output folder", printable(folder_).c_str(),
                         printable(name).c_str());
  if (!listed_.insert(name).second) return Status::ok();
  return write_record();
}

Status OutputFolder::write_record() const {
  std::string text = tool_ + "\n";
  for (const std::string& name : listed_) text += name + "\n";
  return write_file_atomic((fs::path(folder_) / kOutputRecord).string(), text);
}

}  // namespace lsnif
