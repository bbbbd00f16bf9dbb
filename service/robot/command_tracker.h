#pragma once
/// The service's record of the grasps it forwarded to robots: idempotent submission by a
/// client-chosen id, the state of each command as it moves (queued -> sent -> executing ->
/// result), timeouts, and a journal on disk so that a restart loses no accepted command and no
/// result. Knows nothing of HTTP; the REST layer (service/rest/robot_api.cpp) sits on top.
/// docs/robot-api.md describes the states and the journal.

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "service/bridge/messages.h"
#include "service/core/status.h"
#include "service/robot/journal.h"

namespace softgrasp::bridge {
// service/bridge/bridge.h. Only declared here: the tracker's users (REST) see plain values and
// never compile the DDS API; whoever creates a tracker includes bridge.h to make its bridge.
class ServiceBridge;
}  // namespace softgrasp::bridge

namespace softgrasp::robot {

enum class CommandState {
  kQueued,     ///< accepted and journaled, not yet written on the bus (retried)
  kSent,       ///< written on the bus; no robot reported it as running yet
  kExecuting,  ///< a robot's heartbeat names it as its current command
  kSucceeded,  ///< terminal states: the robot's outcome, or the service's timeout
  kFailed,
  kRejected,
  kTimedOut,
};

/// "queued", "sent", "executing", "succeeded", "failed", "rejected", "timed_out".
const char* CommandStateName(CommandState state);
bool IsTerminal(CommandState state);

struct TrackerOptions {
  /// Folder of the journal (created if needed). Required.
  std::string journal_dir;
  /// A command with no result this long after it was accepted becomes kTimedOut and is retired
  /// from the bus. After a restart, pending commands get this long again from the restart.
  double command_timeout_s = 60.0;
  /// How often the background thread drains results, checks timeouts and robot states.
  double poll_period_s = 0.05;
  /// How often queued commands (whose first write failed) are written again.
  double republish_period_s = 1.0;
  /// Finished commands (succeeded, failed, rejected, timed_out) stay known, in memory and in the
  /// journal, for this long after they finished (the result's or the timeout's time): Get answers
  /// them and their ids stay idempotent. Older ones are forgotten by the next compaction of the
  /// journal; their ids are then new again. Commands not finished are kept whatever their age.
  double retention_s = 86400.0;
  /// At most this many finished commands are kept (the most recently finished) past a
  /// compaction, whatever their age: a bound on memory, on the journal's size and on the time to
  /// replay it.
  std::int64_t retention_max_commands = 100000;
  /// How often the background thread looks whether the journal is worth compacting: when it
  /// holds at least compaction_min_dropped_records records that are no longer needed, and at
  /// least as many as are still needed (so rewriting costs at most one write per record
  /// appended). Compaction also runs once at start, after the replay, when anything can go.
  double compaction_check_period_s = 10.0;
  std::int64_t compaction_min_dropped_records = 1000;
  /// Warnings (journal problems, late or unknown results). Default: stderr.
  std::function<void(const std::string&)> log;
};

struct CommandRecord {
  bridge::GraspCommand command;  ///< as sent (robot_id is the robot chosen)
  /// The request as the client gave it, canonical: same id with another fingerprint is kConflict.
  std::string fingerprint;
  CommandState state = CommandState::kQueued;
  std::int64_t accepted_unix_ns = 0;
  std::optional<bridge::GraspResult> result;
  std::int64_t result_received_unix_ns = 0;
  /// A result that arrived after the command had timed out (the state stays kTimedOut).
  bool result_late = false;
  std::int64_t timed_out_unix_ns = 0;
  std::string detail;  ///< why it is queued or timed out, for people
};

/// What the background thread and the replay have seen, for tests and /v1/robot.
struct TrackerStats {
  std::int64_t replayed_commands = 0;  ///< commands read back from the journal at start
  std::int64_t republished = 0;        ///< queued commands written again (start, retries)
  std::int64_t skipped_records = 0;    ///< journal records that could not be used
  std::int64_t unknown_results = 0;    ///< results for ids this service never accepted
  std::int64_t journal_errors = 0;     ///< failed journal writes after acceptance
  std::int64_t compactions = 0;        ///< journal compactions done (at start and later)
  std::int64_t compaction_errors = 0;  ///< compactions that failed (the old file stays in use)
  std::int64_t compaction_dropped_records = 0;  ///< records the compactions left out, in all
  /// Finished commands forgotten after their retention: their ids are new again.
  std::int64_t forgotten_commands = 0;
  std::int64_t last_compaction_bytes_before = 0;  ///< the journal's size before the last one
  std::int64_t last_compaction_bytes_after = 0;
  JournalReport journal;
};

/// The journal records the tracker writes, one JSON object each (docs/robot-api.md, "Journal").
/// Exposed for tests, which prepare journals with them.
std::string AcceptedJournalRecord(const CommandRecord& record);
std::string ResultJournalRecord(const std::string& command_id, std::int64_t received_unix_ns,
                                const bridge::GraspResult& result);
std::string TimedOutJournalRecord(const std::string& command_id, std::int64_t unix_ns,
                                  const std::string& detail);
/// The top-level "id" member of a journal record; nullopt when the record is not a JSON object or
/// has no string "id". What compaction reads to tell whose record it is.
std::optional<std::string> JournalRecordId(std::string_view payload);

class CommandTracker {
 public:
  /// Opens the journal, replays it, writes pending commands on the bus again (robots run an id
  /// at most once, so this is safe) and starts the background thread. Errors: bad options
  /// (kInvalidArgument), the journal's errors (kConflict when another process holds it).
  static core::Result<std::unique_ptr<CommandTracker>> Create(
      TrackerOptions options, std::unique_ptr<bridge::ServiceBridge> bridge);
  ~CommandTracker();
  CommandTracker(const CommandTracker&) = delete;
  CommandTracker& operator=(const CommandTracker&) = delete;

