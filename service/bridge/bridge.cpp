#include "service/bridge/bridge.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "service/bridge/messages_dds.h"

namespace softgrasp::bridge {
namespace {

using core::ErrorCode;
using core::MakeError;

// Samples taken per dds_take call when draining a reader.
constexpr uint32_t kTakeBatch = 16;
// How many delivered command ids a robot remembers to refuse repeats.
constexpr std::size_t kMaxRememberedCommands = 4096;

core::Result<dds_entity_t> CreateTopic(dds_entity_t participant,
                                       const dds_topic_descriptor_t* descriptor, const char* name) {
  const dds_entity_t topic = dds_create_topic(participant, descriptor, name, nullptr, nullptr);
  if (topic < 0) return DdsError(topic, std::string("dds_create_topic(") + name + ")");
  return topic;
}

// Creates a reader whose data-available listener calls `callback(reader, arg)`.
core::Result<Entity> CreateListeningReader(dds_entity_t participant, dds_entity_t topic,
                                           const dds_qos_t* qos, dds_on_data_available_fn callback,
                                           void* arg, const std::string& what) {
  dds_listener_t* listener = dds_create_listener(arg);
  dds_lset_data_available(listener, callback);
  const dds_entity_t reader = dds_create_reader(participant, topic, qos, listener);
  dds_delete_listener(listener);  // the reader keeps its own copy
  return Adopt(reader, what);
}

// Takes every available sample of `reader` and hands each to `visit(sample, info)`; returns the
// first DDS error, if any. Loaned buffers are always returned.
template <class CType, class Visit>
dds_return_t TakeAll(dds_entity_t reader, Visit&& visit) {
  for (;;) {
    void* samples[kTakeBatch] = {};
    dds_sample_info_t infos[kTakeBatch];
    const dds_return_t n = dds_take(reader, samples, infos, kTakeBatch, kTakeBatch);
    if (n <= 0) return n;
    for (dds_return_t i = 0; i < n; ++i) visit(*static_cast<const CType*>(samples[i]), infos[i]);
    const dds_return_t rc = dds_return_loan(reader, samples, n);
    if (rc < 0) return rc;
    if (static_cast<uint32_t>(n) < kTakeBatch) return 0;
  }
}

core::Result<int> MatchedCount(dds_entity_t entity, bool writer) {
  if (writer) {
    dds_publication_matched_status_t status;
    const dds_return_t rc = dds_get_publication_matched_status(entity, &status);
    if (rc < 0) return DdsError(rc, "dds_get_publication_matched_status");
    return static_cast<int>(status.current_count);
  }
  dds_subscription_matched_status_t status;
  const dds_return_t rc = dds_get_subscription_matched_status(entity, &status);
  if (rc < 0) return DdsError(rc, "dds_get_subscription_matched_status");
  return static_cast<int>(status.current_count);
}

// Unregisters the instance with key `command_id` from a writer of GraspCommand or GraspResult.
// An instance the writer never had (or already dropped) is not an error.
template <class Message>
core::Result<Ok> UnregisterById(dds_entity_t writer, const std::string& command_id,
                                const char* what) {
  Message key;
  key.command_id = command_id;
  auto sample = ToC(key);
  const dds_return_t rc = dds_unregister_instance(writer, sample.get());
  if (rc < 0 && rc != DDS_RETCODE_PRECONDITION_NOT_MET && rc != DDS_RETCODE_BAD_PARAMETER) {
    return DdsError(rc, what);
  }
  return Ok{};
}

}  // namespace

std::string LoopbackConfigXml(const std::string& discovery_tag) {
  for (char c : discovery_tag) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_') {
      throw std::invalid_argument("LoopbackConfigXml: discovery_tag must be [A-Za-z0-9_-]");
    }
  }
  std::string tag;
  if (!discovery_tag.empty()) tag = "<Tag>" + discovery_tag + "</Tag>";
  return "<CycloneDDS><Domain id=\"any\">"
         "<General><Interfaces><NetworkInterface address=\"127.0.0.1\"/></Interfaces>"
         "<AllowMulticast>false</AllowMulticast></General>"
         "<Discovery>" +
         tag +
         "<ParticipantIndex>auto</ParticipantIndex>"
         "<MaxAutoParticipantIndex>30</MaxAutoParticipantIndex>"
         "<Peers><Peer address=\"127.0.0.1\"/></Peers>"
         "<LeaseDuration>2 s</LeaseDuration></Discovery>"
         "</Domain></CycloneDDS>";
}

