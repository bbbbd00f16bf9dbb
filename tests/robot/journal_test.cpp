// The journal on its own: records survive reopening, a torn last line and corrupted lines are
// skipped with a warning (never a crash), a second opener is refused, random bytes never crash
// the reader, and compaction keeps what its caller keeps, also while records are appended and
// when the process is killed (SIGKILL) at random points.
#include "service/robot/journal.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <map>
#include <optional>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "tests/support/temp_dir.h"

namespace softgrasp::robot {
namespace {

namespace fs = std::filesystem;

class JournalTest : public ::testing::Test {
 protected:
  void SetUp() override {
    temp_.emplace(std::string("journal-test-") +
                  ::testing::UnitTest::GetInstance()->current_test_info()->name());
    dir_ = temp_->path();
  }
  void TearDown() override { temp_.reset(); }

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

  std::optional<softgrasp::testing::TempDir> temp_;
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
    ASSERT_TRUE(complete == 0 || complete == bytes.size() || bytes[complete - 1] == '\n');
    if (round % 2 == 1) {
      // A flipped byte damages at most the lines it lands in (a flip to '\n' splits one
      // line into two bad ones); everything that survives is an original payload.
      for (const std::string& p : got) {
        ASSERT_NE(std::find(payloads.begin(), payloads.end(), p), payloads.end()) << p;
      }
    }
  }
}

// ---- compaction ----

std::function<bool(std::string_view)> KeepAllBut(std::set<std::string> dropped) {
  return [dropped = std::move(dropped)](std::string_view payload) {
    return dropped.count(std::string(payload)) == 0;
  };
}

std::int64_t LineBytes(const std::vector<std::string>& payloads) {
  std::int64_t bytes = 0;
  for (const std::string& p : payloads) bytes += static_cast<std::int64_t>(p.size()) + 10;
  return bytes;
}

TEST_F(JournalTest, CompactionKeepsWhatTheCallerKeepsInOrderAndSurvivesReopening) {
  {
    Journal::Opened opened = Open();
    ASSERT_TRUE(opened.journal);
    for (const char* p : {"a", "drop-b", "c", "drop-d", "e"})
      ASSERT_TRUE(opened.journal->Append(p));
    const Journal::Position decided = opened.journal->End();
    EXPECT_EQ(decided.records, 5);
    EXPECT_EQ(decided.bytes, LineBytes({"a", "drop-b", "c", "drop-d", "e"}));
    // Appended after the decision: kept although `keep` would say no.
    ASSERT_TRUE(opened.journal->Append("drop-f"));
    std::vector<std::string> asked;
    auto compacted = opened.journal->Compact(decided, [&](std::string_view payload) {
      asked.emplace_back(payload);
      return payload.substr(0, 5) != "drop-";
    });
    ASSERT_TRUE(compacted) << compacted.error().message;
    EXPECT_EQ(asked, (std::vector<std::string>{"a", "drop-b", "c", "drop-d", "e"}));
    EXPECT_EQ(compacted.value().records_before, 6);
    EXPECT_EQ(compacted.value().records_after, 4);
    EXPECT_EQ(compacted.value().bytes_before,
              LineBytes({"a", "drop-b", "c", "drop-d", "e", "drop-f"}));
    EXPECT_EQ(compacted.value().bytes_after, LineBytes({"a", "c", "e", "drop-f"}));
    EXPECT_EQ(static_cast<std::int64_t>(fs::file_size(file())), compacted.value().bytes_after);
    const Journal::Position after = opened.journal->End();
    EXPECT_EQ(after.records, 4);
    EXPECT_EQ(after.compactions, 1);
    // Appends go on in the new file.
    ASSERT_TRUE(opened.journal->Append("g"));
  }
  EXPECT_FALSE(fs::exists(dir_ / kJournalTempFileName));
  EXPECT_EQ(fs::status(file()).permissions() & fs::perms::all,
            fs::perms::owner_read | fs::perms::owner_write);
  Journal::Opened again = Open();
  ASSERT_TRUE(again.journal);
  EXPECT_EQ(again.payloads, (std::vector<std::string>{"a", "c", "e", "drop-f", "g"}));
  EXPECT_TRUE(again.report.warnings.empty());
  EXPECT_FALSE(again.report.removed_temp_file);
}

TEST_F(JournalTest, CompactionDropsDamagedLinesAndRefusesAStalePosition) {
  {
    Journal::Opened opened = Open();
    ASSERT_TRUE(opened.journal->Append("alpha"));
  }
  std::string damaged = EncodeJournalLine("beta");
  damaged[10] = 'X';
  WriteFile(ReadFile() + damaged + "\n" + EncodeJournalLine("gamma") + "\n");
  Journal::Opened opened = Open();
  ASSERT_TRUE(opened.journal);
  EXPECT_EQ(opened.report.corrupt_lines, 1);
  const Journal::Position stale = opened.journal->End();
  EXPECT_EQ(stale.records, 3);  // damaged lines count: they take room until compacted away
  auto compacted = opened.journal->Compact(stale, KeepAllBut({}));
  ASSERT_TRUE(compacted) << compacted.error().message;
  EXPECT_EQ(compacted.value().records_before, 3);
  EXPECT_EQ(compacted.value().records_after, 2);
  EXPECT_EQ(ReadFile(), EncodeJournalLine("alpha") + "\n" + EncodeJournalLine("gamma") + "\n");
  // Offsets of the old file mean nothing in the new one.
  auto refused = opened.journal->Compact(stale, KeepAllBut({}));
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error().code, core::ErrorCode::kInvalidArgument);
  Journal::Position beyond = opened.journal->End();
  beyond.bytes += 1;
  EXPECT_FALSE(opened.journal->Compact(beyond, KeepAllBut({})));
  EXPECT_EQ(ReadFile(), EncodeJournalLine("alpha") + "\n" + EncodeJournalLine("gamma") + "\n");
}

