// The sensor HTTP client (drivers/ouster/sensor_http.hpp) against a real httplib::Server on
// 127.0.0.1 playing the sensor: the three metadata forms, every failure a SensorHttpError
// naming host, method and path, configuration with its wait for RUNNING, and the pure
// parsing functions the fuzzer also exercises.

#include "drivers/ouster/sensor_http.hpp"

#include <gtest/gtest.h>
#include <httplib.h>
#include <pthread.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <thread>

#include "drivers/sim/sensor_rig.hpp"

namespace lidarfuse::ouster {
namespace {

using nlohmann::json;

constexpr const char* kWholePath = "/api/v1/sensor/metadata";
constexpr const char* kSensorInfoPath = "/api/v1/sensor/metadata/sensor_info";

// A valid OS1-64 1024x20 (the simulator's), RUNNING, udp_dest 169.254.10.1.
SensorInfo sample_info() { return sim::make_sensor_info(sim::SensorRigParams{}); }
json sample_document() { return json::parse(to_nested_json(sample_info())); }

bool contains(const std::string& text, const std::string& needle) {
    return text.find(needle) != std::string::npos;
}

// An httplib::Server on a kernel-assigned port of 127.0.0.1, serving from its own thread.
// Handlers are registered through server() before start(). Records every request line.
class FakeSensor {
public:
    FakeSensor() {
        server_.set_pre_routing_handler([this](const httplib::Request& req, httplib::Response&) {
            std::lock_guard<std::mutex> lock(mutex_);
            requests_.push_back(req.method + " " + req.path);
            return httplib::Server::HandlerResponse::Unhandled;
        });
    }
    ~FakeSensor() { stop(); }
    FakeSensor(const FakeSensor&) = delete;
    FakeSensor& operator=(const FakeSensor&) = delete;

    httplib::Server& server() { return server_; }

    void start() {
        port_ = server_.bind_to_any_port("127.0.0.1");
        ASSERT_GT(port_, 0);
        thread_ = std::thread([this] {
            // httplib sends without MSG_NOSIGNAL: a client that stops reading (the body
            // bound) would end the test process by SIGPIPE. The server's worker threads,
            // created by listen, inherit this thread's mask.
            sigset_t pipe;
            sigemptyset(&pipe);
            sigaddset(&pipe, SIGPIPE);
            pthread_sigmask(SIG_BLOCK, &pipe, nullptr);
            server_.listen_after_bind();
        });
        const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(10);
        while (!server_.is_running() && std::chrono::steady_clock::now() < give_up) {
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
        }
        ASSERT_TRUE(server_.is_running());
    }

    // Wakes handlers waiting on stopping(), stops the server and joins its thread.
    void stop() {
        stopping_ = true;
        if (thread_.joinable()) {
            server_.stop();
            thread_.join();
        }
    }

    bool stopping() const { return stopping_; }
    int port() const { return port_; }

    SensorHttpParams params() const {
        SensorHttpParams p;
        p.host = "127.0.0.1";
        p.port = port_;
        p.connect_timeout_s = 2.0;
        p.read_timeout_s = 2.0;
        p.sensor_name = "lidar0";
        return p;
    }

    std::vector<std::string> requests() const {
        std::lock_guard<std::mutex> lock(mutex_);
        return requests_;
    }

private:
    httplib::Server server_;
    std::thread thread_;
    std::atomic<bool> stopping_{false};
    int port_ = -1;
    mutable std::mutex mutex_;
    std::vector<std::string> requests_;
};

// Runs `call` expecting a SensorHttpError; returns its message.
template <typename F>
std::string error_of(F&& call) {
    try {
        call();
    } catch (const SensorHttpError& e) {
        return e.what();
    }
    ADD_FAILURE() << "expected a SensorHttpError";
    return {};
}

void serve_json(httplib::Response& res, const json& value) {
    res.set_content(value.dump(), "application/json");
}

class SensorHttpTest : public ::testing::Test {
protected:
    void TearDown() override { sensor_.stop(); }

    // Parts of the sample document for forms 2/3: `part` may be served unless it is in
    // `absent`; "config_param" is the active configuration.
    void serve_part(const std::string& part, httplib::Response& res,
                    const std::set<std::string>& absent = {}) {
        const std::string name = part == "config_param" ? "config_params" : part;
        if (absent.count(name) || !document_.contains(name)) {
            res.status = 404;
            return;
        }
        serve_json(res, document_[name]);
    }

