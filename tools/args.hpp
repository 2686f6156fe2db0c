#pragma once
// Minimal argument parser shared by the subcommands: `--flag`, `--key VALUE` (repeatable),
// and positionals. Unknown options and missing values are errors naming the option.

#include <map>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace lidarfuse::tools {

class Args {
public:
    // `value_options` take one value each (e.g. "--out"); `flag_options` take none.
    Args(int argc, char** argv, const std::set<std::string>& value_options,
         const std::set<std::string>& flag_options);

    bool help() const { return help_; }
    bool flag(const std::string& name) const { return flags_.count(name) > 0; }
    std::optional<std::string> value(const std::string& name) const;
    std::vector<std::string> values(const std::string& name) const;  // every occurrence
    std::string required(const std::string& name) const;
    const std::vector<std::string>& positionals() const { return positionals_; }

    double number(const std::string& name, double fallback) const;
    long long integer(const std::string& name, long long fallback) const;

private:
    bool help_ = false;
    std::set<std::string> flags_;
    std::map<std::string, std::vector<std::string>> values_;
    std::vector<std::string> positionals_;
};

class UsageError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

}  // namespace lidarfuse::tools