TEST_F(JournalTest, ALeftoverTempFileIsRemovedAtOpenAndNeverRead) {
  {
    Journal::Opened opened = Open();
    ASSERT_TRUE(opened.journal->Append("kept"));
  }
  // A compaction cut short: its temporary file, half written (a good line and a torn one).
  {
    std::ofstream out(dir_ / kJournalTempFileName, std::ios::binary);
    out << EncodeJournalLine("from the temp file") << "\n"
        << EncodeJournalLine("torn").substr(0, 6);
  }
  Journal::Opened opened = Open();
  ASSERT_TRUE(opened.journal);
  EXPECT_EQ(opened.payloads, (std::vector<std::string>{"kept"}));
  EXPECT_TRUE(opened.report.removed_temp_file);
  ASSERT_EQ(opened.report.warnings.size(), 1u);
  EXPECT_NE(opened.report.warnings[0].find(kJournalTempFileName), std::string::npos);
  EXPECT_FALSE(fs::exists(dir_ / kJournalTempFileName));
  ASSERT_TRUE(opened.journal->Append("next"));
  opened.journal.reset();
  EXPECT_EQ(Open().payloads, (std::vector<std::string>{"kept", "next"}));
}

TEST_F(JournalTest, ASecondOpenerIsRefusedAfterCompactionToo) {
  Journal::Opened first = Open();
  ASSERT_TRUE(first.journal);
  ASSERT_TRUE(first.journal->Append("old"));
  ASSERT_TRUE(first.journal->Append("new"));
  ASSERT_TRUE(first.journal->Compact(first.journal->End(), KeepAllBut({"old"})));
  EXPECT_EQ(fs::status(dir_ / kJournalLockFileName).permissions() & fs::perms::all,
            fs::perms::owner_read | fs::perms::owner_write);

  auto second = Journal::Open(dir_.string());
  ASSERT_FALSE(second);
  EXPECT_EQ(second.error().code, core::ErrorCode::kConflict);
  EXPECT_EQ(second.error().field, "journal_dir");
  // A server that locks the journal file itself (as before the lock file) is refused as well:
  // the new file is locked too.
  const int fd = ::open(file().c_str(), O_RDWR | O_CLOEXEC);
  ASSERT_GE(fd, 0);
  EXPECT_NE(::flock(fd, LOCK_EX | LOCK_NB), 0);
  EXPECT_EQ(errno, EWOULDBLOCK);
  ::close(fd);

  first.journal.reset();
  auto third = Journal::Open(dir_.string());
  ASSERT_TRUE(third) << third.error().message;
  EXPECT_EQ(third.value().payloads, (std::vector<std::string>{"new"}));
}

