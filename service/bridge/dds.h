#pragma once
/// Thin RAII layer over the Cyclone DDS C API: owned entity handles, owned QoS objects, the
/// process-wide domain registry, and the translation of dds_return_t codes into core::Error.

#include <dds/dds.h>

#include <memory>
#include <string>

#include "service/core/status.h"

namespace softgrasp::bridge {

/// Error for a failed DDS call: kInternal, message "<what>: <DDS error text> (<code>)".
core::Error DdsError(dds_return_t code, const std::string& what);

/// Owns one DDS entity handle (participant, topic, reader, writer, waitset, condition) and
/// deletes it, and with it its children, when it goes. Move-only; 0 means "none".
class Entity {
 public:
  Entity() = default;
  explicit Entity(dds_entity_t handle) : handle_(handle) {}
  ~Entity() { Reset(); }
  Entity(const Entity&) = delete;
  Entity& operator=(const Entity&) = delete;
  Entity(Entity&& other) noexcept : handle_(other.handle_) { other.handle_ = 0; }
  Entity& operator=(Entity&& other) noexcept;

  dds_entity_t get() const { return handle_; }
  /// Deletes the entity now. A child already deleted with its parent is not an error here.
  void Reset();

 private:
  dds_entity_t handle_ = 0;
};

/// Wraps a dds_create_* result: the handle, or an Error naming `what` with the DDS text.
core::Result<Entity> Adopt(dds_entity_t handle_or_error, const std::string& what);

struct QosDeleter {
  void operator()(dds_qos_t* qos) const { dds_delete_qos(qos); }
};
using Qos = std::unique_ptr<dds_qos_t, QosDeleter>;

/// The QoS of each topic (docs/robot-bridge.md explains each choice). Readers and writers of a
/// topic use the same QoS, so what the bridge offers is always what it requests.
///
/// Commands: reliable, transient-local, keep-last 1 per command instance. A robot that
/// (re)joins gets commands the service still holds; the service retires (unregisters) a command
/// when its result arrives, so a finished command is never replayed.
Qos CommandQos();
/// Results: reliable, transient-local, keep-last 1 per command instance, so a service that
/// restarts while the robot runs still receives results written while it was away.
Qos ResultQos();
/// Robot status: reliable, transient-local, keep-last 1 per robot, liveliness MANUAL_BY_TOPIC
/// with `lease_s`: a robot that stops writing heartbeats (hang, crash, unplugged cable) loses
/// liveliness after the lease and its instance goes NOT_ALIVE_NO_WRITERS at every reader.
/// Writers keep their instances registered-but-not-disposed when deleted (autodispose off), so a
/// robot that exits also reads as NOT_ALIVE_NO_WRITERS.
Qos StatusQos(double lease_s);
/// PoseStamped for ROS 2: reliable, transient-local, keep-last 10. Compatible with ROS 2's
/// default subscription (reliable, volatile, keep-last 10) and with "latched" (transient-local)
/// subscriptions, which get the latest poses on joining.
Qos PoseQos();

/// A reference to one Cyclone DDS domain instance in this process, created from an XML config.
/// Domains are shared: everything in the process that asks for the same domain id gets the same
/// instance (in-process endpoints then talk through it directly), and it is deleted when the last
/// reference goes.
class Domain {
 public:
  /// Opens domain `domain_id` (0..232) with `config`: Cyclone XML (`<CycloneDDS>...`) or a list
  /// of file URIs, exactly what CYCLONEDDS_URI accepts. Empty `config` means the CYCLONEDDS_URI
  /// environment variable (or Cyclone's defaults if unset). Errors (kInvalidArgument): bad id,
  /// config rejected by Cyclone, or the domain already open in this process with another config.
  static core::Result<std::shared_ptr<Domain>> Open(int domain_id, const std::string& config);

  ~Domain();
  Domain(const Domain&) = delete;
  Domain& operator=(const Domain&) = delete;

  int id() const { return domain_id_; }
  const std::string& config() const { return config_; }

  /// Creates a participant in this domain. The caller must keep this Domain alive as long as the
  /// participant: deleting the domain deletes its participants.
  core::Result<Entity> CreateParticipant() const;

 private:
  Domain(int domain_id, std::string config, dds_entity_t handle)
      : domain_id_(domain_id), config_(std::move(config)), handle_(handle) {}
  int domain_id_;
  std::string config_;
  dds_entity_t handle_;
};

}  // namespace softgrasp::bridge
