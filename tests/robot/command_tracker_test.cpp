// CommandTracker with a real ServiceBridge and a real RobotEndpoint in this process (loopback DDS,
// this binary's own domain): forward -> executing -> result, idempotency counted on the bus,
// robot choice, timeouts, restarts over the journal (including a result written while the
// service was down), and the retention of finished commands when the journal is compacted.
#include "service/robot/command_tracker.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "service/robot/journal.h"
#include "tests/robot/robot_test_util.h"

namespace softgrasp::robot {
namespace {

using bridge::GraspCommand;
using bridge::RobotState;
using bridge::testing::MakeCommand;
using testing::MakeRobot;
using testing::MakeServiceBridge;
using testing::PoseCounter;
using testing::SqueezeResult;
using testing::TempDir;
using testing::WaitUntil;

struct Logged {
  std::vector<std::string> lines;
  std::mutex mutex;
};

std::unique_ptr<CommandTracker> MakeTracker(const std::string& dir, double timeout_s = 20.0,
                                            Logged* logged = nullptr) {
  TrackerOptions options;
  options.journal_dir = dir;
  options.command_timeout_s = timeout_s;
  options.republish_period_s = 0.2;
  if (logged != nullptr) {
    options.log = [logged](const std::string& line) {
      std::lock_guard<std::mutex> lock(logged->mutex);
      logged->lines.push_back(line);
    };
  }
  auto tracker = CommandTracker::Create(options, MakeServiceBridge());
  if (!tracker) ADD_FAILURE() << tracker.error().message;
  return tracker ? std::move(tracker).value() : nullptr;
}

bool RobotAlive(const CommandTracker& tracker, const std::string& id) {
  for (const auto& r : tracker.Robots()) {
    if (r.status.robot_id == id && r.alive) return true;
  }
  return false;
}

CommandState StateOf(const CommandTracker& tracker, const std::string& id) {
  auto record = tracker.Get(id);
  return record ? record->state : CommandState::kQueued;
}

// Commands from the service carry no robot id; the tracker fills it in.
GraspCommand Command(const std::string& id) {
  GraspCommand c = MakeCommand(id);
  c.issued_unix_ns = 0;
  return c;
}

TEST(CommandTrackerTest, ForwardExecuteAndResultWithTheRobotsNumbers) {
  TempDir dir("tracker-forward");
  auto tracker = MakeTracker(dir.str());
  auto robot = MakeRobot("arm-1");
  ASSERT_TRUE(tracker && robot);
  ASSERT_GE(WaitUntil([&] { return RobotAlive(*tracker, "arm-1"); }, 10.0), 0.0);

  auto submitted = tracker->Submit(Command("grasp-1"), "fp-1");
  ASSERT_TRUE(submitted) << submitted.error().message;
  EXPECT_TRUE(submitted.value().created);
  EXPECT_EQ(submitted.value().record.command.robot_id, "arm-1");  // the only robot alive
  EXPECT_EQ(submitted.value().record.state, CommandState::kSent);
  EXPECT_GT(submitted.value().record.accepted_unix_ns, 0);

  auto received = robot->WaitForCommand(10.0);
  ASSERT_TRUE(received && received.value()) << "the robot got no command";
  const GraspCommand& c = *received.value();
  EXPECT_EQ(c.command_id, "grasp-1");
  EXPECT_EQ(c.position_m, MakeCommand("x").position_m);

  ASSERT_TRUE(robot->Heartbeat(RobotState::kExecuting, c.command_id));
  EXPECT_GE(
      WaitUntil([&] { return StateOf(*tracker, "grasp-1") == CommandState::kExecuting; }, 5.0),
      0.0);
  const bridge::GraspResult sent = SqueezeResult(c);
  ASSERT_TRUE(robot->PublishResult(sent));
  ASSERT_TRUE(robot->Heartbeat(RobotState::kIdle));
  ASSERT_GE(
      WaitUntil([&] { return StateOf(*tracker, "grasp-1") == CommandState::kSucceeded; }, 10.0),
      0.0);
  const CommandRecord record = *tracker->Get("grasp-1");
  ASSERT_TRUE(record.result.has_value());
  EXPECT_EQ(record.result->robot_id, "arm-1");
  EXPECT_DOUBLE_EQ(record.result->contact_width_m, 0.06);
  EXPECT_DOUBLE_EQ(record.result->grasped_width_m, 0.048);
  EXPECT_NEAR(record.result->deformation_rate, 0.2, 1e-12);
  EXPECT_DOUBLE_EQ(record.result->execution_s, 1.25);
  EXPECT_FALSE(record.result_late);
  EXPECT_GE(record.result_received_unix_ns, record.accepted_unix_ns);
  EXPECT_FALSE(tracker->Get("never-sent").has_value());
}

TEST(CommandTrackerTest, SameIdTwiceGoesOnTheBusOnceAndAnotherBodyConflicts) {
  TempDir dir("tracker-idempotent");
  auto tracker = MakeTracker(dir.str());
  auto robot = MakeRobot("arm-1");
  ASSERT_TRUE(tracker && robot);
  PoseCounter poses;
  ASSERT_GE(WaitUntil([&] { return RobotAlive(*tracker, "arm-1") && poses.matched() > 0; }, 10.0),
            0.0);

  auto first = tracker->Submit(Command("same"), "fp-a");
  ASSERT_TRUE(first) << first.error().message;
  EXPECT_TRUE(first.value().created);
  auto again = tracker->Submit(Command("same"), "fp-a");
  ASSERT_TRUE(again) << again.error().message;
  EXPECT_FALSE(again.value().created);
  EXPECT_EQ(again.value().record.accepted_unix_ns, first.value().record.accepted_unix_ns);
  auto other = tracker->Submit(Command("same"), "fp-b");
  ASSERT_FALSE(other);
  EXPECT_EQ(other.error().code, core::ErrorCode::kConflict);
  EXPECT_EQ(other.error().field, "id");

  // A later command as a marker: once its pose is here, so is any second write of "same".
  GraspCommand marker = Command("marker");
  marker.position_m = {0.03, 0.02, 0.7};
  ASSERT_TRUE(tracker->Submit(marker, "fp-m"));
  ASSERT_GE(WaitUntil([&] { return poses.Seen(marker.position_m); }, 5.0), 0.0);
  EXPECT_EQ(poses.count(), 2);  // "same" once, then the marker
  std::set<std::string> received;
  for (int i = 0; i < 2; ++i) {
    auto command = robot->WaitForCommand(5.0);
    ASSERT_TRUE(command && command.value());
    received.insert(command.value()->command_id);
  }
  EXPECT_EQ(received, (std::set<std::string>{"marker", "same"}));
}

TEST(CommandTrackerTest, RobotChoiceNoneSeveralAndNamed) {
  TempDir dir("tracker-choice");
  auto tracker = MakeTracker(dir.str());
  ASSERT_TRUE(tracker);
  PoseCounter poses;

  auto none = tracker->Submit(Command("c1"), "fp");
  ASSERT_FALSE(none);
  EXPECT_EQ(none.error().code, core::ErrorCode::kUnavailable);
  EXPECT_FALSE(tracker->Get("c1").has_value());  // not accepted: the id stays free

  auto left = MakeRobot("arm-left");
  auto right = MakeRobot("arm-right");
  ASSERT_TRUE(left && right);
  ASSERT_GE(
      WaitUntil([&] { return tracker->bridge().AliveRobots().size() == 2 && poses.matched() > 0; },
                10.0),
      0.0);
  auto several = tracker->Submit(Command("c1"), "fp");
  ASSERT_FALSE(several);
  EXPECT_EQ(several.error().code, core::ErrorCode::kUnprocessable);
  EXPECT_EQ(several.error().field, "robot_id");
  EXPECT_NE(several.error().message.find("arm-left, arm-right"), std::string::npos);

  GraspCommand named = Command("c1");
  named.robot_id = "arm-ghost";
  auto ghost = tracker->Submit(named, "fp");
  ASSERT_FALSE(ghost);
  EXPECT_EQ(ghost.error().code, core::ErrorCode::kUnavailable);

  named.robot_id = "arm-right";
  named.position_m = {0.03, 0.02, 0.7};  // its pose tells it from the refused ones
  auto ok = tracker->Submit(named, "fp");
  ASSERT_TRUE(ok) << ok.error().message;
  auto at_right = right->WaitForCommand(10.0);
  ASSERT_TRUE(at_right && at_right.value());
  EXPECT_EQ(at_right.value()->command_id, "c1");
  // Nothing was written for the three refused submissions: poses come in order, so once the
  // accepted one's pose is here, any written before it is too.
  ASSERT_GE(WaitUntil([&] { return poses.Seen(named.position_m); }, 5.0), 0.0);
  EXPECT_EQ(poses.count(), 1);
  // c1 never reached the left arm: a command sent to it after c1 is the first it executes.
  GraspCommand for_left = Command("c2");
  for_left.robot_id = "arm-left";
  ASSERT_TRUE(tracker->Submit(for_left, "fp"));
  auto at_left = left->WaitForCommand(10.0);
  ASSERT_TRUE(at_left && at_left.value());
  EXPECT_EQ(at_left.value()->command_id, "c2");
}

TEST(CommandTrackerTest, NoResultInTimeBecomesTimedOutAndIsWithdrawnFromTheBus) {
  TempDir dir("tracker-timeout");
  auto tracker = MakeTracker(dir.str(), /*timeout_s=*/0.8);
  ASSERT_TRUE(tracker);
  {
    auto silent = MakeRobot("arm-1");  // alive, but never takes the command
    ASSERT_GE(WaitUntil([&] { return RobotAlive(*tracker, "arm-1"); }, 10.0), 0.0);
    ASSERT_TRUE(tracker->Submit(Command("slow"), "fp"));
    const double waited =
        WaitUntil([&] { return StateOf(*tracker, "slow") == CommandState::kTimedOut; }, 5.0);
    ASSERT_GE(waited, 0.0);
    EXPECT_GE(waited, 0.5);  // not before the deadline
    const CommandRecord record = *tracker->Get("slow");
    EXPECT_NE(record.detail.find("no result within 0.8 s"), std::string::npos);
    EXPECT_GT(record.timed_out_unix_ns, record.accepted_unix_ns);
    EXPECT_FALSE(record.result.has_value());
  }
  // A robot (re)joining now is not offered the withdrawn command.
  auto fresh = MakeRobot("arm-1");
  ASSERT_TRUE(fresh);
  ASSERT_GE(WaitUntil([&] { return RobotAlive(*tracker, "arm-1"); }, 10.0), 0.0);
  EXPECT_FALSE(fresh->WaitForCommand(1.0).value().has_value());
}

TEST(CommandTrackerTest, RestartKeepsResultsAndResendsPendingCommands) {
  TempDir dir("tracker-restart");
  {
    auto tracker = MakeTracker(dir.str());
    auto robot = MakeRobot("arm-1");
    ASSERT_TRUE(tracker && robot);
    ASSERT_GE(WaitUntil([&] { return RobotAlive(*tracker, "arm-1"); }, 10.0), 0.0);
    ASSERT_TRUE(tracker->Submit(Command("done"), "fp-done"));
    auto c = robot->WaitForCommand(10.0);
    ASSERT_TRUE(c && c.value());
    ASSERT_TRUE(robot->PublishResult(SqueezeResult(*c.value())));
    ASSERT_GE(
        WaitUntil([&] { return StateOf(*tracker, "done") == CommandState::kSucceeded; }, 10.0),
        0.0);
    // Accepted while the robot was there; the robot goes away before taking it.
    ASSERT_TRUE(tracker->Submit(Command("pending"), "fp-pending"));
    robot.reset();
  }  // the service "crashes": bridge and tracker gone, only the journal stays

  auto tracker = MakeTracker(dir.str());
  ASSERT_TRUE(tracker);
  EXPECT_EQ(tracker->stats().replayed_commands, 2);
  EXPECT_EQ(tracker->stats().republished, 1);
  const auto done = tracker->Get("done");
  ASSERT_TRUE(done && done->result);
  EXPECT_EQ(done->state, CommandState::kSucceeded);
  EXPECT_DOUBLE_EQ(done->result->grasped_width_m, 0.048);
  EXPECT_EQ(done->fingerprint, "fp-done");
  // Idempotency survives the restart too.
  auto replay = tracker->Submit(Command("done"), "fp-done");
  ASSERT_TRUE(replay);
  EXPECT_FALSE(replay.value().created);
  EXPECT_EQ(tracker->Submit(Command("done"), "other").error().code, core::ErrorCode::kConflict);

  // A robot starting now gets the pending command from the restarted service alone.
  auto robot = MakeRobot("arm-1");
  ASSERT_TRUE(robot);
  auto c = robot->WaitForCommand(10.0);
  ASSERT_TRUE(c && c.value()) << "the pending command was not re-sent";
  EXPECT_EQ(c.value()->command_id, "pending");
  ASSERT_TRUE(robot->PublishResult(SqueezeResult(*c.value())));
  EXPECT_GE(
      WaitUntil([&] { return StateOf(*tracker, "pending") == CommandState::kSucceeded; }, 10.0),
      0.0);
}

TEST(CommandTrackerTest, ResultWrittenWhileTheServiceWasDownArrivesAfterRestart) {
  TempDir dir("tracker-down");
  auto robot = MakeRobot("arm-1");
  ASSERT_TRUE(robot);
  std::optional<GraspCommand> running;
  {
    auto tracker = MakeTracker(dir.str());
    ASSERT_TRUE(tracker);
    ASSERT_GE(WaitUntil([&] { return RobotAlive(*tracker, "arm-1"); }, 10.0), 0.0);
    ASSERT_TRUE(tracker->Submit(Command("mid"), "fp"));
    auto c = robot->WaitForCommand(10.0);
    ASSERT_TRUE(c && c.value());
    running = *c.value();
  }  // the service dies while the robot executes
  ASSERT_TRUE(robot->PublishResult(SqueezeResult(*running)));

  auto tracker = MakeTracker(dir.str());
  ASSERT_TRUE(tracker);
  EXPECT_GE(WaitUntil([&] { return StateOf(*tracker, "mid") == CommandState::kSucceeded; }, 10.0),
            0.0);
  // The re-sent command was not run again: the robot delivers each id once, so the next command
  // it executes is the one submitted after the restart.
  ASSERT_TRUE(tracker->Submit(Command("after"), "fp"));
  auto next = robot->WaitForCommand(10.0);
  ASSERT_TRUE(next && next.value());
  EXPECT_EQ(next.value()->command_id, "after");
}

TEST(CommandTrackerTest, BadJournalRecordsAreSkippedWithWarnings) {
  TempDir dir("tracker-badjournal");
  std::filesystem::create_directories(dir.path());
  {
    std::ofstream out(dir.path() / kJournalFileName, std::ios::binary);
    const std::vector<std::string> payloads = {
        "not json",
        R"({"type":"accepted"})",
        R"({"type":"accepted","id":"x","fingerprint":"f","accepted_unix_ns":1,"command":{"command_id":"x"}})",
        R"({"type":"result","id":"unknown","received_unix_ns":1,"result":{}})",
        R"({"type":"mystery","id":"y"})",
    };
    for (const auto& p : payloads) out << EncodeJournalLine(p) << "\n";
    out << "deadbeef torn";  // no newline: a torn tail
  }
  Logged logged;
  auto tracker = MakeTracker(dir.str(), 20.0, &logged);
  ASSERT_TRUE(tracker);
  const TrackerStats stats = tracker->stats();
  EXPECT_EQ(stats.skipped_records, 5);
  EXPECT_EQ(stats.replayed_commands, 0);
  EXPECT_TRUE(stats.journal.torn_tail);
  std::lock_guard<std::mutex> lock(logged.mutex);
  EXPECT_EQ(logged.lines.size(), 6u);  // five records and the torn tail
}

// ---- retention and compaction ----

constexpr std::int64_t kNsPerS = 1'000'000'000;

// Like the REST layer's fingerprints: JSON in a string, here with a decoy "id" inside.
std::string Fingerprint(const std::string& id) {
  return R"({"id":"decoy-)" + id + R"(","note":"a \"quoted\" word, a \\ and }]"})";
}