// Compactions running while another thread appends: every appended record ends up in the
// journal exactly once and in order, and only the dropped ones are gone.
TEST_F(JournalTest, AppendsDuringCompactionsAreNeitherLostNorDuplicated) {
  Journal::Opened opened = Open();
  ASSERT_TRUE(opened.journal);
  for (int i = 0; i < 50; ++i) ASSERT_TRUE(opened.journal->Append("old-" + std::to_string(i)));
  constexpr int kAppends = 150;
  std::atomic<bool> appending{true};
  std::atomic<int> append_errors{0};
  std::atomic<int> compactions{0};
  std::thread appender([&] {
    for (int i = 0; i < kAppends; ++i) {
      // Half-way, wait for a finished compaction, so appends meet more than one compaction
      // however the threads are scheduled.
      if (i == kAppends / 2) {
        while (compactions.load() == 0) std::this_thread::yield();
      }
      if (!opened.journal->Append("new-" + std::to_string(i))) ++append_errors;
    }
    // And one more compaction after the last append (the loop below runs until this is false).
    const int seen = compactions.load();
    while (compactions.load() < std::max(seen + 1, 2)) std::this_thread::yield();
    appending = false;
  });
  const auto keep = [](std::string_view payload) { return payload.substr(0, 4) != "old-"; };
  do {
    auto compacted = opened.journal->Compact(opened.journal->End(), keep);
    ASSERT_TRUE(compacted) << compacted.error().message;
    ++compactions;
  } while (appending);
  appender.join();
  EXPECT_EQ(append_errors, 0);
  EXPECT_GE(compactions, 2);
  opened.journal.reset();
  std::vector<std::string> expected;
  for (int i = 0; i < kAppends; ++i) expected.push_back("new-" + std::to_string(i));
  Journal::Opened again = Open();
  EXPECT_EQ(again.payloads, expected);
  EXPECT_EQ(again.report.corrupt_lines, 0);
}

// ---- kill -9 during appends and compactions ----
//
// A child process opens a prepared journal and loops: append a new unfinished command, append the
// result of the oldest unfinished one, compact away the finished commands outside a retention
// window (the newest kRetainedResults results are kept). It reports each step on a pipe: "I
// <payload>" before an append and "A" after it, "S <threshold>" before a compaction and "C
// <threshold>" after it (finished commands with a result sequence number <= threshold go). The
// parent kills it with SIGKILL after a seeded random delay, reopens the journal and checks it
// against what was acknowledged, then starts the next child on the same journal.

constexpr int kRetainedResults = 60;
const std::string kPadding(150, 'x');  // records of a realistic size

std::string AcceptedPayload(const std::string& id) { return "accepted " + id + " " + kPadding; }
std::string ResultPayload(const std::string& id, std::int64_t seq) {
  return "result " + id + " " + std::to_string(seq) + " " + kPadding;
}

struct CrashRecord {
  bool accepted = false;
  std::string id;
  std::int64_t seq = -1;
};

std::optional<CrashRecord> ParseCrashPayload(const std::string& payload) {
  std::istringstream in(payload);
  std::string type;
  CrashRecord r;
  std::string padding;
  in >> type >> r.id;
  if (type == "accepted") {
    r.accepted = true;
  } else if (type == "result") {
    if (!(in >> r.seq)) return std::nullopt;
  } else {
    return std::nullopt;
  }
  if (!(in >> padding) || padding != kPadding || r.id.empty()) return std::nullopt;
  return r;
}

// What a journal says: each command id, with its result's sequence number once it has one.
struct CrashModel {
  std::map<std::string, std::optional<std::int64_t>> commands;
  std::deque<std::string> unfinished;  // in order of acceptance, without the permanent "u" ones
  std::int64_t next_seq = 0;

