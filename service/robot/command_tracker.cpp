#include "service/robot/command_tracker.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <unordered_set>
#include <utility>

#include "service/bridge/bridge.h"
#include "service/codec/json_codec.h"

namespace softgrasp::robot {
namespace {

using bridge::GraspCommand;
using bridge::GraspOutcome;
using bridge::GraspResult;
using core::ErrorCode;
using core::MakeError;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

// Journal records are one JSON object per line (docs/robot-api.md lists them); the command and
// the result inside them are in the codec's bus form.

CommandState StateFor(GraspOutcome outcome) {
  switch (outcome) {
    case GraspOutcome::kSucceeded:
      return CommandState::kSucceeded;
    case GraspOutcome::kFailed:
      return CommandState::kFailed;
    case GraspOutcome::kRejected:
      return CommandState::kRejected;
    case GraspOutcome::kTimedOut:
      return CommandState::kTimedOut;
  }
  return CommandState::kFailed;
}

Clock::duration Seconds(double s) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

std::string TimeoutDetail(double timeout_s) {
  std::ostringstream os;
  os << "no result within " << timeout_s << " s; the command was withdrawn from the bus";
  return os.str();
}

// When a finished command finished, on the service's clock: its timeout, else its result.
std::int64_t FinishedUnixNs(const CommandRecord& r) {
  if (r.timed_out_unix_ns > 0) return r.timed_out_unix_ns;
  if (r.result_received_unix_ns > 0) return r.result_received_unix_ns;
  return r.accepted_unix_ns;
}

// The journal records behind a command: accepted, and its result and timeout when it has them.
std::int64_t JournalRecordsOf(const CommandRecord& r) {
  return 1 + (r.result ? 1 : 0) + (r.timed_out_unix_ns > 0 ? 1 : 0);
}

}  // namespace

std::string AcceptedJournalRecord(const CommandRecord& record) {
  return json{{"type", "accepted"},
              {"id", record.command.command_id},
              {"fingerprint", record.fingerprint},
              {"accepted_unix_ns", record.accepted_unix_ns},
              {"command", codec::ToJson(record.command)}}
      .dump();
}

std::string ResultJournalRecord(const std::string& command_id, std::int64_t received_unix_ns,
                                const GraspResult& result) {
  return json{{"type", "result"},
              {"id", command_id},
              {"received_unix_ns", received_unix_ns},
              {"result", codec::ToJson(result)}}
      .dump();
}

std::string TimedOutJournalRecord(const std::string& command_id, std::int64_t unix_ns,
                                  const std::string& detail) {
  return json{{"type", "timed_out"}, {"id", command_id}, {"unix_ns", unix_ns}, {"detail", detail}}
      .dump();
}

std::optional<std::string> JournalRecordId(std::string_view payload) {
  // A scan for the top-level "id" member that skips strings (with their escapes) and tracks the
  // nesting, so that "id" keys inside nested objects or inside string values are not taken. Much
  // faster than parsing whole records, which matters when a compaction reads a large journal.
  const auto skip_string = [&](std::size_t open, bool* escaped) {  // index of the closing quote
    std::size_t i = open + 1;
    while (i < payload.size() && payload[i] != '"') {
      if (payload[i] == '\\') {
        *escaped = true;
        ++i;
      }
      ++i;
    }
    return i;
  };
  const auto skip_space = [&](std::size_t i) {
    while (i < payload.size() && std::isspace(static_cast<unsigned char>(payload[i]))) ++i;
    return i;
  };
  int depth = 0;
  bool expect_key = false;
  for (std::size_t i = 0; i < payload.size(); ++i) {
    const char c = payload[i];
    if (c == '"') {
      bool escaped = false;
      const std::size_t close = skip_string(i, &escaped);
      if (close >= payload.size()) break;
      const bool is_id_key =
          depth == 1 && expect_key && !escaped && payload.substr(i + 1, close - i - 1) == "id";
      expect_key = false;
      i = close;
      if (!is_id_key) continue;
      std::size_t value = skip_space(close + 1);
      if (value >= payload.size() || payload[value] != ':') break;
      value = skip_space(value + 1);
      if (value >= payload.size() || payload[value] != '"') break;
      bool value_escaped = false;
      const std::size_t value_close = skip_string(value, &value_escaped);
      if (value_close >= payload.size() || value_escaped) break;
      return std::string(payload.substr(value + 1, value_close - value - 1));
    }
    if (c == '{' || c == '[') {
      ++depth;
      expect_key = c == '{' && depth == 1;
    } else if (c == '}' || c == ']') {
      --depth;
    } else if (c == ',' && depth == 1) {
      expect_key = true;
    }
  }
  // Anything unusual (escapes in the id, a malformed record): the parser decides.
  const json j = json::parse(payload.begin(), payload.end(), nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object()) return std::nullopt;
  const auto id = j.find("id");
  if (id == j.end() || !id->is_string()) return std::nullopt;
  return id->get<std::string>();
}

const char* CommandStateName(CommandState state) {
  switch (state) {
    case CommandState::kQueued:
      return "queued";
    case CommandState::kSent:
      return "sent";
    case CommandState::kExecuting:
      return "executing";
    case CommandState::kSucceeded:
      return "succeeded";
    case CommandState::kFailed:
      return "failed";
    case CommandState::kRejected:
      return "rejected";
    case CommandState::kTimedOut:
      return "timed_out";
  }
  return "failed";
}

bool IsTerminal(CommandState state) {
  return state == CommandState::kSucceeded || state == CommandState::kFailed ||
         state == CommandState::kRejected || state == CommandState::kTimedOut;
}

CommandTracker::CommandTracker(TrackerOptions options,
                               std::unique_ptr<bridge::ServiceBridge> bridge)
    : options_(std::move(options)), bridge_(std::move(bridge)) {}

core::Result<std::unique_ptr<CommandTracker>> CommandTracker::Create(
    TrackerOptions options, std::unique_ptr<bridge::ServiceBridge> bridge) {
  if (!bridge) throw std::invalid_argument("CommandTracker::Create: bridge is null");
  if (!(options.command_timeout_s > 0.0) || !std::isfinite(options.command_timeout_s)) {
    return MakeError(ErrorCode::kInvalidArgument, "command_timeout_s must be > 0",
                     "command_timeout_s");
  }
  if (!(options.poll_period_s > 0.0) || !(options.republish_period_s > 0.0) ||
      !(options.compaction_check_period_s > 0.0)) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "poll, republish and compaction check periods must be > 0", "poll_period_s");
  }
  if (!(options.retention_s >= 0.0) || !std::isfinite(options.retention_s)) {
    return MakeError(ErrorCode::kInvalidArgument, "retention_s must be >= 0", "retention_s");
  }
  if (options.retention_max_commands < 0) {
    return MakeError(ErrorCode::kInvalidArgument, "retention_max_commands must be >= 0",
                     "retention_max_commands");
  }
  if (options.compaction_min_dropped_records < 1) {
    return MakeError(ErrorCode::kInvalidArgument, "compaction_min_dropped_records must be >= 1",
                     "compaction_min_dropped_records");
  }
  auto opened = Journal::Open(options.journal_dir);
  if (!opened) return opened.error();
  std::unique_ptr<CommandTracker> tracker(
      new CommandTracker(std::move(options), std::move(bridge)));
  tracker->journal_ = std::move(opened.value().journal);
  tracker->stats_.journal = opened.value().report;
  for (const std::string& w : opened.value().report.warnings) {
    tracker->Warn("robot journal " + tracker->journal_->path() + ": " + w);
  }
  tracker->Replay(opened.value().payloads);
  tracker->CompactJournal(/*at_start=*/true);
  tracker->RepublishQueued();
  tracker->thread_ = std::thread([t = tracker.get()] { t->Loop(); });
  return tracker;
}

