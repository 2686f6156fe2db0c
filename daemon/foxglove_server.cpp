#include "daemon/foxglove_server.hpp"

#include <pthread.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <map>
#include <mutex>
#include <stdexcept>
#include <thread>
// websocketpp on Debian's standalone asio (libasio-dev, ASIO_STANDALONE), not Boost's.
#include <websocketpp/config/asio_no_tls.hpp>
#include <websocketpp/server.hpp>

#include "daemon/foxglove_protocol.hpp"
#include "daemon/sensor_ingest.hpp"

namespace lidarfuse::daemon {

namespace {

using WsServer = websocketpp::server<websocketpp::config::asio>;
using Handle = websocketpp::connection_hdl;

// A client's own JSON requests are small; anything larger is refused by websocketpp.
constexpr std::size_t kMaxClientMessageBytes = 64 * 1024;
// How long a closing client may take to answer the close (a stalled one never does).
constexpr long kCloseTimeoutMs = 500;
constexpr auto kStopTimeout = std::chrono::milliseconds(1000);

}  // namespace

struct FoxgloveServer::Impl {
    struct Client {
        std::string peer;
        std::map<std::uint32_t, std::uint32_t> subscriptions;  // subscription id -> channel
        std::atomic<std::uint64_t> sent{0}, dropped{0};
    };
    struct Latched {
        std::int64_t receive_ns = 0;
        std::shared_ptr<const std::vector<std::uint8_t>> payload;
    };

    FoxgloveConfig config;
    std::vector<FoxgloveChannelInfo> channels;
    std::string name;
    std::shared_ptr<spdlog::logger> log;
    std::size_t buffer_bytes = 0;
    std::string session_id = std::to_string(realtime_ns());  // a new one per start
    WsServer server;
    std::unique_ptr<asio::steady_timer> stop_timer;
    std::thread thread;
    std::uint16_t port = 0;
    bool stopping = false;  // server thread: close_all() ran

    // Subscriptions per channel id; written by the server thread, read by publishers.
    std::array<std::atomic<int>, kFoxgloveChannelCount + 1> subscribers{};
    std::atomic<std::size_t> handed_over_bytes{0};  // published, not yet at any client
    std::atomic<std::uint64_t> queue_drops{0};

    // `clients`' structure and the totals: changed by the server thread under the mutex,
    // which stats() takes to read them. The server thread reads them without it.
    mutable std::mutex mutex;
    std::map<Handle, Client, std::owner_less<Handle>> clients;
    std::map<std::uint32_t, Latched> latched;  // channel -> its last message
    std::uint64_t connections = 0, refused = 0, sent_closed = 0, dropped_closed = 0;
    std::string frame;  // server thread: the message-data frame being sent

    Impl(const FoxgloveConfig& c, std::vector<FoxgloveChannelInfo> ch, std::string n,
         std::shared_ptr<spdlog::logger> l)
        : config(c),
          channels(std::move(ch)),
          name(std::move(n)),
          log(std::move(l)),
          buffer_bytes(static_cast<std::size_t>(c.client_buffer_mb * 1024 * 1024)) {}

    const FoxgloveChannelInfo* channel(std::uint32_t id) const {
        for (const auto& c : channels) {
            if (static_cast<std::uint32_t>(c.id) == id) return &c;
        }
        return nullptr;
    }

