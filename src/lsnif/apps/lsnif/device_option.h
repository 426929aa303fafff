// device_option.h -- the --device option of every subcommand that runs on a Vulkan device
// (vk::ContextOptions::device; the choice itself is src/lsnif/vulkan/device_choice.h).
#pragma once
#include <string>

#include "lsnif/apps/lsnif/args.h"

namespace lsnif::cli {

inline void add_device_option(Args& args, std::string* device) {
  args.option("device",
              "Vulkan device: its INDEX in `lsnif devices` or a case-insensitive part of its NAME "
              "(default: the first discrete GPU that can ray trace, else an integrated, virtual GPU, else a "
              "CPU device)",
              device);
}

}  // namespace lsnif::cli
