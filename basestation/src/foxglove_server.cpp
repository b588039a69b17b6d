// Foxglove WebSocket protocol server on websocketpp (see foxglove_server.h). The only translation unit that
// includes websocketpp and asio.
#define ASIO_STANDALONE
#include "cairn/base/foxglove_server.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <utility>
#include <websocketpp/config/asio_no_tls.hpp>
#include <websocketpp/server.hpp>

namespace cairn::base {
namespace {

using json = nlohmann::json;
using WsServer = websocketpp::server<websocketpp::config::asio>;
using Handle = websocketpp::connection_hdl;
constexpr const char* kSubprotocol = "foxglove.websocket.v1";

// Binary opcodes (server -> client, client -> server).
constexpr std::uint8_t kMessageData = 0x01;
constexpr std::uint8_t kServiceCallResponse = 0x03;
constexpr std::uint8_t kClientMessageData = 0x01;
constexpr std::uint8_t kServiceCallRequest = 0x02;

void PutU32(std::string* out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out->push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}
void PutU64(std::string* out, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) out->push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}
bool GetU32(const std::string& in, std::size_t at, std::uint32_t* v) {
  if (at + 4 > in.size()) return false;
  *v = 0;
  for (int i = 0; i < 4; ++i)
    *v |= static_cast<std::uint32_t>(static_cast<unsigned char>(in[at + i])) << (8 * i);
  return true;
}

std::string ContentType(const std::filesystem::path& path) {
  static const std::map<std::string, std::string> kTypes = {{".html", "text/html; charset=utf-8"},
                                                            {".js", "text/javascript; charset=utf-8"},
                                                            {".css", "text/css; charset=utf-8"},
                                                            {".json", "application/json"},
                                                            {".png", "image/png"},
                                                            {".svg", "image/svg+xml"},
                                                            {".map", "application/json"},
                                                            {".ico", "image/x-icon"}};
  const auto it = kTypes.find(path.extension().string());
  return it == kTypes.end() ? "application/octet-stream" : it->second;
}

}  // namespace

void ParseListenAddress(const std::string& text, std::string* address, int* port) {
  const auto colon = text.rfind(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == text.size()) {
    throw std::invalid_argument("--listen '" + text + "' must be ADDR:PORT, e.g. 127.0.0.1:8080");
  }
  std::string addr = text.substr(0, colon);
  if (addr.size() >= 2 && addr.front() == '[' && addr.back() == ']') addr = addr.substr(1, addr.size() - 2);
  const std::string port_text = text.substr(colon + 1);
  const bool digits = port_text.size() <= 5 && std::all_of(port_text.begin(), port_text.end(),
                                                           [](char c) { return c >= '0' && c <= '9'; });
  const int value = digits ? std::stoi(port_text) : -1;
  if (!digits || value > 65535) {
    throw std::invalid_argument("--listen '" + text + "': port '" + port_text +
                                "' must be an integer in [0, 65535]");
  }
  std::error_code ec;
  asio::ip::make_address(addr, ec);
  if (ec) throw std::invalid_argument("--listen '" + text + "': '" + addr + "' is not an IP address");
  *address = addr;
  *port = value;
}

class FoxgloveServer::Impl {
 public:
  Impl(const FoxgloveServerOptions& options, Handlers handlers)
      : options_(options), handlers_(std::move(handlers)) {
    std::error_code ec;
    const asio::ip::address address = asio::ip::make_address(options.address, ec);
    if (ec)
      throw std::invalid_argument("FoxgloveServerOptions::address '" + options.address +
                                  "' is not an IP address");
    if (options.port < 0 || options.port > 65535) {
      throw std::invalid_argument("FoxgloveServerOptions::port " + std::to_string(options.port) +
                                  " must be in [0, 65535]");
    }
    if (!options.web_root.empty() && !std::filesystem::is_directory(options.web_root)) {
      throw std::invalid_argument("the GUI's web root '" + options.web_root +
                                  "' is not a directory (build the web app: ./cairn build)");
    }
    server_.clear_access_channels(websocketpp::log::alevel::all);
    server_.clear_error_channels(websocketpp::log::elevel::all);
    server_.init_asio();
    server_.set_reuse_addr(true);
    server_.set_validate_handler([this](Handle h) { return Validate(std::move(h)); });
    server_.set_open_handler([this](const Handle& h) { OnOpen(h); });
    server_.set_close_handler([this](const Handle& h) { OnClose(h); });
    server_.set_fail_handler([](const Handle&) {});
    server_.set_message_handler([this](const Handle& h, const WsServer::message_ptr& m) { OnMessage(h, m); });
    server_.set_http_handler([this](Handle h) { OnHttp(std::move(h)); });
    server_.listen(asio::ip::tcp::endpoint(address, static_cast<unsigned short>(options.port)), ec);
    if (ec) {
      throw std::runtime_error("cannot listen on " + options.address + ":" + std::to_string(options.port) +
                               ": " + ec.message());
    }
    port_ = server_.get_local_endpoint(ec).port();
    server_.start_accept(ec);
    if (ec)
      throw std::runtime_error("cannot accept on " + options.address + ":" + std::to_string(port_) + ": " +
                               ec.message());
    thread_ = std::thread([this] {
      try {
        server_.run();
      } catch (const std::exception& e) {
        spdlog::error("GUI server stopped: {}", e.what());
      }
    });
  }

