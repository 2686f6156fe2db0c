// The long commands' progress line (tools/progress.hpp): its text, its redraw rules, and the
// real commands run on a pseudo-terminal (a line on stderr) and without one (none; the
// `name value unit` lines on stdout the same either way).
#include "tools/progress.hpp"

#include <gtest/gtest.h>
#include <pty.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <filesystem>
#include <string>

#include "tests/support/test_data.hpp"

namespace lidarfuse::tools {
namespace {

namespace fs = std::filesystem;

TEST(ProgressFormat, KnownTotalShowsShareRateAndTimeLeft) {
    ProgressState s{"rendering", 50, 200, "frames", 0.25, 10.0};
    EXPECT_EQ(format_progress("sim", s),
              "sim: rendering 50/200 frames (25 %), 5.0 frames/s, 0:10 elapsed, 0:30 left");
}

TEST(ProgressFormat, CountWithoutTotalTakesTheShareFromElsewhere) {
    ProgressState s{"fusing", 120, 0, "frames", 0.4, 4.0};
    EXPECT_EQ(format_progress("fuse", s),
              "fuse: fusing 120 frames (40 %), 30.0 frames/s, 0:04 elapsed, 0:06 left");
}

TEST(ProgressFormat, UnknownShareShowsNoTimeLeftAndAStageAloneNoCount) {
    ProgressState looping{"pass 3", 4096, 0, "datagrams", -1, 2.0};
    EXPECT_EQ(format_progress("replay", looping),
              "replay: pass 3 4096 datagrams, 2048.0 datagrams/s, 0:02 elapsed");
    ProgressState stage{"reading the capture", 0, 0, "", -1, 0.4};
    EXPECT_EQ(format_progress("calibrate", stage), "calibrate: reading the capture, 0:00 elapsed");
}

TEST(ProgressFormat, HoursAndAShareAboveOneAreShownSanely) {
    ProgressState s{"", 7200, 0, "frames", 1.3, 3725.0};
    EXPECT_EQ(format_progress("fuse", s),
              "fuse: 7200 frames (100 %), 1.9 frames/s, 1:02:05 elapsed, 0:00 left");
}

std::string read_all(std::FILE* f) {
    std::fflush(f);
    std::rewind(f);
    std::string text;
    char buffer[256];
    std::size_t n;
    while ((n = std::fread(buffer, 1, sizeof buffer, f)) > 0) text.append(buffer, n);
    return text;
}

TEST(ProgressLine, DisabledWritesNothing) {
    std::FILE* f = std::tmpfile();
    ASSERT_NE(f, nullptr);
    {
        ProgressLine line("fuse", false, f);
        line.update({"fusing", 1, 0, "frames", 0.1, 0});
        line.finish();
    }
    EXPECT_EQ(read_all(f), "");
    std::fclose(f);
}

TEST(ProgressLine, RedrawsInPlaceAtMostFiveTimesASecondButOnEveryNewStage) {
    std::FILE* f = std::tmpfile();
    ASSERT_NE(f, nullptr);
    {
        ProgressLine line("calibrate", true, f);
        line.update({"features", 0, 4, "sensors", 0, 0});
        line.update({"features", 1, 4, "sensors", 0.25, 0});  // within 0.2 s: not drawn
        line.update({"pairs", 0, 6, "pairs", 0, 0});          // new stage: drawn
    }                                                         // the destructor clears the line
    const std::string text = read_all(f);
    EXPECT_EQ(text.find("1/4 sensors"), std::string::npos) << text;
    EXPECT_NE(text.find("\rcalibrate: features 0/4 sensors (0 %)"), std::string::npos) << text;
    EXPECT_NE(text.find("\rcalibrate: pairs 0/6 pairs (0 %)"), std::string::npos) << text;
    EXPECT_EQ(text.substr(text.size() - 4), "\r\x1b[K") << "cleared at the end";
    std::fclose(f);
}

// Runs `command` through sh with stderr (and stdin) on a pseudo-terminal; returns what the
// terminal showed. stdout goes where the command redirects it.
std::string run_on_terminal(const std::string& command, int* status) {
    int master = -1;
    const pid_t pid = ::forkpty(&master, nullptr, nullptr, nullptr);
    if (pid == 0) {
        ::execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char*>(nullptr));
        ::_exit(127);
    }
    std::string shown;
    if (pid < 0) return shown;
    char buffer[4096];
    for (;;) {
        const ssize_t n = ::read(master, buffer, sizeof buffer);
        if (n > 0) {
            shown.append(buffer, static_cast<std::size_t>(n));
        } else if (n < 0 && errno == EINTR) {
            continue;
        } else {
            break;  // EIO once the child side is closed
        }
    }
    ::close(master);
    ::waitpid(pid, status, 0);
    return shown;
}

class ProgressCommands : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        dir_ = fs::temp_directory_path() / ("lidarfuse_progress_" + std::to_string(::getpid()));
        fs::remove_all(dir_);
        fs::create_directories(dir_);
        std::string out;
        ASSERT_EQ(test::run_command(test::tool_path() +
                                        " sim --scenario curve --sensors 2 --seconds 0.6"
                                        " --quiet --out " +
                                        (dir_ / "sim").string(),
                                    &out),
                  0)
            << out;
    }
    static void TearDownTestSuite() { fs::remove_all(dir_); }
    static fs::path dir_;
};
fs::path ProgressCommands::dir_;

