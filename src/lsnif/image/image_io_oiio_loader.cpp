// image_io_oiio_loader.cpp -- load_image / save_image of image_io.h for the tools: the OpenImageIO
// module (image_io_module.h) is opened on the first call and kept; a process that never reads or
// writes an image never loads OpenImageIO. When the module cannot be opened, every image call fails
// with the reason (the module's path and the loader's message); nothing falls back to another reader.
#include <dlfcn.h>
#include <unistd.h>

#include <climits>
#include <filesystem>
#include <string>

#include "lsnif/image/image_io.h"
#include "lsnif/image/image_io_module.h"

#ifndef LSNIF_IMAGE_MODULE_FROM_EXECUTABLE
#error "LSNIF_IMAGE_MODULE_FROM_EXECUTABLE (the module's path relative to the executables' folder) is not defined"
#endif

namespace lsnif::image {
namespace module {

Status open_codec(const std::string& path, const Codec*& codec) {
  codec = nullptr;
  if (access(path.c_str(), F_OK) != 0)
    return Status::error("the OpenImageIO image module '%s' is missing (it is built and installed with the lsnif "
                         "program, at %s relative to the program's folder)",
                         path.c_str(), LSNIF_IMAGE_MODULE_FROM_EXECUTABLE);
  void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle) {
    const char* why = dlerror();
    return Status::error("cannot load the OpenImageIO image module '%s': %s", path.c_str(), why ? why : "unknown error");
  }
  using Entry = const Codec* (*)();
  const auto entry = reinterpret_cast<Entry>(dlsym(handle, kEntryPoint));
  if (!entry) return Status::error("'%s' is not an LSNIF image module: it has no '%s'", path.c_str(), kEntryPoint);
  const Codec* c = entry();
  if (!c || c->abi_version != kAbiVersion || !c->load || !c->save)
    return Status::error("the image module '%s' is of another LSNIF build (interface version %u, this program needs %u)",
                         path.c_str(), c ? c->abi_version : 0u, kAbiVersion);
  codec = c;
  return Status::ok();
}

std::string module_path_for_this_executable() {
  char buf[PATH_MAX];
  const ssize_t n = readlink("/proc/self/exe", buf, sizeof(buf) - 1);
  if (n <= 0) return std::string();
  const std::filesystem::path exe(std::string(buf, size_t(n)));
  return (exe.parent_path() / LSNIF_IMAGE_MODULE_FROM_EXECUTABLE).lexically_normal().string();
}

}  // namespace module

namespace {

// This process's module: opened by the first caller (a function-local static: once, thread-safe).
struct Opened {
  Status status;
  const module::Codec* codec = nullptr;
};

const Opened& the_module() {
  static const Opened opened = [] {
    Opened o;
    const std::string path = module::module_path_for_this_executable();
    o.status = path.empty() ? Status::error("cannot find the OpenImageIO image module: /proc/self/exe is unreadable")
                            : module::open_codec(path, o.codec);
    return o;
  }();
  return opened;
}

}  // namespace

Status load_image(const std::string& path, Image& out, bool raw) {
  const Opened& m = the_module();
  if (!m.status) return Status(m.status).context(format("cannot read image '%s'", path.c_str()));
  return m.codec->load(path, out, raw);
}

Status save_image(const std::string& path, const Image& img) {
  const Opened& m = the_module();
  if (!m.status) return Status(m.status).context(format("cannot write '%s'", path.c_str()));
  return m.codec->save(path, img);
}

}  // namespace lsnif::image
