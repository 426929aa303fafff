// file_io_test.cpp -- the whole-file reader against files written here with the standard streams:
// every byte value back exactly (NULs included), an empty file, the size limit (at it, one byte
// over, a huge sparse file refused before any allocation), and the problems a caller words itself:
// a missing file, a folder, a FIFO, an unreadable file, a file whose size is not its content.
#include "lsnif/format/file_io.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "lsnif/testing/scoped_test_dir.h"

namespace lsnif {
namespace {

namespace fs = std::filesystem;

// The test's own folder (lsnif/testing/scoped_test_dir.h); file(NAME) is a path in it.
struct TempDir : test::ScopedTestDir {
  TempDir() : ScopedTestDir("lsnif_file_io") {}
  std::string file(const std::string& name) const { return path(name); }
};

void put(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), std::streamsize(bytes.size()));
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

// Every byte value, NULs among them, in both containers.
TEST(ReadFile, ReturnsEveryByteOfTheFile) {
  TempDir dir;
  std::string bytes;
  for (int round = 0; round < 3; ++round)
    for (int b = 0; b < 256; ++b) bytes.push_back(char(b));
  bytes += std::string(5, '\0');
  const std::string path = dir.file("all.bin");
  put(path, bytes);
  std::string text = "old";
  Status s = read_file(path, text, bytes.size());
  ASSERT_TRUE(s) << s.message();
  EXPECT_EQ(text, bytes);
  std::vector<uint8_t> data = {1, 2, 3};
  ReadFailure f;
  s = read_file(path, data, uint64_t(1) << 20, &f);
  ASSERT_TRUE(s) << s.message();
  EXPECT_EQ(f.problem, ReadProblem::None);
  EXPECT_EQ(data, std::vector<uint8_t>(bytes.begin(), bytes.end()));

  // Through a symbolic link: the file it points to.
  fs::create_symlink(path, dir.file("link.bin"));
  text.clear();
  ASSERT_TRUE(read_file(dir.file("link.bin"), text, bytes.size()));
  EXPECT_EQ(text, bytes);
}

TEST(ReadFile, AnEmptyFileIsEmptyContent) {
  TempDir dir;
  const std::string path = dir.file("empty");
  put(path, "");
  std::string text = "old";
  Status s = read_file(path, text, 0);
  ASSERT_TRUE(s) << s.message();
  EXPECT_TRUE(text.empty());
  std::vector<uint8_t> data = {7};
  ASSERT_TRUE(read_file(path, data, 10));
  EXPECT_TRUE(data.empty());
}

TEST(ReadFile, RefusesMoreBytesThanTheCallerAccepts) {
  TempDir dir;
  const std::string path = dir.file("ten.txt");
  put(path, "0123456789");
  std::string text;
  ASSERT_TRUE(read_file(path, text, 10));  // the limit itself is accepted
  EXPECT_EQ(text, "0123456789");

  text = "kept";
  ReadFailure f;
  Status s = read_file(path, text, 9, &f);
  ASSERT_FALSE(s);
  EXPECT_EQ(f.problem, ReadProblem::TooLarge);
  EXPECT_EQ(f.size, 10u);
  EXPECT_EQ(text, "kept");  // left as it was
  EXPECT_TRUE(contains(s.message(), path)) << s.message();
  EXPECT_TRUE(contains(s.message(), "10 bytes, more than the 9 accepted")) << s.message();

  // A sparse file far larger than memory: refused from its size, nothing allocated.
  const std::string huge = dir.file("huge.bin");
  put(huge, "");
  std::error_code ec;
  fs::resize_file(huge, uint64_t(1) << 40, ec);
  if (!ec) {
    std::vector<uint8_t> data;
    s = read_file(huge, data, uint64_t(1) << 20, &f);
    ASSERT_FALSE(s);
    EXPECT_EQ(f.problem, ReadProblem::TooLarge);
    EXPECT_EQ(f.size, uint64_t(1) << 40);
    EXPECT_TRUE(data.empty());
  }
}

TEST(ReadFile, NamesTheFileAndTheProblem) {
  TempDir dir;
  std::string text = "kept";
  ReadFailure f;

  const std::string missing = dir.file("missing.bin");
  Status s = read_file(missing, text, 100, &f);
  ASSERT_FALSE(s);
  EXPECT_EQ(f.problem, ReadProblem::Missing);
  EXPECT_EQ(s.message(), "'" + missing + "': no such file");
  s = read_file(dir.file("no/folder/x.bin"), text, 100, &f);
  ASSERT_FALSE(s);
  EXPECT_EQ(f.problem, ReadProblem::Missing);

  const std::string folder = dir.file("folder");
  fs::create_directories(folder);
  s = read_file(folder, text, 100, &f);
  ASSERT_FALSE(s);
  EXPECT_EQ(f.problem, ReadProblem::Directory);
  EXPECT_EQ(s.message(), "'" + folder + "' is a folder, not a file");

  // A FIFO is refused from its type, not opened (opening it would wait for a writer).
  const std::string fifo = dir.file("fifo");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  s = read_file(fifo, text, 100, &f);
  ASSERT_FALSE(s);
  EXPECT_EQ(f.problem, ReadProblem::NotRegular);
  EXPECT_TRUE(contains(s.message(), fifo)) << s.message();
  EXPECT_EQ(text, "kept");

  // No read permission (root reads anything: nothing to check then).
  if (::geteuid() != 0) {
    const std::string locked = dir.file("locked.txt");
    put(locked, "secret");
    fs::permissions(locked, fs::perms::none);
    s = read_file(locked, text, 100, &f);
    ASSERT_FALSE(s);
    EXPECT_EQ(f.problem, ReadProblem::CannotOpen);
    EXPECT_EQ(f.size, 6u);
    EXPECT_FALSE(f.reason.empty());
    EXPECT_EQ(s.message(), "cannot open '" + locked + "': " + f.reason);
    // A folder on the way that cannot be searched.
    const std::string closed = dir.file("closed");
    fs::create_directories(closed);
    put(closed + "/in.txt", "x");
    fs::permissions(closed, fs::perms::none);
    s = read_file(closed + "/in.txt", text, 100, &f);
    fs::permissions(closed, fs::perms::owner_all);
    ASSERT_FALSE(s);
    EXPECT_EQ(f.problem, ReadProblem::CannotAccess);
    EXPECT_TRUE(contains(s.message(), closed + "/in.txt")) << s.message();
  }
  EXPECT_EQ(text, "kept");
}

// A /proc file says it has 0 bytes and then has more: the size taken before the read is not the
// content, which must be an error, not an empty or cut result.
TEST(ReadFile, AFileWhoseSizeIsNotItsContentIsAnError) {
  const std::string path = "/proc/self/status";
  std::error_code ec;
  if (!fs::is_regular_file(path, ec) || fs::file_size(path, ec) != 0 || ec)
    GTEST_SKIP() << path << " is not a regular file of size 0 here";
  std::string text = "kept";
  ReadFailure f;
  Status s = read_file(path, text, 1 << 20, &f);
  ASSERT_FALSE(s);
  EXPECT_EQ(f.problem, ReadProblem::ChangedSize);
  EXPECT_EQ(s.message(), "'" + path + "' changed size while it was read");
  EXPECT_EQ(text, "kept");
}

}  // namespace
}  // namespace lsnif