// ---------------------------------------------------------------------------------------------
// ServiceBridge

core::Result<std::unique_ptr<ServiceBridge>> ServiceBridge::Create(const BridgeOptions& options) {
  auto domain = Domain::Open(options.domain_id, options.config);
  if (!domain) return domain.error();
  std::unique_ptr<ServiceBridge> bridge(new ServiceBridge(options));
  bridge->domain_ = std::move(domain).value();
  auto participant = bridge->domain_->CreateParticipant();
  if (!participant) return participant.error();
  bridge->participant_ = std::move(participant).value();
  const dds_entity_t pp = bridge->participant_.get();

  auto command_topic = CreateTopic(pp, &softgrasp_msg_GraspCommand_desc, kCommandTopic);
  auto result_topic = CreateTopic(pp, &softgrasp_msg_GraspResult_desc, kResultTopic);
  auto status_topic = CreateTopic(pp, &softgrasp_msg_RobotStatus_desc, kStatusTopic);
  auto pose_topic = CreateTopic(pp, &geometry_msgs_msg_dds__PoseStamped__desc, kPoseTopic);
  for (const auto* t : {&command_topic, &result_topic, &status_topic, &pose_topic}) {
    if (!*t) return t->error();
  }

  auto command_writer =
      Adopt(dds_create_writer(pp, command_topic.value(), CommandQos().get(), nullptr),
            "dds_create_writer(grasp_command)");
  if (!command_writer) return command_writer.error();
  bridge->command_writer_ = std::move(command_writer).value();
  auto pose_writer = Adopt(dds_create_writer(pp, pose_topic.value(), PoseQos().get(), nullptr),
                           "dds_create_writer(grasp_pose)");
  if (!pose_writer) return pose_writer.error();
  bridge->pose_writer_ = std::move(pose_writer).value();

  auto result_reader =
      CreateListeningReader(pp, result_topic.value(), ResultQos().get(), &ServiceBridge::OnResults,
                            bridge.get(), "dds_create_reader(grasp_result)");
  if (!result_reader) return result_reader.error();
  bridge->result_reader_ = std::move(result_reader).value();
  // The reader requests no liveliness (automatic, infinite) so robots with any lease match; the
  // writer's own lease still drives the instance state seen here.
  auto status_reader = CreateListeningReader(pp, status_topic.value(), StatusQos(0.0).get(),
                                             &ServiceBridge::OnStatus, bridge.get(),
                                             "dds_create_reader(robot_status)");
  if (!status_reader) return status_reader.error();
  bridge->status_reader_ = std::move(status_reader).value();
  // Historical (transient-local) samples may have arrived before the listeners were attached.
  bridge->DrainResults();
  bridge->DrainStatus();
  return bridge;
}

ServiceBridge::~ServiceBridge() {
  // Readers first: dds_delete waits for a running listener, after which none can start.
  status_reader_.Reset();
  result_reader_.Reset();
}

core::Result<Ok> ServiceBridge::Publish(GraspCommand command) {
  if (command.issued_unix_ns == 0) command.issued_unix_ns = UnixNowNs();
  auto valid = Validate(std::move(command));
  if (!valid) return valid.error();
  const GraspCommand& c = valid.value();
  auto sample = ToC(c);
  dds_return_t rc = dds_write(command_writer_.get(), sample.get());
  if (rc < 0) return DdsError(rc, "dds_write(grasp_command " + c.command_id + ")");
  auto pose = ToPoseStamped(c);
  rc = dds_write(pose_writer_.get(), pose.get());
  if (rc < 0) {
    return DdsError(rc, "command " + c.command_id + " was sent, but dds_write(grasp_pose)");
  }
  return Ok{};
}

