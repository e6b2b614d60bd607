#include "dds/dds.hpp"

#include <pthread.h>
#include <signal.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <string>

#include "config/errors.hpp"

namespace sg::dds {

dds_return_t check(dds_return_t rc, const char* what) {
  if (rc < 0) throw DdsError(std::string(what) + " failed: " + dds_strretcode(-rc), rc);
  return rc;
}

dds_entity_t checkEntity(dds_entity_t entity, const char* what) {
  if (entity < 0) throw DdsError(std::string(what) + " failed: " + dds_strretcode(-entity), entity);
  return entity;
}

dds_entity_t checkEntity(dds_entity_t entity, const char* what, const std::string& topic, const char* access) {
  if (entity >= 0) return entity;
  std::string message = std::string(what) + " for topic '" + topic + "' failed: " + dds_strretcode(-entity);
  if (entity == DDS_RETCODE_NOT_ALLOWED_BY_SECURITY) {
    message += " (the permissions of this DDS Security identity do not grant " + std::string(access) + " it)";
  }
  throw DdsError(message, entity);
}

void requireDdsConfig() {
  const char* uri = std::getenv("CYCLONEDDS_URI");
  if (uri == nullptr || uri[0] == '\0') {
    throw InputError(
        "CYCLONEDDS_URI is not set: refusing to start DDS on the default (external) network interface; "
        "point it at a configuration, e.g. CYCLONEDDS_URI=file://<repo>/config/dds/loopback.xml");
  }
}

dds_domainid_t domainId(int configured) {
  if (const char* env = std::getenv("SG_DDS_DOMAIN"); env != nullptr && env[0] != '\0') {
    char* end = nullptr;
    const long id = std::strtol(env, &end, 10);
    if (*end != '\0' || id < 0 || id > 230) {
      throw InputError(std::string("SG_DDS_DOMAIN = '") + env + "' must be an integer in [0, 230]");
    }
    return static_cast<dds_domainid_t>(id);
  }
  if (configured < 0 || configured > 230) {
    throw InputError("transport.domain_id = " + std::to_string(configured) + " must be in [0, 230]");
  }
  return static_cast<dds_domainid_t>(configured);
}

void Entity::reset() {
  if (handle_ > 0) dds_delete(handle_);  // may already be gone with its parent: the result is irrelevant
  handle_ = 0;
}

Participant::Participant(dds_domainid_t domain)
    : Entity((requireDdsConfig(), checkEntity(dds_create_participant(domain, nullptr, nullptr),
                                               "dds_create_participant"))) {}

Qos::Qos(const QosParams& params) : qos_(dds_create_qos()) {
  params.validate();
  dds_qset_reliability(qos_, params.reliable ? DDS_RELIABILITY_RELIABLE : DDS_RELIABILITY_BEST_EFFORT,
                       DDS_MSECS(100));
  if (params.history_depth == 0) dds_qset_history(qos_, DDS_HISTORY_KEEP_ALL, 0);
  else dds_qset_history(qos_, DDS_HISTORY_KEEP_LAST, params.history_depth);
  dds_qset_durability(qos_, params.transient_local ? DDS_DURABILITY_TRANSIENT_LOCAL : DDS_DURABILITY_VOLATILE);
  if (params.deadline_ms > 0.0) {
    dds_qset_deadline(qos_, static_cast<dds_duration_t>(std::llround(params.deadline_ms * 1e6)));
  }
  if (params.liveliness_lease_ms > 0.0) {
    dds_qset_liveliness(qos_, DDS_LIVELINESS_AUTOMATIC,
                        static_cast<dds_duration_t>(std::llround(params.liveliness_lease_ms * 1e6)));
  }
}

Qos::~Qos() { dds_delete_qos(qos_); }

GuardCondition::GuardCondition(const Participant& participant)
    : Entity(checkEntity(dds_create_guardcondition(participant.handle()), "dds_create_guardcondition")) {}

void GuardCondition::set() { check(dds_set_guardcondition(handle(), true), "dds_set_guardcondition"); }

bool GuardCondition::triggered() const {
  bool value = false;
  check(dds_read_guardcondition(handle(), &value), "dds_read_guardcondition");
  return value;
}

WaitSet::WaitSet(const Participant& participant)
    : Entity(checkEntity(dds_create_waitset(participant.handle()), "dds_create_waitset")) {}

void WaitSet::attach(dds_entity_t entity, dds_attach_t token) {
  check(dds_waitset_attach(handle(), entity, token), "dds_waitset_attach");
}

std::vector<dds_attach_t> WaitSet::wait(std::chrono::milliseconds timeout) {
  std::array<dds_attach_t, 16> triggered{};
  const dds_return_t n =
      check(dds_waitset_wait(handle(), triggered.data(), triggered.size(), DDS_MSECS(timeout.count())),
            "dds_waitset_wait");
  return {triggered.begin(), triggered.begin() + std::min<std::ptrdiff_t>(n, static_cast<std::ptrdiff_t>(triggered.size()))};
}

namespace {

// SIGUSR2 only wakes the helper thread for its own shutdown.
sigset_t handledSignals() {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGTERM);
  sigaddset(&set, SIGUSR2);
  return set;
}

}  // namespace

ShutdownSignal::ShutdownSignal() {
  const sigset_t set = handledSignals();
  if (const int rc = pthread_sigmask(SIG_BLOCK, &set, nullptr); rc != 0) {
    throw DdsError("pthread_sigmask failed: error " + std::to_string(rc));
  }
  thread_ = std::thread([this] { run(); });
}

ShutdownSignal::~ShutdownSignal() {
  pthread_kill(thread_.native_handle(), SIGUSR2);
  thread_.join();
}

void ShutdownSignal::run() {
  const sigset_t set = handledSignals();
  for (;;) {
    int sig = 0;
    if (sigwait(&set, &sig) != 0) continue;
    if (sig == SIGUSR2) return;
    signal_.store(sig);
    requested_.store(true);
    std::lock_guard lock(mutex_);
    if (guard_ != nullptr) {
      try {
        guard_->set();
      } catch (const DdsError&) {
        // the participant is being deleted: the flag above still ends the loops
      }
    }
  }
}

void ShutdownSignal::bind(GuardCondition& guard) {
  std::lock_guard lock(mutex_);
  guard_ = &guard;
  if (requested_.load()) guard.set();
}

void ShutdownSignal::unbind() {
  std::lock_guard lock(mutex_);
  guard_ = nullptr;
}

}  // namespace sg::dds
