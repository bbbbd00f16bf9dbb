#pragma once
/// The robot bridge over Cyclone DDS: the service side (ServiceBridge) forwards grasps and hears
/// results and heartbeats; the robot side (RobotEndpoint) is what a robot process runs. Topics,
/// QoS and liveliness are documented in docs/robot-bridge.md.

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "service/bridge/dds.h"
#include "service/bridge/messages.h"
#include "service/core/status.h"

namespace softgrasp::bridge {

/// DDS topic names. Only the pose topic follows ROS 2's "rt/" convention: it is the one a ROS 2
/// node reads with a standard type.
inline constexpr char kCommandTopic[] = "softgrasp/grasp_command";
inline constexpr char kResultTopic[] = "softgrasp/grasp_result";
inline constexpr char kStatusTopic[] = "softgrasp/robot_status";
inline constexpr char kPoseTopic[] = "rt/softgrasp/grasp_pose";

struct BridgeOptions {
  int domain_id = 0;  ///< DDS domain, 0..232 (ROS 2's ROS_DOMAIN_ID is the same number)
  /// Cyclone config: XML or file URIs, as CYCLONEDDS_URI takes; "" = the CYCLONEDDS_URI
  /// environment variable, else Cyclone's defaults. See LoopbackConfigXml().
  std::string config;
  /// Robot side: liveliness lease of the status writer. A robot silent this long is not alive.
  double liveliness_lease_s = 2.0;
  /// Robot side: a background thread re-sends the current status this often (0 = only on
  /// Heartbeat()). Must be well below the lease; lease / 4 leaves room for lost packets.
  double heartbeat_period_s = 0.5;
  /// Robot side: how many result instances the robot keeps for late-joining services before
  /// unregistering the oldest.
  int max_kept_results = 256;
};

/// Cyclone DDS 0.10 config for loopback-only traffic: the 127.0.0.1 interface, multicast off,
/// unicast discovery to the local peer (participant indices auto, up to 31 processes per domain),
/// and a 2 s participant lease. Tests use it; so can a single-host deployment. A non-empty
/// `discovery_tag` (Discovery/Tag) hides this process from processes with another tag on the same
/// domain, so test runs in parallel never see each other. @throws std::invalid_argument unless
/// the tag is [A-Za-z0-9_-]*.
std::string LoopbackConfigXml(const std::string& discovery_tag = "");

/// Service side: publishes commands (and their ROS 2 pose), receives results and heartbeats.
/// Thread-safe. Not movable (DDS listeners point at it); hold it by the unique_ptr.
class ServiceBridge {
 public:
  static core::Result<std::unique_ptr<ServiceBridge>> Create(const BridgeOptions& options);
  ~ServiceBridge();
  ServiceBridge(const ServiceBridge&) = delete;
  ServiceBridge& operator=(const ServiceBridge&) = delete;

  /// Validates the command, writes it on softgrasp/grasp_command and its pose on
  /// rt/softgrasp/grasp_pose. An invalid command is kUnprocessable and nothing is sent.
  /// issued_unix_ns = 0 is replaced by the current time. Publishing an id again rewrites the
  /// same instance; robots never run an id twice. If only the pose write fails, the error says
  /// the command itself was sent.
  core::Result<Ok> Publish(GraspCommand command);

  /// Results received since the last call, oldest first (never blocks). Each result retires its
  /// command (see Retire). Invalid results from a foreign robot are dropped and counted.
  std::vector<GraspResult> TakeResults();
  /// Like TakeResults, but waits up to `timeout_s` for at least one result.
  std::vector<GraspResult> WaitForResults(double timeout_s);
  /// Waits up to `timeout_s` for the result of `command_id` (other results stay queued).
  std::optional<GraspResult> WaitForResult(const std::string& command_id, double timeout_s);

  /// Unregisters a command so the service stops offering it to robots that join later (used for
  /// commands that timed out). Unknown or already retired ids are fine.
  core::Result<Ok> Retire(const std::string& command_id);

  /// Every robot heard from since the bridge started, sorted by id, with its liveness.
  std::vector<RobotInfo> Robots() const;
  /// The alive ones among Robots().
  std::vector<RobotInfo> AliveRobots() const;

  /// Number of robot command readers currently matched (discovery progress; for tests/health).
  core::Result<int> MatchedCommandReaders() const;
  /// Samples dropped because they failed validation (foreign or corrupt writers).
  std::int64_t invalid_samples() const;

