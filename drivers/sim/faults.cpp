#include "drivers/sim/faults.hpp"

#include <sstream>
#include <stdexcept>

#include "drivers/sim/rng.hpp"

namespace lidarfuse::sim {

namespace {

std::vector<std::string> split(const std::string& s, char sep) {
    std::vector<std::string> out;
    std::string item;
    std::istringstream in(s);
    while (std::getline(in, item, sep)) out.push_back(item);
    return out;
}

[[noreturn]] void fail(const std::string& spec, const std::string& why) {
    throw std::invalid_argument("--fault " + spec + ": " + why +
                                " (see `lidarfuse sim --help` for the syntax)");
}

double number(const std::string& spec, const std::string& text, const char* what) {
    try {
        std::size_t used = 0;
        const double v = std::stod(text, &used);
        if (used != text.size()) throw std::invalid_argument(text);
        return v;
    } catch (const std::exception&) {
        fail(spec, std::string("expected a number for ") + what + ", got \"" + text + "\"");
    }
}

int sensor_index(const std::string& spec, const std::string& name, int sensors) {
    for (int k = 0; k < sensors; ++k) {
        if (name == "lidar" + std::to_string(k)) return k;
    }
    fail(spec,
         "unknown sensor \"" + name + "\" (lidar0..lidar" + std::to_string(sensors - 1) + ")");
}

}  // namespace

bool FaultPlan::empty() const {
    return drop.share <= 0 && reorder.share <= 0 && duplicate.share <= 0 && truncate.share <= 0 &&
           init_id_changes.empty() && silences.empty() && clock_offsets.empty();
}

std::int64_t FaultPlan::clock_offset_ns(int sensor) const {
    double s = 0;
    for (const auto& c : clock_offsets) {
        if (c.sensor == sensor) s += c.offset_s;
    }
    return static_cast<std::int64_t>(s * 1e9);
}

std::uint32_t FaultPlan::init_id_at(int sensor, std::uint32_t initial, double t_s) const {
    std::uint32_t id = initial;
    for (const auto& c : init_id_changes) {
        if (c.sensor == sensor && t_s >= c.at_s)
            id = static_cast<std::uint32_t>(mix64(id) & 0xFFFFFFu);
    }
    return id;
}

bool FaultPlan::silenced(int sensor, double t_s) const {
    for (const auto& s : silences) {
        if (s.sensor == sensor && t_s >= s.from_s && t_s < s.from_s + s.duration_s) return true;
    }
    return false;
}

void parse_fault(const std::string& spec, int sensors, FaultPlan* plan) {
    const auto f = split(spec, ':');
    if (f.empty()) fail(spec, "empty");
    const std::string& kind = f[0];
    if (kind == "drop" || kind == "reorder" || kind == "duplicate" || kind == "truncate") {
        if (f.size() < 2 || f.size() > 3) fail(spec, "expected " + kind + ":SHARE[:SENSOR]");
        FaultRate r;
        r.share = number(spec, f[1], "SHARE");
        if (r.share < 0 || r.share > 1) fail(spec, "SHARE must be in 0..1");
        if (f.size() == 3) r.sensor = sensor_index(spec, f[2], sensors);
        (kind == "drop"        ? plan->drop
         : kind == "reorder"   ? plan->reorder
         : kind == "duplicate" ? plan->duplicate
                               : plan->truncate) = r;
    } else if (kind == "init-id") {
        if (f.size() != 3) fail(spec, "expected init-id:SENSOR:AT_S");
        plan->init_id_changes.push_back(
            {sensor_index(spec, f[1], sensors), number(spec, f[2], "AT_S")});
    } else if (kind == "silence") {
        if (f.size() != 4) fail(spec, "expected silence:SENSOR:FROM_S:DUR_S");
        const double dur = number(spec, f[3], "DUR_S");
        if (dur < 0) fail(spec, "DUR_S must not be negative");
        plan->silences.push_back(
            {sensor_index(spec, f[1], sensors), number(spec, f[2], "FROM_S"), dur});
    } else if (kind == "clock-offset") {
        if (f.size() != 3) fail(spec, "expected clock-offset:SENSOR:OFFSET_S");
        plan->clock_offsets.push_back(
            {sensor_index(spec, f[1], sensors), number(spec, f[2], "OFFSET_S")});
    } else {
        fail(spec, "unknown fault \"" + kind +
                       "\" (drop, reorder, duplicate, truncate, init-id, silence, clock-offset)");
    }
}

PacketFate packet_fate(const FaultPlan& plan, std::uint64_t seed, int sensor,
                       std::uint64_t sequence, double t_s, std::size_t size) {
    PacketFate fate;
    if (plan.silenced(sensor, t_s)) {
        fate.drop = true;
        return fate;
    }
    CounterRng rng(seed ^ 0x6661756C74ULL /* "fault" */, static_cast<std::uint64_t>(sensor),
                   sequence);
    const double u_drop = rng.uniform(), u_dup = rng.uniform(), u_reorder = rng.uniform(),
                 u_trunc = rng.uniform(), u_len = rng.uniform();
    if (plan.drop.applies(sensor) && u_drop < plan.drop.share) {
        fate.drop = true;
        return fate;
    }
    fate.duplicate = plan.duplicate.applies(sensor) && u_dup < plan.duplicate.share;
    fate.reorder = plan.reorder.applies(sensor) && u_reorder < plan.reorder.share;
    if (plan.truncate.applies(sensor) && u_trunc < plan.truncate.share && size > 1) {
        fate.truncate_to = 1 + static_cast<std::size_t>(u_len * static_cast<double>(size - 1));
    }
    return fate;
}

}  // namespace lidarfuse::sim