TEST(JournalRecordIdTest, FindsTheTopLevelIdOnly) {
  EXPECT_EQ(JournalRecordId(R"({"type":"result","id":"a-1","result":{"command_id":"x"}})"), "a-1");
  // Not the "id" of a nested object or inside a string value, nor a value that reads "id".
  EXPECT_EQ(
      JournalRecordId(
          R"({"command":{"id":"nested"},"note":"\",\"id\":\"in-a-string","type":"id","id":"top"})"),
      "top");
  EXPECT_EQ(JournalRecordId(R"({"list":[{"id":"in-array"}],"id":"top"})"), "top");
  EXPECT_EQ(JournalRecordId(" { \"id\" : \"spaced\" } "), "spaced");
  // Escapes in the key or the value: the parser decides.
  EXPECT_EQ(JournalRecordId(R"({"i\u0064":"escaped-key"})"), "escaped-key");
  EXPECT_EQ(JournalRecordId(R"({"id":"with \"quote\""})"), "with \"quote\"");
  EXPECT_EQ(JournalRecordId(AcceptedJournalRecord([] {
              CommandRecord r;
              r.command = MakeCommand("real", "arm-1");
              r.fingerprint = Fingerprint("real");
              return r;
            }())),
            "real");
  for (const char* none : {R"({"type":"result"})", R"({"id":5})", R"(["id","x"])", "not json",
                           R"({"command":{"id":"nested"}})", R"({"id":"unterminated)", ""}) {
    EXPECT_FALSE(JournalRecordId(none)) << none;
  }
}

