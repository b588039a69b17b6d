// FoxgloveServer (foxglove.websocket.v1 over websocketpp) seen from a client: the handshake, serverInfo and
// advertise, subscriptions and Message Data frames, service calls, client publish, malformed input, and the
// static files on the same port. Runs inside the test's private network namespace (loopback only).
#define ASIO_STANDALONE
#include "cairn/base/foxglove_server.h"

#include <gtest/gtest.h>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <websocketpp/client.hpp>
#include <websocketpp/config/asio_no_tls_client.hpp>

namespace cairn::base {
namespace {

using json = nlohmann::json;
using WsClient = websocketpp::client<websocketpp::config::asio_client>;
using namespace std::chrono_literals;

TEST(ParseListenAddress, AcceptsIpv4AndBracketedIpv6WithAPort) {
  std::string address;
  int port = -1;
  ParseListenAddress("127.0.0.1:8080", &address, &port);
  EXPECT_EQ(address, "127.0.0.1");
  EXPECT_EQ(port, 8080);
  ParseListenAddress("[::1]:0", &address, &port);
  EXPECT_EQ(address, "::1");
  EXPECT_EQ(port, 0);
}

TEST(ParseListenAddress, RefusesWhatIsNotAddrPortNamingTheText) {
  for (const std::string bad :
       {"127.0.0.1", "127.0.0.1:", ":8080", "127.0.0.1:99999", "127.0.0.1:-1", "127.0.0.1: 80",
        "127.0.0.1:80 ", "127.0.0.1:8o", "localhost:8080", "[::1:80"}) {
    std::string address;
    int port = -1;
    try {
      ParseListenAddress(bad, &address, &port);
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("'" + bad + "'"), std::string::npos) << e.what();
    }
  }
}

TEST(FoxgloveServer, RefusesBadOptionsNamingTheField) {
  FoxgloveServerOptions options;
  options.address = "not-an-address";
  EXPECT_THROW(FoxgloveServer(options, {}), std::invalid_argument);
  options = {};
  options.port = 70000;
  EXPECT_THROW(FoxgloveServer(options, {}), std::invalid_argument);
  options = {};
  options.port = 0;
  options.web_root = "/nonexistent/cairn-web";
  try {
    FoxgloveServer server(options, {});
    ADD_FAILURE() << "accepted a missing web root";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/cairn-web"), std::string::npos) << e.what();
  }
}

/// A websocketpp client on its own thread that records what it receives.
class TestClient {
 public:
  explicit TestClient(int port, bool foxglove_subprotocol = true) {
    client_.clear_access_channels(websocketpp::log::alevel::all);
    client_.clear_error_channels(websocketpp::log::elevel::all);
    client_.init_asio();
    client_.set_open_handler([this](const websocketpp::connection_hdl&) { Set(&opened_); });
    client_.set_fail_handler([this](const websocketpp::connection_hdl&) { Set(&failed_); });
    client_.set_message_handler([this](const websocketpp::connection_hdl&, const WsClient::message_ptr& m) {
      std::lock_guard<std::mutex> lock(mutex_);
      if (m->get_opcode() == websocketpp::frame::opcode::text) {
        texts_.push_back(json::parse(m->get_payload()));
      } else {
        binaries_.push_back(m->get_payload());
      }
      cv_.notify_all();
    });
    websocketpp::lib::error_code ec;
    connection_ = client_.get_connection("ws://127.0.0.1:" + std::to_string(port) + "/", ec);
    if (ec) throw std::runtime_error(ec.message());
    if (foxglove_subprotocol) connection_->add_subprotocol("foxglove.websocket.v1");
    client_.connect(connection_);
    thread_ = std::thread([this] { client_.run(); });
  }
  ~TestClient() {
    websocketpp::lib::error_code ec;
    if (opened_) client_.close(connection_, websocketpp::close::status::normal, "", ec);
    client_.stop_perpetual();
    thread_.join();
  }