void ServiceBridge::OnResults(dds_entity_t /*reader*/, void* self) {
  static_cast<ServiceBridge*>(self)->DrainResults();
}

void ServiceBridge::OnStatus(dds_entity_t /*reader*/, void* self) {
  static_cast<ServiceBridge*>(self)->DrainStatus();
}

void ServiceBridge::DrainResults() {
  std::vector<GraspResult> fresh;
  std::int64_t invalid = 0;
  // Runs on a Cyclone thread: a failed take cannot be reported to anyone, and the next
  // data-available event retries it.
  (void)TakeAll<softgrasp_msg_GraspResult>(
      result_reader_.get(), [&](const softgrasp_msg_GraspResult& c, const dds_sample_info_t& info) {
        if (!info.valid_data) return;  // a robot went away: its results stay valid
        auto r = FromC(c);
        if (r) {
          fresh.push_back(std::move(r).value());
        } else {
          ++invalid;
        }
      });
  if (fresh.empty() && invalid == 0) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    invalid_samples_ += invalid;
    for (auto& r : fresh) results_.push_back(std::move(r));
  }
  results_cv_.notify_all();
}

void ServiceBridge::DrainStatus() {
  const auto now = std::chrono::steady_clock::now();
  std::lock_guard<std::mutex> lock(mutex_);
  (void)TakeAll<softgrasp_msg_RobotStatus>(
      status_reader_.get(), [&](const softgrasp_msg_RobotStatus& c, const dds_sample_info_t& info) {
        const bool alive = info.instance_state == DDS_IST_ALIVE;
        if (!info.valid_data) {
          // Instance-state change only (writer gone, lease expired). The instance may already be
          // freed by this take, so find the robot by handle, not by dds_instance_get_key.
          auto id = robot_by_instance_.find(info.instance_handle);
          if (id == robot_by_instance_.end()) return;
          auto it = robots_.find(id->second);
          if (it != robots_.end()) it->second.alive = alive;
          return;
        }
        auto status = FromC(c);
        if (!status) {
          ++invalid_samples_;
          return;
        }
        robot_by_instance_[info.instance_handle] = status.value().robot_id;
        RobotEntry& entry = robots_[status.value().robot_id];
        entry.status = std::move(status).value();
        entry.alive = alive;
        entry.received = now;
      });
}

std::vector<GraspResult> ServiceBridge::PopAllLocked() {
  std::vector<GraspResult> out(std::make_move_iterator(results_.begin()),
                               std::make_move_iterator(results_.end()));
  results_.clear();
  return out;
}

std::vector<GraspResult> ServiceBridge::TakeResults() { return WaitForResults(0.0); }

std::vector<GraspResult> ServiceBridge::WaitForResults(double timeout_s) {
  std::vector<GraspResult> out;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    if (timeout_s > 0.0) {
      results_cv_.wait_for(lock, std::chrono::duration<double>(timeout_s),
                           [&] { return !results_.empty(); });
    }
    out = PopAllLocked();
  }
  // Retiring is best effort: a failure only means a late-joining robot could see the command
  // again, and robots refuse ids they already executed.
  for (const auto& r : out) (void)Retire(r.command_id);
  return out;
}

std::optional<GraspResult> ServiceBridge::WaitForResult(const std::string& command_id,
                                                        double timeout_s) {
  std::optional<GraspResult> found;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    auto find = [&] {
      auto it = std::find_if(results_.begin(), results_.end(),
                             [&](const GraspResult& r) { return r.command_id == command_id; });
      if (it == results_.end()) return false;
      found = std::move(*it);
      results_.erase(it);
      return true;
    };
    results_cv_.wait_for(lock, std::chrono::duration<double>(std::max(0.0, timeout_s)), find);
  }
  if (found) (void)Retire(found->command_id);
  return found;
}

