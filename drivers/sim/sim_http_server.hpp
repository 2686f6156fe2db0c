#pragma once
// The simulated sensors' HTTP API (`lidarfuse sim --live --http ADDRESS[:PORT]`): sensor k
// answers on ADDRESS + k (127.0.1.1, 127.0.1.2, ... are all loopback on Linux), so a daemon
// configured with `hostname:` fetches, configures and follows the simulated sensors the
// way it does real ones (drivers/ouster/sensor_http.hpp).
//
// Served, with the JSON a sensor sends (the nested metadata document of the sensor's
// SensorInfo, with the current init_id, status and configuration):
//   GET  /api/v1/sensor/metadata                       the whole document
//   GET  /api/v1/sensor/metadata/<part>                one part of it
//   GET  /api/v1/sensor/cmd/get_config_param?args=active, GET /api/v1/sensor/config
//   POST /api/v1/sensor/config[?reinit=true]           udp_dest, udp_port_lidar,
//        udp_port_imu, lidar_mode, timestamp_mode, operating_mode
// A POST changes where the sensor sends (LiveRoutes). With reinit=true the sensor is
// INITIALIZING for `reinit_s` and sends nothing meanwhile, as a real one does; the
// simulated sensor keeps its init_id then (a reboot is the init-id fault, which the API
// reports from the moment its packets carry the new id). It renders one lidar_mode only:
// asking for another is refused with 400, as a sensor refuses an unknown mode.
//
// Each sensor's server runs on its own thread until the object is destroyed.

#include <cstdint>
#include <memory>
#include <string>

#include "drivers/sim/live_sink.hpp"
#include "drivers/sim/simulator.hpp"

namespace lidarfuse::sim {

struct SimHttpParams {
    std::uint32_t first_ip = 0;  // sensor k on first_ip + k; host byte order
    int port = 80;
    double reinit_s = 0.5;
};

class SimHttpServer {
public:
    // Starts listening; throws std::runtime_error naming the address that cannot be bound.
    SimHttpServer(const Simulator& simulator, LiveRoutes* routes, const SimHttpParams& params);
    ~SimHttpServer();
    SimHttpServer(const SimHttpServer&) = delete;
    SimHttpServer& operator=(const SimHttpServer&) = delete;

    // Requests answered (any status), for the `name value unit` lines.
    std::uint64_t requests() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace lidarfuse::sim