CommandTracker::~CommandTracker() {
  {
    std::lock_guard<std::mutex> lock(stop_mutex_);
    stop_ = true;
  }
  stop_cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void CommandTracker::Warn(const std::string& message) const {
  if (options_.log) {
    options_.log(message);
  } else {
    std::cerr << "softgrasp robot: " << message << "\n";
  }
}

// ---- replay ----

void CommandTracker::Replay(const std::vector<std::string>& payloads) {
  for (const std::string& payload : payloads) ReplayOne(payload);
  // What was accepted but has no outcome goes out again, with a fresh deadline: the robot may
  // still deliver a result it wrote while the service was down (results are transient-local).
  const auto now = Clock::now();
  std::lock_guard<std::mutex> lock(mutex_);
  for (auto& [id, entry] : entries_) {
    if (IsTerminal(entry.record.state)) continue;
    entry.record.state = CommandState::kQueued;
    entry.deadline = now + Seconds(options_.command_timeout_s);
    entry.last_publish = now - Seconds(options_.republish_period_s);  // due now
  }
}

void CommandTracker::ReplayOne(const std::string& payload) {
  const auto skip = [&](const std::string& why) {
    ++stats_.skipped_records;
    Warn("robot journal: record skipped (" + why + "): " + payload.substr(0, 200));
  };
  const json j = json::parse(payload, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object() || !j.contains("type") || !j["type"].is_string() ||
      !j.contains("id") || !j["id"].is_string()) {
    return skip("not a journal record");
  }
  const std::string type = j["type"];
  const std::string id = j["id"];
  try {
    if (type == "accepted") {
      auto read = codec::CommandFromJson(j.at("command"), "command");
      if (!read) return skip(read.error().message);
      auto command = bridge::Validate(std::move(read).value());
      if (!command) return skip(command.error().message);
      if (command.value().command_id != id) return skip("id does not match the command");
      if (entries_.count(id) != 0) return skip("id accepted twice");
      Entry entry;
      entry.record.command = std::move(command).value();
      entry.record.fingerprint = j.at("fingerprint").get<std::string>();
      entry.record.accepted_unix_ns = j.at("accepted_unix_ns").get<std::int64_t>();
      entries_.emplace(id, std::move(entry));
      ++stats_.replayed_commands;
      return;
    }
    const auto it = entries_.find(id);
    if (it == entries_.end()) return skip("no accepted command with this id");
    CommandRecord& record = it->second.record;
    if (type == "result") {
      auto read = codec::ResultFromJson(j.at("result"), "result");
      if (!read) return skip(read.error().message);
      auto result = bridge::Validate(std::move(read).value());
      if (!result) return skip(result.error().message);
      if (record.result) return skip("second result for the id");
      record.result_late = record.state == CommandState::kTimedOut;
      if (!record.result_late) record.state = StateFor(result.value().outcome);
      record.result = std::move(result).value();
      record.result_received_unix_ns = j.at("received_unix_ns").get<std::int64_t>();
    } else if (type == "timed_out") {
      if (IsTerminal(record.state)) return skip("timeout for a finished command");
      record.state = CommandState::kTimedOut;
      record.timed_out_unix_ns = j.at("unix_ns").get<std::int64_t>();
      record.detail = j.at("detail").get<std::string>();
    } else {
      return skip("unknown type '" + type + "'");
    }
  } catch (const std::exception& e) {
    return skip(e.what());
  }
}

// ---- submission ----

core::Result<CommandTracker::Submitted> CommandTracker::Submit(GraspCommand command,
                                                               std::string fingerprint) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (const auto it = entries_.find(command.command_id); it != entries_.end()) {
      if (it->second.record.fingerprint != fingerprint) {
        return MakeError(ErrorCode::kConflict,
                         "command id '" + command.command_id +
                             "' was already used for a different grasp; choose a new id",
                         "id");
      }
      return Submitted{it->second.record, false};
    }
  }
  // Pick the robot. Reading the robots does not need our lock.
  const std::vector<bridge::RobotInfo> alive = bridge_->AliveRobots();
  if (command.robot_id.empty()) {
    if (alive.empty()) {
      return MakeError(ErrorCode::kUnavailable, "no robot is alive on the bus; retry later");
    }
    if (alive.size() > 1) {
      std::string names;
      for (const auto& r : alive) names += (names.empty() ? "" : ", ") + r.status.robot_id;
      return MakeError(ErrorCode::kUnprocessable,
                       "several robots are alive (" + names + "): name one in robot_id",
                       "robot_id");
    }
    command.robot_id = alive.front().status.robot_id;
  } else {
    bool found = false;
    for (const auto& r : alive) found = found || r.status.robot_id == command.robot_id;
    if (!found) {
      return MakeError(ErrorCode::kUnavailable,
                       "robot '" + command.robot_id + "' is not alive on the bus; retry later");
    }
  }
  command.issued_unix_ns = bridge::UnixNowNs();
  auto valid = bridge::Validate(std::move(command));
  if (!valid) return valid.error();

  Submitted out;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const GraspCommand& c = valid.value();
    // Another request with this id may have won while we looked at the robots.
    if (const auto it = entries_.find(c.command_id); it != entries_.end()) {
      if (it->second.record.fingerprint != fingerprint) {
        return MakeError(ErrorCode::kConflict,
                         "command id '" + c.command_id +
                             "' was already used for a different grasp; choose a new id",
                         "id");
      }
      return Submitted{it->second.record, false};
    }
    Entry entry;
    entry.record.command = c;
    entry.record.fingerprint = std::move(fingerprint);
    entry.record.accepted_unix_ns = c.issued_unix_ns;
    entry.record.state = CommandState::kQueued;
    entry.deadline = Clock::now() + Seconds(options_.command_timeout_s);
    entry.last_publish = Clock::now();
    // Journal first: a command the journal does not hold is never sent.
    auto journaled = journal_->Append(AcceptedJournalRecord(entry.record));
    if (!journaled) {
      return MakeError(
          ErrorCode::kInternal,
          "the command could not be journaled, so it was not sent: " + journaled.error().message);
    }
    entries_.emplace(c.command_id, entry);
    out = Submitted{entry.record, true};
  }
  PublishOutsideLock(out.record.command);
  if (auto now = Get(out.record.command.command_id)) out.record = *now;
  return out;
}

