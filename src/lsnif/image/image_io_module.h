// image_io_module.h -- the OpenImageIO backend of image_io.h as a module loaded at first use.
// Debian's OpenImageIO pulls in ~260 shared libraries whose loading and initialisers cost ~0.4 s of
// CPU in every process that links it, most of which never touch an image (`lsnif info`, `train`,
// `--help`, an option refused). So image_io_oiio.cpp is built as a shared module
// (liblsnif_image_oiio.so, target lsnif_image_oiio) that exports one C entry point, and the tools
// link image_io_oiio_loader.cpp, which opens the module with dlopen on the first load_image /
// save_image. The module lives at a fixed path relative to the executables' folder, the same in the
// build tree and in an installed prefix (LSNIF_IMAGE_MODULE_FROM_EXECUTABLE, CMakeLists.txt beside this file); it is built by the same compiler
// and standard library as the executables, so the C++ types below cross the boundary unchanged.
#pragma once
#include <cstdint>
#include <string>

#include "lsnif/format/status.h"
#include "lsnif/image/image_io.h"

namespace lsnif::image::module {

// Raised whenever Codec changes; the loader refuses a module of another version.
constexpr uint32_t kAbiVersion = 1;

// The module's functions, with the contracts of load_image and save_image (image_io.h).
struct Codec {
  uint32_t abi_version;
  Status (*load)(const std::string& path, Image& out, bool raw);
  Status (*save)(const std::string& path, const Image& img);
};

// The name of the module's entry point: extern "C" const Codec* lsnif_image_oiio_codec().
constexpr const char* kEntryPoint = "lsnif_image_oiio_codec";

// Opens the module at `path` (never closed again) and returns its codec in `codec`. Fails naming
// `path` when the file is missing, the dynamic loader refuses it (its message, e.g. a missing
// OpenImageIO), the entry point is absent or the module's abi_version is not kAbiVersion.
Status open_codec(const std::string& path, const Codec*& codec);

// The module's path for the running executable: its folder (/proc/self/exe) joined with the
// configured relative path (LSNIF_IMAGE_MODULE_FROM_EXECUTABLE), lexically normalized. Empty when
// /proc/self/exe cannot be read.
std::string module_path_for_this_executable();

}  // namespace lsnif::image::module