core::Result<Ok> ServiceBridge::Retire(const std::string& command_id) {
  return UnregisterById<GraspCommand>(command_writer_.get(), command_id,
                                      "dds_unregister_instance(grasp_command)");
}

std::vector<RobotInfo> ServiceBridge::Robots() const {
  const auto now = std::chrono::steady_clock::now();
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<RobotInfo> out;
  out.reserve(robots_.size());
  for (const auto& [id, entry] : robots_) {
    out.push_back(RobotInfo{entry.status, entry.alive,
                            std::chrono::duration<double>(now - entry.received).count()});
  }
  return out;
}

std::vector<RobotInfo> ServiceBridge::AliveRobots() const {
  std::vector<RobotInfo> out = Robots();
  std::erase_if(out, [](const RobotInfo& r) { return !r.alive; });
  return out;
}

core::Result<int> ServiceBridge::MatchedCommandReaders() const {
  return MatchedCount(command_writer_.get(), /*writer=*/true);
}

std::int64_t ServiceBridge::invalid_samples() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return invalid_samples_;
}

// ---------------------------------------------------------------------------------------------
// RobotEndpoint

core::Result<std::unique_ptr<RobotEndpoint>> RobotEndpoint::Create(const BridgeOptions& options,
                                                                   std::string robot_id,
                                                                   bool simulated,
                                                                   Workspace workspace) {
  if (!(options.liveliness_lease_s > 0.0) || !std::isfinite(options.liveliness_lease_s)) {
    return MakeError(ErrorCode::kInvalidArgument, "liveliness_lease_s must be > 0",
                     "liveliness_lease_s");
  }
  if (!(options.heartbeat_period_s >= 0.0) ||
      options.heartbeat_period_s >= options.liveliness_lease_s) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "heartbeat_period_s must be >= 0 and below liveliness_lease_s",
                     "heartbeat_period_s");
  }
  if (options.max_kept_results < 1) {
    return MakeError(ErrorCode::kInvalidArgument, "max_kept_results must be >= 1",
                     "max_kept_results");
  }
  RobotStatus first;
  first.robot_id = std::move(robot_id);
  first.simulated = simulated;
  first.workspace = std::move(workspace);
  first.stamp_unix_ns = UnixNowNs();
  auto valid = Validate(std::move(first));
  if (!valid) return valid.error();

  auto domain = Domain::Open(options.domain_id, options.config);
  if (!domain) return domain.error();
  std::unique_ptr<RobotEndpoint> robot(new RobotEndpoint(options, valid.value().robot_id));
  robot->status_ = std::move(valid).value();
  robot->domain_ = std::move(domain).value();
  auto participant = robot->domain_->CreateParticipant();
  if (!participant) return participant.error();
  robot->participant_ = std::move(participant).value();
  const dds_entity_t pp = robot->participant_.get();

  auto command_topic = CreateTopic(pp, &softgrasp_msg_GraspCommand_desc, kCommandTopic);
  auto result_topic = CreateTopic(pp, &softgrasp_msg_GraspResult_desc, kResultTopic);
  auto status_topic = CreateTopic(pp, &softgrasp_msg_RobotStatus_desc, kStatusTopic);
  for (const auto* t : {&command_topic, &result_topic, &status_topic}) {
    if (!*t) return t->error();
  }
  auto status_writer =
      Adopt(dds_create_writer(pp, status_topic.value(), StatusQos(options.liveliness_lease_s).get(),
                              nullptr),
            "dds_create_writer(robot_status)");
  if (!status_writer) return status_writer.error();
  robot->status_writer_ = std::move(status_writer).value();
  auto result_writer =
      Adopt(dds_create_writer(pp, result_topic.value(), ResultQos().get(), nullptr),
            "dds_create_writer(grasp_result)");
  if (!result_writer) return result_writer.error();
  robot->result_writer_ = std::move(result_writer).value();
  auto command_reader =
      Adopt(dds_create_reader(pp, command_topic.value(), CommandQos().get(), nullptr),
            "dds_create_reader(grasp_command)");
  if (!command_reader) return command_reader.error();
  robot->command_reader_ = std::move(command_reader).value();

  auto waitset = Adopt(dds_create_waitset(pp), "dds_create_waitset");
  if (!waitset) return waitset.error();
  robot->waitset_ = std::move(waitset).value();
  auto condition = Adopt(dds_create_readcondition(robot->command_reader_.get(), DDS_ANY_STATE),
                         "dds_create_readcondition(grasp_command)");
  if (!condition) return condition.error();
  robot->read_condition_ = std::move(condition).value();
  const dds_return_t rc =
      dds_waitset_attach(robot->waitset_.get(), robot->read_condition_.get(), 0);
  if (rc < 0) return DdsError(rc, "dds_waitset_attach");

  {
    std::lock_guard<std::mutex> lock(robot->status_mutex_);
    auto written = robot->WriteStatusLocked();
    if (!written) return written.error();
  }
  if (options.heartbeat_period_s > 0.0) {
    robot->heartbeat_thread_ = std::thread([r = robot.get()] { r->HeartbeatLoop(); });
  }
  return robot;
}

