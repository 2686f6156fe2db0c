#include "bench/gicp_pair_files.hpp"

#include <fstream>
#include <sstream>
#include <stdexcept>

namespace lidarfuse::bench {

namespace fs = std::filesystem;

void write_matrix(std::ostream& out, const Eigen::Isometry3d& T) {
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) out << ' ' << T.matrix()(r, c);
}

Eigen::Isometry3d read_matrix(std::istream& in) {
    Eigen::Matrix4d m;
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) in >> m(r, c);
    return Eigen::Isometry3d(m);
}

void write_gicp_pair(std::ostream& out, const GicpPair& p) {
    out << p.name << ' ' << p.voxel_m << ' ' << p.k << ' ' << p.bound_m << ' ' << p.max_iterations
        << ' ' << p.eps << ' ' << p.target_file << ' ' << p.source_file;
    write_matrix(out, p.T_init);
    write_matrix(out, p.T_ref);
    out << '\n';
}

std::vector<GicpPair> read_gicp_pairs(const fs::path& dir) {
    const fs::path file = dir / "pairs.txt";
    std::ifstream in(file);
    if (!in) throw std::runtime_error(file.string() + ": cannot read");
    std::vector<GicpPair> pairs;
    std::string line;
    while (std::getline(in, line)) {
        std::istringstream s(line);
        GicpPair p;
        s >> p.name >> p.voxel_m >> p.k >> p.bound_m >> p.max_iterations >> p.eps >>
            p.target_file >> p.source_file;
        p.T_init = read_matrix(s);
        p.T_ref = read_matrix(s);
        if (!s) throw std::runtime_error(file.string() + ": expected a pair, got: " + line);
        pairs.push_back(p);
    }
    return pairs;
}

std::vector<Eigen::Vector3d> read_pair_points(const fs::path& file) {
    std::ifstream in(file, std::ios::binary | std::ios::ate);
    if (!in) throw std::runtime_error(file.string() + ": cannot read");
    const auto bytes = static_cast<std::size_t>(in.tellg());
    if (bytes % (3 * sizeof(double)) != 0) {
        throw std::runtime_error(file.string() + ": expected x y z float64 triples, got " +
                                 std::to_string(bytes) + " bytes");
    }
    std::vector<Eigen::Vector3d> points(bytes / (3 * sizeof(double)));
    in.seekg(0);
    for (Eigen::Vector3d& p : points)
        in.read(reinterpret_cast<char*>(p.data()), 3 * sizeof(double));
    return points;
}

void write_pair_points(const fs::path& file, const std::vector<Eigen::Vector3d>& points) {
    std::ofstream out(file, std::ios::binary);
    for (const Eigen::Vector3d& p : points) {
        out.write(reinterpret_cast<const char*>(p.data()), 3 * sizeof(double));
    }
    if (!out) throw std::runtime_error(file.string() + ": cannot write");
}

std::string result_name(const GicpPair& pair) {
    std::ostringstream name;
    name << pair.name << '@' << pair.voxel_m;
    return name.str();
}

void write_pair_result(std::ostream& out, const GicpPair& pair, const PairResult& result) {
    out << result_name(pair);
    for (const double ms : result.stage_ms) out << ' ' << ms;
    out << ' ' << result.total_ms;
    write_matrix(out, result.T);
    out << '\n';
}

std::map<std::string, PairResult> read_pair_results(const fs::path& file) {
    std::ifstream in(file);
    if (!in) throw std::runtime_error(file.string() + ": cannot read");
    std::map<std::string, PairResult> results;
    std::string line;
    while (std::getline(in, line)) {
        std::istringstream s(line);
        std::string name;
        PairResult r;
        s >> name >> r.stage_ms[0] >> r.stage_ms[1] >> r.stage_ms[2] >> r.stage_ms[3] >> r.total_ms;
        r.T = read_matrix(s);
        if (!s) throw std::runtime_error(file.string() + ": expected a result, got: " + line);
        results[name] = r;
    }
    return results;
}

std::string pair_kind(const std::string& name) {
    for (const char* kind : {"sim_temporal", "sim_spatial"}) {
        if (name.rfind(kind, 0) == 0) return kind;
    }
    return name;
}

}  // namespace lidarfuse::bench