  const BridgeOptions& options() const { return options_; }

 private:
  explicit ServiceBridge(BridgeOptions options) : options_(std::move(options)) {}
  static void OnResults(dds_entity_t reader, void* self);
  static void OnStatus(dds_entity_t reader, void* self);
  void DrainResults();
  void DrainStatus();
  std::vector<GraspResult> PopAllLocked();

  struct RobotEntry {
    RobotStatus status;
    bool alive = false;
    std::chrono::steady_clock::time_point received;
  };

  BridgeOptions options_;
  mutable std::mutex mutex_;
  std::condition_variable results_cv_;
  std::deque<GraspResult> results_;
  std::map<std::string, RobotEntry> robots_;
  std::map<dds_instance_handle_t, std::string> robot_by_instance_;
  std::int64_t invalid_samples_ = 0;

  // DDS entities last: they are deleted first (listeners stop before the state above goes).
  std::shared_ptr<Domain> domain_;
  Entity participant_;
  Entity command_writer_;
  Entity pose_writer_;
  Entity result_reader_;
  Entity status_reader_;
};

/// Robot side: heartbeats, receives the commands meant for this robot, publishes results.
/// This is the reference implementation of the robot half of the contract; a vendor may use it
/// or implement the same topics with any DDS. Thread-safe. Not movable.
class RobotEndpoint {
 public:
  /// Joins the bus as `robot_id` and writes a first IDLE heartbeat. Errors: invalid id or
  /// workspace (kUnprocessable), bad options or config (kInvalidArgument), DDS failures.
  static core::Result<std::unique_ptr<RobotEndpoint>> Create(const BridgeOptions& options,
                                                             std::string robot_id, bool simulated,
                                                             Workspace workspace);
  ~RobotEndpoint();
  RobotEndpoint(const RobotEndpoint&) = delete;
  RobotEndpoint& operator=(const RobotEndpoint&) = delete;

  /// Sets the state (and what it is doing / why it faulted) and writes a heartbeat now; the
  /// background thread keeps repeating it.
  core::Result<Ok> Heartbeat(RobotState state, std::string current_command_id = {},
                             std::string detail = {});

  /// Waits up to `timeout_s` for the next command addressed to this robot or to any robot.
  /// Commands for other robots, repeats of an id already delivered, and retirements are skipped.
  /// A repeat of an id whose result is still kept writes that result again: a service that sends
  /// an id another service already had executed (replicas behind a balancer) hears its outcome
  /// instead of waiting for one that will never come, and the robot does not move twice.
  /// An invalid command (NaN, bad quaternion, ...) is answered with a REJECTED result here and
  /// not returned. Returns nullopt on timeout.
  core::Result<std::optional<GraspCommand>> WaitForCommand(double timeout_s);

  /// Publishes a result (robot_id is filled in if empty). Invalid results are kUnprocessable.
  core::Result<Ok> PublishResult(GraspResult result);

  /// Number of service result readers currently matched.
  core::Result<int> MatchedResultReaders() const;

  const std::string& robot_id() const { return robot_id_; }

 private:
  RobotEndpoint(BridgeOptions options, std::string robot_id)
      : options_(std::move(options)), robot_id_(std::move(robot_id)) {}
  core::Result<Ok> WriteStatusLocked();
  void HeartbeatLoop();
  /// Takes at most one command sample (returns how many: 0 or 1) and sets `command` if it is a
  /// new, valid command for this robot.
  core::Result<int> TakeOneCommand(std::optional<GraspCommand>* command);
  /// Writes the kept result of `command_id` again, if there is one.
  core::Result<Ok> RewriteKeptResult(const std::string& command_id);

  BridgeOptions options_;
  std::string robot_id_;

  std::mutex status_mutex_;  // guards status_ and the write order of heartbeats
  RobotStatus status_;
  std::mutex results_mutex_;
  std::deque<GraspResult> kept_results_;  // oldest first, at most options_.max_kept_results
  std::mutex commands_mutex_;             // one WaitForCommand at a time
  std::set<std::string> delivered_;
  std::deque<std::string> delivered_order_;

  std::mutex stop_mutex_;
  std::condition_variable stop_cv_;
  bool stop_ = false;
  std::thread heartbeat_thread_;

  std::shared_ptr<Domain> domain_;
  Entity participant_;
  Entity status_writer_;
  Entity result_writer_;
  Entity command_reader_;
  Entity waitset_;
  Entity read_condition_;
};

}  // namespace softgrasp::bridge
