// config/cyclonedds.xml, which ROS 2 nodes on a station share with lidarfused: Cyclone
// accepts it, it is well-formed XML for other parsers, and it never makes a process fail
// to start on a host left at the kernel's default socket buffers.
#include <dds/dds.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cctype>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>

#include "tests/support/test_data.hpp"

namespace lidarfuse {
namespace {

std::string cyclonedds_xml() {
    std::ifstream in(test::source_dir() / "config" / "cyclonedds.xml");
    std::stringstream buffer;
    buffer << in.rdbuf();
    return buffer.str();
}

// Bytes of a Cyclone size such as "2MiB", "512kB" or "65536". (No std::regex: GCC 12
// warns inside it under the sanitizers, and warnings are errors.)
double size_bytes(const std::string& text) {
    std::size_t digits = 0;
    while (digits < text.size() &&
           (std::isdigit(static_cast<unsigned char>(text[digits])) || text[digits] == '.')) {
        ++digits;
    }
    EXPECT_GT(digits, 0u) << text;
    std::size_t unit_at = digits;
    while (unit_at < text.size() && std::isspace(static_cast<unsigned char>(text[unit_at])))
        ++unit_at;
    const std::string unit = text.substr(unit_at);
    const double scale = unit == "kB"    ? 1e3
                         : unit == "KiB" ? 1024.0
                         : unit == "MB"  ? 1e6
                         : unit == "MiB" ? 1048576.0
                         : unit == "GB"  ? 1e9
                         : unit == "GiB" ? 1073741824.0
                                         : 1.0;
    EXPECT_TRUE(unit.empty() || unit == "B" || scale != 1.0) << text;
    return digits == 0 ? 0.0 : std::stod(text.substr(0, digits)) * scale;
}

// The text without its XML comments.
std::string without_comments(const std::string& xml) {
    std::string out;
    std::size_t at = 0;
    while (true) {
        const std::size_t begin = xml.find("<!--", at);
        out += xml.substr(at, begin == std::string::npos ? std::string::npos : begin - at);
        if (begin == std::string::npos) return out;
        const std::size_t end = xml.find("-->", begin + 4);
        if (end == std::string::npos) return out;
        at = end + 3;
    }
}

// The value of attribute `name` in an element's attribute text, or nullopt.
std::optional<std::string> attribute(const std::string& attributes, const std::string& name) {
    const std::string key = name + "=\"";
    std::size_t at = attributes.find(key);
    while (at != std::string::npos && at > 0 &&
           !std::isspace(static_cast<unsigned char>(attributes[at - 1]))) {
        at = attributes.find(key, at + 1);
    }
    if (at == std::string::npos) return std::nullopt;
    const std::size_t begin = at + key.size();
    const std::size_t end = attributes.find('"', begin);
    if (end == std::string::npos) return std::nullopt;
    return attributes.substr(begin, end - begin);
}

// Linux's default net.core.rmem_max: a host without systemd/60-lidarfuse-udp.conf.
constexpr double kDefaultRmemMax = 212992;

TEST(CycloneddsXml, NoMinimumBufferAboveTheKernelsDefault) {
    // The settings Cyclone reads: comments (which show the stricter variant) removed.
    const std::string xml = without_comments(cyclonedds_xml());
    const std::string tag = "<SocketReceiveBufferSize";
    const std::size_t at = xml.find(tag);
    ASSERT_NE(at, std::string::npos);
    const std::size_t end = xml.find("/>", at);
    ASSERT_NE(end, std::string::npos);
    const std::string attributes = xml.substr(at + tag.size(), end - at - tag.size());
    if (const auto min = attribute(attributes, "min")) {
        EXPECT_TRUE(*min == "default" || size_bytes(*min) <= kDefaultRmemMax)
            << "min=\"" << *min << "\" stops every process sharing the file on a host at "
            << "the kernel's default buffers";
    }
    const auto max = attribute(attributes, "max");
    ASSERT_TRUE(max.has_value()) << attributes;
    EXPECT_GE(size_bytes(*max), 8.0 * 1048576.0);
}

// The text of element `name` in the settings (comments removed), or "".
std::string element(const std::string& name) {
    const std::string xml = without_comments(cyclonedds_xml());
    const std::size_t at = xml.find("<" + name + ">");
    if (at == std::string::npos) return "";
    const std::size_t begin = at + name.size() + 2;
    const std::size_t end = xml.find("</" + name + ">", begin);
    return end == std::string::npos ? "" : xml.substr(begin, end - begin);
}

// Datagrams of one Ethernet frame each cost the output thread about a third of a core and
// lose clouds for a subscriber that keeps up with larger ones (bench/BENCHMARK.md,
// "Delivery"): a message carries several fragments, and IP fragments it to the MTU.
TEST(CycloneddsXml, MessagesCarrySeveralFragments) {
    const std::string message = element("MaxMessageSize");
    const std::string fragment = element("FragmentSize");
    ASSERT_FALSE(message.empty());
    ASSERT_FALSE(fragment.empty());
    EXPECT_GE(size_bytes(message), 14720.0) << message;
    EXPECT_GE(size_bytes(message), 8.0 * size_bytes(fragment)) << message << " / " << fragment;
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
    const dds_entity_t participant = dds_create_participant(
        static_cast<dds_domainid_t>(1 + test::port_block_index()), nullptr, nullptr);
    EXPECT_GT(participant, 0) << dds_strretcode(participant);
    if (participant > 0) dds_delete(participant);
}

}  // namespace
}  // namespace lidarfuse