  bool WaitOpenOrFail() {
    std::unique_lock<std::mutex> lock(mutex_);
    cv_.wait_for(lock, 5s, [this] { return opened_ || failed_; });
    return opened_;
  }
  /// The first text message whose "op" is `op` (waits up to 5 s); null when none came.
  json WaitText(const std::string& op) {
    std::unique_lock<std::mutex> lock(mutex_);
    json found;
    cv_.wait_for(lock, 5s, [&] {
      for (const json& t : texts_) {
        if (t.value("op", "") == op) {
          found = t;
          return true;
        }
      }
      return false;
    });
    return found;
  }
  /// The first binary frame with opcode `opcode` (waits up to 5 s); "" when none came.
  std::string WaitBinary(std::uint8_t opcode) {
    std::unique_lock<std::mutex> lock(mutex_);
    std::string found;
    cv_.wait_for(lock, 5s, [&] {
      for (const std::string& b : binaries_) {
        if (!b.empty() && static_cast<std::uint8_t>(b[0]) == opcode) {
          found = b;
          return true;
        }
      }
      return false;
    });
    return found;
  }
  void SendText(const json& j) { client_.send(connection_, j.dump(), websocketpp::frame::opcode::text); }
  void SendBinary(const std::string& bytes) {
    client_.send(connection_, bytes, websocketpp::frame::opcode::binary);
  }

 private:
  void Set(bool* flag) {
    std::lock_guard<std::mutex> lock(mutex_);
    *flag = true;
    cv_.notify_all();
  }

  WsClient client_;
  WsClient::connection_ptr connection_;
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool opened_ = false;
  bool failed_ = false;
  std::deque<json> texts_;
  std::deque<std::string> binaries_;
};

std::uint32_t U32(const std::string& b, std::size_t at) {
  std::uint32_t v = 0;
  for (int i = 3; i >= 0; --i) v = (v << 8) | static_cast<std::uint8_t>(b[at + static_cast<std::size_t>(i)]);
  return v;
}
std::string LeU32(std::uint32_t v) {
  std::string out;
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xff));
  return out;
}

/// One HTTP GET over a plain TCP socket (asio): the status line and the body.
std::pair<std::string, std::string> HttpGet(int port, const std::string& target) {
  asio::io_context io;
  asio::ip::tcp::socket socket(io);
  socket.connect({asio::ip::make_address("127.0.0.1"), static_cast<unsigned short>(port)});
  const std::string request = "GET " + target + " HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n";
  asio::write(socket, asio::buffer(request));
  std::string response;
  asio::error_code ec;
  char buf[4096];
  for (std::size_t n; (n = socket.read_some(asio::buffer(buf), ec)) > 0 || !ec;) response.append(buf, n);
  const auto line_end = response.find("\r\n");
  const auto body_at = response.find("\r\n\r\n");
  return {response.substr(0, line_end), body_at == std::string::npos ? "" : response.substr(body_at + 4)};
}

class FoxgloveServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = std::filesystem::temp_directory_path() / ("cairn-fox-" + std::to_string(::getpid()));
    std::filesystem::create_directories(root_);
    std::ofstream(root_ / "index.html") << "<html>cairn gui</html>";
    FoxgloveServerOptions options;
    options.port = 0;
    options.web_root = root_.string();
    options.name = "test-server";
    FoxgloveServer::Handlers handlers;
    handlers.on_subscribe = [this](FoxgloveServer::ClientId, std::uint32_t channel) {
      std::lock_guard<std::mutex> lock(mutex_);
      subscribed_.push_back(channel);
    };
    handlers.on_client_message = [this](FoxgloveServer::ClientId, const std::string& topic,
                                        const std::string&, const std::string& payload) {
      std::lock_guard<std::mutex> lock(mutex_);
      client_messages_.push_back(topic + " " + payload);
    };
    handlers.on_service_call = [](FoxgloveServer::ClientId, std::uint32_t, const std::string& request,
                                  const FoxgloveServer::Responder& respond) {
      const json j = json::parse(request);
      if (j.value("fail", false)) {
        respond(false, "asked to fail");
      } else {
        respond(true, json{{"echo", j.value("text", "")}}.dump());
      }
    };
    server_ = std::make_unique<FoxgloveServer>(options, handlers);
    channel_ = server_->AddChannel({"/fleet", "json", "cairn.FleetState", R"({"type":"object"})"});
    service_ = server_->AddService({"/cairn/command", "cairn.Command", "Req", "{}", "Resp", "{}"});
  }
  void TearDown() override {
    server_.reset();
    std::filesystem::remove_all(root_);
  }

  std::filesystem::path root_;
  std::unique_ptr<FoxgloveServer> server_;
  std::uint32_t channel_ = 0, service_ = 0;
  std::mutex mutex_;
  std::vector<std::uint32_t> subscribed_;
  std::vector<std::string> client_messages_;
};

TEST_F(FoxgloveServerTest, ServesTheWebRootAndNothingOutsideIt) {
  EXPECT_EQ(server_->url(), "http://127.0.0.1:" + std::to_string(server_->port()) + "/");
  const auto [status, body] = HttpGet(server_->port(), "/");
  EXPECT_NE(status.find("200"), std::string::npos) << status;
  EXPECT_EQ(body, "<html>cairn gui</html>");
  EXPECT_NE(HttpGet(server_->port(), "/missing.js").first.find("404"), std::string::npos);
  EXPECT_NE(HttpGet(server_->port(), "/../../etc/passwd").first.find("404"), std::string::npos);
  EXPECT_NE(HttpGet(server_->port(), "/%2e%2e/%2e%2e/etc/passwd").first.find("404"), std::string::npos);
}

TEST_F(FoxgloveServerTest, RefusesAWebSocketWithoutTheFoxgloveSubprotocol) {
  TestClient plain(server_->port(), /*foxglove_subprotocol=*/false);
  EXPECT_FALSE(plain.WaitOpenOrFail());
}

TEST_F(FoxgloveServerTest, AdvertisesDeliversSubscribedMessagesAndAnswersServiceCalls) {
  TestClient client(server_->port());
  ASSERT_TRUE(client.WaitOpenOrFail());
  const json info = client.WaitText("serverInfo");
  EXPECT_EQ(info.value("name", ""), "test-server");
  EXPECT_EQ(info["capabilities"], json::array({"clientPublish", "services"}));
  const json advertise = client.WaitText("advertise");
  ASSERT_EQ(advertise["channels"].size(), 1u);
  EXPECT_EQ(advertise["channels"][0]["topic"], "/fleet");
  EXPECT_EQ(advertise["channels"][0]["schemaName"], "cairn.FleetState");
  EXPECT_EQ(advertise["channels"][0]["encoding"], "json");
  EXPECT_EQ(client.WaitText("advertiseServices")["services"][0]["name"], "/cairn/command");

  // Not subscribed: nothing arrives. Subscribed as 7: Message Data with subscription 7, the stamp, the
  // payload.
  server_->Publish(channel_, 1, R"({"before":1})");
  client.SendText({{"op", "subscribe"}, {"subscriptions", {{{"id", 7}, {"channelId", channel_}}}}});
  for (int i = 0; i < 50 && !server_->HasSubscribers(channel_); ++i) std::this_thread::sleep_for(20ms);
  ASSERT_TRUE(server_->HasSubscribers(channel_));
  server_->Publish(channel_, 123456789012ULL, R"({"robots":[]})");
  const std::string data = client.WaitBinary(0x01);
  ASSERT_GE(data.size(), 13u);
  EXPECT_EQ(U32(data, 1), 7u);
  EXPECT_EQ(U32(data, 5) | (static_cast<std::uint64_t>(U32(data, 9)) << 32), 123456789012ULL);
  EXPECT_EQ(data.substr(13), R"({"robots":[]})");
  {
    std::lock_guard<std::mutex> lock(mutex_);
    EXPECT_EQ(subscribed_, std::vector<std::uint32_t>{channel_});
  }

  // Service call: opcode 0x02, service id, call id, encoding; the answer is 0x03 with the same ids.
  const std::string request = R"({"text":"hello"})";
  client.SendBinary(std::string(1, '\x02') + LeU32(service_) + LeU32(42) + LeU32(4) + "json" + request);
  const std::string response = client.WaitBinary(0x03);
  ASSERT_GE(response.size(), 17u);
  EXPECT_EQ(U32(response, 1), service_);
  EXPECT_EQ(U32(response, 5), 42u);
  EXPECT_EQ(response.substr(13, 4), "json");
  EXPECT_EQ(json::parse(response.substr(17)), json({{"echo", "hello"}}));
  client.SendBinary(std::string(1, '\x02') + LeU32(service_) + LeU32(43) + LeU32(4) + "json" +
                    R"({"fail":true})");
  const json failure = client.WaitText("serviceCallFailure");
  EXPECT_EQ(failure.value("callId", 0), 43);
  EXPECT_EQ(failure.value("message", ""), "asked to fail");
}