void CommandTracker::PublishOutsideLock(const GraspCommand& command) {
  // The DDS write can block (reliable, up to 1 s): never under our lock.
  auto published = bridge_->Publish(command);
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = entries_.find(command.command_id);
  if (it == entries_.end()) return;
  CommandRecord& record = it->second.record;
  if (published) {
    if (record.state == CommandState::kQueued) record.state = CommandState::kSent;
    record.detail.clear();
  } else if (record.state == CommandState::kQueued) {
    record.detail = "writing on the bus failed, retrying: " + published.error().message;
  }
}

// ---- reading ----

std::optional<CommandRecord> CommandTracker::Get(const std::string& command_id) const {
  std::optional<CommandRecord> out;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = entries_.find(command_id);
    if (it == entries_.end()) return std::nullopt;
    out = it->second.record;
  }
  // Between two polls of the background thread the heartbeat may already say "executing".
  if (out->state == CommandState::kSent || out->state == CommandState::kQueued) {
    for (const auto& robot : bridge_->AliveRobots()) {
      if (robot.status.state == bridge::RobotState::kExecuting &&
          robot.status.current_command_id == command_id) {
        out->state = CommandState::kExecuting;
      }
    }
  }
  return out;
}

std::vector<bridge::RobotInfo> CommandTracker::Robots() const { return bridge_->Robots(); }

