// data_dir.h -- the folder of test data that scripts/setup.sh fetches (meshes/, hdr/): the default of
// the --data option of `lsnif demo` and `lsnif bench` (LSNIF_DATA_DIR, set by the build: the source
// tree's data/), and the error when it does not exist (e.g. an installed lsnif without the sources).
#pragma once
#include <string>

namespace lsnif::cli {

// LSNIF_DATA_DIR, one string in the program (data_dir.cpp).
const char* default_data_dir();

// True when `dir` is a folder; otherwise prints why `lsnif COMMAND` needs it and how to get it.
bool check_data_dir(const char* command, const std::string& dir);

}  // namespace lsnif::cli