RobotEndpoint::~RobotEndpoint() {
  {
    std::lock_guard<std::mutex> lock(stop_mutex_);
    stop_ = true;
  }
  stop_cv_.notify_all();
  if (heartbeat_thread_.joinable()) heartbeat_thread_.join();
  // Members then delete the DDS entities; the status writer's deletion unregisters this robot,
  // which readers see as NOT_ALIVE_NO_WRITERS.
}

core::Result<Ok> RobotEndpoint::WriteStatusLocked() {
  ++status_.heartbeat_seq;
  status_.stamp_unix_ns = UnixNowNs();
  auto sample = ToC(status_);
  const dds_return_t rc = dds_write(status_writer_.get(), sample.get());
  if (rc < 0) return DdsError(rc, "dds_write(robot_status)");
  return Ok{};
}

void RobotEndpoint::HeartbeatLoop() {
  const auto period = std::chrono::duration<double>(options_.heartbeat_period_s);
  std::unique_lock<std::mutex> stop_lock(stop_mutex_);
  while (!stop_cv_.wait_for(stop_lock, period, [&] { return stop_; })) {
    std::lock_guard<std::mutex> lock(status_mutex_);
    // A failed write is retried on the next tick; if writes keep failing the lease expires and
    // the service sees the robot as gone, which is the truth.
    (void)WriteStatusLocked();
  }
}

core::Result<Ok> RobotEndpoint::Heartbeat(RobotState state, std::string current_command_id,
                                          std::string detail) {
  std::lock_guard<std::mutex> lock(status_mutex_);
  RobotStatus next = status_;
  next.state = state;
  next.current_command_id = std::move(current_command_id);
  next.detail = std::move(detail);
  auto valid = Validate(std::move(next));
  if (!valid) return valid.error();
  status_ = std::move(valid).value();
  return WriteStatusLocked();
}

core::Result<int> RobotEndpoint::TakeOneCommand(std::optional<GraspCommand>* command) {
  void* samples[1] = {nullptr};
  dds_sample_info_t info;
  const dds_return_t n = dds_take(command_reader_.get(), samples, &info, 1, 1);
  if (n < 0) return DdsError(n, "dds_take(grasp_command)");
  if (n == 0) return 0;
  const auto& c = *static_cast<const softgrasp_msg_GraspCommand*>(samples[0]);
  const std::string id = c.command_id == nullptr ? std::string() : c.command_id;
  const std::string target = c.robot_id == nullptr ? std::string() : c.robot_id;
  const bool valid_data = info.valid_data;
  auto parsed = valid_data ? FromC(c) : core::Result<GraspCommand>(GraspCommand{});
  const dds_return_t rc = dds_return_loan(command_reader_.get(), samples, n);
  if (rc < 0) return DdsError(rc, "dds_return_loan(grasp_command)");

  // A retired command (instance-state change only), or one for another robot: not ours.
  if (!valid_data || (!target.empty() && target != robot_id_)) return 1;
  if (id.empty()) return 1;
  if (delivered_.count(id) != 0) {
    auto rewritten = RewriteKeptResult(id);
    if (!rewritten) return rewritten.error();
    return 1;
  }
  delivered_.insert(id);
  delivered_order_.push_back(id);
  if (delivered_order_.size() > kMaxRememberedCommands) {
    delivered_.erase(delivered_order_.front());
    delivered_order_.pop_front();
  }
  if (!parsed) {
    GraspResult rejected;
    rejected.command_id = id;
    rejected.outcome = GraspOutcome::kRejected;
    rejected.reason = "invalid command: " + parsed.error().message;
    // If even the rejection is invalid (e.g. the id has control characters) there is nobody we
    // could address it to; the service's own deadline turns it into timed_out.
    (void)PublishResult(std::move(rejected));
    return 1;
  }
  *command = std::move(parsed).value();
  return 1;
}

