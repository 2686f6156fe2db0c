// ros2/lidarfuse_msgs (the ROS 2 package) against what the daemon publishes: the IDL the
// daemon compiles (daemon/idl/lidarfuse_msgs.idl) is rosidl's conversion of the package's
// .msg files in ROS 2's DDS mapping, and the type hash on rt/lidarfuse/poses is the one
// rosidl computes from those files.
#include <gtest/gtest.h>

#include <cctype>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "daemon/ros_type_hash.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse::daemon {
namespace {

const char* const kPackage = "lidarfuse_msgs";

std::string read_text(const std::filesystem::path& file) {
    std::ifstream in(file);
    EXPECT_TRUE(in) << file;
    std::stringstream buffer;
    buffer << in.rdbuf();
    return buffer.str();
}

// One field of a .msg file: its type as written ("float64", "SensorPose[]",
// "builtin_interfaces/Time") and its name.
struct MsgField {
    std::string type, name;
};

std::vector<MsgField> parse_msg(const std::string& text) {
    std::vector<MsgField> fields;
    std::istringstream in(text);
    std::string line;
    while (std::getline(in, line)) {
        line = line.substr(0, line.find('#'));
        std::istringstream words(line);
        MsgField f;
        if (!(words >> f.type >> f.name)) continue;
        std::string rest;
        EXPECT_FALSE(words >> rest) << "constants and default values are not handled: " << line;
        fields.push_back(f);
    }
    return fields;
}

// rosidl's names: a primitive's IDL type and type description id (unbounded types only:
// lidarfuse_msgs uses no bounded strings or fixed arrays, and a test below fails on them).
struct Primitive {
    const char* idl;
    int type_id;
};
const std::map<std::string, Primitive>& primitives() {
    static const std::map<std::string, Primitive> kPrimitives = {
        {"bool", {"boolean", kRosBool}},      {"byte", {"octet", kRosByte}},
        {"char", {"uint8", kRosUint8}},       {"float32", {"float", kRosFloat32}},
        {"float64", {"double", kRosFloat64}}, {"int8", {"int8", kRosInt8}},
        {"uint8", {"uint8", kRosUint8}},      {"int16", {"int16", kRosInt16}},
        {"uint16", {"uint16", kRosUint16}},   {"int32", {"int32", kRosInt32}},
        {"uint32", {"uint32", kRosUint32}},   {"int64", {"int64", kRosInt64}},
        {"uint64", {"uint64", kRosUint64}},   {"string", {"string", kRosString}}};
    return kPrimitives;
}

// "pkg/Type" or "Type" (this package) -> "pkg/msg/Type".
std::string nested_type_name(const std::string& type) {
    const auto slash = type.find('/');
    if (slash == std::string::npos) return std::string(kPackage) + "/msg/" + type;
    return type.substr(0, slash) + "/msg/" + type.substr(slash + 1);
}

bool is_sequence(const std::string& type) {
    return type.size() > 2 && type.compare(type.size() - 2, 2, "[]") == 0;
}

// rosidl_adapter's msg -> IDL member, then ROS 2's DDS mapping of the type names.
std::string idl_member(const MsgField& f) {
    const bool sequence = is_sequence(f.type);
    const std::string base = sequence ? f.type.substr(0, f.type.size() - 2) : f.type;
    EXPECT_EQ(base.find_first_of("[]<="), std::string::npos) << "unhandled type " << f.type;
    std::string idl;
    const auto p = primitives().find(base);
    if (p != primitives().end()) {
        idl = p->second.idl;
    } else {
        const std::string ros = nested_type_name(base);  // pkg/msg/Type
        const auto a = ros.find('/'), b = ros.rfind('/');
        idl = ros.substr(0, a) + "::msg::dds_::" + ros.substr(b + 1) + "_";
    }
    return (sequence ? "sequence<" + idl + ">" : idl) + " " + f.name + ";";
}

RosTypeDescription description(const std::string& type_name, const std::vector<MsgField>& fields) {
    RosTypeDescription t{type_name, {}};
    for (const auto& f : fields) {
        const bool sequence = is_sequence(f.type);
        const std::string base = sequence ? f.type.substr(0, f.type.size() - 2) : f.type;
        RosField field;
        field.name = f.name;
        const auto p = primitives().find(base);
        if (p != primitives().end()) {
            field.type_id = p->second.type_id;
        } else {
            field.type_id = kRosNested;
            field.nested_type_name = nested_type_name(base);
        }
        if (sequence) field.type_id += kRosUnboundedSequence;
        t.fields.push_back(field);
    }
    return t;
}

// `text` with every run of white space as one space, none at either end.
std::string squeeze_spaces(const std::string& text) {
    std::string out;
    for (const char c : text) {
        if (std::isspace(static_cast<unsigned char>(c))) {
            if (!out.empty() && out.back() != ' ') out += ' ';
        } else {
            out += c;
        }
    }
    if (!out.empty() && out.back() == ' ') out.pop_back();
    return out;
}

// The member declarations of `struct <name> { ... };` in an IDL text, comments removed,
// one per entry with single spaces. (No std::regex: GCC 12 warns inside it under the
// sanitizers, and warnings are errors.)
std::vector<std::string> idl_struct_members(const std::string& idl, const std::string& name) {
    std::string code;
    std::istringstream lines(idl);
    for (std::string line; std::getline(lines, line);)
        code += line.substr(0, line.find("//")) + "\n";
    const std::string squeezed = squeeze_spaces(code);
    std::size_t at = squeezed.find("struct " + name + " {");
    if (at == std::string::npos) at = squeezed.find("struct " + name + "{");
    if (at == std::string::npos) return {};
    const std::size_t begin = squeezed.find('{', at) + 1;
    const std::size_t end = squeezed.find('}', begin);
    if (end == std::string::npos) return {};
    std::vector<std::string> members;
    std::istringstream in(squeezed.substr(begin, end - begin));
    std::string declaration;
    while (std::getline(in, declaration, ';')) {
        declaration = squeeze_spaces(declaration);
        if (!declaration.empty()) members.push_back(declaration + ";");
    }
    return members;
}

std::vector<MsgField> msg_file(const std::string& type) {
    return parse_msg(read_text(test::source_dir() / "ros2" / kPackage / "msg" / (type + ".msg")));
}

TEST(LidarfuseMsgs, DaemonIdlIsRosidlsConversionOfTheMsgFiles) {
    const std::string idl = read_text(test::source_dir() / "daemon" / "idl" / "lidarfuse_msgs.idl");
    EXPECT_NE(idl.find("module lidarfuse_msgs { module msg { module dds_ {"), std::string::npos);
    for (const std::string type : {"SensorPose", "FramePoses"}) {
        const auto fields = msg_file(type);
        ASSERT_FALSE(fields.empty()) << type;
        std::vector<std::string> expected;
        for (const auto& f : fields) expected.push_back(idl_member(f));
        EXPECT_EQ(idl_struct_members(idl, type + "_"), expected) << type;
    }
}

TEST(LidarfuseMsgs, PublishedTypeHashIsTheMsgFilesHash) {
    std::vector<RosTypeDescription> types;
    for (const auto& t : published_ros_types()) {
        if (t.type_name.rfind(std::string(kPackage) + "/", 0) != 0) types.push_back(t);
    }
    for (const std::string type : {"SensorPose", "FramePoses"})
        types.push_back(description(std::string(kPackage) + "/msg/" + type, msg_file(type)));
    const std::string from_msg = ros_type_hash("lidarfuse_msgs/msg/FramePoses", types);
    EXPECT_EQ(from_msg, ros_type_hash("lidarfuse_msgs/msg/FramePoses"));
    EXPECT_EQ(ros_type_hash_user_data("lidarfuse_msgs::msg::dds_::FramePoses_"),
              "typehash=" + from_msg + ";");
}

TEST(LidarfuseMsgs, PackageDeclaresItsMessagesAndDependencies) {
    const auto dir = test::source_dir() / "ros2" / kPackage;
    const std::string cmake = read_text(dir / "CMakeLists.txt");
    EXPECT_NE(cmake.find("\"msg/SensorPose.msg\""), std::string::npos);
    EXPECT_NE(cmake.find("\"msg/FramePoses.msg\""), std::string::npos);
    const std::string package = read_text(dir / "package.xml");
    EXPECT_NE(package.find("<name>lidarfuse_msgs</name>"), std::string::npos);
    EXPECT_NE(package.find("<member_of_group>rosidl_interface_packages</member_of_group>"),
              std::string::npos);
    for (const char* dependency : {"builtin_interfaces", "geometry_msgs", "std_msgs"}) {
        EXPECT_NE(cmake.find(dependency), std::string::npos) << dependency;
        EXPECT_NE(package.find(std::string("<depend>") + dependency + "</depend>"),
                  std::string::npos)
            << dependency;
    }
}

}  // namespace
}  // namespace lidarfuse::daemon
