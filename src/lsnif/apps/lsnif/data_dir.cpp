#include "lsnif/apps/lsnif/data_dir.h"

#include <cstdio>
#include <filesystem>

namespace lsnif::cli {

const char* default_data_dir() { return LSNIF_DATA_DIR; }

bool check_data_dir(const char* command, const std::string& dir) {
  std::error_code ec;
  if (std::filesystem::is_directory(dir, ec)) return true;
  std::fprintf(stderr,
               "lsnif %s: the data folder %s does not exist: run scripts/setup.sh in the LSNIF source tree (it "
               "fetches the meshes and HDR environments into its data/ folder) and pass that folder with --data DIR\n",
               command, dir.c_str());
  return false;
}

}  // namespace lsnif::cli