  ~Impl() {
    std::error_code ec;
    server_.stop_listening(ec);
    std::vector<Handle> open;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      for (const auto& [handle, id] : ids_) open.push_back(handle);
    }
    for (const Handle& h : open)
      server_.close(h, websocketpp::close::status::going_away, "server stopping", ec);
    server_.stop();
    if (thread_.joinable()) thread_.join();
  }

  int port() const { return port_; }
  std::string url() const {
    const bool v6 = options_.address.find(':') != std::string::npos;
    return "http://" + (v6 ? "[" + options_.address + "]" : options_.address) + ":" + std::to_string(port_) +
           "/";
  }

  std::uint32_t AddChannel(const ChannelSpec& spec) {
    std::lock_guard<std::mutex> lock(mutex_);
    const std::uint32_t id = next_channel_++;
    channels_[id] = spec;
    SendTextToAll(json{{"op", "advertise"}, {"channels", json::array({ChannelJson(id, spec)})}}.dump());
    return id;
  }

  void RemoveChannel(std::uint32_t channel) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (channels_.erase(channel) == 0) return;
    for (auto& [cid, client] : clients_) {
      for (auto it = client.subscriptions.begin(); it != client.subscriptions.end();) {
        it = it->second == channel ? client.subscriptions.erase(it) : std::next(it);
      }
    }
    SendTextToAll(json{{"op", "unadvertise"}, {"channelIds", json::array({channel})}}.dump());
  }

  std::uint32_t AddService(const ServiceSpec& spec) {
    std::lock_guard<std::mutex> lock(mutex_);
    const std::uint32_t id = next_service_++;
    services_[id] = spec;
    SendTextToAll(
        json{{"op", "advertiseServices"}, {"services", json::array({ServiceJson(id, spec)})}}.dump());
    return id;
  }

  void Publish(std::uint32_t channel, std::uint64_t timestamp_ns, const std::string& payload) {
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto& [cid, client] : clients_) SendOn(client, channel, timestamp_ns, payload);
  }

  void SendTo(ClientId id, std::uint32_t channel, std::uint64_t timestamp_ns, const std::string& payload) {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = clients_.find(id);
    if (it != clients_.end()) SendOn(it->second, channel, timestamp_ns, payload);
  }

  bool HasSubscribers(std::uint32_t channel) const {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& [cid, client] : clients_) {
      for (const auto& [sub, ch] : client.subscriptions) {
        if (ch == channel) return true;
      }
    }
    return false;
  }

  FoxgloveServerStats Stats() const {
    std::lock_guard<std::mutex> lock(mutex_);
    FoxgloveServerStats s = stats_;
    s.clients_now = clients_.size();
    return s;
  }

 private:
  struct Client {
    Handle handle;
    std::map<std::uint32_t, std::uint32_t> subscriptions;  // subscription id -> channel id
    std::map<std::uint32_t, ChannelSpec> advertised;       // client channel id -> its channel
  };

  static json ChannelJson(std::uint32_t id, const ChannelSpec& spec) {
    return {{"id", id},
            {"topic", spec.topic},
            {"encoding", spec.encoding},
            {"schemaName", spec.schema_name},
            {"schema", spec.schema},
            {"schemaEncoding", spec.schema_encoding}};
  }

  static json ServiceJson(std::uint32_t id, const ServiceSpec& spec) {
    // Both the original fields (requestSchema, responseSchema) and the later request/response objects, so
    // that clients of either protocol revision can call it.
    return {{"id", id},
            {"name", spec.name},
            {"type", spec.type},
            {"requestSchema", spec.request_schema},
            {"responseSchema", spec.response_schema},
            {"request",
             {{"encoding", "json"},
              {"schemaName", spec.request_schema_name},
              {"schemaEncoding", "jsonschema"},
              {"schema", spec.request_schema}}},
            {"response",
             {{"encoding", "json"},
              {"schemaName", spec.response_schema_name},
              {"schemaEncoding", "jsonschema"},
              {"schema", spec.response_schema}}}};
  }

  // Caller holds mutex_.
  void SendTextToAll(const std::string& text) {
    for (auto& [cid, client] : clients_) SendText(client.handle, text);
  }

  // Caller holds mutex_.
  void SendText(const Handle& h, const std::string& text) {
    std::error_code ec;
    server_.send(h, text, websocketpp::frame::opcode::text, ec);
    if (!ec) stats_.bytes_sent += text.size();
  }
  void SendBinary(const Handle& h, const std::string& data) {
    std::error_code ec;
    server_.send(h, data, websocketpp::frame::opcode::binary, ec);
    if (!ec) stats_.bytes_sent += data.size();
  }
  void SendStatus(const Handle& h, int level, const std::string& message) {
    SendText(h, json{{"op", "status"}, {"level", level}, {"message", message}}.dump());
  }
  void SendOn(Client& client, std::uint32_t channel, std::uint64_t timestamp_ns, const std::string& payload) {
    for (const auto& [sub, ch] : client.subscriptions) {
      if (ch != channel) continue;
      std::string frame;
      frame.reserve(13 + payload.size());
      frame.push_back(static_cast<char>(kMessageData));
      PutU32(&frame, sub);
      PutU64(&frame, timestamp_ns);
      frame += payload;
      SendBinary(client.handle, frame);
      ++stats_.messages_sent;
    }
  }

  bool Validate(Handle h) {
    auto con = server_.get_con_from_hdl(std::move(h));
    for (const std::string& p : con->get_requested_subprotocols()) {
      if (p == kSubprotocol) {
        con->select_subprotocol(p);
        return true;
      }
    }
    con->set_status(websocketpp::http::status_code::bad_request);
    con->set_body(
        std::string("this WebSocket speaks the Foxglove WebSocket protocol only: request subprotocol ") +
        kSubprotocol);
    return false;
  }

  void OnOpen(const Handle& h) {
    std::lock_guard<std::mutex> lock(mutex_);
    const ClientId id = next_client_++;
    ids_[h] = id;
    clients_[id] = Client{h, {}, {}};
    ++stats_.clients_connected;
    SendText(h, json{{"op", "serverInfo"},
                     {"name", options_.name},
                     {"capabilities", json::array({"clientPublish", "services"})},
                     {"supportedEncodings", json::array({"json"})},
                     {"metadata", json::object()},
                     {"sessionId", std::to_string(session_)}}
                    .dump());
    json channels = json::array();
    for (const auto& [cid, spec] : channels_) channels.push_back(ChannelJson(cid, spec));
    SendText(h, json{{"op", "advertise"}, {"channels", channels}}.dump());
    json services = json::array();
    for (const auto& [sid, spec] : services_) services.push_back(ServiceJson(sid, spec));
    if (!services.empty()) SendText(h, json{{"op", "advertiseServices"}, {"services", services}}.dump());
  }

  void OnClose(const Handle& h) {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = ids_.find(h);
    if (it == ids_.end()) return;
    clients_.erase(it->second);
    ids_.erase(it);
  }

  void OnMessage(const Handle& h, const WsServer::message_ptr& message) {
    std::vector<std::pair<ClientId, std::uint32_t>> subscribed;  // handlers run without the lock
    std::function<void()> deliver;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      const auto it = ids_.find(h);
      if (it == ids_.end()) return;
      const ClientId id = it->second;
      Client& client = clients_[id];
      const std::string& payload = message->get_payload();
      if (message->get_opcode() == websocketpp::frame::opcode::text) {
        HandleText(id, client, payload, &subscribed);
      } else {
        deliver = HandleBinary(id, client, payload);
      }
    }
    if (handlers_.on_subscribe) {
      for (const auto& [client, channel] : subscribed) handlers_.on_subscribe(client, channel);
    }
    if (deliver) deliver();
  }

  // Caller holds mutex_.
  void HandleText(ClientId id, Client& client, const std::string& text,
                  std::vector<std::pair<ClientId, std::uint32_t>>* subscribed) {
    json j;
    try {
      j = json::parse(text);
    } catch (const std::exception& e) {
      ++stats_.protocol_errors;
      SendStatus(client.handle, 2, std::string("message is not JSON: ") + e.what());
      return;
    }
    const std::string op =
        j.is_object() && j.contains("op") && j["op"].is_string() ? j["op"].get<std::string>() : "";
    try {
      if (op == "subscribe") {
        for (const json& s : j.at("subscriptions")) {
          const auto sub = s.at("id").get<std::uint32_t>();
          const auto channel = s.at("channelId").get<std::uint32_t>();
          if (!channels_.count(channel)) {
            SendStatus(client.handle, 1,
                       "subscribe: channel " + std::to_string(channel) + " is not advertised");
            continue;
          }
          if (client.subscriptions.count(sub)) {
            SendStatus(client.handle, 1, "subscribe: subscription id " + std::to_string(sub) + " is in use");
            continue;
          }
          client.subscriptions[sub] = channel;
          subscribed->emplace_back(id, channel);
        }
      } else if (op == "unsubscribe") {
        for (const json& s : j.at("subscriptionIds")) client.subscriptions.erase(s.get<std::uint32_t>());
      } else if (op == "advertise") {
        for (const json& c : j.at("channels")) {
          ChannelSpec spec;
          spec.topic = c.at("topic").get<std::string>();
          spec.encoding = c.at("encoding").get<std::string>();
          spec.schema_name = c.value("schemaName", "");
          client.advertised[c.at("id").get<std::uint32_t>()] = spec;
        }
      } else if (op == "unadvertise") {
        for (const json& c : j.at("channelIds")) client.advertised.erase(c.get<std::uint32_t>());
      } else {
        ++stats_.protocol_errors;
        SendStatus(client.handle, 1, "unsupported op '" + op + "'");
      }
    } catch (const std::exception& e) {
      ++stats_.protocol_errors;
      SendStatus(client.handle, 2, "malformed '" + op + "' message: " + e.what());
    }
  }

  // Caller holds mutex_. Returns what to hand to the owner once the lock is released.
  std::function<void()> HandleBinary(ClientId id, Client& client, const std::string& data) {
    if (data.empty()) return {};
    const auto opcode = static_cast<std::uint8_t>(data[0]);
    if (opcode == kClientMessageData) {
      std::uint32_t channel = 0;
      if (!GetU32(data, 1, &channel) || !client.advertised.count(channel)) {
        ++stats_.protocol_errors;
        SendStatus(client.handle, 1,
                   "client message on channel " + std::to_string(channel) + ", which it did not advertise");
        return {};
      }
      if (!handlers_.on_client_message) return {};
      const ChannelSpec spec = client.advertised[channel];
      return [this, id, spec, payload = data.substr(5)] {
        handlers_.on_client_message(id, spec.topic, spec.encoding, payload);
      };
    }
    if (opcode == kServiceCallRequest) {
      std::uint32_t service = 0, call = 0, encoding_length = 0;
      if (!GetU32(data, 1, &service) || !GetU32(data, 5, &call) || !GetU32(data, 9, &encoding_length) ||
          13 + static_cast<std::size_t>(encoding_length) > data.size()) {
        ++stats_.protocol_errors;
        SendStatus(client.handle, 2, "malformed service call request");
        return {};
      }
      const std::string encoding = data.substr(13, encoding_length);
      const std::string request = data.substr(13 + encoding_length);
      if (!services_.count(service) || encoding != "json" || !handlers_.on_service_call) {
        const std::string why = !services_.count(service)
                                    ? "service " + std::to_string(service) + " is not advertised"
                                    : "encoding '" + encoding + "' is not supported (json)";
        SendText(
            client.handle,
            json{{"op", "serviceCallFailure"}, {"serviceId", service}, {"callId", call}, {"message", why}}
                .dump());
        return {};
      }
      const Handle handle = client.handle;
      Responder respond = [this, handle, service, call](bool ok, const std::string& payload) {
        std::lock_guard<std::mutex> lock(mutex_);
        std::error_code ec;
        if (server_.get_con_from_hdl(handle, ec) == nullptr || ec) return;  // the client has gone
        if (ok) {
          std::string frame;
          frame.push_back(static_cast<char>(kServiceCallResponse));
          PutU32(&frame, service);
          PutU32(&frame, call);
          PutU32(&frame, 4);
          frame += "json";
          frame += payload;
          SendBinary(handle, frame);
        } else {
          SendText(handle, json{{"op", "serviceCallFailure"},
                                {"serviceId", service},
                                {"callId", call},
                                {"message", payload}}
                               .dump());
        }
      };
      return
          [this, id, service, request, respond] { handlers_.on_service_call(id, service, request, respond); };
    }
    ++stats_.protocol_errors;
    SendStatus(client.handle, 1, "unsupported binary opcode " + std::to_string(opcode));
    return {};
  }

  void OnHttp(Handle h) {
    auto con = server_.get_con_from_hdl(std::move(h));
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++stats_.http_requests;
    }
    std::string resource = con->get_resource();
    resource = resource.substr(0, resource.find_first_of("?#"));
    if (resource.empty() || resource == "/") resource = "/index.html";
    const std::filesystem::path relative = std::filesystem::path(resource).relative_path().lexically_normal();
    const bool escapes = relative.empty() || *relative.begin() == "..";
    const std::filesystem::path file = std::filesystem::path(options_.web_root) / relative;
    std::ifstream in;
    if (!options_.web_root.empty() && !escapes && std::filesystem::is_regular_file(file))
      in.open(file, std::ios::binary);
    if (!in.is_open() || !in) {  // a stream never opened is not in a failed state
      con->set_status(websocketpp::http::status_code::not_found);
      con->set_body("not found: " + resource);
      return;
    }
    std::ostringstream body;
    body << in.rdbuf();
    con->set_status(websocketpp::http::status_code::ok);
    con->append_header("Content-Type", ContentType(file));
    con->append_header("Cache-Control", "no-cache");
    con->set_body(body.str());
  }

  FoxgloveServerOptions options_;
  Handlers handlers_;
  WsServer server_;
  std::thread thread_;
  int port_ = 0;
  const std::uint64_t session_ =
      static_cast<std::uint64_t>(std::chrono::system_clock::now().time_since_epoch().count());
  mutable std::mutex mutex_;
  std::map<Handle, ClientId, std::owner_less<Handle>> ids_;
  std::map<ClientId, Client> clients_;
  std::map<std::uint32_t, ChannelSpec> channels_;
  std::map<std::uint32_t, ServiceSpec> services_;
  std::uint32_t next_channel_ = 1;
  std::uint32_t next_service_ = 1;
  ClientId next_client_ = 1;
  FoxgloveServerStats stats_;
};

