#include "drivers/sim/sim_http_server.hpp"

#include <httplib.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>
#include <vector>

#include "drivers/net/ipv4_address.hpp"
#include "drivers/ouster/metadata.hpp"

namespace lidarfuse::sim {

namespace {

using nlohmann::json;

std::int64_t steady_now_ns() {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(
               std::chrono::steady_clock::now().time_since_epoch())
        .count();
}

// One simulated sensor's API: its SensorInfo as it stands now (configuration, init_id at
// the simulated time of the packets being sent, status).
class SensorApi {
public:
    SensorApi(int index, ouster::SensorInfo info, const FaultPlan& faults, LiveRoutes* routes,
              double reinit_s)
        : index_(index),
          info_(std::move(info)),
          faults_(faults),
          routes_(routes),
          reinit_ns_(static_cast<std::int64_t>(reinit_s * 1e9)) {}

    json document() const {
        ouster::SensorInfo info;
        {
            std::lock_guard<std::mutex> lock(mutex_);
            info = info_;
        }
        const LiveRoutes::Route route = routes_->get(index_);
        const double t_s = static_cast<double>(routes_->last_capture_ns() - kEpochNs) * 1e-9;
        info.init_id = faults_.init_id_at(index_, info.init_id, t_s);
        info.udp_dest = net::ipv4_to_string(route.ip);
        info.udp_port_lidar = route.port;
        info.status = steady_now_ns() < route.resume_steady_ns ? "INITIALIZING" : "RUNNING";
        json doc = json::parse(ouster::to_nested_json(info));
        doc["config_params"]["operating_mode"] = route.standby ? "STANDBY" : "NORMAL";
        return doc;
    }

    // POST /api/v1/sensor/config: empty on success, else the reason for a 400.
    std::string configure(const json& request, bool reinit) {
        if (!request.is_object()) return "expected a JSON object";
        LiveRoutes::Route route = routes_->get(index_);
        std::lock_guard<std::mutex> lock(mutex_);
        ouster::SensorInfo info = info_;
        for (const auto& [key, value] : request.items()) {
            const std::string problem = apply(key, value, &route, &info);
            if (!problem.empty()) return problem;
        }
        info_ = info;
        if (reinit) route.resume_steady_ns = steady_now_ns() + reinit_ns_;
        routes_->set(index_, route);
        return "";
    }

private:
    static std::string text_of(const json& value) {
        if (value.is_string()) return value.get<std::string>();
        return value.dump();
    }

    // Sensors accept numbers as JSON numbers or strings ("7502").
    static std::string apply(const std::string& key, const json& value, LiveRoutes::Route* route,
                             ouster::SensorInfo* info) {
        const std::string text = text_of(value);
        if (key == "udp_dest") {
            try {
                route->ip = net::parse_ipv4(text);
            } catch (const std::exception&) {
                return "udp_dest: not an IPv4 address: " + text;
            }
        } else if (key == "udp_port_lidar" || key == "udp_port_imu") {
            const long port = std::strtol(text.c_str(), nullptr, 10);
            if (port < 1 || port > 65535) return key + ": not a port: " + text;
            if (key == "udp_port_lidar") route->port = static_cast<std::uint16_t>(port);
        } else if (key == "lidar_mode") {
            if (text != info->lidar_mode)
                return "lidar_mode: the simulated sensor renders " + info->lidar_mode + " only";
        } else if (key == "timestamp_mode") {
            info->timestamp_mode = text;
        } else if (key == "operating_mode") {
            if (text != "NORMAL" && text != "STANDBY") return "operating_mode: " + text;
            route->standby = text == "STANDBY";
        } else {
            return "unknown parameter: " + key;
        }
        return "";
    }

    int index_;
    mutable std::mutex mutex_;  // guards info_
    ouster::SensorInfo info_;
    const FaultPlan& faults_;
    LiveRoutes* routes_;
    std::int64_t reinit_ns_;
};

const char* const kParts[] = {"sensor_info",      "beam_intrinsics",   "imu_intrinsics",
                              "lidar_intrinsics", "lidar_data_format", "calibration_status"};

void send_json(httplib::Response& res, const json& body) {
    res.set_content(body.dump(), "application/json");
}

}  // namespace

struct SimHttpServer::Impl {
    std::vector<std::unique_ptr<SensorApi>> apis;
    std::vector<std::unique_ptr<httplib::Server>> servers;
    std::vector<std::thread> threads;
    std::atomic<std::uint64_t> requests{0};

    void route(httplib::Server* server, SensorApi* api);
};

void SimHttpServer::Impl::route(httplib::Server* server, SensorApi* api) {
    server->set_logger([this](const httplib::Request&, const httplib::Response&) { ++requests; });
    server->Get("/api/v1/sensor/metadata", [api](const httplib::Request&, httplib::Response& res) {
        send_json(res, api->document());
    });
    for (const char* part : kParts) {
        server->Get(std::string("/api/v1/sensor/metadata/") + part,
                    [api, part](const httplib::Request&, httplib::Response& res) {
                        send_json(res, api->document()[part]);
                    });
    }
    const auto config = [api](const httplib::Request&, httplib::Response& res) {
        send_json(res, api->document()["config_params"]);
    };
    server->Get("/api/v1/sensor/cmd/get_config_param", config);
    server->Get("/api/v1/sensor/config", config);
    server->Post("/api/v1/sensor/config",
                 [api](const httplib::Request& req, httplib::Response& res) {
                     const json request = json::parse(req.body, nullptr, false);
                     const bool reinit = req.get_param_value("reinit") == "true";
                     const std::string problem = api->configure(request, reinit);
                     if (problem.empty()) {
                         res.status = 204;
                     } else {
                         res.status = 400;
                         res.set_content(problem, "text/plain");
                     }
                 });
}

SimHttpServer::SimHttpServer(const Simulator& simulator, LiveRoutes* routes,
                             const SimHttpParams& params)
    : impl_(std::make_unique<Impl>()) {
    // Debian's cpp-httplib 0.11 writes without MSG_NOSIGNAL: a client that hangs up while
    // it is answered would end the simulator with SIGPIPE instead of an EPIPE.
    std::signal(SIGPIPE, SIG_IGN);
    const auto& rigs = simulator.rigs();
    for (std::size_t k = 0; k < rigs.size(); ++k) {
        const int index = static_cast<int>(k);
        impl_->apis.push_back(std::make_unique<SensorApi>(
            index, rigs[k].info(), simulator.params().faults, routes, params.reinit_s));
        auto server = std::make_unique<httplib::Server>();
        // Two threads per sensor: a client and a stuck peer at most (the default is a
        // pool per core, per sensor).
        server->new_task_queue = [] { return new httplib::ThreadPool(2); };
        impl_->route(server.get(), impl_->apis.back().get());
        const std::string address =
            net::ipv4_to_string(params.first_ip + static_cast<std::uint32_t>(k));
        if (!server->bind_to_port(address.c_str(), params.port)) {
            throw std::runtime_error("sim --http: cannot listen on " + address + ":" +
                                     std::to_string(params.port) +
                                     " (in use, or not a local address)");
        }
        impl_->threads.emplace_back([s = server.get()] { s->listen_after_bind(); });
        impl_->servers.push_back(std::move(server));
    }
    // stop() only ends a server that is already listening.
    for (auto& s : impl_->servers) {
        while (!s->is_running()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
}

SimHttpServer::~SimHttpServer() {
    for (auto& s : impl_->servers) s->stop();
    for (auto& t : impl_->threads) t.join();
}

std::uint64_t SimHttpServer::requests() const { return impl_->requests.load(); }

}  // namespace lidarfuse::sim
