// A Foxglove WebSocket protocol server (subprotocol "foxglove.websocket.v1", docs/spec.md of
// github.com/foxglove/ws-protocol) on one TCP port that also serves a directory of static files over HTTP
// (the operator GUI). Channels are advertised to every client; messages go to the clients subscribed to them;
// clients may call services and publish on channels they advertise. Built on websocketpp (Debian's
// libwebsocketpp-dev, standalone asio): no hand-written HTTP or WebSocket framing. No DDS here.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace cairn::base {

/// Where and what the server serves.
struct FoxgloveServerOptions {
  /// IPv4 or IPv6 address to listen on; loopback by default (any other address only when given).
  std::string address = "127.0.0.1";
  /// TCP port, [1, 65535]; 0 picks a free one (see FoxgloveServer::port()).
  int port = 8080;
  /// Directory served over HTTP on the same port ("/" is index.html); "" = no HTTP files (404).
  std::string web_root;
  /// Server name sent in serverInfo.
  std::string name = "cairn";
};

/// A channel the server publishes on (Advertise): JSON messages with a JSON schema by default.
struct ChannelSpec {
  std::string topic;              ///< e.g. "/fleet_map"
  std::string encoding = "json";  ///< message encoding
  std::string schema_name;        ///< e.g. "foxglove.SceneUpdate"
  std::string schema;             ///< the schema text (a JSON schema for "jsonschema")
  std::string schema_encoding = "jsonschema";
};

/// A service clients may call (AdvertiseServices), JSON request and response.
struct ServiceSpec {
  std::string name;                 ///< e.g. "/cairn/command"
  std::string type;                 ///< e.g. "cairn.Command"
  std::string request_schema_name;  ///< e.g. "cairn.CommandRequest"
  std::string request_schema;       ///< JSON schema text
  std::string response_schema_name;
  std::string response_schema;
};

/// Counters of the server since it started.
struct FoxgloveServerStats {
  std::uint64_t clients_connected = 0;  ///< connections accepted over the server's life
  std::uint64_t clients_now = 0;        ///< open WebSocket connections
  std::uint64_t messages_sent = 0;      ///< Message Data frames
  std::uint64_t bytes_sent = 0;         ///< all WebSocket payload bytes sent (text and binary)
  std::uint64_t http_requests = 0;
  std::uint64_t protocol_errors = 0;  ///< malformed client messages answered with an error status
};

/// The server. Thread-safe: channels, services and messages may be added and published from any thread.
class FoxgloveServer {
 public:
  /// Identifies one WebSocket connection.
  using ClientId = std::uint64_t;
  /// Sends the response of a service call (JSON payload), once.
  using Responder = std::function<void(bool ok, const std::string& payload_or_error)>;

  /// What the owner is told; each handler runs on the server's network thread and must not block.
  struct Handlers {
    /// A client subscribed to `channel` (e.g. to send it the current state with SendTo()).
    std::function<void(ClientId client, std::uint32_t channel)> on_subscribe;
    /// A client published `payload` on its channel `topic` with `encoding` (clientPublish capability).
    std::function<void(ClientId client, const std::string& topic, const std::string& encoding,
                       const std::string& payload)>
        on_client_message;
    /// A client called service `service` with the JSON `request`; answer with `respond` (from any thread).
    std::function<void(ClientId client, std::uint32_t service, const std::string& request, Responder respond)>
        on_service_call;
  };

  /// Listens on options.address:options.port and serves in a thread of its own.
  /// @throws std::invalid_argument naming the field for a bad address or port, or a web_root that is not a
  ///         readable directory; std::runtime_error naming address:port when it cannot listen there.
  FoxgloveServer(const FoxgloveServerOptions& options, Handlers handlers);
  /// Closes every connection and stops.
  ~FoxgloveServer();
  FoxgloveServer(const FoxgloveServer&) = delete;
  FoxgloveServer& operator=(const FoxgloveServer&) = delete;

  /// The port listened on (options.port, or the one picked for 0).
  int port() const;
  /// "http://ADDRESS:PORT/".
  std::string url() const;

  /// Advertises a channel to every client (now and later); returns its id.
  std::uint32_t AddChannel(const ChannelSpec& spec);
  /// Unadvertises a channel; its subscriptions end.
  void RemoveChannel(std::uint32_t channel);
  /// Advertises a service (services capability); returns its id.
  std::uint32_t AddService(const ServiceSpec& spec);

  /// Sends `payload` on `channel` to every subscribed client, stamped `timestamp_ns` (receive time).
  void Publish(std::uint32_t channel, std::uint64_t timestamp_ns, const std::string& payload);
  /// Sends `payload` on `channel` to `client` only, if it is subscribed to it.
  void SendTo(ClientId client, std::uint32_t channel, std::uint64_t timestamp_ns, const std::string& payload);
  /// True when some client is subscribed to `channel`.
  bool HasSubscribers(std::uint32_t channel) const;

  FoxgloveServerStats Stats() const;

  class Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

/// "ADDR:PORT" (IPv6 as "[ADDR]:PORT") into address and port. @throws std::invalid_argument naming the text.
void ParseListenAddress(const std::string& text, std::string* address, int* port);

}  // namespace cairn::base
