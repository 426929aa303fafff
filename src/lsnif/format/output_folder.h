// output_folder.h -- the one rule for what a tool may delete: in an output folder it owns, only
// what an earlier run of the same tool wrote there, as that run listed it in the folder's record
// (kOutputRecord: the tool's name, then a name a line). A folder that holds anything else (a file
// its owner put there, the record of another tool) is refused before any work, naming what it
// holds, so a tool neither removes nor overwrites a file it did not write. A name is listed before
// the file is written, so a run that is killed leaves a record that still covers what it wrote.
#pragma once
#include <set>
#include <string>

#include "lsnif/format/status.h"

namespace lsnif {

inline constexpr const char* kOutputRecord = ".lsnif-outputs";

class OutputFolder {
 public:
  // Takes `folder` for `tool`: creates it when missing; else, when it holds a record of `tool`,
  // removes every entry the record lists (files, or folders the tool made, whole) and keeps the
  // record; an error (nothing removed) when it holds an entry the record does not list, or any
  // entry without a record. Errors name the folder, up to five entries and the reason.
  static Status claim(const std::string& folder, const std::string& tool, OutputFolder& out);

  // Lists `name`, a plain name in the folder (no '/', not "." or ".."), in the record (rewritten
  // atomically) before the caller writes it.
  Status will_write(const std::string& name);

  const std::string& folder() const { return folder_; }

 private:
  Status write_record() const;
  std::string folder_, tool_;
  std::set<std::string> listed_;
};

}  // namespace lsnif