    FakeSensor sensor_;
    json document_ = sample_document();
};

TEST_F(SensorHttpTest, WholeDocumentFromTheFirstForm) {
    sensor_.server().Get(kWholePath, [this](const httplib::Request&, httplib::Response& res) {
        serve_json(res, document_);
    });
    sensor_.start();
    const FetchedMetadata got = fetch_metadata(sensor_.params());
    EXPECT_EQ(got.endpoint, kWholePath);
    EXPECT_EQ(got.status, "RUNNING");
    EXPECT_EQ(got.json, document_.dump());
    const SensorInfo expected = sample_info();
    EXPECT_EQ(got.info.lidar_mode, expected.lidar_mode);
    EXPECT_EQ(got.info.prod_sn, expected.prod_sn);
    EXPECT_EQ(got.info.beam_altitude_angles_deg, expected.beam_altitude_angles_deg);
    EXPECT_EQ(got.info.udp_dest, expected.udp_dest);
    EXPECT_EQ(sensor_.requests(), std::vector<std::string>{"GET /api/v1/sensor/metadata"});
}

TEST_F(SensorHttpTest, PartsFromTheSecondFormWhenTheWholeDocumentIs404) {
    sensor_.server().Get(R"(/api/v1/sensor/metadata/(\w+))",
                         [this](const httplib::Request& req, httplib::Response& res) {
                             serve_part(req.matches[1], res);
                         });
    sensor_.server().Get("/api/v1/sensor/cmd/get_config_param",
                         [this](const httplib::Request& req, httplib::Response& res) {
                             if (req.get_param_value("args") != "active") res.status = 400;
                             if (res.status != 400) serve_part("config_param", res);
                         });
    sensor_.start();
    const FetchedMetadata got = fetch_metadata(sensor_.params());
    EXPECT_EQ(got.endpoint, "/api/v1/sensor/metadata/<part>");
    EXPECT_EQ(got.status, "RUNNING");
    EXPECT_EQ(got.info.lidar_mode, "1024x20");
    EXPECT_EQ(got.info.pixels_per_column, 64);
    EXPECT_EQ(got.info.udp_dest, "169.254.10.1");  // from the active configuration
    const auto requests = sensor_.requests();
    ASSERT_EQ(requests.size(), 8u);
    EXPECT_EQ(requests[0], "GET /api/v1/sensor/metadata");
    EXPECT_EQ(requests[1], "GET /api/v1/sensor/metadata/sensor_info");
    EXPECT_EQ(requests[7], "GET /api/v1/sensor/cmd/get_config_param");
}

TEST_F(SensorHttpTest, PartsFromTheThirdFormWhenTheFirstTwoAre404) {
    // FW 2.0 without the optional parts: they answer 404 and are left out.
    sensor_.server().Get(R"(/api/v1/sensor/cmd/get_(\w+))", [this](const httplib::Request& req,
                                                                   httplib::Response& res) {
        serve_part(req.matches[1], res, {"imu_intrinsics", "lidar_intrinsics"});
    });
    sensor_.start();
    const FetchedMetadata got = fetch_metadata(sensor_.params());
    EXPECT_EQ(got.endpoint, "/api/v1/sensor/cmd/get_<part>");
    EXPECT_EQ(got.info.lidar_mode, "1024x20");
    EXPECT_EQ(got.info.beam_azimuth_angles_deg, sample_info().beam_azimuth_angles_deg);
    const json assembled = json::parse(got.json);
    EXPECT_TRUE(assembled.contains("config_params"));
    EXPECT_FALSE(assembled.contains("imu_intrinsics"));
    const auto requests = sensor_.requests();
    ASSERT_GE(requests.size(), 3u);
    EXPECT_EQ(requests[1], "GET /api/v1/sensor/metadata/sensor_info");
    EXPECT_EQ(requests[2], "GET /api/v1/sensor/cmd/get_sensor_info");
}

TEST_F(SensorHttpTest, NoFormAnsweringIsAnErrorListingThePathsTried) {
    sensor_.start();
    const std::string error = error_of([&] { fetch_metadata(sensor_.params()); });
    EXPECT_TRUE(contains(error, "no metadata endpoint")) << error;
    EXPECT_TRUE(contains(error, "/api/v1/sensor/cmd/get_sensor_info")) << error;
}

TEST_F(SensorHttpTest, ASensorThatNeverAnswersIsAReadTimeOut) {
    // Waits up to 3 s, or until the fixture stops the server.
    sensor_.server().Get(kWholePath, [this](const httplib::Request&, httplib::Response& res) {
        for (int i = 0; i < 300 && !sensor_.stopping(); ++i) {
            std::this_thread::sleep_for(std::chrono::milliseconds(10));
        }
        serve_json(res, document_);
    });
    sensor_.start();
    SensorHttpParams params = sensor_.params();
    params.read_timeout_s = 0.3;
    const std::string error = error_of([&] { fetch_metadata(params); });
    const std::string who =
        "lidar0 host 127.0.0.1:" + std::to_string(sensor_.port()) + " GET /api/v1/sensor/metadata";
    EXPECT_TRUE(contains(error, who)) << error;
    EXPECT_TRUE(contains(error, "read time-out of 0.3 s")) << error;
}

TEST_F(SensorHttpTest, ARefusedConnectionNamesHostAndPort) {
    int port = 0;
    {
        FakeSensor gone;  // bound, served, stopped: nothing listens on its port any more
        gone.start();
        port = gone.port();
    }
    SensorHttpParams params = sensor_.params();
    params.port = port;
    const std::string error = error_of([&] { fetch_metadata(params); });
    EXPECT_TRUE(contains(error, "127.0.0.1:" + std::to_string(port) + " GET")) << error;
    EXPECT_TRUE(contains(error, "could not connect")) << error;
}

TEST_F(SensorHttpTest, ABodyThatIsNotJsonNamesThePath) {
    sensor_.server().Get(kWholePath, [](const httplib::Request&, httplib::Response& res) {
        res.set_content("<html>sensor busy</html>", "text/html");
    });
    sensor_.start();
    const std::string error = error_of([&] { fetch_metadata(sensor_.params()); });
    EXPECT_TRUE(contains(error, "GET /api/v1/sensor/metadata")) << error;
    EXPECT_TRUE(contains(error, "malformed JSON")) << error;
}

TEST_F(SensorHttpTest, ABodyOverTheBoundIsRefused) {
    sensor_.server().Get(kWholePath, [](const httplib::Request&, httplib::Response& res) {
        res.set_content(std::string(100000, ' ') + "{}", "application/json");
    });
    sensor_.start();
    SensorHttpParams params = sensor_.params();
    params.max_body_bytes = 1000;
    const std::string error = error_of([&] { fetch_metadata(params); });
    EXPECT_TRUE(contains(error, "body over 1000 bytes")) << error;
    EXPECT_TRUE(contains(error, "GET /api/v1/sensor/metadata")) << error;
}

TEST_F(SensorHttpTest, InvalidMetadataListsTheProblem) {
    document_["beam_intrinsics"]["beam_altitude_angles"].erase(0);  // 63 angles for 64 rows
    sensor_.server().Get(kWholePath, [this](const httplib::Request&, httplib::Response& res) {
        serve_json(res, document_);
    });
    sensor_.start();
    const std::string error = error_of([&] { fetch_metadata(sensor_.params()); });
    EXPECT_TRUE(contains(error, "GET /api/v1/sensor/metadata")) << error;
    EXPECT_TRUE(contains(error, "beam_intrinsics.beam_altitude_angles")) << error;
    EXPECT_TRUE(contains(error, "63")) << error;
}

TEST_F(SensorHttpTest, AServerErrorIsNotTakenForAMissingForm) {
    sensor_.server().Get(kWholePath,
                         [](const httplib::Request&, httplib::Response& res) { res.status = 500; });
    sensor_.start();
    const std::string error = error_of([&] { fetch_metadata(sensor_.params()); });
    EXPECT_TRUE(contains(error, "GET /api/v1/sensor/metadata: HTTP 500, expected 200")) << error;
    EXPECT_EQ(sensor_.requests().size(), 1u);
}

// A sensor whose POST /api/v1/sensor/config answers `post_status` with `post_body`, and
// whose sensor_info reports INITIALIZING `initializing_polls` times, then RUNNING.
class ConfigureTest : public SensorHttpTest {
protected:
    void start(int post_status, const std::string& post_body, int initializing_polls) {
        sensor_.server().Post(
            "/api/v1/sensor/config",
            [this, post_status, post_body](const httplib::Request& req, httplib::Response& res) {
                std::lock_guard<std::mutex> lock(mutex_);
                posted_.push_back(req.body);
                content_type_ = req.get_header_value("Content-Type");
                query_ = req.get_param_value("reinit") + "," + req.get_param_value("persist");
                res.status = post_status;
                res.set_content(post_body, "application/json");
            });
        sensor_.server().Get(kSensorInfoPath, [this, initializing_polls](const httplib::Request&,
                                                                         httplib::Response& res) {
            const int poll = polls_++;
            serve_json(res, {{"status", poll < initializing_polls ? "INITIALIZING" : "RUNNING"}});
        });
        sensor_.start();
    }

