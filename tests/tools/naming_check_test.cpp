// scripts/check_naming.sh, the test command's naming stage, on a build folder of one unit
// written here: a bad name is reported with its file and line, a unit that passed is taken
// from the cache on the next run, and any change of its text, a comment included (NOLINT is
// one), has it checked again.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "tests/support/test_data.hpp"

namespace lidarfuse::test {
namespace {

namespace fs = std::filesystem;

bool clang_tools_missing() {
    std::string out;
    return run_command("command -v clang-tidy-14 && command -v clang++-14", &out) != 0;
}

// A compile database of one unit, compiled from `build` with `flags`.
void write_compile_database(const fs::path& build, const fs::path& unit, const std::string& flags) {
    fs::create_directories(build);
    std::ofstream(build / "compile_commands.json")
        << "[{\"directory\": \"" << build.string() << "\", \"command\": \"/usr/bin/c++ " << flags
        << " -o unit.o -c " << unit.string() << "\", \"file\": \"" << unit.string() << "\"}]\n";
}

// `script BUILD` with its memory in `cache`: the exit status, the output in *out.
int run_naming_check(const fs::path& script, const fs::path& build, const fs::path& cache,
                     std::string* out) {
    return run_command(
        "LIDARFUSE_NAMING_CACHE=" + cache.string() + " " + script.string() + " " + build.string(),
        out);
}

class NamingCheck : public ::testing::Test {
protected:
    void SetUp() override {
        if (clang_tools_missing()) {
            GTEST_SKIP() << "clang-tidy-14 or clang++-14 not installed (scripts/setup.sh)";
        }
        write_compile_database(dir_.path() / "build", dir_.path() / "unit.cpp",
                               "-std=c++17 -Wshadow=local");
    }

    // Runs the check on the unit `text`; its exit status, the output in *out.
    int check(const std::string& text, std::string* out) {
        std::ofstream(dir_.path() / "unit.cpp") << text;
        return run_naming_check(source_dir() / "scripts" / "check_naming.sh", dir_.path() / "build",
                                dir_.path() / "cache", out);
    }

    int cache_entries() const {
        int n = 0;
        for (const auto& entry : fs::directory_iterator(dir_.path() / "cache")) n += entry.exists();
        return n;
    }

    TempDir dir_{"naming_check"};
};

TEST_F(NamingCheck, ReportsABadNameAndRemembersOnlyPasses) {
    std::string out;
    EXPECT_NE(check("int BadName() { return 0; }\n", &out), 0) << out;
    EXPECT_NE(out.find("unit.cpp:1:5: error: invalid case style for function 'BadName'"),
              std::string::npos)
        << out;
    EXPECT_EQ(cache_entries(), 0);

    EXPECT_EQ(check("int good_name() { return 0; }\n", &out), 0) << out;
    EXPECT_NE(out.find("1 units follow .clang-tidy's naming rules, 0 of them unchanged"),
              std::string::npos)
        << out;
    EXPECT_EQ(cache_entries(), 1);
    EXPECT_EQ(check("int good_name() { return 0; }\n", &out), 0) << out;
    EXPECT_NE(out.find("1 of them unchanged"), std::string::npos) << out;

    // The same bad name after a pass: checked again, reported again.
    EXPECT_NE(check("int BadName() { return 0; }\n", &out), 0) << out;
    EXPECT_NE(out.find("'BadName'"), std::string::npos) << out;
    EXPECT_EQ(cache_entries(), 1);
}

TEST_F(NamingCheck, ACommentIsPartOfTheUnitsText) {
    std::string out;
    const std::string name = "int BadName() { return 0; }";
    EXPECT_EQ(check(name + "  // NOLINT(readability-identifier-naming)\n", &out), 0) << out;
    EXPECT_EQ(cache_entries(), 1);
    // Without the NOLINT the preprocessed code is the same; the comment is not.
    EXPECT_NE(check(name + "\n", &out), 0) << out;
    EXPECT_NE(out.find("'BadName'"), std::string::npos) << out;
}

// Two checkouts in different folders with the same unit: what passed in one is reused in
// the other (the keys hold the checkout's path as @TOP@), and the cache is shared.
TEST(NamingCheckClones, AUnitThatPassedInOneCheckoutIsReusedInAnother) {
    if (clang_tools_missing()) {
        GTEST_SKIP() << "clang-tidy-14 or clang++-14 not installed (scripts/setup.sh)";
    }
    TempDir first("naming_clone_a"), second("naming_clone_b"), cache("naming_clone_cache");
    for (const fs::path& top : {first.path(), second.path()}) {
        fs::create_directories(top / "scripts");
        fs::create_directories(top / "core");
        fs::copy_file(source_dir() / "scripts" / "check_naming.sh",
                      top / "scripts" / "check_naming.sh");
        fs::copy_file(source_dir() / ".clang-tidy", top / ".clang-tidy");
        std::ofstream(top / "core" / "unit.hpp") << "#pragma once\nint good_name();\n";
        std::ofstream(top / "core" / "unit.cpp")
            << "#include \"core/unit.hpp\"\nint good_name() { return 0; }\n";
        write_compile_database(top / "build", top / "core" / "unit.cpp",
                               "-I" + top.string() + " -std=c++17");
    }
    std::string out;
    const auto check = [&](const fs::path& top) {
        return run_naming_check(top / "scripts" / "check_naming.sh", top / "build", cache.path(),
                                &out);
    };
    ASSERT_EQ(check(first.path()), 0) << out;
    EXPECT_NE(out.find("0 of them unchanged"), std::string::npos) << out;
    ASSERT_EQ(check(second.path()), 0) << out;
    EXPECT_NE(out.find("1 of them unchanged"), std::string::npos) << out;
}

}  // namespace
}  // namespace lidarfuse::test