// A journal as a service would have left it, with commands accepted and finished at chosen times.
class JournalWriter {
 public:
  explicit JournalWriter(const std::string& dir) {
    auto opened = Journal::Open(dir);
    if (!opened) ADD_FAILURE() << opened.error().message;
    if (opened) journal_ = std::move(opened.value().journal);
  }
  void Accepted(const std::string& id, std::int64_t unix_ns) {
    CommandRecord record;
    record.command = MakeCommand(id, "arm-1");
    record.fingerprint = Fingerprint(id);
    record.accepted_unix_ns = unix_ns;
    Write(AcceptedJournalRecord(record));
  }
  void Result(const std::string& id, std::int64_t unix_ns) {
    bridge::GraspResult result = SqueezeResult(MakeCommand(id, "arm-1"));
    result.robot_id = "arm-1";
    Write(ResultJournalRecord(id, unix_ns, result));
  }
  void TimedOut(const std::string& id, std::int64_t unix_ns) {
    Write(TimedOutJournalRecord(id, unix_ns, "no result within 60 s"));
  }
  void Write(const std::string& payload) {
    if (auto appended = journal_->Append(payload); !appended) {
      ADD_FAILURE() << appended.error().message;
    }
  }

 private:
  std::unique_ptr<Journal> journal_;
};

