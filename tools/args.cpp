#include "tools/args.hpp"

#include <cstdlib>

namespace lidarfuse::tools {

Args::Args(int argc, char** argv, const std::set<std::string>& value_options,
           const std::set<std::string>& flag_options) {
    for (int i = 1; i < argc; ++i) {
        const std::string arg = argv[i];
        if (arg == "--help" || arg == "-h") {
            help_ = true;
        } else if (flag_options.count(arg)) {
            flags_.insert(arg);
        } else if (value_options.count(arg)) {
            if (i + 1 >= argc) throw UsageError("option " + arg + " expects a value");
            values_[arg].push_back(argv[++i]);
        } else if (arg.size() > 1 && arg[0] == '-') {
            throw UsageError("unknown option " + arg);
        } else {
            positionals_.push_back(arg);
        }
    }
}

std::optional<std::string> Args::value(const std::string& name) const {
    const auto it = values_.find(name);
    if (it == values_.end() || it->second.empty()) return std::nullopt;
    return it->second.back();
}

std::vector<std::string> Args::values(const std::string& name) const {
    const auto it = values_.find(name);
    return it == values_.end() ? std::vector<std::string>{} : it->second;
}

std::string Args::required(const std::string& name) const {
    auto v = value(name);
    if (!v) throw UsageError("missing required option " + name);
    return *v;
}

double Args::number(const std::string& name, double fallback) const {
    const auto v = value(name);
    if (!v) return fallback;
    char* end = nullptr;
    const double x = std::strtod(v->c_str(), &end);
    if (end == v->c_str() || *end != '\0') {
        throw UsageError("option " + name + " expects a number, got '" + *v + "'");
    }
    return x;
}

long long Args::integer(const std::string& name, long long fallback) const {
    const auto v = value(name);
    if (!v) return fallback;
    char* end = nullptr;
    const long long x = std::strtoll(v->c_str(), &end, 10);
    if (end == v->c_str() || *end != '\0') {
        throw UsageError("option " + name + " expects an integer, got '" + *v + "'");
    }
    return x;
}

}  // namespace lidarfuse::tools