TEST_F(ProgressCommands, SimDrawsOnATerminalAndKeepsStdoutClean) {
    int status = 0;
    const fs::path out = dir_ / "sim_tty.txt";
    const std::string shown = run_on_terminal(
        test::tool_path() + " sim --scenario straight --sensors 1 --seconds 0.3 --out " +
            (dir_ / "tty").string() + " > " + out.string(),
        &status);
    ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << shown;
    EXPECT_NE(shown.find("\rsim: rendering "), std::string::npos) << shown;
    EXPECT_NE(shown.find("/6 frames"), std::string::npos) << shown;
    const std::string stdout_text = test::file_text(out);
    EXPECT_NE(stdout_text.find("sim_rays "), std::string::npos);
    EXPECT_EQ(stdout_text.find('\r'), std::string::npos) << "stdout must carry only figures";
}

TEST_F(ProgressCommands, QuietOrNoTerminalMeansNoProgressLine) {
    int status = 0;
    const std::string cap = (dir_ / "sim").string();
    const std::string quiet = run_on_terminal(
        test::tool_path() + " fuse " + cap + "/capture.pcap --config " + cap +
            "/station.yaml --out " + (dir_ / "fuse_quiet").string() + " --quiet > /dev/null",
        &status);
    ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << quiet;
    EXPECT_EQ(quiet.find("fuse: fusing"), std::string::npos) << quiet;
    // stderr into a pipe (not a terminal): no line either.
    std::string piped;
    ASSERT_EQ(test::run_command(test::tool_path() + " fuse " + cap + "/capture.pcap --config " +
                                    cap + "/station.yaml --out " + (dir_ / "fuse_pipe").string(),
                                &piped),
              0);
    EXPECT_EQ(piped.find('\r'), std::string::npos) << piped;
    EXPECT_NE(piped.find("fuse_frames 12 frames"), std::string::npos) << piped;
}

TEST_F(ProgressCommands, FuseCalibrateAndReplayDrawOnATerminal) {
    const std::string cap = (dir_ / "sim").string();
    int status = 0;
    const std::string fuse =
        run_on_terminal(test::tool_path() + " fuse " + cap + "/capture.pcap --config " + cap +
                            "/station.yaml --out " + (dir_ / "fuse_tty").string() + " > /dev/null",
                        &status);
    ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << fuse;
    EXPECT_NE(fuse.find("\rfuse: fusing "), std::string::npos) << fuse;
    EXPECT_NE(fuse.find(" frames ("), std::string::npos) << "the share of the file: " << fuse;

    const std::string calibrate = run_on_terminal(
        test::tool_path() + " calibrate " + cap + "/capture.pcap --config " + cap +
            "/station.yaml --out " + (dir_ / "extrinsics.yaml").string() + " > /dev/null",
        &status);
    ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << calibrate;
    EXPECT_NE(calibrate.find("\rcalibrate: reading the capture"), std::string::npos) << calibrate;
    EXPECT_NE(calibrate.find("\rcalibrate: features 0/2 sensors"), std::string::npos) << calibrate;
    EXPECT_NE(calibrate.find("\rcalibrate: pairs 0/1 pairs"), std::string::npos) << calibrate;
    EXPECT_NE(calibrate.find("\rcalibrate: pose graph"), std::string::npos) << calibrate;

    // Sent to a port nobody listens on (UDP: no error), as fast as possible.
    const std::string replay = run_on_terminal(test::tool_path() + " replay " + cap +
                                                   "/capture.pcap --max-rate --port-map 7502:9 "
                                                   "--port-map 7504:9 > /dev/null",
                                               &status);
    ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << replay;
    EXPECT_NE(replay.find("\rreplay: sending "), std::string::npos) << replay;
    EXPECT_NE(replay.find(" datagrams ("), std::string::npos) << replay;
}

}  // namespace
}  // namespace lidarfuse::tools
