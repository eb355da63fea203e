// hyq-viewer's HTTP and WebSocket side (Boost.Beast): GET serves a fixed set of files (the
// bundled page and the robot's URDF), a WebSocket upgrade on /ws joins the broadcast of frames.
// Text the browser sends on the WebSocket goes to one callback (playback controls); nothing else
// is read from it. All of it runs on one io_context thread.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>

namespace hyq::viewer {

/// A file the server may send: its path on disk and its MIME type.
struct ServedFile {
  std::string path;
  std::string content_type;
};

class WsSession;

class WebServer {
 public:
  /// `files` maps a URL path ("/", "/app.js") to a file; any other path is 404. `on_text` gets
  /// each text message a browser sends (at most 4 KiB; longer ones close that connection).
  /// Throws std::runtime_error naming the address when it cannot listen.
  WebServer(boost::asio::io_context& io, const boost::asio::ip::tcp::endpoint& endpoint,
            std::map<std::string, ServedFile> files, std::function<void(const std::string&)> on_text);
  ~WebServer();

  /// Sends `text` to every connected WebSocket (a slow browser skips frames, see WsSession).
  void Broadcast(const std::string& text);

  /// The port actually bound (useful with port 0).
  std::uint16_t port() const noexcept { return port_; }
  std::size_t clients() const noexcept { return sessions_.size(); }

  // for the sessions
  void Join(const std::shared_ptr<WsSession>& s) { sessions_.insert(s); }
  void Leave(const std::shared_ptr<WsSession>& s) { sessions_.erase(s); }
  const std::map<std::string, ServedFile>& files() const noexcept { return files_; }
  void OnText(const std::string& text) const { on_text_(text); }

 private:
  void Accept();

  boost::asio::io_context& io_;
  boost::asio::ip::tcp::acceptor acceptor_;
  std::map<std::string, ServedFile> files_;
  std::function<void(const std::string&)> on_text_;
  std::set<std::shared_ptr<WsSession>> sessions_;
  std::uint16_t port_ = 0;
};

}  // namespace hyq::viewer
