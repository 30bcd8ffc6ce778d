#pragma once
// The web server of `cdff serve` (docs/web-ui.md): HTTP and WebSocket on one port (Boost.Beast),
// a few threads, one session per connection. The Router answers requests; a WebSocket session
// runs a ReplayStream into its own bounded FrameQueue, so a slow browser only loses frames of
// its own.

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "cdff/serve/recording.hpp"
#include "cdff/types/status.hpp"

namespace cdff::serve {

struct ServerOptions {
  std::string address = "127.0.0.1";  // an IP address to listen on
  unsigned short port = 8765;         // 0: any free port (port() tells which)
  /// Required by every request when not empty. A server on an address other than the loopback
  /// interface must have one.
  std::string token;
  std::filesystem::path app_dir;        // the bundled web application
  std::vector<std::string> recordings;  // the MCAP files it may serve
  /// The DFPC graph files a live run may use, as the browser names them (no other path is
  /// accepted).
  std::vector<std::string> graphs;
  std::size_t max_header_bytes = 8 * 1024;  // larger headers: 431
  std::size_t max_body_bytes = 64 * 1024;   // larger bodies: 413
  std::size_t client_queue_frames = 8;      // frames waiting per WebSocket client
  int threads = 2;
};

/// A random token of 32 hexadecimal digits (128 bits from std::random_device).
std::string randomToken();
/// True for 127.0.0.0/8 and ::1.
bool isLoopbackAddress(const std::string& address);

class Server {
 public:
  /// Opens the recordings, checks the application directory, binds and starts serving on
  /// `options.threads` threads. Errors name the file, the address or the option at fault.
  static Result<std::unique_ptr<Server>> start(ServerOptions options);
  ~Server();  // stops serving and joins the threads

  unsigned short port() const;
  const std::vector<std::unique_ptr<Recording>>& recordings() const;

 private:
  struct Impl;
  explicit Server(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace cdff::serve