  void Accept(const std::string& id) {
    commands[id] = std::nullopt;
    if (id[0] != 'u') unfinished.push_back(id);
  }
  void Finish(const std::string& id, std::int64_t seq) {
    commands[id] = seq;
    unfinished.erase(std::remove(unfinished.begin(), unfinished.end(), id), unfinished.end());
    next_seq = std::max(next_seq, seq + 1);
  }
};

// The model of a journal's payloads, or a description of what is wrong with them: an unknown
// record, a duplicate, a result without its command.
std::string ModelOf(const std::vector<std::string>& payloads, CrashModel* model) {
  std::set<std::string> accepted;
  std::set<std::string> finished;
  for (const std::string& payload : payloads) {
    const auto r = ParseCrashPayload(payload);
    if (!r) return "unknown record: " + payload.substr(0, 60);
    if (r->accepted) {
      if (!accepted.insert(r->id).second) return "accepted twice: " + r->id;
      model->Accept(r->id);
    } else {
      if (accepted.count(r->id) == 0) return "result without its command: " + r->id;
      if (!finished.insert(r->id).second) return "two results: " + r->id;
      model->Finish(r->id, r->seq);
    }
  }
  return {};
}

void Report(int fd, const std::string& message) {
  const std::string line = message + "\n";
  if (::write(fd, line.data(), line.size()) != static_cast<ssize_t>(line.size())) ::_exit(9);
}

// The child's loop; never returns.
[[noreturn]] void RunCrashChild(const std::string& dir, int round, int report_fd) {
  try {
    auto opened = Journal::Open(dir);
    if (!opened) ::_exit(3);
    CrashModel model;
    if (!ModelOf(opened.value().payloads, &model).empty()) ::_exit(4);
    Journal& journal = *opened.value().journal;
    for (int k = 0; k < 100000; ++k) {
      const std::string id = "c" + std::to_string(round) + "-" + std::to_string(k);
      Report(report_fd, "I " + AcceptedPayload(id));
      if (!journal.Append(AcceptedPayload(id))) ::_exit(5);
      model.Accept(id);
      Report(report_fd, "A");

      const std::string oldest = model.unfinished.front();
      const std::int64_t seq = model.next_seq;
      Report(report_fd, "I " + ResultPayload(oldest, seq));
      if (!journal.Append(ResultPayload(oldest, seq))) ::_exit(5);
      model.Finish(oldest, seq);
      Report(report_fd, "A");

      const std::int64_t threshold = model.next_seq - 1 - kRetainedResults;
      std::set<std::string> forget;
      for (const auto& [command, result_seq] : model.commands) {
        if (result_seq && *result_seq <= threshold) forget.insert(command);
      }
      Report(report_fd, "S " + std::to_string(threshold));
      auto compacted = journal.Compact(journal.End(), [&forget](std::string_view payload) {
        const auto r = ParseCrashPayload(std::string(payload));
        return !r || forget.count(r->id) == 0;
      });
      if (!compacted) ::_exit(6);
      for (const std::string& command : forget) model.commands.erase(command);
      Report(report_fd, "C " + std::to_string(threshold));
    }
  } catch (...) {
    ::_exit(7);
  }
  ::_exit(8);  // never killed: the parent waits far less
}

struct ChildRun {
  std::vector<std::string> acknowledged;  // payloads whose append returned
  std::optional<std::string> in_flight;   // announced, not acknowledged
  std::optional<std::int64_t> started_threshold;
  std::optional<std::int64_t> completed_threshold;
  bool killed_in_compaction = false;
  int status = 0;
};