    void listen();
    bool validate(Handle hdl);
    void on_open(Handle hdl);
    void on_gone(Handle hdl);
    void on_message(Handle hdl, WsServer::message_ptr message);
    void subscribe(Handle hdl, Client* client, std::uint32_t id, std::uint32_t channel_id);
    void send_text(Handle hdl, const std::string& text);
    void deliver(std::uint32_t channel, std::int64_t receive_ns,
                 const std::shared_ptr<const std::vector<std::uint8_t>>& payload);
    void send_message(Handle hdl, Client* client, std::uint32_t subscription,
                      std::int64_t receive_ns, const std::vector<std::uint8_t>& payload);
    void close_all();
};

void FoxgloveServer::Impl::listen() {
    server.clear_access_channels(websocketpp::log::alevel::all);
    server.clear_error_channels(websocketpp::log::elevel::all);
    server.init_asio();
    server.set_reuse_addr(true);
    server.set_max_message_size(kMaxClientMessageBytes);
    server.set_validate_handler([this](Handle h) { return validate(h); });
    server.set_open_handler([this](Handle h) { on_open(h); });
    server.set_close_handler([this](Handle h) { on_gone(h); });
    server.set_fail_handler([this](Handle h) { on_gone(h); });
    server.set_message_handler(
        [this](Handle h, WsServer::message_ptr m) { on_message(h, std::move(m)); });
    stop_timer = std::make_unique<asio::steady_timer>(server.get_io_service());
    std::error_code ec;
    const auto where = "ws://" + config.bind_address + ":" + std::to_string(config.port);
    const auto address = asio::ip::make_address(config.bind_address, ec);
    if (!ec) {
        server.listen(asio::ip::tcp::endpoint(address, static_cast<std::uint16_t>(config.port)),
                      ec);
    }
    if (!ec) server.start_accept(ec);
    if (!ec) port = server.get_local_endpoint(ec).port();
    if (ec)
        throw std::runtime_error("output.foxglove: cannot listen on " + where + ": " +
                                 ec.message());
}

bool FoxgloveServer::Impl::validate(Handle hdl) {
    const auto con = server.get_con_from_hdl(hdl);
    const auto& wanted = con->get_requested_subprotocols();
    const bool speaks = std::find(wanted.begin(), wanted.end(), kSubprotocol) != wanted.end();
    std::lock_guard<std::mutex> lock(mutex);
    if (!speaks || clients.size() >= static_cast<std::size_t>(config.max_clients)) {
        ++refused;
        con->set_status(speaks ? websocketpp::http::status_code::service_unavailable
                               : websocketpp::http::status_code::bad_request);
        log->warn("foxglove: refused {} ({})", con->get_remote_endpoint(),
                  speaks ? "max_clients " + std::to_string(config.max_clients) + " connected"
                         : std::string("no ") + kSubprotocol + " subprotocol");
        return false;
    }
    con->select_subprotocol(kSubprotocol);
    con->set_close_handshake_timeout(kCloseTimeoutMs);
    clients[hdl].peer = con->get_remote_endpoint();  // counted from here against max_clients
    ++connections;
    return true;
}

void FoxgloveServer::Impl::on_open(Handle hdl) {
    const auto it = clients.find(hdl);
    if (it == clients.end()) return;
    send_text(hdl, foxglove_server_info(name, session_id));
    send_text(hdl, foxglove_advertise(channels));
    log->info("foxglove: {} connected ({} clients)", it->second.peer, clients.size());
}

void FoxgloveServer::Impl::on_gone(Handle hdl) {
    const auto it = clients.find(hdl);
    if (it == clients.end()) return;  // refused at validation
    for (const auto& s : it->second.subscriptions) subscribers[s.second].fetch_sub(1);
    log->info("foxglove: {} disconnected: {} messages sent, {} dropped", it->second.peer,
              it->second.sent.load(), it->second.dropped.load());
    std::lock_guard<std::mutex> lock(mutex);
    sent_closed += it->second.sent.load();
    dropped_closed += it->second.dropped.load();
    clients.erase(it);
    if (stopping && clients.empty()) server.stop();  // the last one closed: no need to wait
}

void FoxgloveServer::Impl::on_message(Handle hdl, WsServer::message_ptr message) {
    const auto it = clients.find(hdl);
    if (it == clients.end()) return;
    if (message->get_opcode() != websocketpp::frame::opcode::text) {
        send_text(hdl, foxglove_status(FoxgloveStatusLevel::kError,
                                       "this server accepts no binary messages"));
        return;
    }
    const FoxgloveRequest request = parse_foxglove_request(message->get_payload());
    if (request.kind == FoxgloveRequest::Kind::kInvalid) {
        send_text(hdl, foxglove_status(FoxgloveStatusLevel::kError, request.error));
        return;
    }
    for (const auto& [id, channel_id] : request.subscribe)
        subscribe(hdl, &it->second, id, channel_id);
    for (const auto id : request.unsubscribe) {
        const auto s = it->second.subscriptions.find(id);
        if (s == it->second.subscriptions.end()) continue;
        subscribers[s->second].fetch_sub(1);
        std::lock_guard<std::mutex> lock(mutex);
        it->second.subscriptions.erase(s);
    }
}

void FoxgloveServer::Impl::subscribe(Handle hdl, Client* client, std::uint32_t id,
                                     std::uint32_t channel_id) {
    if (!channel(channel_id) || client->subscriptions.count(id)) {
        send_text(hdl, foxglove_status(FoxgloveStatusLevel::kError,
                                       "subscribe: unknown channel " + std::to_string(channel_id) +
                                           " or subscription id " + std::to_string(id) +
                                           " already in use"));
        return;
    }
    {
        std::lock_guard<std::mutex> lock(mutex);
        client->subscriptions[id] = channel_id;
    }
    subscribers[channel_id].fetch_add(1);
    Latched last;
    {
        std::lock_guard<std::mutex> lock(mutex);  // publish() stores it from another thread
        const auto l = latched.find(channel_id);
        if (l != latched.end()) last = l->second;
    }
    if (last.payload) send_message(hdl, client, id, last.receive_ns, *last.payload);
}

void FoxgloveServer::Impl::send_text(Handle hdl, const std::string& text) {
    std::error_code ec;
    server.send(hdl, text, websocketpp::frame::opcode::text, ec);  // failures end in on_gone
}

void FoxgloveServer::Impl::deliver(
    std::uint32_t channel_id, std::int64_t receive_ns,
    const std::shared_ptr<const std::vector<std::uint8_t>>& payload) {
    handed_over_bytes.fetch_sub(payload->size());
    for (auto& [hdl, client] : clients) {
        for (const auto& [id, subscribed_channel] : client.subscriptions) {
            if (subscribed_channel == channel_id)
                send_message(hdl, &client, id, receive_ns, *payload);
        }
    }
}

void FoxgloveServer::Impl::send_message(Handle hdl, Client* client, std::uint32_t subscription,
                                        std::int64_t receive_ns,
                                        const std::vector<std::uint8_t>& payload) {
    std::error_code ec;
    const auto con = server.get_con_from_hdl(hdl, ec);
    if (ec) return;
    // Bytes websocketpp holds for this client that its socket has not taken yet: a client
    // that reads too slowly (or not at all) fills it and then loses messages.
    const std::size_t bytes = kFoxgloveMessageDataHeaderBytes + payload.size();
    if (con->get_buffered_amount() + bytes > buffer_bytes) {
        client->dropped.fetch_add(1, std::memory_order_relaxed);
        return;
    }
    foxglove_message_data(subscription, static_cast<std::uint64_t>(receive_ns), payload, &frame);
    con->send(frame, websocketpp::frame::opcode::binary);
    client->sent.fetch_add(1, std::memory_order_relaxed);
}

void FoxgloveServer::Impl::close_all() {
    stopping = true;
    std::error_code ec;
    server.stop_listening(ec);
    if (clients.empty()) {
        server.stop();
        return;
    }
    for (auto& c : clients) {
        server.close(c.first, websocketpp::close::status::going_away, "lidarfused stopping", ec);
    }
    stop_timer->expires_after(kStopTimeout);
    stop_timer->async_wait([this](const std::error_code&) { server.stop(); });
}

FoxgloveServer::FoxgloveServer(const FoxgloveConfig& config,
                               std::vector<FoxgloveChannelInfo> channels, std::string server_name,
                               std::shared_ptr<spdlog::logger> log)
    : impl_(std::make_unique<Impl>(config, std::move(channels), std::move(server_name),
                                   std::move(log))) {
    impl_->listen();
}

FoxgloveServer::~FoxgloveServer() { stop(); }

void FoxgloveServer::start() {
    Impl& m = *impl_;
    m.thread = std::thread([&m] {
        ::pthread_setname_np(::pthread_self(), "lf-foxglove");
        try {
            m.server.run();
        } catch (const std::exception& error) {
            m.log->error("foxglove: the server stopped: {}", error.what());
        }
    });
}

void FoxgloveServer::stop() {
    Impl& m = *impl_;
    if (!m.thread.joinable()) return;
    asio::post(m.server.get_io_service(), [&m] { m.close_all(); });
    m.thread.join();
}

bool FoxgloveServer::wants(FoxgloveChannel channel) const {
    const auto id = static_cast<std::uint32_t>(channel);
    if (impl_->subscribers[id].load(std::memory_order_relaxed) > 0) return true;
    const auto* info = impl_->channel(id);
    return info && info->latched;
}

void FoxgloveServer::publish(FoxgloveChannel channel, std::int64_t receive_ns,
                             std::shared_ptr<const std::vector<std::uint8_t>> payload) {
    Impl& m = *impl_;
    const auto id = static_cast<std::uint32_t>(channel);
    const auto* info = m.channel(id);
    if (!info || !payload) return;
    if (info->latched) {
        std::lock_guard<std::mutex> lock(m.mutex);
        m.latched[id] = {receive_ns, payload};
    }
    if (m.subscribers[id].load(std::memory_order_relaxed) == 0) return;
    if (m.handed_over_bytes.load() + payload->size() > m.buffer_bytes) {
        m.queue_drops.fetch_add(1, std::memory_order_relaxed);
        return;
    }
    m.handed_over_bytes.fetch_add(payload->size());
    asio::post(m.server.get_io_service(),
               [&m, id, receive_ns, p = std::move(payload)] { m.deliver(id, receive_ns, p); });
}

std::uint16_t FoxgloveServer::port() const { return impl_->port; }

FoxgloveStats FoxgloveServer::stats() const {
    const Impl& m = *impl_;
    FoxgloveStats s;
    s.enabled = true;
    s.port = m.port;
    s.queue_drops = m.queue_drops.load();
    std::lock_guard<std::mutex> lock(m.mutex);
    s.connections = m.connections;
    s.refused = m.refused;
    s.sent = m.sent_closed;
    s.dropped = m.dropped_closed;
    for (const auto& c : m.clients) {
        s.clients.push_back({c.second.peer, c.second.sent.load(), c.second.dropped.load()});
        s.sent += s.clients.back().sent;
        s.dropped += s.clients.back().dropped;
    }
    return s;
}

}  // namespace lidarfuse::daemon
