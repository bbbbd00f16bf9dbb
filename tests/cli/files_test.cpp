#include "service/cli/files.h"

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <filesystem>
#include <string>
#include <vector>

namespace softgrasp::cli {
namespace {

namespace fs = std::filesystem;

class CliFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) /
           ("softgrasp_cli_files_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    fs::permissions(dir_, fs::perms::owner_all, fs::perm_options::add);
    fs::remove_all(dir_);
  }
  /// Every name in the test's folder, hidden temporary files included.
  std::vector<std::string> Names(const fs::path& folder) const {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(folder)) {
      names.push_back(entry.path().filename().string());
    }
    std::sort(names.begin(), names.end());
    return names;
  }
  fs::path dir_;
};

TEST_F(CliFiles, RoundTripKeepsEveryByte) {
  std::string bytes;
  for (unsigned i = 0; i < 300000; ++i) bytes.push_back(static_cast<char>(i * 7919u % 251u));
  const fs::path path = dir_ / "data.bin";
  ASSERT_FALSE(WriteFile(path, bytes));
  auto read = ReadFile(path);
  ASSERT_TRUE(read.ok()) << read.error().message;
  EXPECT_EQ(read.value(), bytes);
  // Rewriting replaces the whole file, also with fewer bytes; no temporary file stays behind.
  ASSERT_FALSE(WriteFile(path, "short"));
  EXPECT_EQ(ReadFile(path).value(), "short");
  ASSERT_FALSE(WriteFile(dir_ / "empty", ""));
  EXPECT_EQ(ReadFile(dir_ / "empty").value(), "");
  EXPECT_EQ(Names(dir_), (std::vector<std::string>{"data.bin", "empty"}));
}

TEST_F(CliFiles, ANewFileFollowsTheUmaskAndAReplacedOneKeepsItsPermissions) {
  const fs::path path = dir_ / "f.txt";
  const mode_t old_mask = ::umask(022);
  ASSERT_FALSE(WriteFile(path, "a"));
  ::umask(old_mask);
  EXPECT_EQ(fs::status(path).permissions(), fs::perms::owner_read | fs::perms::owner_write |
                                                fs::perms::group_read | fs::perms::others_read);
  fs::permissions(path, fs::perms::owner_read | fs::perms::owner_write);
  ASSERT_FALSE(WriteFile(path, "b"));
  EXPECT_EQ(fs::status(path).permissions(), fs::perms::owner_read | fs::perms::owner_write);
}

TEST_F(CliFiles, AMissingFileIsNotFoundAndNamesThePath) {
  const fs::path path = dir_ / "nowhere" / "scene.json";
  auto read = ReadFile(path);
  ASSERT_FALSE(read.ok());
  EXPECT_EQ(read.error().code, core::ErrorCode::kNotFound);
  EXPECT_NE(read.error().message.find(path.string()), std::string::npos) << read.error().message;
  EXPECT_NE(read.error().message.find("cannot read"), std::string::npos);
  auto folder = ReadFile(dir_);
  ASSERT_FALSE(folder.ok());
  EXPECT_EQ(folder.error().code, core::ErrorCode::kUnprocessable);
  EXPECT_NE(folder.error().message.find(dir_.string()), std::string::npos);
}

TEST_F(CliFiles, WritingIntoAMissingFolderFailsUnlessAskedToCreateIt) {
  const fs::path path = dir_ / "a" / "b" / "index.json";
  const auto error = WriteFile(path, "{}");
  ASSERT_TRUE(error);
  EXPECT_EQ(error->code, core::ErrorCode::kNotFound);
  EXPECT_NE(error->message.find(path.string()), std::string::npos) << error->message;
  EXPECT_FALSE(fs::exists(dir_ / "a"));
  ASSERT_FALSE(WriteFile(path, "{}", Parents::kCreate));
  EXPECT_EQ(ReadFile(path).value(), "{}");
  EXPECT_EQ(Names(dir_ / "a" / "b"), (std::vector<std::string>{"index.json"}));
}

TEST_F(CliFiles, AFileWhereAFolderShouldBeIsAnErrorAndLeavesNothing) {
  const fs::path file = dir_ / "plain";
  ASSERT_FALSE(WriteFile(file, "x"));
  for (const Parents parents : {Parents::kMustExist, Parents::kCreate}) {
    const auto error = WriteFile(file / "inside.txt", "y", parents);
    ASSERT_TRUE(error);
    EXPECT_EQ(error->code, core::ErrorCode::kNotFound) << error->message;
    EXPECT_NE(error->message.find(parents == Parents::kCreate ? file.string()
                                                              : (file / "inside.txt").string()),
              std::string::npos)
        << error->message;
  }
  EXPECT_EQ(ReadFile(file).value(), "x");
  EXPECT_EQ(Names(dir_), (std::vector<std::string>{"plain"}));
}

TEST_F(CliFiles, AFolderAtThePathIsNotReplaced) {
  fs::create_directories(dir_ / "taken" / "child");
  const auto error = WriteFile(dir_ / "taken", "bytes");
  ASSERT_TRUE(error);
  EXPECT_EQ(error->code, core::ErrorCode::kUnprocessable) << error->message;
  EXPECT_TRUE(fs::is_directory(dir_ / "taken" / "child"));
  EXPECT_EQ(Names(dir_), (std::vector<std::string>{"taken"}));
  EXPECT_EQ(WriteFile(dir_ / "slash/", "x")->code, core::ErrorCode::kInvalidArgument);
}

TEST_F(CliFiles, AReadOnlyFolderKeepsItsOldFileAndGetsNoTemporaryFile) {
  if (::geteuid() == 0) GTEST_SKIP() << "root writes into read-only folders";
  const fs::path path = dir_ / "keep.txt";
  ASSERT_FALSE(WriteFile(path, "old"));
  fs::permissions(dir_, fs::perms::owner_read | fs::perms::owner_exec);
  const auto error = WriteFile(path, "new");
  fs::permissions(dir_, fs::perms::owner_all, fs::perm_options::add);
  ASSERT_TRUE(error);
  EXPECT_EQ(error->code, core::ErrorCode::kUnprocessable);
  EXPECT_NE(error->message.find(path.string()), std::string::npos) << error->message;
  EXPECT_EQ(ReadFile(path).value(), "old");
  EXPECT_EQ(Names(dir_), (std::vector<std::string>{"keep.txt"}));
}

// A write that fails half way (here: the file size limit, EFBIG) leaves the old file whole and
// no temporary file; root is bound by the limit as well.
TEST_F(CliFiles, AWriteThatFailsHalfWayLeavesTheOldFileWhole) {
  const fs::path path = dir_ / "big.bin";
  ASSERT_FALSE(WriteFile(path, "old contents"));
  rlimit old_limit{};
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &old_limit), 0);
  const auto old_handler = std::signal(SIGXFSZ, SIG_IGN);
  rlimit small = old_limit;
  small.rlim_cur = 4096;
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &small), 0);
  const auto error = WriteFile(path, std::string(100000, 'n'));
  ::setrlimit(RLIMIT_FSIZE, &old_limit);
  std::signal(SIGXFSZ, old_handler);
  ASSERT_TRUE(error);
  EXPECT_EQ(error->code, core::ErrorCode::kUnprocessable);
  EXPECT_NE(error->message.find(path.string()), std::string::npos) << error->message;
  EXPECT_EQ(ReadFile(path).value(), "old contents");
  EXPECT_EQ(Names(dir_), (std::vector<std::string>{"big.bin"}));
}

}  // namespace
}  // namespace softgrasp::cli