TrackerStats CommandTracker::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stats_;
}

// ---- background thread ----

void CommandTracker::Loop() {
  auto next_republish = Clock::now() + Seconds(options_.republish_period_s);
  auto next_compaction_check = Clock::now() + Seconds(options_.compaction_check_period_s);
  for (;;) {
    {
      std::unique_lock<std::mutex> lock(stop_mutex_);
      if (stop_) return;
    }
    // Waits for results up to one poll period (this is also the loop's sleep).
    ApplyResults(bridge_->WaitForResults(options_.poll_period_s));
    NoteExecuting();
    ExpireOverdue();
    if (Clock::now() >= next_republish) {
      RepublishQueued();
      next_republish = Clock::now() + Seconds(options_.republish_period_s);
    }
    if (Clock::now() >= next_compaction_check) {
      CompactJournal(/*at_start=*/false);
      next_compaction_check = Clock::now() + Seconds(options_.compaction_check_period_s);
    }
  }
}

void CommandTracker::AppendJournal(const std::string& payload) {
  auto appended = journal_->Append(payload);
  if (appended) return;
  std::lock_guard<std::mutex> lock(mutex_);
  ++stats_.journal_errors;
  Warn("robot journal: write failed (" + appended.error().message +
       "); the state is kept in memory only");
}

