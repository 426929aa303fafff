// atomic_file_test.cpp -- the file-writing mechanism: whole files or nothing, no temporary file left,
// never through a symbolic link or over a device, a failing write (a file size limit standing in for
// a full disk) reported with the old file intact, and output-equals-input detection.
#include "lsnif/format/atomic_file.h"

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <string>
#include <vector>

#include "lsnif/testing/scoped_test_dir.h"

namespace lsnif {
namespace {

namespace fs = std::filesystem;

// The test's own folder (lsnif/testing/scoped_test_dir.h); file(NAME) is a path in it.
struct TempDir : test::ScopedTestDir {
  TempDir() : ScopedTestDir("lsnif_atomic") {}
  std::string file(const std::string& name) const { return path(name); }
  // Names in the folder (symbolic links not followed).
  std::set<std::string> names() const {
    std::set<std::string> out;
    for (const fs::directory_entry& e : fs::directory_iterator(path())) out.insert(e.path().filename().string());
    return out;
  }
};

std::string read(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void put(const std::string& path, const std::string& text) { std::ofstream(path, std::ios::binary) << text; }

TEST(AtomicFile, WritesAndReplacesWholeFilesLeavingNothingElse) {
  TempDir dir;
  const std::string path = dir.file("a.bin");
  const std::string first(100000, 'x');
  Status s = write_file_atomic(path, first);
  ASSERT_TRUE(s) << s.message();
  EXPECT_EQ(read(path), first);
  EXPECT_EQ(dir.names(), std::set<std::string>{"a.bin"});
  // A replaced file keeps its permissions.
  fs::permissions(path, fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read);
  s = write_file_atomic(path, std::string("second"));
  ASSERT_TRUE(s) << s.message();
  EXPECT_EQ(read(path), "second");
  EXPECT_EQ(fs::status(path).permissions(), fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read);
  EXPECT_EQ(dir.names(), std::set<std::string>{"a.bin"});
  // An empty file is a valid content.
  ASSERT_TRUE(write_file_atomic(path, std::string()));
  EXPECT_EQ(fs::file_size(path), 0u);
}

TEST(AtomicFile, NeverWritesThroughALinkOrOverANonRegularFile) {
  TempDir dir;
  const std::string outside = dir.file("outside.txt");
  put(outside, "precious");
  // A link at the target and links at the old fixed temporary names: nothing behind them changes.
  const std::string target = dir.file("x.lsnif");
  fs::create_symlink(outside, dir.file("x.lsnif.tmp"));
  Status s = write_file_atomic(target, std::string("model"));
  ASSERT_TRUE(s) << s.message();
  EXPECT_EQ(read(outside), "precious");
  EXPECT_FALSE(fs::is_symlink(target));
  EXPECT_EQ(read(target), "model");

  const std::string link = dir.file("link.lsnif");
  fs::create_symlink(outside, link);
  s = write_file_atomic(link, std::string("model"));
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find("symbolic link"), std::string::npos) << s.message();
  EXPECT_EQ(read(outside), "precious");
  EXPECT_TRUE(fs::is_symlink(link));
  const std::string dangling = dir.file("dangling.lsnif");
  fs::create_symlink(dir.file("nowhere"), dangling);
  EXPECT_FALSE(write_file_atomic(dangling, std::string("model")));
  EXPECT_FALSE(fs::exists(dir.file("nowhere")));

  // A device, a FIFO and a folder are refused (and checked before any work).
  ASSERT_EQ(::mkfifo(dir.file("fifo").c_str(), 0600), 0);
  fs::create_directories(dir.file("sub"));
  for (const std::string& p : {std::string("/dev/null"), dir.file("fifo"), dir.file("sub")}) {
    s = write_file_atomic(p, std::string("data"));
    ASSERT_FALSE(s) << p;
    EXPECT_NE(s.message().find(p), std::string::npos) << s.message();
    EXPECT_FALSE(check_output_path(p)) << p;
  }
  EXPECT_TRUE(fs::is_character_file("/dev/null"));
  EXPECT_TRUE(fs::is_fifo(dir.file("fifo")));
  EXPECT_TRUE(fs::is_directory(dir.file("sub")));
}

TEST(AtomicFile, MissingOrUnwritableFoldersAreNamed) {
  TempDir dir;
  Status s = write_file_atomic(dir.file("missing/a.bin"), std::string("x"));
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find("folder '" + dir.file("missing") + "' does not exist"), std::string::npos) << s.message();
  s = check_output_path(dir.file("missing/a.bin"));
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find("does not exist"), std::string::npos) << s.message();
  put(dir.file("plain"), "file");
  s = check_output_path(dir.file("plain/a.bin"));
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find("is not a folder"), std::string::npos) << s.message();
  // /proc accepts no new file, not even from root.
  s = check_output_path("/proc/lsnif_atomic_test.bin");
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find("cannot create a file in '/proc'"), std::string::npos) << s.message();
  // A writable folder passes and keeps nothing.
  s = check_output_path(dir.file("ok.bin"));
  ASSERT_TRUE(s) << s.message();
  EXPECT_EQ(dir.names(), std::set<std::string>{"plain"});
}

