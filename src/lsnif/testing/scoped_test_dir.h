// scoped_test_dir.h -- a temporary folder per running test (header only: the standard library and
// GoogleTest, so that the tests of every library can use it, lsnif_format's included).
#pragma once
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>
#include <system_error>

namespace lsnif::test {

// A fresh folder PREFIX_PID_TESTNAME under the system's temporary folder for the running test
// (emptied first if a crashed run left it), removed with everything in it when this object goes,
// also after a test took the owner's permissions away (construct it while a test runs, e.g. as a
// fixture member or in SetUp).
class ScopedTestDir {
 public:
  explicit ScopedTestDir(const std::string& prefix)
      : path_(std::filesystem::temp_directory_path() /
              (prefix + "_" + std::to_string(::getpid()) + "_" +
               ::testing::UnitTest::GetInstance()->current_test_info()->name())) {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
    std::filesystem::create_directories(path_);
  }
  ~ScopedTestDir() {
    std::error_code ec;
    std::filesystem::permissions(path_, std::filesystem::perms::owner_all, std::filesystem::perm_options::add, ec);
    std::filesystem::remove_all(path_, ec);
  }
  ScopedTestDir(const ScopedTestDir&) = delete;
  ScopedTestDir& operator=(const ScopedTestDir&) = delete;

  const std::filesystem::path& path() const { return path_; }
  // Path of `name` inside the folder.
  std::string path(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

}  // namespace lsnif::test