core::Result<Ok> RobotEndpoint::RewriteKeptResult(const std::string& command_id) {
  std::lock_guard<std::mutex> lock(results_mutex_);
  const auto it = std::find_if(kept_results_.rbegin(), kept_results_.rend(),
                               [&](const GraspResult& r) { return r.command_id == command_id; });
  if (it == kept_results_.rend()) return Ok{};  // still running, or forgotten
  auto sample = ToC(*it);
  const dds_return_t rc = dds_write(result_writer_.get(), sample.get());
  if (rc < 0) return DdsError(rc, "dds_write(grasp_result " + command_id + ")");
  return Ok{};
}

core::Result<std::optional<GraspCommand>> RobotEndpoint::WaitForCommand(double timeout_s) {
  std::lock_guard<std::mutex> lock(commands_mutex_);
  const auto deadline =
      std::chrono::steady_clock::now() + std::chrono::duration<double>(std::max(0.0, timeout_s));
  for (;;) {
    // Drain what is ready before waiting: skipped samples (other robots' commands, retirements)
    // must not hide a later one for us.
    for (;;) {
      std::optional<GraspCommand> command;
      auto taken = TakeOneCommand(&command);
      if (!taken) return taken.error();
      if (command) return command;
      if (taken.value() == 0) break;
    }
    const auto left = deadline - std::chrono::steady_clock::now();
    if (left <= std::chrono::steady_clock::duration::zero()) return std::optional<GraspCommand>();
    const dds_return_t rc =
        dds_waitset_wait(waitset_.get(), nullptr, 0,
                         std::chrono::duration_cast<std::chrono::nanoseconds>(left).count());
    if (rc < 0) return DdsError(rc, "dds_waitset_wait");
  }
}

core::Result<Ok> RobotEndpoint::PublishResult(GraspResult result) {
  if (result.robot_id.empty()) result.robot_id = robot_id_;
  if (result.finished_unix_ns == 0) result.finished_unix_ns = UnixNowNs();
  auto valid = Validate(std::move(result));
  if (!valid) return valid.error();
  auto sample = ToC(valid.value());
  std::lock_guard<std::mutex> lock(results_mutex_);
  const dds_return_t rc = dds_write(result_writer_.get(), sample.get());
  if (rc < 0) return DdsError(rc, "dds_write(grasp_result " + valid.value().command_id + ")");
  // Keep the newest results for services that (re)join; drop the oldest beyond the limit.
  kept_results_.push_back(std::move(valid).value());
  while (kept_results_.size() > static_cast<std::size_t>(options_.max_kept_results)) {
    auto dropped =
        UnregisterById<GraspResult>(result_writer_.get(), kept_results_.front().command_id,
                                    "dds_unregister_instance(grasp_result)");
    kept_results_.pop_front();
    if (!dropped) return dropped.error();
  }
  return Ok{};
}

core::Result<int> RobotEndpoint::MatchedResultReaders() const {
  return MatchedCount(result_writer_.get(), /*writer=*/true);
}

}  // namespace softgrasp::bridge
