// The network half of sensor_http.hpp over cpp-httplib: one fresh connection per request
// (no keep-alive, so nothing is shared between calls), every request with the connect,
// read and write time-outs of SensorHttpParams and its body bounded while it arrives.

#include "drivers/ouster/sensor_http.hpp"

#include <httplib.h>
#include <pthread.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <thread>

#include "core/common/stopwatch.hpp"

namespace lidarfuse::ouster {
namespace {

using Clock = std::chrono::steady_clock;

constexpr const char* kWholePath = "/api/v1/sensor/metadata";
constexpr const char* kPartPrefix = "/api/v1/sensor/metadata/";
constexpr const char* kCmdPrefix = "/api/v1/sensor/cmd/get_";
constexpr const char* kActiveConfigPath = "/api/v1/sensor/cmd/get_config_param?args=active";
constexpr const char* kConfigPath = "/api/v1/sensor/config?reinit=true&persist=false";
constexpr const char* kSensorInfoPath = "/api/v1/sensor/metadata/sensor_info";
constexpr double kPollPeriodS = 0.25;
constexpr std::size_t kQuotedAnswerBytes = 200;

struct Answer {
    int status = 0;
    std::string body;
};

// "2.0" for whole tenths, else up to three significant digits ("0.25").
std::string seconds_text(double s) {
    char text[32];
    const bool tenths = std::abs(s * 10.0 - std::round(s * 10.0)) < 1e-9;
    std::snprintf(text, sizeof(text), tenths ? "%.1f" : "%.3g", s);
    return text;
}

// "lidar0 host 10.5.5.87:80 GET /api/v1/sensor/metadata": who was asked what.
std::string describe(const SensorHttpParams& params, const std::string& method,
                     const std::string& path) {
    std::string out = params.sensor_name.empty() ? "" : params.sensor_name + " ";
    out += "host " + params.host + ":" + std::to_string(params.port);
    if (!method.empty()) out += " " + method + " " + path;
    return out;
}

// The first kQuotedAnswerBytes of a sensor's answer, control characters blanked.
std::string quoted(const std::string& body) {
    std::string out = body.substr(0, kQuotedAnswerBytes);
    for (char& c : out) {
        if (static_cast<unsigned char>(c) < 0x20) c = ' ';
    }
    return "\"" + out + (body.size() > kQuotedAnswerBytes ? "...\"" : "\"");
}

// Configured seconds within [0, one day]; NaN as 0.
double bounded_s(double seconds) {
    return std::isfinite(seconds) ? std::clamp(seconds, 0.0, 86400.0) : 0.0;
}

Clock::duration to_duration(double seconds) {
    return std::chrono::duration_cast<Clock::duration>(
        std::chrono::duration<double>(bounded_s(seconds)));
}

// Seconds as httplib's (sec, usec).
template <typename Set>
void set_timeout(double seconds, Set&& set) {
    const double s = bounded_s(seconds);
    const auto whole = static_cast<time_t>(s);
    set(whole, static_cast<time_t>(std::lround((s - static_cast<double>(whole)) * 1e6)));
}

// httplib's error code as a sentence; Read after the full read time-out is a time-out.
std::string transport_failure(httplib::Error error, double elapsed_s,
                              const SensorHttpParams& params) {
    const std::string code = " (httplib: " + httplib::to_string(error) + ")";
    switch (error) {
        case httplib::Error::Canceled:
            return "body over " + std::to_string(params.max_body_bytes) +
                   " bytes (max_body_bytes), stopped reading";
        case httplib::Error::ConnectionTimeout:
        case httplib::Error::Connection:
            if (error == httplib::Error::ConnectionTimeout ||
                elapsed_s >= 0.9 * params.connect_timeout_s) {
                return "connection timed out after " + seconds_text(params.connect_timeout_s) +
                       " s" + code;
            }
            return "could not connect (refused, unreachable or not resolved)" + code;
        case httplib::Error::Read:
            if (elapsed_s >= 0.9 * params.read_timeout_s) {
                return "no answer within the read time-out of " +
                       seconds_text(params.read_timeout_s) + " s" + code;
            }
            return "the connection closed before a complete answer" + code;
        default:
            return "request failed" + code;
    }
}

// Debian's libcpp-httplib 0.11 sends with flags 0 (no MSG_NOSIGNAL): a sensor closing the
// connection while the request is written would raise SIGPIPE and end the process.
// SIGPIPE from send() is directed at the calling thread, so it is blocked in this thread
// for the request and one raised meanwhile is consumed before unblocking; the process's
// disposition stays untouched.
class SigpipeBlock {
public:
    SigpipeBlock() {
        sigemptyset(&pipe_);
        sigaddset(&pipe_, SIGPIPE);
        sigset_t pending;
        sigpending(&pending);
        was_pending_ = sigismember(&pending, SIGPIPE) == 1;
        pthread_sigmask(SIG_BLOCK, &pipe_, &previous_);
    }
    ~SigpipeBlock() {
        sigset_t pending;
        sigpending(&pending);
        if (!was_pending_ && sigismember(&pending, SIGPIPE) == 1) {
            const timespec no_wait{0, 0};
            while (sigtimedwait(&pipe_, nullptr, &no_wait) == -1 && errno == EINTR) {
            }
        }
        pthread_sigmask(SIG_SETMASK, &previous_, nullptr);
    }
    SigpipeBlock(const SigpipeBlock&) = delete;
    SigpipeBlock& operator=(const SigpipeBlock&) = delete;

private:
    sigset_t pipe_;
    sigset_t previous_;
    bool was_pending_ = false;
};

// One request on a fresh connection; the body is kept only up to max_body_bytes. A
// transport failure or an over-long body is a SensorHttpError; any status is returned.
Answer send(const SensorHttpParams& params, const std::string& method, const std::string& path,
            const std::string& body = {}) {
    httplib::Client client(params.host, params.port);
    client.set_keep_alive(false);
    set_timeout(params.connect_timeout_s,
                [&](time_t s, time_t us) { client.set_connection_timeout(s, us); });
    set_timeout(params.read_timeout_s,
                [&](time_t s, time_t us) { client.set_read_timeout(s, us); });
    set_timeout(params.read_timeout_s,
                [&](time_t s, time_t us) { client.set_write_timeout(s, us); });

    Answer answer;
    httplib::Request request;
    request.method = method;
    request.path = path;
    if (!body.empty()) {
        request.body = body;
        request.set_header("Content-Type", "application/json");
    }
    request.content_receiver = [&](const char* data, std::size_t size, std::uint64_t,
                                   std::uint64_t) {
        if (answer.body.size() + size > params.max_body_bytes) return false;
        answer.body.append(data, size);
        return true;
    };
    httplib::Response response;
    httplib::Error error = httplib::Error::Success;
    const core::Stopwatch request_time;
    bool sent = false;
    {
        const SigpipeBlock no_sigpipe;
        sent = client.send(request, response, error);
    }
    if (!sent) {
        const double elapsed_s = request_time.seconds();
        throw SensorHttpError(describe(params, method, path) + ": " +
                              transport_failure(error, elapsed_s, params));
    }
    answer.status = response.status;
    return answer;
}

// GET of a JSON document: nullopt on 404, else the body of a 200 within the bound.
std::optional<std::string> get_unless_404(const SensorHttpParams& params, const std::string& path) {
    Answer answer = send(params, "GET", path);
    if (answer.status == 404) return std::nullopt;
    check_response(answer.status, answer.body.size(), params.max_body_bytes,
                   describe(params, "GET", path));
    return std::move(answer.body);
}

// Forms 2 and 3: the parts one by one, assembled. nullopt when sensor_info is 404 (the
// form does not exist); other parts answering 404 are left out, and a missing required
// one is reported by assemble_metadata_document().
std::optional<FetchedMetadata> fetch_parts(const SensorHttpParams& params,
                                           const std::string& prefix) {
    std::map<std::string, std::string> parts;
    for (const char* part : kMetadataParts) {
        const std::string name = part;
        const std::string path = name == "config_params" ? kActiveConfigPath : prefix + name;
        std::optional<std::string> body = get_unless_404(params, path);
        if (!body && name == "sensor_info") return std::nullopt;
        if (body) parts[name] = std::move(*body);
    }
    const std::string what = describe(params, "GET", prefix + "<part>");
    FetchedMetadata out = parse_metadata_response(assemble_metadata_document(parts, what), what);
    out.endpoint = prefix + "<part>";
    return out;
}

FetchedMetadata fetch_metadata_forms(const SensorHttpParams& params) {
    if (std::optional<std::string> body = get_unless_404(params, kWholePath)) {
        FetchedMetadata out = parse_metadata_response(*body, describe(params, "GET", kWholePath));
        out.endpoint = kWholePath;
        return out;
    }
    for (const char* prefix : {kPartPrefix, kCmdPrefix}) {
        if (std::optional<FetchedMetadata> out = fetch_parts(params, prefix)) return *out;
    }
    throw SensorHttpError(describe(params, "", "") + ": no metadata endpoint (HTTP 404 on " +
                          kWholePath + ", " + kSensorInfoPath + " and " + kCmdPrefix +
                          "sensor_info), expected one of them to answer 200");
}

// The status field of a sensor_info answer, or a description of what came instead.
std::string polled_status(const SensorHttpParams& params) {
    try {
        const std::optional<std::string> body = get_unless_404(params, kSensorInfoPath);
        if (!body) return "HTTP 404";
        const auto info = nlohmann::json::parse(*body, nullptr, /*allow_exceptions=*/false);
        if (info.is_object() && info.contains("status") && info["status"].is_string()) {
            return info["status"].get<std::string>();
        }
        return "sensor_info without a status: " + quoted(*body);
    } catch (const nlohmann::json::exception&) {
        return "sensor_info that is not JSON";
    } catch (const SensorHttpError& e) {
        // The sensor's web server may be briefly away while it re-initialises: keep polling.
        return e.what();
    }
}

// Polls sensor_info every kPollPeriodS until RUNNING (or cancelled). At least one poll;
// the last may end up to one request's time-outs after apply_timeout_s.
void wait_until_running(const SensorHttpParams& params, double apply_timeout_s,
                        const std::atomic<bool>* cancel) {
    const Clock::time_point deadline = Clock::now() + to_duration(apply_timeout_s);
    std::string last;
    for (;;) {
        last = polled_status(params);
        if (last == "RUNNING") return;
        if (cancel && cancel->load()) {
            throw SensorHttpError(describe(params, "GET", kSensorInfoPath) +
                                  ": cancelled while waiting for RUNNING; last: " + last);
        }
        if (Clock::now() >= deadline) break;
        std::this_thread::sleep_until(std::min(Clock::now() + to_duration(kPollPeriodS), deadline));
    }
    throw SensorHttpError(describe(params, "GET", kSensorInfoPath) +
                          ": status not RUNNING within " + seconds_text(apply_timeout_s) +
                          " s of the configuration; last: " + last);
}

// Runs `body`, letting only SensorHttpError out (httplib and the standard library may
// throw, e.g. bad_alloc or a system_error from a thread).
template <typename F>
auto guarded(const SensorHttpParams& params, F&& body) -> decltype(body()) {
    try {
        return body();
    } catch (const SensorHttpError&) {
        throw;
    } catch (const std::exception& e) {
        throw SensorHttpError(describe(params, "", "") + ": " + e.what());
    }
}

}  // namespace

FetchedMetadata fetch_metadata(const SensorHttpParams& params) {
    return guarded(params, [&] { return fetch_metadata_forms(params); });
}

void configure_sensor(const SensorHttpParams& params, const SensorConfigRequest& request,
                      double apply_timeout_s, const std::atomic<bool>* cancel) {
    guarded(params, [&] {
        const Answer answer = send(params, "POST", kConfigPath, to_json(request));
        if (answer.status < 200 || answer.status > 299) {
            throw SensorHttpError(describe(params, "POST", kConfigPath) + ": HTTP " +
                                  std::to_string(answer.status) +
                                  ", expected 2xx; the sensor answered " + quoted(answer.body));
        }
        wait_until_running(params, apply_timeout_s, cancel);
    });
}

}  // namespace lidarfuse::ouster