  struct Submitted {
    CommandRecord record;
    bool created = false;  ///< false: the id was known with the same fingerprint (a replay)
  };

  /// Accepts a command at most once per command_id. A known id with the same fingerprint gives
  /// the existing record (nothing is sent again); with another fingerprint, kConflict. For a new
  /// id: picks the robot (the named one, or the only alive one), journals the command, then
  /// writes it on the bus. Errors: kUnavailable (no robot alive, or the named one is not),
  /// kUnprocessable (several robots alive and none named; the command is invalid for the bus),
  /// kInternal (the journal cannot be written: nothing is sent).
  core::Result<Submitted> Submit(bridge::GraspCommand command, std::string fingerprint);

  /// The record of `command_id`, with kExecuting when a robot's heartbeat says so.
  std::optional<CommandRecord> Get(const std::string& command_id) const;

  /// Every robot the bridge has heard from (bridge::ServiceBridge::Robots).
  std::vector<bridge::RobotInfo> Robots() const;
  TrackerStats stats() const;
  const TrackerOptions& options() const { return options_; }
  bridge::ServiceBridge& bridge() { return *bridge_; }

 private:
  using SteadyTime = std::chrono::steady_clock::time_point;
  struct Entry {
    CommandRecord record;
    SteadyTime deadline;
    SteadyTime last_publish;  ///< last write attempt, so the retry does not race Submit's write
  };

  CommandTracker(TrackerOptions options, std::unique_ptr<bridge::ServiceBridge> bridge);
  void Replay(const std::vector<std::string>& payloads);
  void ReplayOne(const std::string& payload);
  void Warn(const std::string& message) const;
  void Loop();
  void ApplyResults(std::vector<bridge::GraspResult> results);
  void ExpireOverdue();
  void NoteExecuting();
  void RepublishQueued();
  /// Writes the command on the bus and moves it from queued to sent, outside the lock.
  void PublishOutsideLock(const bridge::GraspCommand& command);
  void AppendJournal(const std::string& payload);  // logs and counts failures
  /// Forgets finished commands past their retention and rewrites the journal without them (and
  /// without records nothing uses). At start (`at_start`), when anything can go; later, when
  /// enough can go. Runs on the background thread (or before it starts).
  void CompactJournal(bool at_start);

  TrackerOptions options_;
  std::unique_ptr<bridge::ServiceBridge> bridge_;
  std::unique_ptr<Journal> journal_;

  mutable std::mutex mutex_;
  std::map<std::string, Entry> entries_;
  TrackerStats stats_;

  std::mutex stop_mutex_;
  std::condition_variable stop_cv_;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace softgrasp::robot