void CommandTracker::ApplyResults(std::vector<GraspResult> results) {
  const std::int64_t now_ns = bridge::UnixNowNs();
  for (GraspResult& result : results) {
    std::string record;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      const auto it = entries_.find(result.command_id);
      if (it == entries_.end()) {
        ++stats_.unknown_results;  // another service's command, or one from before the journal
        continue;
      }
      CommandRecord& r = it->second.record;
      if (r.result) continue;  // robots re-send kept results to a service that (re)joins
      r.result_late = r.state == CommandState::kTimedOut;
      if (r.result_late) {
        Warn("robot result for '" + r.command.command_id + "' arrived after its timeout");
      } else {
        r.state = StateFor(result.outcome);
        r.detail.clear();
      }
      r.result_received_unix_ns = now_ns;
      r.result = result;
      record = ResultJournalRecord(r.command.command_id, now_ns, result);
    }
    AppendJournal(record);
  }
}

void CommandTracker::NoteExecuting() {
  const auto robots = bridge_->AliveRobots();
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& robot : robots) {
    if (robot.status.state != bridge::RobotState::kExecuting) continue;
    const auto it = entries_.find(robot.status.current_command_id);
    if (it == entries_.end()) continue;
    CommandState& state = it->second.record.state;
    if (state == CommandState::kQueued || state == CommandState::kSent) {
      state = CommandState::kExecuting;
    }
  }
}

void CommandTracker::ExpireOverdue() {
  const auto now = Clock::now();
  std::vector<std::string> overdue;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& [id, entry] : entries_) {
      if (!IsTerminal(entry.record.state) && now >= entry.deadline) overdue.push_back(id);
    }
  }
  if (overdue.empty()) return;
  // Withdraw first, then say "timed_out": a client told so may start a robot at once, and that
  // robot must not be offered the command any more.
  for (const std::string& id : overdue) {
    if (auto retired = bridge_->Retire(id); !retired) {
      Warn("retiring timed-out command '" + id + "': " + retired.error().message);
    }
  }
  std::vector<std::string> records;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const std::string& id : overdue) {
      CommandRecord& r = entries_.at(id).record;
      if (IsTerminal(r.state)) continue;  // its result came in meanwhile: the result wins
      r.state = CommandState::kTimedOut;
      r.timed_out_unix_ns = bridge::UnixNowNs();
      r.detail = TimeoutDetail(options_.command_timeout_s);
      records.push_back(TimedOutJournalRecord(id, r.timed_out_unix_ns, r.detail));
    }
  }
  for (const std::string& record : records) AppendJournal(record);
}

void CommandTracker::RepublishQueued() {
  const auto now = Clock::now();
  std::vector<GraspCommand> due;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto& [id, entry] : entries_) {
      if (entry.record.state != CommandState::kQueued) continue;
      if (now - entry.last_publish < Seconds(options_.republish_period_s)) continue;
      entry.last_publish = now;
      due.push_back(entry.record.command);
    }
  }
  for (const GraspCommand& command : due) {
    PublishOutsideLock(command);
    std::lock_guard<std::mutex> lock(mutex_);
    ++stats_.republished;
  }
}

