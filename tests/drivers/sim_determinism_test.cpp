// Same arguments, same bytes: the simulator's output does not depend on the run or on the
// number of render threads, and the seed does change it.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "drivers/sim/simulator.hpp"
#include "tests/support/test_data.hpp"

namespace lidarfuse::sim {
namespace {

class HashSink : public DatagramSink {
public:
    void write(const SimDatagram& d) override {
        std::ostringstream head;
        head << d.capture_ns << ' ' << d.sensor << ' ' << d.src_ip << ' ' << d.dst_port << ' ';
        bytes_ += head.str();
        bytes_.append(reinterpret_cast<const char*>(d.payload.data()), d.payload.size());
        ++count_;
    }
    std::string md5() const { return test::md5_hex(bytes_.data(), bytes_.size()); }
    std::size_t count() const { return count_; }

private:
    std::string bytes_;
    std::size_t count_ = 0;
};

std::string run_hash(int threads, std::uint64_t seed, std::size_t* datagrams = nullptr) {
    SimParams p;
    p.scenario = Scenario::kIntersection;
    p.sensors = 3;
    p.seconds = 0.15;
    p.columns_per_frame = 512;
    p.frames_per_second = 20;
    p.seed = seed;
    p.threads = threads;
    parse_fault("drop:0.05", p.sensors, &p.faults);
    parse_fault("reorder:0.05:lidar1", p.sensors, &p.faults);
    Simulator sim(p);
    HashSink sink;
    sim.run(sink);
    if (datagrams) *datagrams = sink.count();
    return sink.md5();
}

TEST(SimDeterminism, ThreadCountAndRepetitionDoNotChangeTheOutput) {
    std::size_t n = 0;
    const std::string one = run_hash(1, 5, &n);
    EXPECT_GT(n, 100u);
    EXPECT_EQ(run_hash(1, 5), one);
    EXPECT_EQ(run_hash(3, 5), one);
    EXPECT_NE(run_hash(2, 6), one);
}

std::string file_md5(const std::filesystem::path& f) {
    std::ifstream in(f, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    return test::md5_hex(bytes.data(), bytes.size());
}

TEST(SimDeterminism, CommandLineRunsAreByteIdentical) {
    test::TempDir a("sim_det_a"), b("sim_det_b");
    const std::string args = " sim --scenario straight --sensors 2 --seconds 0.1 --mode 512x20 ";
    std::string log;
    ASSERT_EQ(test::run_command(test::tool_path() + args + "--threads 1 --out " + a.path().string(),
                                &log),
              0)
        << log;
    ASSERT_EQ(test::run_command(test::tool_path() + args + "--threads 2 --out " + b.path().string(),
                                &log),
              0)
        << log;
    for (const char* f :
         {"capture.pcap", "ground_truth.csv", "station.yaml", "lidar0.json", "lidar1.json"}) {
        EXPECT_EQ(file_md5(a.path() / f), file_md5(b.path() / f)) << f;
    }
}

}  // namespace
}  // namespace lidarfuse::sim
