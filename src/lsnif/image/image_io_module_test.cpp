// Tests of the OpenImageIO module and its loader (image_io_module.h): a process opens OpenImageIO
// only at its first image call, finds the module beside its own folder, and a module that cannot be
// used is an error naming it. This executable links the loader and not OpenImageIO; CTest runs each
// test in a fresh process.
#include "lsnif/image/image_io_module.h"

#include <dlfcn.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <climits>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "lsnif/image/image_io.h"
#include "lsnif/testing/scoped_test_dir.h"

namespace lsnif::image {
namespace {

namespace fs = std::filesystem;

std::string mapped_files() {
  std::ifstream maps("/proc/self/maps");
  return std::string(std::istreambuf_iterator<char>(maps), std::istreambuf_iterator<char>());
}

bool has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

TEST(ImageModule, OpenImageIOIsLoadedByTheFirstImageCallOnly) {
  EXPECT_FALSE(has(mapped_files(), "libOpenImageIO")) << "loaded before any image call";
  EXPECT_FALSE(has(mapped_files(), "liblsnif_image_oiio"));
  test::ScopedTestDir dir("lsnif_image_module");
  Image img;
  img.width = 3;
  img.height = 2;
  // 8-bit sRGB codes 0, 51, ..., 255 as linear values: a PNG round trip gives them back exactly.
  for (int i = 0; i < 18; ++i) img.rgb.push_back(srgb_to_linear(float((i * 15) % 256) / 255.0f));
  ASSERT_TRUE(save_image(dir.path("a.png"), img).is_ok());
  EXPECT_TRUE(has(mapped_files(), "libOpenImageIO"));
  EXPECT_TRUE(has(mapped_files(), "liblsnif_image_oiio"));
  Image back;
  const Status s = load_image(dir.path("a.png"), back);
  ASSERT_TRUE(s.is_ok()) << s.message();
  ASSERT_EQ(back.width, 3u);
  ASSERT_EQ(back.height, 2u);
  for (size_t i = 0; i < img.rgb.size(); ++i) EXPECT_EQ(encode_srgb8(back.rgb[i]), encode_srgb8(img.rgb[i])) << i;
}

TEST(ImageModule, ThePathIsRelativeToTheExecutablesFolder) {
  char buf[PATH_MAX];
  const ssize_t n = readlink("/proc/self/exe", buf, sizeof(buf) - 1);
  ASSERT_GT(n, 0);
  const fs::path exe(std::string(buf, size_t(n)));
  const std::string path = module::module_path_for_this_executable();
  EXPECT_EQ(fs::path(path).lexically_normal(),
            (exe.parent_path() / LSNIF_IMAGE_MODULE_FROM_EXECUTABLE).lexically_normal());
  EXPECT_TRUE(fs::is_regular_file(path)) << path;
  const module::Codec* codec = nullptr;
  const Status s = module::open_codec(path, codec);
  ASSERT_TRUE(s.is_ok()) << s.message();
  ASSERT_NE(codec, nullptr);
  EXPECT_EQ(codec->abi_version, module::kAbiVersion);
}

TEST(ImageModule, AModuleThatCannotBeUsedIsNamed) {
  test::ScopedTestDir dir("lsnif_image_module");
  const module::Codec* codec = nullptr;
  // Missing.
  Status s = module::open_codec(dir.path("none.so"), codec);
  EXPECT_FALSE(s.is_ok());
  EXPECT_TRUE(has(s.message(), dir.path("none.so")) && has(s.message(), "missing")) << s.message();
  EXPECT_EQ(codec, nullptr);
  // Not a shared library: the dynamic loader's reason.
  std::ofstream(dir.path("text.so")) << "not an ELF file\n";
  s = module::open_codec(dir.path("text.so"), codec);
  EXPECT_FALSE(s.is_ok());
  EXPECT_TRUE(has(s.message(), "cannot load the OpenImageIO image module '" + dir.path("text.so") + "'")) << s.message();
  EXPECT_EQ(codec, nullptr);
  // A shared library without the entry point (the C++ standard library this test runs with).
  Dl_info info{};
  ASSERT_NE(dladdr(reinterpret_cast<void*>(&std::terminate), &info), 0);
  ASSERT_NE(info.dli_fname, nullptr);
  s = module::open_codec(info.dli_fname, codec);
  EXPECT_FALSE(s.is_ok());
  EXPECT_TRUE(has(s.message(), "is not an LSNIF image module") && has(s.message(), module::kEntryPoint)) << s.message();
  EXPECT_EQ(codec, nullptr);
}

}  // namespace
}  // namespace lsnif::image
