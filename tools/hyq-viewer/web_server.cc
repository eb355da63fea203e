#include "tools/hyq-viewer/web_server.h"

#include <deque>
#include <fstream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <utility>

#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>

namespace hyq::viewer {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;

namespace {
constexpr std::size_t kMaxIncomingBytes = 4096;
constexpr std::size_t kMaxQueuedFrames = 32;  // ~1 s at 30 Hz; more and frames are skipped
}  // namespace

/// One browser's WebSocket: frames are queued and written one at a time; a browser that does
/// not keep up loses frames (counted), never the server's memory.
class WsSession : public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(tcp::socket socket, WebServer* server) : ws_(std::move(socket)), server_(server) {}

  void Run(http::request<http::string_body> req) {
    ws_.read_message_max(kMaxIncomingBytes);
    ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    ws_.async_accept(req, [self = shared_from_this()](beast::error_code ec) {
      if (ec) return;
      self->server_->Join(self);
      self->Read();
    });
  }

  void Send(std::shared_ptr<const std::string> text) {
    if (closed_) return;
    if (queue_.size() >= kMaxQueuedFrames) {
      ++skipped_;
      return;
    }
    queue_.push_back(std::move(text));
    if (queue_.size() == 1) Write();
  }

 private:
  void Read() {
    ws_.async_read(buffer_, [self = shared_from_this()](beast::error_code ec, std::size_t) {
      if (ec) return self->Close();
      if (self->ws_.got_text()) self->server_->OnText(beast::buffers_to_string(self->buffer_.data()));
      self->buffer_.consume(self->buffer_.size());
      self->Read();
    });
  }
  void Write() {
    ws_.text(true);
    ws_.async_write(asio::buffer(*queue_.front()),
                    [self = shared_from_this()](beast::error_code ec, std::size_t) {
                      if (ec) return self->Close();
                      self->queue_.pop_front();
                      if (!self->queue_.empty()) self->Write();
                    });
  }
  void Close() {
    if (closed_) return;
    closed_ = true;
    queue_.clear();
    server_->Leave(shared_from_this());
  }

  websocket::stream<beast::tcp_stream> ws_;
  WebServer* server_;
  beast::flat_buffer buffer_;
  std::deque<std::shared_ptr<const std::string>> queue_;
  std::uint64_t skipped_ = 0;
  bool closed_ = false;
};

namespace {

/// One HTTP connection: GET of a served file, or the WebSocket upgrade.
class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(tcp::socket socket, WebServer* server) : stream_(std::move(socket)), server_(server) {}

  void Read() {
    req_ = {};
    parser_.emplace();
    parser_->body_limit(kMaxIncomingBytes);
    parser_->header_limit(8192);
    stream_.expires_after(std::chrono::seconds(30));
    http::async_read(stream_, buffer_, *parser_,
                     [self = shared_from_this()](beast::error_code ec, std::size_t) {
                       if (ec) return self->Shutdown();
                       self->req_ = self->parser_->release();
                       self->Handle();
                     });
  }

 private:
  void Handle() {
    if (websocket::is_upgrade(req_)) {
      if (req_.target() != "/ws") return Respond(http::status::not_found, "text/plain", "no such WebSocket\n");
      stream_.expires_never();
      std::make_shared<WsSession>(stream_.release_socket(), server_)->Run(std::move(req_));
      return;
    }
    if (req_.method() != http::verb::get && req_.method() != http::verb::head)
      return Respond(http::status::method_not_allowed, "text/plain", "read-only: GET only\n");
    std::string target(req_.target());
    if (const auto q = target.find('?'); q != std::string::npos) target.resize(q);
    const auto it = server_->files().find(target);
    if (it == server_->files().end()) return Respond(http::status::not_found, "text/plain", "not found\n");
    std::ifstream in(it->second.path, std::ios::binary);
    if (!in)
      return Respond(http::status::not_found, "text/plain",
                     "hyq-viewer: " + it->second.path +
                         " is missing (the page is bundled at build time: scripts/bootstrap.sh runs npm ci, "
                         "then build the target hyq-viewer)\n");
    std::ostringstream body;
    body << in.rdbuf();
    Respond(http::status::ok, it->second.content_type, body.str());
  }

  void Respond(http::status status, const std::string& type, std::string body) {
    auto res = std::make_shared<http::response<http::string_body>>(status, req_.version());
    res->set(http::field::server, "hyq-viewer");
    res->set(http::field::content_type, type);
    res->set(http::field::cache_control, "no-store");
    res->keep_alive(req_.keep_alive());
    res->body() = std::move(body);
    res->prepare_payload();
    http::async_write(stream_, *res, [self = shared_from_this(), res](beast::error_code ec, std::size_t) {
      if (ec || !res->keep_alive()) return self->Shutdown();
      self->Read();
    });
  }

  void Shutdown() {
    beast::error_code ec;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ec);
  }

  beast::tcp_stream stream_;
  WebServer* server_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
  http::request<http::string_body> req_;
};

}  // namespace

WebServer::WebServer(asio::io_context& io, const tcp::endpoint& endpoint,
                     std::map<std::string, ServedFile> files,
                     std::function<void(const std::string&)> on_text)
    : io_(io), acceptor_(io), files_(std::move(files)), on_text_(std::move(on_text)) {
  beast::error_code ec;
  const std::string where = endpoint.address().to_string() + ":" + std::to_string(endpoint.port());
  acceptor_.open(endpoint.protocol(), ec);
  if (!ec) acceptor_.set_option(asio::socket_base::reuse_address(true), ec);
  if (!ec) acceptor_.bind(endpoint, ec);
  if (!ec) acceptor_.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) throw std::runtime_error("cannot listen on " + where + ": " + ec.message());
  port_ = acceptor_.local_endpoint().port();
  Accept();
}

WebServer::~WebServer() = default;

void WebServer::Accept() {
  acceptor_.async_accept([this](beast::error_code ec, tcp::socket socket) {
    if (!ec) std::make_shared<HttpSession>(std::move(socket), this)->Read();
    if (acceptor_.is_open()) Accept();
  });
}

void WebServer::Broadcast(const std::string& text) {
  auto shared = std::make_shared<const std::string>(text);
  const auto sessions = sessions_;  // a failed write may Leave() meanwhile
  for (const auto& s : sessions) s->Send(shared);
}

}  // namespace hyq::viewer