std::unique_ptr<CommandTracker> MakeRetainingTracker(const std::string& dir, double retention_s,
                                                     std::int64_t max_commands) {
  TrackerOptions options;
  options.journal_dir = dir;
  options.command_timeout_s = 20.0;
  options.retention_s = retention_s;
  options.retention_max_commands = max_commands;
  options.compaction_check_period_s = 0.1;
  options.compaction_min_dropped_records = 1;
  auto tracker = CommandTracker::Create(options, MakeServiceBridge());
  if (!tracker) ADD_FAILURE() << tracker.error().message;
  return tracker ? std::move(tracker).value() : nullptr;
}

// The command ids the journal file holds records of, in order of their first record.
std::vector<std::string> JournalIds(const std::string& dir) {
  auto opened = Journal::Open(dir);
  if (!opened) {
    ADD_FAILURE() << opened.error().message;
    return {};
  }
  std::vector<std::string> ids;
  for (const std::string& payload : opened.value().payloads) {
    const std::string id = nlohmann::json::parse(payload).at("id").get<std::string>();
    if (std::find(ids.begin(), ids.end(), id) == ids.end()) ids.push_back(id);
  }
  return ids;
}

TEST(CommandTrackerTest, AtStartFinishedCommandsPastTheirRetentionAreForgottenByAgeAndByCount) {
  TempDir dir("tracker-retention");
  const std::int64_t now = bridge::UnixNowNs();
  const std::int64_t hours_ago = now - 3 * 3600 * kNsPerS;
  {
    JournalWriter journal(dir.str());
    journal.Accepted("old-done", hours_ago);
    journal.Result("old-done", hours_ago + kNsPerS);
    journal.Accepted("old-timeout", hours_ago);
    journal.TimedOut("old-timeout", hours_ago + 60 * kNsPerS);
    // Accepted hours ago and never finished: kept whatever its age.
    journal.Accepted("old-pending", hours_ago);
    // Five recent ones: with `late` below, six finished within the hour, and only the four that
    // finished last are kept (retention_max_commands).
    for (int i = 1; i <= 5; ++i) {
      const std::string id = "recent-" + std::to_string(i);
      journal.Accepted(id, now - 100 * kNsPerS);
      journal.Result(id, now - (60 - 10 * i) * kNsPerS);
    }
    // An old command that timed out recently (its age counts from the timeout) and got its
    // result late: kept, with both records.
    journal.Accepted("late", hours_ago);
    journal.TimedOut("late", now - 5 * kNsPerS);
    journal.Result("late", now - 4 * kNsPerS);
    // A record replay cannot use: dropped.
    journal.Result("never-accepted", now);
  }
  const std::vector<std::string> forgotten = {"old-done", "old-timeout", "recent-1", "recent-2"};
  const std::vector<std::string> kept = {"old-pending", "recent-3", "recent-4", "recent-5", "late"};
  {
    auto tracker = MakeRetainingTracker(dir.str(), /*retention_s=*/3600, /*max_commands=*/4);
    ASSERT_TRUE(tracker);
    const TrackerStats stats = tracker->stats();
    EXPECT_EQ(stats.replayed_commands, 9);
    EXPECT_EQ(stats.compactions, 1);
    EXPECT_EQ(stats.compaction_errors, 0);
    EXPECT_EQ(stats.forgotten_commands, 4);
    EXPECT_EQ(stats.compaction_dropped_records, 9);  // 2 for each forgotten, 1 unusable
    EXPECT_GT(stats.last_compaction_bytes_before, stats.last_compaction_bytes_after);
    EXPECT_EQ(static_cast<std::int64_t>(std::filesystem::file_size(dir.path() / kJournalFileName)),
              stats.last_compaction_bytes_after);
    for (const std::string& id : forgotten) EXPECT_FALSE(tracker->Get(id)) << id;
    for (const std::string& id : kept) EXPECT_TRUE(tracker->Get(id)) << id;
    EXPECT_EQ(StateOf(*tracker, "late"), CommandState::kTimedOut);
    EXPECT_TRUE(tracker->Get("late")->result_late);
    EXPECT_FALSE(IsTerminal(StateOf(*tracker, "old-pending")));

    // Kept ids keep their idempotency; a forgotten id is a new command (no robot: 503).
    auto same = tracker->Submit(Command("recent-4"), Fingerprint("recent-4"));
    ASSERT_TRUE(same) << same.error().message;
    EXPECT_FALSE(same.value().created);
    EXPECT_EQ(tracker->Submit(Command("recent-4"), "other").error().code,
              core::ErrorCode::kConflict);
    EXPECT_EQ(tracker->Submit(Command("recent-1"), Fingerprint("recent-1")).error().code,
              core::ErrorCode::kUnavailable);
  }
  EXPECT_EQ(JournalIds(dir.str()),
            (std::vector<std::string>{"old-pending", "recent-3", "recent-4", "recent-5", "late"}));

  // Reopened: the same commands, idempotency intact, nothing more to compact.
  auto tracker = MakeRetainingTracker(dir.str(), 3600, 4);
  ASSERT_TRUE(tracker);
  EXPECT_EQ(tracker->stats().replayed_commands, 5);
  EXPECT_EQ(tracker->stats().compactions, 0);
  for (const std::string& id : forgotten) EXPECT_FALSE(tracker->Get(id)) << id;
  for (const std::string& id : kept) EXPECT_TRUE(tracker->Get(id)) << id;
  auto same = tracker->Submit(Command("recent-3"), Fingerprint("recent-3"));
  ASSERT_TRUE(same) << same.error().message;
  EXPECT_FALSE(same.value().created);
  EXPECT_EQ(tracker->Submit(Command("late"), "other").error().code, core::ErrorCode::kConflict);
}

