#pragma once
// QoS of one reader or writer, from YAML (config/params.hpp table), and the
// transport section every service configuration shares. Why the defaults
// are what they are: docs/transport.md.
#include <dds/dds.h>

#include "config/params.hpp"

namespace sg::dds {

struct QosParams {
  bool reliable = true;              // RELIABLE (retransmits) or BEST_EFFORT
  int history_depth = 1;             // KEEP_LAST depth (samples); 0 = KEEP_ALL (back-pressure on the writer)
  bool transient_local = false;      // TRANSIENT_LOCAL: a late joiner gets the writer's history
  double deadline_ms = 0.0;          // expected period between samples (milliseconds); 0 = none
  double liveliness_lease_ms = 0.0;  // AUTOMATIC liveliness lease (milliseconds); 0 = infinite

  template <class V>
  void visit(V& v) {
    v.field("reliable", reliable, 0, 1, "", "RELIABLE (true) or BEST_EFFORT (false)");
    v.field("history_depth", history_depth, 0, 1000, "samples", "KEEP_LAST depth; 0 = KEEP_ALL");
    v.field("transient_local", transient_local, 0, 1, "", "a late-joining reader gets the last samples");
    v.field("deadline_ms", deadline_ms, 0, 3.6e6, "milliseconds", "expected sample period; 0 = none");
    v.field("liveliness_lease_ms", liveliness_lease_ms, 0, 3.6e6, "milliseconds",
            "automatic liveliness lease; 0 = infinite");
  }
  void validate() const { validateParams(*this, "qos"); }

  // Image topics: the newest frame only; a slow stage skips frames instead of queueing latency.
  static QosParams images() { return {}; }
  // Results: a few kept, and a late-joining display gets the last ones.
  static QosParams results() {
    QosParams q;
    q.history_depth = 8;
    q.transient_local = true;
    return q;
  }
  // Metrics: one per stage (keyed), the last kept for late joiners.
  static QosParams metrics() {
    QosParams q;
    q.history_depth = 1;
    q.transient_local = true;
    return q;
  }
};

// The `transport:` section of every service configuration. Writers and
// readers of one topic must use compatible values; keep the per-topic groups
// identical in every file (they are by default).
struct TransportParams {
  int domain_id = 0;                       // overridden by SG_DDS_DOMAIN when set
  QosParams images = QosParams::images();  // stereo_frame, feature_frame
  QosParams results = QosParams::results();  // segmentation, human_detections
  QosParams metrics = QosParams::metrics();  // stage_metrics
  double metrics_period_s = 1.0;           // StageMetrics publication period
  double match_timeout_s = 10.0;           // how long a writer waits for a reader before its first sample

  template <class V>
  void visit(V& v) {
    v.field("domain_id", domain_id, 0, 230, "", "DDS domain id (SG_DDS_DOMAIN overrides)");
    v.group("images", images);
    v.group("results", results);
    v.group("metrics", metrics);
    v.field("metrics_period_s", metrics_period_s, 0.05, 60, "seconds", "StageMetrics publication period");
    v.field("match_timeout_s", match_timeout_s, 0, 600, "seconds",
            "wait at most this long for a matched reader before the first write");
  }
  void validate() const { validateParams(*this, "transport"); }
};

// RAII dds_qos_t built from QosParams.
class Qos {
 public:
  explicit Qos(const QosParams& params);
  ~Qos();
  Qos(const Qos&) = delete;
  Qos& operator=(const Qos&) = delete;
  const dds_qos_t* get() const { return qos_; }

 private:
  dds_qos_t* qos_;
};

}  // namespace sg::dds