FoxgloveServer::FoxgloveServer(const FoxgloveServerOptions& options, Handlers handlers)
    : impl_(std::make_unique<Impl>(options, std::move(handlers))) {}
FoxgloveServer::~FoxgloveServer() = default;
int FoxgloveServer::port() const { return impl_->port(); }
std::string FoxgloveServer::url() const { return impl_->url(); }
std::uint32_t FoxgloveServer::AddChannel(const ChannelSpec& spec) { return impl_->AddChannel(spec); }
void FoxgloveServer::RemoveChannel(std::uint32_t channel) { impl_->RemoveChannel(channel); }
std::uint32_t FoxgloveServer::AddService(const ServiceSpec& spec) { return impl_->AddService(spec); }
void FoxgloveServer::Publish(std::uint32_t channel, std::uint64_t timestamp_ns, const std::string& payload) {
  impl_->Publish(channel, timestamp_ns, payload);
}
void FoxgloveServer::SendTo(ClientId client, std::uint32_t channel, std::uint64_t timestamp_ns,
                            const std::string& payload) {
  impl_->SendTo(client, channel, timestamp_ns, payload);
}
bool FoxgloveServer::HasSubscribers(std::uint32_t channel) const { return impl_->HasSubscribers(channel); }
FoxgloveServerStats FoxgloveServer::Stats() const { return impl_->Stats(); }

}  // namespace cairn::base
