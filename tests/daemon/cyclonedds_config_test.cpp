// config/cyclonedds.xml, which ROS 2 nodes on a station share with lidarfused: Cyclone
// accepts it, it is well-formed XML for other parsers, and it never makes a process fail
// to start on a host left at the kernel's default socket buffers.
#include <dds/dds.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <regex>
#include <sstream>

#include "tests/support/test_data.hpp"

namespace lidarfuse {
namespace {

std::string cyclonedds_xml() {
    std::ifstream in(test::source_dir() / "config" / "cyclonedds.xml");
    std::stringstream buffer;
    buffer << in.rdbuf();
    return buffer.str();
}

// Bytes of a Cyclone size such as "2MiB", "512kB" or "65536".
double size_bytes(const std::string& text) {
    std::smatch m;
    EXPECT_TRUE(std::regex_match(text, m, std::regex("([0-9.]+)\\s*(B|kB|KiB|MB|MiB|GB|GiB)?")))
        << text;
    const std::string unit = m[2].str();
    const double scale = unit == "kB"    ? 1e3
                         : unit == "KiB" ? 1024.0
                         : unit == "MB"  ? 1e6
                         : unit == "MiB" ? 1048576.0
                         : unit == "GB"  ? 1e9
                         : unit == "GiB" ? 1073741824.0
                                         : 1.0;
    return std::stod(m[1].str()) * scale;
}

// Linux's default net.core.rmem_max: a host without systemd/60-lidarfuse-udp.conf.
constexpr double kDefaultRmemMax = 212992;

TEST(CycloneddsXml, NoMinimumBufferAboveTheKernelsDefault) {
    // The settings Cyclone reads: comments (which show the stricter variant) removed.
    const std::string xml = std::regex_replace(cyclonedds_xml(), std::regex("<!--[^]*?-->"), "");
    std::smatch m;
    ASSERT_TRUE(std::regex_search(xml, m, std::regex("<SocketReceiveBufferSize([^>]*)/>")));
    const std::string attributes = m[1].str();
    std::smatch min;
    if (std::regex_search(attributes, min, std::regex("min=\"([^\"]*)\""))) {
        EXPECT_TRUE(min[1].str() == "default" || size_bytes(min[1].str()) <= kDefaultRmemMax)
            << "min=\"" << min[1].str() << "\" stops every process sharing the file on a host at "
            << "the kernel's default buffers";
    }
    ASSERT_TRUE(std::regex_search(attributes, min, std::regex("max=\"([^\"]*)\"")));
    EXPECT_GE(size_bytes(min[1].str()), 8.0 * 1048576.0);
}

TEST(CycloneddsXml, CommentsAreWellFormedXml) {
    const std::string xml = cyclonedds_xml();
    std::size_t at = 0, comments = 0;
    while ((at = xml.find("<!--", at)) != std::string::npos) {
        const std::size_t end = xml.find("-->", at + 4);
        ASSERT_NE(end, std::string::npos);
        EXPECT_EQ(xml.substr(at + 4, end - at - 4).find("--"), std::string::npos)
            << "\"--\" inside the comment at byte " << at;
        at = end + 3;
        ++comments;
    }
    EXPECT_GT(comments, 0u);
}

TEST(CycloneddsXml, CycloneStartsWithIt) {
    const std::string uri = "file://" + (test::source_dir() / "config" / "cyclonedds.xml").string();
    ::setenv("CYCLONEDDS_URI", uri.c_str(), 1);
    const dds_entity_t participant =
        dds_create_participant(static_cast<dds_domainid_t>(1 + ::getpid() % 230), nullptr, nullptr);
    EXPECT_GT(participant, 0) << dds_strretcode(participant);
    if (participant > 0) dds_delete(participant);
}

}  // namespace
}  // namespace lidarfuse
