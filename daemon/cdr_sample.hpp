#pragma once
// A DDS sample as the CDR bytes Cyclone itself puts on the wire for it (XCDR1, little
// endian, the types of daemon/idl/ are final), behind the 4-byte encapsulation header
// (CDR_LE) that a ROS 2 reader of raw bytes expects, e.g. Foxglove's "cdr" encoding.
// Cyclone's own stream writer (dds_stream_writeLE with the type's ops) builds them, so they
// are the bytes DDS sends, not a second serialiser of ours.
//
// Not thread safe: one per thread (the output thread). The stream's buffer is kept and
// grows to the largest sample, so the steady state allocates only the returned copy.

#include <dds/dds.h>
#include <dds/ddsi/ddsi_cdrstream.h>

#include <cstdint>
#include <memory>
#include <vector>

namespace lidarfuse::daemon {

// CDR_LE, options 0: the header before every sample's bytes.
inline constexpr std::uint8_t kCdrLeHeader[4] = {0x00, 0x01, 0x00, 0x00};

class CdrSampleWriter {
public:
    CdrSampleWriter();
    ~CdrSampleWriter();
    CdrSampleWriter(const CdrSampleWriter&) = delete;
    CdrSampleWriter& operator=(const CdrSampleWriter&) = delete;

    // The header and `sample` (a C struct of `type`) serialised.
    std::shared_ptr<const std::vector<std::uint8_t>> write(const dds_topic_descriptor_t& type,
                                                           const void* sample);

private:
    dds_ostreamLE_t stream_{};
};

}  // namespace lidarfuse::daemon
