#pragma once
// Internal to the metadata parser (drivers/ouster/metadata.cpp): reads typed values out of
// an Ouster metadata JSON document at dotted paths, collecting every problem with its
// path instead of stopping at the first. Not part of the drivers' interface (it exposes
// nlohmann::json, a private dependency).

#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

namespace lidarfuse::ouster::detail {

using nlohmann::json;

inline std::string type_name(const json& v) {
    if (v.is_null()) return "null";
    if (v.is_boolean()) return "a boolean";
    if (v.is_number()) return "a number";
    if (v.is_string()) return "a string";
    if (v.is_array()) return "an array";
    return "an object";
}

// Short rendering of a JSON value for messages (strings quoted, long values cut).
inline std::string show(const json& v) {
    std::string s = v.dump();
    if (s.size() > 40) s = s.substr(0, 37) + "...";
    return s;
}

// Reads typed values at dotted paths, collecting problems. `bad` remembers paths whose
// value was present but unusable, so the semantic checks do not report them twice.
class Reader {
public:
    Reader(const json& root, std::vector<std::string>* problems, std::set<std::string>* bad)
        : root_(root), problems_(problems), bad_(bad) {}

    const json* find(const std::string& path) const {
        const json* node = &root_;
        std::size_t start = 0;
        while (start <= path.size()) {
            const std::size_t dot = path.find('.', start);
            const std::string key =
                path.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
            if (!node->is_object()) return nullptr;
            const auto it = node->find(key);
            if (it == node->end()) return nullptr;
            node = &*it;
            if (dot == std::string::npos) break;
            start = dot + 1;
        }
        return node->is_null() ? nullptr : node;
    }
    bool has(const std::string& path) const { return find(path) != nullptr; }

    void problem(const std::string& path, const std::string& message) {
        problems_->push_back(path + ": " + message);
        bad_->insert(path);
    }

    bool string(const std::string& path, std::string* out) {
        const json* v = find(path);
        if (v == nullptr) return false;
        if (!v->is_string()) {
            problem(path, "expected a string, got " + type_name(*v) + " " + show(*v));
            return false;
        }
        *out = v->get<std::string>();
        return true;
    }

    // A string, or an integer written without quotes (old files store prod_sn as number).
    bool string_or_integer(const std::string& path, std::string* out) {
        const json* v = find(path);
        if (v == nullptr) return false;
        if (v->is_number_unsigned()) {
            *out = std::to_string(v->get<std::uint64_t>());
            return true;
        }
        return string(path, out);
    }

    bool number(const std::string& path, double* out) {
        const json* v = find(path);
        if (v == nullptr) return false;
        if (!v->is_number()) {
            problem(path, "expected a number, got " + type_name(*v) + " " + show(*v));
            return false;
        }
        const double d = v->get<double>();
        if (!std::isfinite(d)) {
            problem(path, "expected a finite number, got " + show(*v));
            return false;
        }
        *out = d;
        return true;
    }

    bool integer(const std::string& path, long long lo, long long hi, long long* out) {
        const json* v = find(path);
        if (v == nullptr) return false;
        return integer_value(path, *v, lo, hi, out);
    }

    template <typename T>
    bool integer_as(const std::string& path, long long lo, long long hi, T* out) {
        long long value = 0;
        if (!integer(path, lo, hi, &value)) return false;
        *out = static_cast<T>(value);
        return true;
    }

    // Array of numbers of any length (the length is a semantic check).
    bool numbers(const std::string& path, std::vector<double>* out) {
        const json* v = find(path);
        if (v == nullptr) return false;
        if (!v->is_array()) {
            problem(path, "expected an array of numbers, got " + type_name(*v));
            return false;
        }
        std::vector<double> values;
        values.reserve(v->size());
        bool ok = true;
        for (std::size_t i = 0; i < v->size(); ++i) {
            const json& e = (*v)[i];
            if (!e.is_number() || !std::isfinite(e.get<double>())) {
                problems_->push_back(path + "[" + std::to_string(i) +
                                     "]: expected a finite number, got " + type_name(e) + " " +
                                     show(e));
                ok = false;
                continue;
            }
            values.push_back(e.get<double>());
        }
        if (!ok) {
            bad_->insert(path);
            return false;
        }
        *out = std::move(values);
        return true;
    }

    bool integers(const std::string& path, long long lo, long long hi, std::vector<int>* out) {
        const json* v = find(path);
        if (v == nullptr) return false;
        if (!v->is_array()) {
            problem(path, "expected an array of integers, got " + type_name(*v));
            return false;
        }
        std::vector<int> values;
        bool ok = true;
        for (std::size_t i = 0; i < v->size(); ++i) {
            long long value = 0;
            if (!integer_value(path + "[" + std::to_string(i) + "]", (*v)[i], lo, hi, &value)) {
                ok = false;
                continue;
            }
            values.push_back(static_cast<int>(value));
        }
        if (!ok) {
            bad_->insert(path);
            return false;
        }
        *out = std::move(values);
        return true;
    }

    // 16 numbers, row-major 4x4.
    bool matrix4(const std::string& path, Eigen::Matrix4d* out) {
        std::vector<double> values;
        if (!numbers(path, &values)) return false;
        if (values.size() != 16) {
            problem(path,
                    "expected 16 numbers (row-major 4x4), got " + std::to_string(values.size()));
            return false;
        }
        for (int r = 0; r < 4; ++r)
            for (int c = 0; c < 4; ++c) (*out)(r, c) = values[static_cast<std::size_t>(r * 4 + c)];
        return true;
    }

private:
    bool integer_value(const std::string& path, const json& v, long long lo, long long hi,
                       long long* out) {
        long long value = 0;
        if (v.is_number_integer()) {
            if (v.is_number_unsigned() &&
                v.get<std::uint64_t>() >
                    static_cast<std::uint64_t>(std::numeric_limits<long long>::max())) {
                problem(path, "integer " + show(v) + " out of range");
                return false;
            }
            value = v.get<long long>();
        } else if (v.is_number_float() && std::isfinite(v.get<double>()) &&
                   std::floor(v.get<double>()) == v.get<double>() &&
                   std::fabs(v.get<double>()) < 9e15) {
            value = static_cast<long long>(v.get<double>());
        } else {
            problem(path, "expected an integer, got " + type_name(v) + " " + show(v));
            return false;
        }
        if (value < lo || value > hi) {
            problem(path, "expected an integer in " + std::to_string(lo) + ".." +
                              std::to_string(hi) + ", got " + std::to_string(value));
            return false;
        }
        *out = value;
        return true;
    }

    const json& root_;
    std::vector<std::string>* problems_;
    std::set<std::string>* bad_;
};

}  // namespace lidarfuse::ouster::detail
