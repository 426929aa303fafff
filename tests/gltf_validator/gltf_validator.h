// gltf_validator.h -- the end-to-end tests' access to the Khronos glTF validator (npm's
// gltf-validator, fetched by scripts/setup.sh) through validate_gltf.js beside this file.
#pragma once
#include <string>
#include <vector>

#include "lsnif/testing/test_support.h"

namespace lsnif::test {

// Validates `files` (glTF or GLB); code 0 when none has an error, 1 when one has (the errors are
// in `out`), 2 when node or the validator is missing (scripts/setup.sh installs both).
inline CommandResult validate_gltf(const std::vector<std::string>& files) {
  if (std::string(LSNIF_NODE).empty())
    return CommandResult{2, "node was not found when this build was configured: run scripts/setup.sh"};
  std::string command = std::string(LSNIF_NODE) + " " + LSNIF_GLTF_VALIDATOR_SCRIPT + " " + LSNIF_GLTF_VALIDATOR_DIR;
  for (const std::string& f : files) command += " '" + f + "'";
  return run_command(command + " 2>&1");
}

}  // namespace lsnif::test
