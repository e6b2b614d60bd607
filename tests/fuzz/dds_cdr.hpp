#pragma once
// CDR (XCDR1, the encoding the stereoguard writers use) <-> IDL samples with
// Cyclone's own stream functions: the same validation ("normalize") and
// deserialization a DDS reader applies to a sample arriving from the network.
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include <dds/dds.h>
#include <dds/ddsi/ddsi_cdrstream.h>

namespace sg::fuzz {

// Serializes `sample` (native byte order) without the 4-byte encapsulation header.
inline std::vector<std::uint8_t> toCdr(const void* sample, const dds_topic_descriptor_t& desc) {
  dds_ostream_t os;
  dds_ostream_init(&os, 0, 1);
  dds_stream_write(&os, static_cast<const char*>(sample), desc.m_ops);
  std::vector<std::uint8_t> bytes(os.m_buffer, os.m_buffer + os.m_index);
  dds_ostream_fini(&os);
  return bytes;
}

// A deserialized sample, freed with the descriptor's ops.
class CdrSample {
 public:
  explicit CdrSample(const dds_topic_descriptor_t& desc) : desc_(desc), sample_(std::calloc(1, desc.m_size)) {}
  ~CdrSample() {
    if (loaded_) dds_stream_free_sample(sample_, desc_.m_ops);
    std::free(sample_);
  }
  CdrSample(const CdrSample&) = delete;
  CdrSample& operator=(const CdrSample&) = delete;

  // False when Cyclone's validation rejects the bytes (a reader would drop them).
  bool load(const std::uint8_t* data, std::size_t size, bool byte_swapped) {
    if (size > 0xffffffffu) return false;
    buffer_.assign(size / 4 + 1, 0u);  // 4-byte aligned, writable (normalize works in place), never empty
    if (size > 0) std::memcpy(buffer_.data(), data, size);
    char* bytes = reinterpret_cast<char*>(buffer_.data());
    std::uint32_t offset = 0;
    const auto length = static_cast<std::uint32_t>(size);
    if (dds_stream_normalize_data(bytes, &offset, length, byte_swapped, 1, desc_.m_ops) == nullptr) return false;
    dds_istream_t is;
    dds_istream_init(&is, length, bytes, 1);
    dds_stream_read(&is, static_cast<char*>(sample_), desc_.m_ops);
    dds_istream_fini(&is);
    loaded_ = true;
    return true;
  }

  template <class T>
  const T& as() const {
    return *static_cast<const T*>(sample_);
  }

 private:
  const dds_topic_descriptor_t& desc_;
  void* sample_;
  std::vector<std::uint32_t> buffer_;
  bool loaded_ = false;
};

}  // namespace sg::fuzz
