// The journal on its own: records survive reopening, a torn last line and corrupted lines are
// skipped with a warning (never a crash), a second opener is refused, and random bytes never
// crash the reader.
#include "service/robot/journal.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>

namespace softgrasp::robot {
namespace {

namespace fs = std::filesystem;

class JournalTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("softgrasp-journal-test-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path file() const { return dir_ / kJournalFileName; }
  std::string ReadFile() const {
    std::ifstream in(file(), std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  }
  void WriteFile(const std::string& bytes) const {
    std::ofstream out(file(), std::ios::binary | std::ios::trunc);
    out << bytes;
  }
  Journal::Opened Open() const {
    auto opened = Journal::Open(dir_.string());
    if (!opened) ADD_FAILURE() << opened.error().message;
    return opened ? std::move(opened).value() : Journal::Opened{};
  }

  fs::path dir_;
};

TEST(JournalLineTest, Crc32MatchesTheStandardCheckValue) {
  // The CRC-32 check value of "123456789" (IEEE 802.3 / zlib).
  EXPECT_EQ(Crc32("123456789"), 0xCBF43926U);
  EXPECT_EQ(Crc32(""), 0U);
}

TEST(JournalLineTest, EncodeDecodeRoundTripAndDetectsDamage) {
  const std::string line = EncodeJournalLine(R"({"type":"accepted","id":"a"})");
  EXPECT_EQ(line.substr(8, 1), " ");
  auto payload = DecodeJournalLine(line);
  ASSERT_TRUE(payload) << payload.error().message;
  EXPECT_EQ(payload.value(), R"({"type":"accepted","id":"a"})");

  std::string flipped = line;
  flipped[20] ^= 0x01;  // one bit in the payload
  EXPECT_FALSE(DecodeJournalLine(flipped));
  EXPECT_FALSE(DecodeJournalLine(line.substr(0, line.size() - 1)));  // cut short
  EXPECT_FALSE(DecodeJournalLine("zzzzzzzz {}"));
  EXPECT_FALSE(DecodeJournalLine("1234"));
  EXPECT_FALSE(DecodeJournalLine(""));
}

TEST_F(JournalTest, RecordsSurviveReopening) {
  {
    Journal::Opened opened = Open();
    ASSERT_TRUE(opened.journal);
    EXPECT_TRUE(opened.payloads.empty());
    ASSERT_TRUE(opened.journal->Append("first"));
    ASSERT_TRUE(opened.journal->Append(R"({"x":1})"));
    ASSERT_TRUE(opened.journal->Append(""));
  }
  Journal::Opened again = Open();
  ASSERT_TRUE(again.journal);
  EXPECT_EQ(again.payloads, (std::vector<std::string>{"first", R"({"x":1})", ""}));
  EXPECT_EQ(again.report.good_records, 3);
  EXPECT_EQ(again.report.corrupt_lines, 0);
  EXPECT_FALSE(again.report.torn_tail);
  EXPECT_TRUE(again.report.warnings.empty());
  // Only the owner may read it: it holds every command sent.
  EXPECT_EQ(fs::status(file()).permissions() & fs::perms::all,
            fs::perms::owner_read | fs::perms::owner_write);
}

TEST_F(JournalTest, TornLastLineIsSkippedAndCutOffSoTheNextRecordIsClean) {
  {
    Journal::Opened opened = Open();
    ASSERT_TRUE(opened.journal->Append("one"));
    ASSERT_TRUE(opened.journal->Append("two"));
  }
  const std::string good = ReadFile();
  // A crash in the middle of writing the third record.
  const std::string third = EncodeJournalLine("three, never finished");
  WriteFile(good + third.substr(0, 15));
  {
    Journal::Opened opened = Open();
    ASSERT_TRUE(opened.journal);
    EXPECT_EQ(opened.payloads, (std::vector<std::string>{"one", "two"}));
    EXPECT_TRUE(opened.report.torn_tail);
    EXPECT_EQ(opened.report.torn_tail_bytes, 15);
    ASSERT_EQ(opened.report.warnings.size(), 1u);
    EXPECT_NE(opened.report.warnings[0].find("line 3"), std::string::npos);
    EXPECT_EQ(ReadFile(), good);  // cut back to the last complete line
    ASSERT_TRUE(opened.journal->Append("four"));
  }
  Journal::Opened last = Open();
  EXPECT_EQ(last.payloads, (std::vector<std::string>{"one", "two", "four"}));
  EXPECT_FALSE(last.report.torn_tail);
}

TEST_F(JournalTest, CorruptLinesInTheMiddleAreSkippedWithTheirLineNumbers) {
  {
    Journal::Opened opened = Open();
    ASSERT_TRUE(opened.journal->Append("alpha"));
  }
  std::string bytes = ReadFile();
  std::string damaged = EncodeJournalLine("beta");
  damaged[10] = 'X';  // payload changed, checksum kept
  bytes += damaged + "\n" + "garbage without a checksum\n" + EncodeJournalLine("gamma") + "\n";
  WriteFile(bytes);
  Journal::Opened opened = Open();
  ASSERT_TRUE(opened.journal);
  EXPECT_EQ(opened.payloads, (std::vector<std::string>{"alpha", "gamma"}));
  EXPECT_EQ(opened.report.corrupt_lines, 2);
  ASSERT_EQ(opened.report.warnings.size(), 2u);
  EXPECT_NE(opened.report.warnings[0].find("line 2: checksum mismatch"), std::string::npos);
  EXPECT_NE(opened.report.warnings[1].find("line 3"), std::string::npos);
}

TEST_F(JournalTest, ASecondOpenerIsRefusedUntilTheFirstCloses) {
  Journal::Opened first = Open();
  ASSERT_TRUE(first.journal);
  auto second = Journal::Open(dir_.string());
  ASSERT_FALSE(second);
  EXPECT_EQ(second.error().code, core::ErrorCode::kConflict);
  EXPECT_EQ(second.error().field, "journal_dir");
  first.journal.reset();
  EXPECT_TRUE(Journal::Open(dir_.string()));
}

TEST_F(JournalTest, BadFoldersAreClearErrors) {
  auto empty = Journal::Open("");
  ASSERT_FALSE(empty);
  EXPECT_EQ(empty.error().code, core::ErrorCode::kInvalidArgument);
  // A folder path that runs through a regular file cannot be created.
  fs::create_directories(dir_);
  std::ofstream(dir_ / "plain-file") << "x";
  auto blocked = Journal::Open((dir_ / "plain-file" / "journal").string());
  ASSERT_FALSE(blocked);
  EXPECT_EQ(blocked.error().code, core::ErrorCode::kInternal);
  EXPECT_NE(blocked.error().message.find("plain-file"), std::string::npos);
}

TEST_F(JournalTest, PayloadWithNewlineIsAProgrammingError) {
  Journal::Opened opened = Open();
  EXPECT_THROW((void)opened.journal->Append("two\nlines"), std::invalid_argument);
}

// Random bytes, random damage to a valid journal: ParseJournal never crashes, every payload it
// returns has a matching checksum, and good lines before the damage are kept.
TEST(JournalFuzzTest, ParserSurvivesRandomAndDamagedInput) {
  std::mt19937 rng(20240605);
  std::string valid;
  std::vector<std::string> payloads;
  for (int i = 0; i < 50; ++i) {
    payloads.push_back(R"({"type":"accepted","id":"cmd-)" + std::to_string(i) + R"("})");
    valid += EncodeJournalLine(payloads.back()) + "\n";
  }
  for (int round = 0; round < 2000; ++round) {
    std::string bytes;
    if (round % 2 == 0) {
      bytes.resize(rng() % 512);
      for (char& c : bytes) c = static_cast<char>(rng() % 4 == 0 ? '\n' : rng() % 256);
    } else {
      bytes = valid;
      const std::size_t flips = 1 + rng() % 4;
      for (std::size_t k = 0; k < flips; ++k)
        bytes[rng() % bytes.size()] ^= static_cast<char>(1 + rng() % 255);
      if (rng() % 2) bytes.resize(rng() % bytes.size());
    }
    JournalReport report;
    std::size_t complete = 0;
    const std::vector<std::string> got = ParseJournal(bytes, &report, &complete);
    ASSERT_LE(complete, bytes.size());
    ASSERT_EQ(static_cast<std::int64_t>(got.size()), report.good_records);
    ASSERT_TRUE(complete == bytes.size() || bytes[complete - 1] == '\n' || complete == 0);
    if (round % 2 == 1) {
      // A flipped byte damages at most the lines it lands in (a flip to '\n' splits one
      // line into two bad ones); everything that survives is an original payload.
      for (const std::string& p : got) {
        ASSERT_NE(std::find(payloads.begin(), payloads.end(), p), payloads.end()) << p;
      }
    }
  }
}

}  // namespace
}  // namespace softgrasp::robot
