#include "service/bridge/dds.h"

#include <cstdlib>
#include <map>
#include <mutex>
#include <utility>

namespace softgrasp::bridge {
namespace {

using core::ErrorCode;
using core::MakeError;

dds_duration_t Seconds(double s) { return static_cast<dds_duration_t>(s * 1e9); }

// Reliable writers block at most this long when the history is full before write() fails.
constexpr double kMaxBlockingS = 1.0;

Qos NewReliableQos(dds_durability_kind_t durability, int32_t depth) {
  Qos qos(dds_create_qos());
  dds_qset_reliability(qos.get(), DDS_RELIABILITY_RELIABLE, Seconds(kMaxBlockingS));
  dds_qset_durability(qos.get(), durability);
  dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, depth);
  return qos;
}

// The process-wide registry of open domains. Reference counts are explicit (not weak_ptr
// expiry) so that a domain is deleted and forgotten under one lock: a concurrent Open of the
// same id never sees a half-deleted domain.
struct Registered {
  Domain* domain = nullptr;
  int refs = 0;
};

std::mutex& RegistryMutex() {
  static std::mutex mutex;
  return mutex;
}

std::map<int, Registered>& Registry() {
  static std::map<int, Registered> registry;
  return registry;
}

}  // namespace

core::Error DdsError(dds_return_t code, const std::string& what) {
  return MakeError(ErrorCode::kInternal,
                   what + ": " + dds_strretcode(code) + " (" + std::to_string(code) + ")");
}

Entity& Entity::operator=(Entity&& other) noexcept {
  if (this != &other) {
    Reset();
    handle_ = other.handle_;
    other.handle_ = 0;
  }
  return *this;
}

void Entity::Reset() {
  if (handle_ > 0) {
    // Deleting a parent deletes its children, so a child's own delete may find it gone
    // (DDS_RETCODE_BAD_PARAMETER / ALREADY_DELETED); nothing else can fail for a valid handle,
    // and a destructor has nobody to report to.
    (void)dds_delete(handle_);
  }
  handle_ = 0;
}

core::Result<Entity> Adopt(dds_entity_t handle_or_error, const std::string& what) {
  if (handle_or_error < 0) return DdsError(handle_or_error, what);
  return Entity(handle_or_error);
}

Qos CommandQos() { return NewReliableQos(DDS_DURABILITY_TRANSIENT_LOCAL, 1); }

Qos ResultQos() { return NewReliableQos(DDS_DURABILITY_TRANSIENT_LOCAL, 1); }

Qos StatusQos(double lease_s) {
  Qos qos = NewReliableQos(DDS_DURABILITY_TRANSIENT_LOCAL, 1);
  if (lease_s > 0.0) {
    dds_qset_liveliness(qos.get(), DDS_LIVELINESS_MANUAL_BY_TOPIC, Seconds(lease_s));
  }
  dds_qset_writer_data_lifecycle(qos.get(), false);
  return qos;
}

Qos PoseQos() { return NewReliableQos(DDS_DURABILITY_TRANSIENT_LOCAL, 10); }

core::Result<std::shared_ptr<Domain>> Domain::Open(int domain_id, const std::string& config) {
  // Cyclone's own limit: the DDSI port mapping has room for domain ids 0..232.
  if (domain_id < 0 || domain_id > 232) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "domain_id " + std::to_string(domain_id) + " is outside 0..232", "domain_id");
  }
  std::string resolved = config;
  if (resolved.empty()) {
    const char* env = std::getenv("CYCLONEDDS_URI");
    if (env != nullptr) resolved = env;
  }
  auto release = [](Domain* d) {
    std::lock_guard<std::mutex> lock(RegistryMutex());
    auto it = Registry().find(d->id());
    if (it != Registry().end() && --it->second.refs == 0) {
      Registry().erase(it);
      delete d;
    }
  };
  std::lock_guard<std::mutex> lock(RegistryMutex());
  auto it = Registry().find(domain_id);
  if (it != Registry().end()) {
    if (it->second.domain->config() != resolved) {
      return MakeError(ErrorCode::kInvalidArgument,
                       "domain " + std::to_string(domain_id) +
                           " is already open in this process with a different Cyclone config",
                       "config");
    }
    ++it->second.refs;
    return std::shared_ptr<Domain>(it->second.domain, release);
  }
  const dds_entity_t handle =
      dds_create_domain(static_cast<dds_domainid_t>(domain_id), resolved.c_str());
  if (handle == DDS_RETCODE_PRECONDITION_NOT_MET) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "domain " + std::to_string(domain_id) +
                         " was created in this process outside the bridge; its config is unknown",
                     "domain_id");
  }
  if (handle < 0) {
    // Cyclone prints the offending element to stderr; the code alone says little.
    return MakeError(ErrorCode::kInvalidArgument,
                     "Cyclone DDS rejected the config for domain " + std::to_string(domain_id) +
                         " (" + dds_strretcode(handle) +
                         "; see its message on stderr). Config: " + resolved.substr(0, 200),
                     "config");
  }
  auto* domain = new Domain(domain_id, resolved, handle);
  Registry()[domain_id] = Registered{domain, 1};
  return std::shared_ptr<Domain>(domain, release);
}

Domain::~Domain() {
  // Deleting the domain deletes every participant still in it; owners released theirs first.
  (void)dds_delete(handle_);
}

core::Result<Entity> Domain::CreateParticipant() const {
  return Adopt(dds_create_participant(static_cast<dds_domainid_t>(domain_id_), nullptr, nullptr),
               "dds_create_participant(domain " + std::to_string(domain_id_) + ")");
}

}  // namespace softgrasp::bridge