// ---- compaction ----

void CommandTracker::CompactJournal(bool at_start) {
  // Records are appended by Submit under mutex_, and by this thread (results, timeouts). So when
  // the plan is made under mutex_, every record of a command chosen to be forgotten starts before
  // `decided`, and none will follow: the command is finished, and it stays in entries_ (a
  // resubmission of its id gets the old record, nothing is appended) until the journal no
  // longer holds it. Memory therefore never forgets an id that the journal still holds, and a
  // new command with a forgotten id is only ever appended after the old one's records are gone.
  Journal::Position decided;
  std::vector<std::string> forget_ids;
  std::unordered_set<std::string> keep_ids;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    decided = journal_->End();
    if (!at_start && decided.records < options_.compaction_min_dropped_records) return;
    const std::int64_t now_ns = bridge::UnixNowNs();
    const double retention_ns = options_.retention_s * 1e9;
    std::int64_t kept_records = 0;
    std::vector<std::pair<std::int64_t, const Entry*>> retained;  // finished unix ns, command
    for (const auto& [id, entry] : entries_) {
      if (!IsTerminal(entry.record.state)) {
        kept_records += JournalRecordsOf(entry.record);
        continue;
      }
      const std::int64_t finished_ns = FinishedUnixNs(entry.record);
      if (static_cast<double>(now_ns - finished_ns) > retention_ns) {
        forget_ids.push_back(id);
      } else {
        retained.emplace_back(finished_ns, &entry);
        kept_records += JournalRecordsOf(entry.record);
      }
    }
    const auto max_retained = static_cast<std::size_t>(options_.retention_max_commands);
    if (retained.size() > max_retained) {
      const auto newest_first = [](const auto& a, const auto& b) {
        return a.first != b.first
                   ? a.first > b.first
                   : a.second->record.command.command_id < b.second->record.command.command_id;
      };
      const auto cut = retained.begin() + static_cast<std::ptrdiff_t>(max_retained);
      std::nth_element(retained.begin(), cut, retained.end(), newest_first);
      for (auto it = cut; it != retained.end(); ++it) {
        forget_ids.push_back(it->second->record.command.command_id);
        kept_records -= JournalRecordsOf(it->second->record);
      }
    }
    // Records that go: those of forgotten commands, and those replay could not use. Compacting
    // only once they are at least as many as those kept bounds the rewriting to one record
    // written per record appended.
    const std::int64_t dropped_records = decided.records - kept_records;
    const std::int64_t worth =
        at_start ? 1 : std::max(kept_records, options_.compaction_min_dropped_records);
    if (dropped_records < worth) return;
    const std::unordered_set<std::string> forget(forget_ids.begin(), forget_ids.end());
    keep_ids.reserve(entries_.size() - forget.size());
    for (const auto& [id, entry] : entries_) {
      if (forget.count(id) == 0) keep_ids.insert(id);
    }
  }

  auto compacted = journal_->Compact(decided, [&keep_ids](std::string_view payload) {
    const std::optional<std::string> id = JournalRecordId(payload);
    return id && keep_ids.count(*id) != 0;
  });
  std::lock_guard<std::mutex> lock(mutex_);
  if (!compacted) {
    ++stats_.compaction_errors;
    Warn("robot journal: compaction failed (" + compacted.error().message +
         "); finished commands are kept until a later one succeeds");
    return;
  }
  for (const std::string& id : forget_ids) entries_.erase(id);
  const CompactionReport& report = compacted.value();
  ++stats_.compactions;
  stats_.compaction_dropped_records += report.records_before - report.records_after;
  stats_.forgotten_commands += static_cast<std::int64_t>(forget_ids.size());
  stats_.last_compaction_bytes_before = report.bytes_before;
  stats_.last_compaction_bytes_after = report.bytes_after;
}

}  // namespace softgrasp::robot
