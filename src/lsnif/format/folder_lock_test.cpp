// folder_lock_test.cpp -- the output folder's lock: one holder at a time (a second open of the lock
// file, as another process makes, is refused at once and told so), released with its holder (also
// a killed one: the lock goes with the process), the file removed on release and reused when a
// killed holder left it, and the busy probe creating nothing.
#include "lsnif/format/folder_lock.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <fstream>

#include "lsnif/testing/scoped_test_dir.h"

namespace lsnif {
namespace {

namespace fs = std::filesystem;
constexpr const char* kName = ".test.lock";

TEST(FolderLock, OneHolderAtATime) {
  test::ScopedTestDir dir("lsnif_folder_lock");
  const std::string folder = dir.path().string();
  EXPECT_FALSE(folder_lock_busy(folder, kName));
  EXPECT_FALSE(fs::exists(dir.path(kName))) << "the probe created the lock file";

  FolderLock first;
  bool busy = true;
  ASSERT_TRUE(first.acquire(folder, kName, busy));
  EXPECT_FALSE(busy);
  EXPECT_TRUE(first.held());
  EXPECT_EQ(first.path(), dir.path(kName));
  EXPECT_TRUE(folder_lock_busy(folder, kName));

  // flock locks belong to an open file: a second acquire is another holder, as in another process.
  FolderLock second;
  const Status s = second.acquire(folder, kName, busy);
  ASSERT_FALSE(s);
  EXPECT_TRUE(busy);
  EXPECT_FALSE(second.held());
  EXPECT_NE(s.message().find(dir.path(kName)), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("another process"), std::string::npos) << s.message();

  // Moved, the lock stays held; released, its file goes and the next holder gets it.
  FolderLock moved = std::move(first);
  EXPECT_TRUE(moved.held());
  EXPECT_FALSE(first.held());
  EXPECT_TRUE(folder_lock_busy(folder, kName));
  moved.release();
  EXPECT_FALSE(fs::exists(dir.path(kName)));
  EXPECT_FALSE(folder_lock_busy(folder, kName));
  ASSERT_TRUE(second.acquire(folder, kName, busy));
  EXPECT_FALSE(busy);
}

TEST(FolderLock, AKilledHolderLeavesNoLock) {
  test::ScopedTestDir dir("lsnif_folder_lock");
  const std::string folder = dir.path().string();
  int ready[2];
  ASSERT_EQ(::pipe(ready), 0);
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    FolderLock lock;
    bool busy = false;
    const char ok = lock.acquire(folder, kName, busy) ? 1 : 0;
    (void)!::write(ready[1], &ok, 1);
    ::pause();  // until killed
    ::_exit(0);
  }
  char ok = 0;
  ASSERT_EQ(::read(ready[0], &ok, 1), 1);
  ASSERT_EQ(ok, 1) << "the child could not take the lock";
  EXPECT_TRUE(folder_lock_busy(folder, kName));
  FolderLock mine;
  bool busy = false;
  EXPECT_FALSE(mine.acquire(folder, kName, busy));
  EXPECT_TRUE(busy);
  ::kill(pid, SIGKILL);
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ::close(ready[0]);
  ::close(ready[1]);
  EXPECT_TRUE(fs::exists(dir.path(kName)));  // left behind, unlocked
  EXPECT_FALSE(folder_lock_busy(folder, kName));
  ASSERT_TRUE(mine.acquire(folder, kName, busy));
  mine.release();
  EXPECT_FALSE(fs::exists(dir.path(kName)));
}

TEST(FolderLock, ErrorsNameTheLockFile) {
  test::ScopedTestDir dir("lsnif_folder_lock");
  FolderLock lock;
  bool busy = true;
  const std::string missing = dir.path("missing");
  const Status s = lock.acquire(missing, kName, busy);
  ASSERT_FALSE(s);
  EXPECT_FALSE(busy);
  EXPECT_NE(s.message().find(missing + "/" + kName), std::string::npos) << s.message();
  EXPECT_FALSE(folder_lock_busy(missing, kName));
}

}  // namespace
}  // namespace lsnif
