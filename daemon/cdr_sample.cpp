#include "daemon/cdr_sample.hpp"

#include <cstring>

namespace lidarfuse::daemon {

namespace {
// CDR_ENC_VERSION_1 of Cyclone's q_protocol.h: classic CDR, as the writers' XCDR1 QoS.
constexpr std::uint32_t kXcdr1 = 1;
// The first buffer; a fused cloud of 4 sensors at 1 m voxels is about 2 MB.
constexpr std::uint32_t kInitialBytes = 64 * 1024;
}  // namespace

CdrSampleWriter::CdrSampleWriter() { dds_ostreamLE_init(&stream_, kInitialBytes, kXcdr1); }

CdrSampleWriter::~CdrSampleWriter() { dds_ostreamLE_fini(&stream_); }

std::shared_ptr<const std::vector<std::uint8_t>> CdrSampleWriter::write(
    const dds_topic_descriptor_t& type, const void* sample) {
    stream_.x.m_index = 0;  // alignment counts from here: the byte after the header
    dds_stream_writeLE(&stream_, static_cast<const char*>(sample), type.m_ops);
    auto bytes =
        std::make_shared<std::vector<std::uint8_t>>(sizeof kCdrLeHeader + stream_.x.m_index);
    std::memcpy(bytes->data(), kCdrLeHeader, sizeof kCdrLeHeader);
    std::memcpy(bytes->data() + sizeof kCdrLeHeader, stream_.x.m_buffer, stream_.x.m_index);
    return bytes;
}

}  // namespace lidarfuse::daemon