// The wait status of a child process that writes 1 MiB to `path` with write_file_atomic under a
// 4096-byte file size limit, SIGXFSZ handled by `on_limit`: SIG_IGN makes write(2) fail with EFBIG
// (the child exits 0 when the error names the file and EFBIG, else 1), SIG_DFL kills the writer in
// the middle of its write.
int write_1mib_under_limit(const std::string& path, void (*on_limit)(int)) {
  const pid_t pid = ::fork();
  if (pid < 0) return -1;
  if (pid == 0) {
    std::signal(SIGXFSZ, on_limit);
    struct rlimit limit = {4096, 4096};
    ::setrlimit(RLIMIT_FSIZE, &limit);
    const Status s = write_file_atomic(path, std::string(1 << 20, 'n'));
    const bool named = !s && s.message().find(path) != std::string::npos &&
                       s.message().find("File too large") != std::string::npos;
    ::_exit(named ? 0 : 1);
  }
  int status = 0;
  return ::waitpid(pid, &status, 0) == pid ? status : -1;
}

// A file size limit makes write(2) fail with EFBIG as a full disk fails with ENOSPC.
TEST(AtomicFile, AFailingWriteKeepsTheOldFileAndLeavesNoTemporaryFile) {
  TempDir dir;
  const std::string path = dir.file("model.lsnif");
  put(path, "old contents");
  const int status = write_1mib_under_limit(path, SIG_IGN);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "the write did not fail with a message naming the file and EFBIG";
  EXPECT_EQ(read(path), "old contents");
  EXPECT_EQ(dir.names(), std::set<std::string>{"model.lsnif"});
}

TEST(AtomicFile, SameFileComparesIdentityNotSpelling) {
  TempDir dir;
  put(dir.file("a.off"), "mesh");
  put(dir.file("b.off"), "mesh");
  fs::create_directories(dir.file("sub"));
  fs::create_hard_link(dir.file("a.off"), dir.file("hard.off"));
  fs::create_symlink(dir.file("a.off"), dir.file("soft.off"));
  EXPECT_TRUE(same_file(dir.file("a.off"), dir.file("sub/../a.off")));
  EXPECT_TRUE(same_file(dir.file("a.off"), dir.file("hard.off")));
  EXPECT_TRUE(same_file(dir.file("a.off"), dir.file("soft.off")));
  EXPECT_FALSE(same_file(dir.file("a.off"), dir.file("b.off")));  // same contents, other file
  EXPECT_FALSE(same_file(dir.file("a.off"), dir.file("missing.off")));
  EXPECT_FALSE(same_file("", dir.file("a.off")));
  Status s = check_not_an_input(dir.file("hard.off"), "-o", {"", dir.file("b.off"), dir.file("a.off")});
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find("-o '" + dir.file("hard.off") + "' is the input file '" + dir.file("a.off") + "'"),
            std::string::npos)
      << s.message();
  EXPECT_TRUE(check_not_an_input(dir.file("new.lsnif"), "-o", {dir.file("a.off")}));
}

// A writer killed in the middle (SIGXFSZ's default action at a file size limit) leaves its temporary
// file: it is recognised by its name and removed by remove_stale_temp_files, which leaves everything
// else alone (other targets, other names, folders, the finished file).
TEST(AtomicFile, TemporaryFilesOfAKilledWriterAreFoundAndRemoved) {
  TempDir dir;
  const std::string path = dir.file("model.lsnif");
  put(path, "old contents");
  const int status = write_1mib_under_limit(path, SIG_DFL);
  ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGXFSZ) << "the writer was not killed";
  std::set<std::string> left = dir.names();
  left.erase("model.lsnif");
  ASSERT_EQ(left.size(), 1u) << "the killed writer left no temporary file";
  const std::string temp = *left.begin();
  EXPECT_EQ(atomic_temp_target(temp), "model.lsnif") << temp;

  // Decoys: another target's temporary file, names that only look alike, a folder of the pattern.
  put(dir.file(".scene.gltf.tmp-0123456789ab"), "other target");
  for (const char* name : {"model.lsnif.tmp-0123456789ab", ".model.lsnif.tmp-0123456789AB",
                           ".model.lsnif.tmp-0123456789a", ".model.lsnif.tmp0123456789ab", "notes.tmp"}) {
    EXPECT_EQ(atomic_temp_target(name), "") << name;
    put(dir.file(name), "decoy");
  }
  fs::create_directory(dir.file(".model.lsnif.tmp-aaaaaaaaaaaa"));
  std::vector<std::string> removed;
  ASSERT_TRUE(remove_stale_temp_files(dir.path().string(),
                                      [](const std::string& target) { return target == "model.lsnif"; }, removed));
  EXPECT_EQ(removed, std::vector<std::string>{dir.file(temp)});
  EXPECT_EQ(read(path), "old contents");
  EXPECT_FALSE(fs::exists(dir.file(temp)));
  EXPECT_EQ(dir.names().size(), 1u + 1u + 5u + 1u);  // the model, the other target's, the decoys, the folder
}

}  // namespace
}  // namespace lsnif