TEST(CommandTrackerTest, TheBackgroundThreadCompactsFinishedCommandsAwayAndKeepsAPendingOne) {
  TempDir dir("tracker-compaction");
  {
    auto tracker = MakeRetainingTracker(dir.str(), /*retention_s=*/1.0, /*max_commands=*/100);
    auto robot = MakeRobot("arm-1");
    ASSERT_TRUE(tracker && robot);
    ASSERT_GE(WaitUntil([&] { return RobotAlive(*tracker, "arm-1"); }, 10.0), 0.0);
    for (int i = 0; i < 4; ++i) {
      const std::string id = "done-" + std::to_string(i);
      ASSERT_TRUE(tracker->Submit(Command(id), "fp"));
      auto c = robot->WaitForCommand(10.0);
      ASSERT_TRUE(c && c.value());
      ASSERT_TRUE(robot->PublishResult(SqueezeResult(*c.value())));
      ASSERT_GE(WaitUntil([&] { return StateOf(*tracker, id) == CommandState::kSucceeded; }, 10.0),
                0.0);
    }
    // The robot takes this one and never answers.
    ASSERT_TRUE(tracker->Submit(Command("pending"), "fp-pending"));
    auto c = robot->WaitForCommand(10.0);
    ASSERT_TRUE(c && c.value());

    // A second after their results, the finished commands are past their retention.
    ASSERT_GE(WaitUntil([&] { return tracker->stats().forgotten_commands == 4; }, 10.0), 0.0);
    const TrackerStats stats = tracker->stats();
    EXPECT_GE(stats.compactions, 1);
    EXPECT_EQ(stats.compaction_errors, 0);
    EXPECT_EQ(stats.compaction_dropped_records, 8);
    EXPECT_GT(stats.last_compaction_bytes_before, stats.last_compaction_bytes_after);
    for (int i = 0; i < 4; ++i) EXPECT_FALSE(tracker->Get("done-" + std::to_string(i)));
    ASSERT_TRUE(tracker->Get("pending"));
    EXPECT_EQ(tracker->Get("pending")->fingerprint, "fp-pending");
    // A forgotten id is a new command now.
    auto again = tracker->Submit(Command("done-0"), "fp");
    ASSERT_TRUE(again) << again.error().message;
    EXPECT_TRUE(again.value().created);
  }
  EXPECT_EQ(JournalIds(dir.str()), (std::vector<std::string>{"pending", "done-0"}));
  auto tracker = MakeRetainingTracker(dir.str(), 1.0, 100);
  ASSERT_TRUE(tracker);
  EXPECT_EQ(tracker->stats().replayed_commands, 2);
  ASSERT_TRUE(tracker->Get("pending"));
  EXPECT_FALSE(IsTerminal(StateOf(*tracker, "pending")));
  EXPECT_FALSE(tracker->Get("done-1"));
}

TEST(CommandTrackerTest, BadOptionsAreErrors) {
  TrackerOptions options;
  options.journal_dir = "";
  auto no_dir = CommandTracker::Create(options, MakeServiceBridge());
  ASSERT_FALSE(no_dir);
  EXPECT_EQ(no_dir.error().field, "journal_dir");
  options.journal_dir = "/tmp/unused";
  options.command_timeout_s = -1;
  auto bad_timeout = CommandTracker::Create(options, MakeServiceBridge());
  ASSERT_FALSE(bad_timeout);
  EXPECT_EQ(bad_timeout.error().field, "command_timeout_s");
  options.command_timeout_s = 1;
  options.retention_s = -1;
  auto bad_retention = CommandTracker::Create(options, MakeServiceBridge());
  ASSERT_FALSE(bad_retention);
  EXPECT_EQ(bad_retention.error().field, "retention_s");
  options.retention_s = 1;
  options.retention_max_commands = -1;
  auto bad_count = CommandTracker::Create(options, MakeServiceBridge());
  ASSERT_FALSE(bad_count);
  EXPECT_EQ(bad_count.error().field, "retention_max_commands");
}

}  // namespace
}  // namespace softgrasp::robot