TEST_F(FoxgloveServerTest, ClientPublishReachesTheOwnerOnlyOnAnAdvertisedChannel) {
  TestClient client(server_->port());
  ASSERT_TRUE(client.WaitOpenOrFail());
  ASSERT_FALSE(client.WaitText("advertise").is_null());
  // On a channel it never advertised: a status, nothing delivered.
  client.SendBinary(std::string(1, '\x01') + LeU32(5) + R"({"x":1})");
  const json status = client.WaitText("status");
  EXPECT_NE(status.value("message", "").find("did not advertise"), std::string::npos) << status.dump();
  client.SendText(
      {{"op", "advertise"},
       {"channels", {{{"id", 5}, {"topic", "/cairn/teleop"}, {"encoding", "json"}, {"schemaName", "t"}}}}});
  client.SendBinary(std::string(1, '\x01') + LeU32(5) + R"({"x":2})");
  for (int i = 0; i < 100; ++i) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (!client_messages_.empty()) break;
    }
    std::this_thread::sleep_for(20ms);
  }
  std::lock_guard<std::mutex> lock(mutex_);
  EXPECT_EQ(client_messages_, std::vector<std::string>{R"(/cairn/teleop {"x":2})"});
}

TEST_F(FoxgloveServerTest, MalformedMessagesGetAnErrorStatusAndTheConnectionStays) {
  TestClient client(server_->port());
  ASSERT_TRUE(client.WaitOpenOrFail());
  client.SendText("not json");  // a JSON string: no "op"
  client.SendText({{"op", "subscribe"}, {"subscriptions", "many"}});
  client.SendBinary(std::string(1, '\x09'));
  client.SendText({{"op", "subscribe"}, {"subscriptions", {{{"id", 1}, {"channelId", 999}}}}});
  for (int i = 0; i < 100 && server_->Stats().protocol_errors < 4; ++i) std::this_thread::sleep_for(20ms);
  EXPECT_GE(server_->Stats().protocol_errors, 3u);
  EXPECT_FALSE(client.WaitText("status").is_null());
  // Still served.
  client.SendText({{"op", "subscribe"}, {"subscriptions", {{{"id", 2}, {"channelId", channel_}}}}});
  for (int i = 0; i < 50 && !server_->HasSubscribers(channel_); ++i) std::this_thread::sleep_for(20ms);
  server_->Publish(channel_, 1, "{}");
  EXPECT_FALSE(client.WaitBinary(0x01).empty());
}

}  // namespace
}  // namespace cairn::base