// Forks the child, kills it after `delay`, and collects what it reported.
// Kills the child after `delay`, or (until_compaction) as soon as it reports its first completed
// compaction, whichever comes first.
ChildRun RunAndKill(const std::string& dir, int round, std::chrono::microseconds delay,
                    bool until_compaction = false) {
  ChildRun run;
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) {
    ADD_FAILURE() << "pipe: " << std::strerror(errno);
    return run;
  }
  const auto start = std::chrono::steady_clock::now();
  const pid_t pid = ::fork();
  if (pid < 0) {
    ADD_FAILURE() << "fork: " << std::strerror(errno);
    return run;
  }
  if (pid == 0) {
    ::close(fds[0]);
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    RunCrashChild(dir, round, fds[1]);
  }
  ::close(fds[1]);
  std::string reported;
  char buffer[65536];
  const auto deadline = start + delay;
  // Read while waiting, so a full pipe never stalls the child.
  for (auto now = std::chrono::steady_clock::now(); now < deadline;
       now = std::chrono::steady_clock::now()) {
    const auto left = std::chrono::duration_cast<std::chrono::nanoseconds>(deadline - now);
    const timespec timeout{static_cast<time_t>(left.count() / 1'000'000'000),
                           static_cast<long>(left.count() % 1'000'000'000)};
    pollfd p{fds[0], POLLIN, 0};
    if (::ppoll(&p, 1, &timeout, nullptr) > 0) {
      const ssize_t n = ::read(fds[0], buffer, sizeof buffer);
      if (n > 0) reported.append(buffer, static_cast<std::size_t>(n));
      if (n == 0) break;  // the child is gone already
      if (until_compaction && reported.find("\nC ") != std::string::npos) break;
    }
  }
  ::kill(pid, SIGKILL);
  ::waitpid(pid, &run.status, 0);
  for (;;) {
    const ssize_t n = ::read(fds[0], buffer, sizeof buffer);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    reported.append(buffer, static_cast<std::size_t>(n));
  }
  ::close(fds[0]);

  std::istringstream lines(reported);
  std::string line;
  char last = ' ';
  while (std::getline(lines, line)) {
    if (lines.eof()) break;  // no newline: cut short (pipe writes this small are atomic)
    if (line.rfind("I ", 0) == 0) {
      run.in_flight = line.substr(2);
    } else if (line == "A" && run.in_flight) {
      run.acknowledged.push_back(*run.in_flight);
      run.in_flight.reset();
    } else if (line.rfind("S ", 0) == 0) {
      run.started_threshold = std::stoll(line.substr(2));
    } else if (line.rfind("C ", 0) == 0) {
      run.completed_threshold = std::stoll(line.substr(2));
    } else {
      ADD_FAILURE() << "unexpected report line: " << line;
    }
    last = line[0];
  }
  run.killed_in_compaction = last == 'S';
  return run;
}

TEST_F(JournalTest, KillNineAtRandomPointsLosesNothingAcknowledged) {
  // The prepared journal: 30 commands that never finish, 20 unfinished ones the children finish
  // one by one, and 100 finished ones (result sequence numbers 0..99).
  {
    Journal::Opened opened = Open();
    ASSERT_TRUE(opened.journal);
    for (int i = 0; i < 30; ++i)
      ASSERT_TRUE(opened.journal->Append(AcceptedPayload("u" + std::to_string(i))));
    for (int i = 0; i < 20; ++i)
      ASSERT_TRUE(opened.journal->Append(AcceptedPayload("p" + std::to_string(i))));
    for (int i = 0; i < 100; ++i) {
      ASSERT_TRUE(opened.journal->Append(AcceptedPayload("f" + std::to_string(i))));
      ASSERT_TRUE(opened.journal->Append(ResultPayload("f" + std::to_string(i), i)));
    }
  }
  CrashModel before;
  {
    Journal::Opened opened = Open();
    ASSERT_EQ(ModelOf(opened.payloads, &before), "");
  }

  constexpr int kKills = 40;
  std::mt19937 rng(4242);
  // Round 0 runs until its first compaction is done: three times how long that took here (a
  // sanitizer build or a slow disk is several times slower), at least 60 ms, is the window the
  // other rounds' kill points are drawn from, so they land before, in and after compactions.
  std::int64_t window_us = 60000;
  int killed_in_compaction = 0;
  int temp_files_found = 0;
  int compactions_completed = 0;
  std::int64_t acknowledged_records = 0;
  const auto test_start = std::chrono::steady_clock::now();
  for (int round = 0; round < kKills; ++round) {
    const bool calibrate = round == 0;
    const auto delay = std::chrono::microseconds(
        calibrate ? 20'000'000 : std::uniform_int_distribution<std::int64_t>(0, window_us)(rng));
    SCOPED_TRACE("round " + std::to_string(round) + ", killed after " +
                 std::to_string(delay.count()) + " us");
    const auto round_start = std::chrono::steady_clock::now();
    const ChildRun run = RunAndKill(dir_.string(), round, delay, calibrate);
    ASSERT_TRUE(WIFSIGNALED(run.status) && WTERMSIG(run.status) == SIGKILL)
        << "the child ended on its own, status " << run.status;
    if (calibrate) {
      ASSERT_TRUE(run.completed_threshold) << "no compaction completed within 20 s";
      const auto took = std::chrono::duration_cast<std::chrono::microseconds>(
          std::chrono::steady_clock::now() - round_start);
      window_us = std::max<std::int64_t>(window_us, 3 * took.count());
    }
    killed_in_compaction += run.killed_in_compaction ? 1 : 0;
    compactions_completed += run.completed_threshold ? 1 : 0;
    acknowledged_records += static_cast<std::int64_t>(run.acknowledged.size());

    // What must be there: the journal before, plus every acknowledged record.
    CrashModel expected = before;
    for (const std::string& payload : run.acknowledged) {
      const auto r = ParseCrashPayload(payload);
      ASSERT_TRUE(r);
      if (r->accepted) {
        expected.Accept(r->id);
      } else {
        expected.Finish(r->id, r->seq);
      }
    }
    std::optional<CrashRecord> in_flight;
    if (run.in_flight) in_flight = ParseCrashPayload(*run.in_flight);

    Journal::Opened opened = Open();
    ASSERT_TRUE(opened.journal);
    EXPECT_EQ(opened.report.corrupt_lines, 0);
    // A record cut short can only be the one being written when the child died.
    if (opened.report.torn_tail) {
      EXPECT_TRUE(in_flight.has_value());
    }
    temp_files_found += opened.report.removed_temp_file ? 1 : 0;
    EXPECT_FALSE(fs::exists(dir_ / kJournalTempFileName));
    CrashModel found;
    ASSERT_EQ(ModelOf(opened.payloads, &found), "");  // no duplicates, no orphans, no garbage

    for (const auto& [id, seq] : expected.commands) {
      SCOPED_TRACE("command " + id);
      const auto it = found.commands.find(id);
      if (!seq) {
        // Unfinished: always there, with a result only if that was being written.
        ASSERT_NE(it, found.commands.end()) << "an unfinished command was lost";
        if (it->second) {
          ASSERT_TRUE(in_flight && !in_flight->accepted && in_flight->id == id);
          EXPECT_EQ(*it->second, in_flight->seq);
        }
      } else if (run.completed_threshold && *seq <= *run.completed_threshold) {
        EXPECT_EQ(it, found.commands.end()) << "a finished command outlived its compaction";
      } else if (!run.started_threshold || *seq > *run.started_threshold) {
        // Finished within the retention of every compaction: there, with its result.
        ASSERT_NE(it, found.commands.end()) << "a retained finished command was lost";
        EXPECT_EQ(it->second, seq);
      } else if (it != found.commands.end()) {
        // The compaction in progress may or may not have dropped it, but never half of it.
        EXPECT_EQ(it->second, seq);
      }
    }
    for (const auto& [id, seq] : found.commands) {
      if (expected.commands.count(id) == 0) {
        EXPECT_TRUE(in_flight && in_flight->accepted && in_flight->id == id)
            << "a command nobody wrote: " << id;
      }
    }
    before = found;
  }
  const double elapsed_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - test_start).count();
  std::cout << kKills << " kills in " << elapsed_s << " s (window " << window_us / 1000
            << " ms): " << killed_in_compaction << " during a compaction, " << temp_files_found
            << " left a temporary file, " << compactions_completed
            << " runs completed a compaction, " << acknowledged_records
            << " records acknowledged\n";
  // The kills did land inside compactions (each takes most of a loop: it writes and fsyncs a
  // file), and the children did make progress.
  EXPECT_GE(killed_in_compaction, 1);
  EXPECT_GE(compactions_completed, 1);
  EXPECT_GE(acknowledged_records, kKills);
}

}  // namespace
}  // namespace softgrasp::robot