    std::mutex mutex_;
    std::vector<std::string> posted_;
    std::string content_type_;
    std::string query_;
    std::atomic<int> polls_{0};
};

SensorConfigRequest full_request() {
    SensorConfigRequest r;
    r.udp_dest = "10.0.0.2";
    r.udp_port_lidar = 7502;
    r.lidar_mode = "1024x20";
    r.timestamp_mode = "TIME_FROM_PTP_1588";
    r.operating_mode = "NORMAL";
    return r;
}

TEST_F(ConfigureTest, PostsTheRequestAndWaitsForRunning) {
    start(200, "{}", 2);
    configure_sensor(sensor_.params(), full_request(), 10.0);
    std::lock_guard<std::mutex> lock(mutex_);
    ASSERT_EQ(posted_.size(), 1u);
    EXPECT_EQ(posted_[0], to_json(full_request()));
    EXPECT_EQ(content_type_, "application/json");
    EXPECT_EQ(query_, "true,false");
    EXPECT_EQ(polls_, 3);
}

TEST_F(ConfigureTest, RefusedParametersQuoteTheSensorsAnswerUpTo200Bytes) {
    const std::string answer = R"({"error": "invalid lidar_mode 1024x30"})";
    start(400, answer + std::string(500, 'Z'), 0);
    SensorConfigRequest request;
    request.lidar_mode = "1024x30";
    const std::string error = error_of([&] { configure_sensor(sensor_.params(), request, 5.0); });
    EXPECT_TRUE(contains(error, "POST /api/v1/sensor/config")) << error;
    EXPECT_TRUE(contains(error, "HTTP 400")) << error;
    EXPECT_TRUE(contains(error, "invalid lidar_mode 1024x30")) << error;
    const std::size_t quoted_z = 200 - answer.size();
    EXPECT_TRUE(contains(error, std::string(quoted_z, 'Z'))) << error;
    EXPECT_FALSE(contains(error, std::string(quoted_z + 1, 'Z'))) << error;
    EXPECT_EQ(polls_, 0);
}

TEST_F(ConfigureTest, ASensorNeverRunningAgainNamesTheLastStatus) {
    start(200, "{}", 1000000);
    const std::string error =
        error_of([&] { configure_sensor(sensor_.params(), full_request(), 0.6); });
    EXPECT_TRUE(contains(error, "GET /api/v1/sensor/metadata/sensor_info")) << error;
    EXPECT_TRUE(contains(error, "not RUNNING within 0.6 s")) << error;
    EXPECT_TRUE(contains(error, "last: INITIALIZING")) << error;
    EXPECT_GE(polls_, 2);
}

TEST(SensorHttpResponse, CheckResponseWantsStatus200WithinTheBound) {
    EXPECT_NO_THROW(check_response(200, 1000, 1000, "x"));
    const std::string not_found = error_of([] { check_response(404, 0, 1000, "h:80 GET /p"); });
    EXPECT_EQ(not_found, "h:80 GET /p: HTTP 404, expected 200");
    const std::string big = error_of([] { check_response(200, 1001, 1000, "h:80 GET /p"); });
    EXPECT_TRUE(contains(big, "h:80 GET /p")) << big;
    EXPECT_TRUE(contains(big, "over 1000 bytes")) << big;
}

std::map<std::string, std::string> sample_parts() {
    const json doc = sample_document();
    std::map<std::string, std::string> parts;
    for (const char* name : kMetadataParts) parts[name] = doc[name].dump();
    return parts;
}

TEST(SensorHttpResponse, AssembledPartsParseToTheSameInfo) {
    const FetchedMetadata got =
        parse_metadata_response(assemble_metadata_document(sample_parts(), "parts"), "parts");
    const SensorInfo expected = sample_info();
    EXPECT_EQ(got.info.lidar_mode, expected.lidar_mode);
    EXPECT_EQ(got.info.beam_altitude_angles_deg, expected.beam_altitude_angles_deg);
    EXPECT_EQ(got.info.imu_to_sensor_transform, expected.imu_to_sensor_transform);
    EXPECT_EQ(got.status, "RUNNING");
    EXPECT_TRUE(got.endpoint.empty());
}

TEST(SensorHttpResponse, APartThatIsNotAnObjectIsNamed) {
    auto parts = sample_parts();
    parts["beam_intrinsics"] = "[1, 2, 3]";
    std::string error = error_of([&] { assemble_metadata_document(parts, "form 2"); });
    EXPECT_TRUE(contains(error, "form 2")) << error;
    EXPECT_TRUE(contains(error, "beam_intrinsics is not a JSON object")) << error;
    parts["beam_intrinsics"] = "{\"beam_altitude_angles\": [";
    error = error_of([&] { assemble_metadata_document(parts, "form 2"); });
    EXPECT_TRUE(contains(error, "beam_intrinsics is not JSON")) << error;
}

TEST(SensorHttpResponse, AMissingRequiredPartIsNamedAndOptionalOnesMayBeAbsent) {
    auto parts = sample_parts();
    parts.erase("imu_intrinsics");
    parts.erase("calibration_status");
    EXPECT_NO_THROW(assemble_metadata_document(parts, "form 3"));
    parts.erase("lidar_data_format");
    const std::string error = error_of([&] { assemble_metadata_document(parts, "form 3"); });
    EXPECT_TRUE(contains(error, "form 3: part lidar_data_format is missing")) << error;
}

TEST(SensorHttpResponse, StatusOfTheLegacyFlatFormAndItsAbsence) {
    const SensorInfo info = sample_info();
    const json flat = {{"beam_altitude_angles", info.beam_altitude_angles_deg},
                       {"beam_azimuth_angles", info.beam_azimuth_angles_deg},
                       {"lidar_mode", "1024x10"},
                       {"status", "INITIALIZING"}};
    EXPECT_EQ(parse_metadata_response(flat.dump(), "flat").status, "INITIALIZING");
    json nested = sample_document();
    nested["sensor_info"].erase("status");
    EXPECT_EQ(parse_metadata_response(nested.dump(), "nested").status, "");
}

TEST(SensorHttpResponse, ToJsonHoldsOnlyTheSetFields) {
    EXPECT_EQ(to_json(SensorConfigRequest{}), "{}");
    const json expected = {{"udp_dest", "10.0.0.2"},
                           {"udp_port_lidar", 7502},
                           {"lidar_mode", "1024x20"},
                           {"timestamp_mode", "TIME_FROM_PTP_1588"},
                           {"operating_mode", "NORMAL"}};
    EXPECT_EQ(json::parse(to_json(full_request())), expected);
    SensorConfigRequest port_only;
    port_only.udp_port_lidar = 7504;
    EXPECT_EQ(to_json(port_only), R"({"udp_port_lidar":7504})");
}

TEST(SensorHttpResponse, DifferingConfigNamesWhatAReconfigurationWouldChange) {
    const SensorInfo info = sample_info();  // 169.254.10.1, 7502, 1024x20, PTP
    SensorConfigRequest same;
    same.udp_dest = info.udp_dest;
    same.udp_port_lidar = info.udp_port_lidar;
    same.lidar_mode = info.lidar_mode;
    same.timestamp_mode = info.timestamp_mode;
    same.operating_mode = "NORMAL";  // not compared: SensorInfo does not carry it
    EXPECT_TRUE(differing_config(same, info).empty());
    EXPECT_TRUE(differing_config(SensorConfigRequest{}, info).empty());

    SensorConfigRequest other = same;
    other.udp_dest = "10.0.0.2";
    other.lidar_mode = "2048x10";
    EXPECT_EQ(differing_config(other, info), (std::vector<std::string>{"udp_dest", "lidar_mode"}));
    SensorConfigRequest port;
    port.udp_port_lidar = info.udp_port_lidar + 2;
    port.timestamp_mode = "TIME_FROM_INTERNAL_OSC";
    EXPECT_EQ(differing_config(port, info),
              (std::vector<std::string>{"udp_port_lidar", "timestamp_mode"}));
}

}  // namespace
}  // namespace lidarfuse::ouster
