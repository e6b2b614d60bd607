#pragma once
// One input topic -> one output topic, with the frame accounting of
// dds/stage_metrics.hpp: gaps in sample_seq counted as superseded, a sample
// that fails validation (InputError) as malformed, any other exception as
// processing_error; end-of-stream forwarded (as a marker when the last frame
// was dropped). The stage supplies one function that converts, computes and
// fills the output sample (borrowing its own buffers) or throws.
#include <chrono>
#include <cstdint>
#include <exception>
#include <string>

#include <spdlog/logger.h>

#include "config/errors.hpp"
#include "dds/conversions.hpp"
#include "dds/service.hpp"

namespace sg::dds {

template <class InMsg, class OutMsg>
class PipeStage {
 public:
  PipeStage(ServiceRuntime& runtime, const char* in_topic, const char* out_topic, std::uint64_t frame_limit)
      : runtime_(runtime),
        reader_(runtime.participant(), in_topic, runtime.transport().images),
        writer_(runtime.participant(), out_topic,
                std::string(out_topic) == kFeatureFrameTopic ? runtime.transport().images
                                                             : runtime.transport().results),
        frame_limit_(frame_limit) {
    runtime_.attach(reader_.dataAvailable(), 1);
  }

  Reader<InMsg>& reader() { return reader_; }
  Writer<OutMsg>& writer() { return writer_; }

  // compute(const InMsg& in, const FrameInfo& info, OutMsg& out): fills `out`
  // completely (its header from `info`); throws to drop the frame.
  template <class Compute>
  void run(Compute compute) {
    StageStats& stats = runtime_.stats();
    bool done = false;
    while (!done && !runtime_.stopping()) {
      runtime_.wait();
      runtime_.watchQos(reader_, "input reader");
      runtime_.watchQos(writer_, "output writer");
      auto samples = reader_.take();
      for (std::size_t i = 0; i < samples.size() && !done; ++i) {
        if (!samples.valid(i)) continue;
        const InMsg& in = samples[i];
        const FrameInfo info = readHeader(in.header);
        const std::uint64_t gap = gaps_.gapBefore(samples.info(i).publication_handle, info.sample_seq);
        if (gap > 0) {
          stats.received(gap);
          stats.dropped(kDropSuperseded, gap);
          runtime_.log().debug("{} sample(s) superseded before frame {}", gap, info.frame_id);
        }
        if (!info.payload_valid) {  // end-of-stream marker, not a frame
          if (info.end_of_stream) {
            publishMarker(info);
            done = true;
          }
          continue;
        }
        stats.received(1);
        const bool last = info.end_of_stream || (frame_limit_ > 0 && stats.framesReceived() >= frame_limit_);
        const auto start = std::chrono::steady_clock::now();
        bool ok = false;
        OutMsg out{};
        try {
          compute(in, info, out);
          ok = true;
        } catch (const InputError& e) {
          stats.dropped(kDropMalformed);
          runtime_.log().warn("frame {} dropped (malformed): {}", info.frame_id, e.what());
        } catch (const std::exception& e) {
          stats.dropped(kDropProcessingError);
          runtime_.log().error("frame {} dropped (processing error): {}", info.frame_id, e.what());
        }
        stats.processed(msBetween(start, std::chrono::steady_clock::now()));
        if (ok) {
          out.header.end_of_stream = last;
          publish(out, info);
        } else if (last) {
          publishMarker(info);
        }
        if (last) done = true;
      }
    }
    if (done) writer_.waitForAcks(std::chrono::seconds(5));
  }

 private:
  void ensureMatched() {
    if (matched_once_) return;
    matched_once_ = true;
    const auto timeout = std::chrono::milliseconds(static_cast<long>(runtime_.transport().match_timeout_s * 1000.0));
    if (!writer_.waitForReaders(1, timeout, [this] { return runtime_.stopping(); })) {
      runtime_.log().warn("no reader matched on {} within {} s; publishing anyway", writer_.topic().name(),
                          runtime_.transport().match_timeout_s);
    }
  }

  void publish(OutMsg& out, const FrameInfo& info) {
    ensureMatched();
    out.header.sample_seq = next_seq_++;
    writer_.write(out);
    runtime_.stats().published(static_cast<double>(realtimeNowNs() - info.capture_time_ns) * 1e-6);
  }

  void publishMarker(const FrameInfo& info) {
    ensureMatched();
    FrameInfo marker = info;
    marker.payload_valid = false;
    marker.end_of_stream = true;
    marker.sample_seq = next_seq_++;
    OutMsg out{};
    fillHeader(marker, out.header);
    writer_.write(out);
  }

  ServiceRuntime& runtime_;
  TopicReader<InMsg> reader_;
  TopicWriter<OutMsg> writer_;
  SampleGapCounter gaps_;
  std::uint64_t frame_limit_;
  std::uint64_t next_seq_ = 0;
  bool matched_once_ = false;
};

}  // namespace sg::dds
