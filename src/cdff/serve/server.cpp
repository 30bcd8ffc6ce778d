#include "cdff/serve/server.hpp"

#include <chrono>
#include <mutex>
#include <random>
#include <thread>

#include <fmt/format.h>
#include <boost/asio/dispatch.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <nlohmann/json.hpp>

#include "cdff/serve/router.hpp"

namespace cdff::serve {

namespace beast = boost::beast;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using nlohmann::json;

std::string randomToken() {
  std::random_device device;
  std::string token;
  for (int i = 0; i < 4; ++i) token += fmt::format("{:08x}", device());
  return token;
}

bool isLoopbackAddress(const std::string& address) {
  boost::system::error_code ec;
  const net::ip::address a = net::ip::make_address(address, ec);
  return !ec && a.is_loopback();
}

namespace {

class WsSession;

// What the sessions share: the router, the limits, and the live WebSocket sessions (stopped
// before the io_context goes).
struct Context {
  Context(const Router& r, const ServerOptions& o, std::shared_ptr<LiveHub> l)
      : router(r), options(o), live(std::move(l)) {}
  const Router& router;
  const ServerOptions& options;
  std::shared_ptr<LiveHub> live;
  std::mutex mutex;
  std::vector<std::weak_ptr<WsSession>> streams;
};

std::string errorFrame(const std::string& message) {
  return json{{"type", "error"}, {"error", message}}.dump(-1, ' ', false,
                                                          json::error_handler_t::replace);
}

class WsSession : public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(tcp::socket&& socket, Context& context, Router::Stream stream,
            std::shared_ptr<LiveHub> live)
      : ws_(std::move(socket)),
        queue_(std::make_shared<FrameQueue>(context.options.client_queue_frames)),
        stream_(std::move(stream)),
        live_(std::move(live)) {}
  ~WsSession() { stopReplay(); }

  void run(Request request) {
    ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    ws_.read_message_max(16 * 1024);  // commands are small
    ws_.async_accept(request, beast::bind_front_handler(&WsSession::onAccept, shared_from_this()));
  }
  void stopReplay() {
    replay_.reset();
    if (live_ && listener_) live_->removeListener(*listener_);
    listener_.reset();
  }

 private:
  void onAccept(beast::error_code ec) {
    if (ec) return;
    // The replay thread holds no reference to the session: it posts to the session's strand,
    // where the session is looked up, so the session is never destroyed on that thread.
    auto sink = [weak = weak_from_this(), ex = ws_.get_executor(), queue = queue_](Frame f) {
      queue->push(std::move(f));
      net::post(ex, [weak] {
        if (auto self = weak.lock()) self->flush();
      });
    };
    if (stream_.live) {
      // The live run's threads hand their frames to this browser's queue (never waiting on it).
      listener_ = live_->addListener(sink, [queue = queue_] { return queue->dropped(); });
      read();
      return;
    }
    Result<std::unique_ptr<ReplayStream>> replay = ReplayStream::start(
        *stream_.recording, stream_.spec, sink, [queue = queue_] { return queue->dropped(); });
    if (!replay) {
      queue_->push({false, errorFrame(replay.status().message())});
      flush();
      return;
    }
    replay_ = std::move(*replay);
    read();
  }

  void read() {
    ws_.async_read(buffer_, beast::bind_front_handler(&WsSession::onRead, shared_from_this()));
  }

  void onRead(beast::error_code ec, std::size_t) {
    if (ec) return;  // closed by the browser, or a protocol error: the session ends
    const std::string text = beast::buffers_to_string(buffer_.data());
    buffer_.consume(buffer_.size());
    const json command = json::parse(text, nullptr, false);
    Status s =
        !replay_ ? invalidInput("the live stream takes no commands; expected POST /api/live/state")
        : command.is_discarded()
            ? invalidInput(
                  "command '{}' is not JSON; expected {{\"cmd\": \"play\"}} or "
                  "the like",
                  text.substr(0, 200))
            : replay_->command(command);
    if (!s.isOk()) {
      queue_->push({false, errorFrame(s.message())});
      flush();
    }
    read();
  }

  void flush() {
    if (writing_) return;
    std::optional<Frame> frame = queue_->pop();
    if (!frame) return;
    writing_ = true;
    current_ = std::move(frame->data);
    ws_.binary(frame->binary);
    ws_.async_write(net::buffer(current_),
                    beast::bind_front_handler(&WsSession::onWrite, shared_from_this()));
  }

  void onWrite(beast::error_code ec, std::size_t) {
    writing_ = false;
    if (!ec) flush();
  }

  websocket::stream<beast::tcp_stream> ws_;
  beast::flat_buffer buffer_;
  std::shared_ptr<FrameQueue> queue_;
  Router::Stream stream_;
  std::unique_ptr<ReplayStream> replay_;
  std::shared_ptr<LiveHub> live_;
  std::optional<std::uint64_t> listener_;
  bool writing_ = false;
  std::string current_;
};

class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(tcp::socket&& socket, Context& context)
      : stream_(std::move(socket)), context_(context) {}

  void run() {
    net::dispatch(stream_.get_executor(),
                  beast::bind_front_handler(&HttpSession::read, shared_from_this()));
  }

 private:
  void read() {
    parser_.emplace();
    parser_->header_limit(static_cast<std::uint32_t>(context_.options.max_header_bytes));
    parser_->body_limit(context_.options.max_body_bytes);
    stream_.expires_after(std::chrono::seconds(30));
    http::async_read(stream_, buffer_, *parser_,
                     beast::bind_front_handler(&HttpSession::onRead, shared_from_this()));
  }

  void onRead(beast::error_code ec, std::size_t) {
    if (ec == http::error::header_limit)
      return reply(errorResponse(http::status::request_header_fields_too_large,
                                 fmt::format("the request's header is larger than {} bytes",
                                             context_.options.max_header_bytes)),
                   true);
    if (ec == http::error::body_limit)
      return reply(errorResponse(http::status::payload_too_large,
                                 fmt::format("the request's body is larger than {} bytes",
                                             context_.options.max_body_bytes)),
                   true);
    if (ec && ec != http::error::end_of_stream &&
        ec.category() == http::make_error_code(http::error::bad_target).category())
      return reply(errorResponse(http::status::bad_request,
                                 fmt::format("malformed HTTP request: {}", ec.message())),
                   true);
    if (ec) return close();  // closed by the client, timed out, or the server stops
    Request request = parser_->release();
    if (websocket::is_upgrade(request)) {
      auto routed = context_.router.stream(request);
      if (Response* refused = std::get_if<Response>(&routed))
        return reply(std::move(*refused), true);
      stream_.expires_never();
      auto ws =
          std::make_shared<WsSession>(stream_.release_socket(), context_,
                                      std::move(std::get<Router::Stream>(routed)), context_.live);
      {
        std::lock_guard lock(context_.mutex);
        std::erase_if(context_.streams, [](const auto& w) { return w.expired(); });
        context_.streams.push_back(ws);
      }
      ws->run(std::move(request));
      return;
    }
    Response response = context_.router.handle(request);
    const bool keep = response.keep_alive();
    reply(std::move(response), !keep);
  }

  void reply(Response response, bool close) {
    response.keep_alive(!close);
    auto held = std::make_shared<Response>(std::move(response));
    http::async_write(stream_, *held,
                      [self = shared_from_this(), held, close](beast::error_code ec, std::size_t) {
                        if (ec) return self->close();
                        if (close) return self->linger();
                        self->read();
                      });
  }

  // After a refusal the client may still be sending (a body over the limit): reading what
  // comes for a moment before closing keeps the kernel from resetting the connection before the
  // client has read the response.
  void linger() {
    beast::error_code ignored;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ignored);
    stream_.expires_after(std::chrono::seconds(2));
    drain();
  }
  void drain() {
    stream_.async_read_some(net::buffer(drain_),
                            [self = shared_from_this()](beast::error_code ec, std::size_t n) {
                              self->drained_ += n;
                              if (ec || self->drained_ > (1u << 20)) return self->close();
                              self->drain();
                            });
  }
  void close() {
    beast::error_code ignored;
    stream_.socket().close(ignored);
  }

  beast::tcp_stream stream_;
  Context& context_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
  std::array<char, 16384> drain_{};
  std::size_t drained_ = 0;
};

}  // namespace

struct Server::Impl {
  ServerOptions options;
  std::vector<std::unique_ptr<Recording>> recordings;
  std::shared_ptr<LiveHub> live;
  std::unique_ptr<Router> router;
  std::unique_ptr<Context> context;
  net::io_context ioc;
  tcp::acceptor acceptor{ioc};
  std::vector<std::thread> threads;

  void accept() {
    acceptor.async_accept(net::make_strand(ioc), [this](beast::error_code ec, tcp::socket s) {
      if (ec == net::error::operation_aborted) return;
      if (!ec) std::make_shared<HttpSession>(std::move(s), *context)->run();
      accept();
    });
  }
};

Result<std::unique_ptr<Server>> Server::start(ServerOptions options) {
  boost::system::error_code ec;
  const net::ip::address address = net::ip::make_address(options.address, ec);
  if (ec)
    return invalidInput(
        "listen address '{}' is not an IP address; expected e.g. 127.0.0.1 or "
        "0.0.0.0",
        options.address);
  if (!address.is_loopback() && options.token.empty())
    return invalidInput(
        "listening on {} (not the loopback interface) needs a token; expected "
        "one (cdff serve makes one with --listen)",
        options.address);
  std::error_code fec;
  if (!std::filesystem::is_regular_file(options.app_dir / "index.html", fec))
    return notFound(
        "the web application is not in '{}' (no index.html); expected the bundle "
        "that the build writes (target cdff_web)",
        options.app_dir.string());
  if (options.threads < 1 || options.threads > 64)
    return invalidInput("threads = {}: expected [1, 64]", options.threads);
  auto impl = std::make_unique<Impl>();
  impl->options = std::move(options);
  for (const std::string& path : impl->options.recordings) {
    Result<std::unique_ptr<Recording>> r = Recording::open(path);
    if (!r) return r.status();
    impl->recordings.push_back(std::move(*r));
  }
  impl->live = std::make_shared<LiveHub>(impl->recordings, impl->options.graphs);
  impl->router = std::make_unique<Router>(
      impl->recordings, RouterOptions{impl->options.app_dir, impl->options.token, impl->live});
  impl->context = std::make_unique<Context>(*impl->router, impl->options, impl->live);
  const tcp::endpoint endpoint(address, impl->options.port);
  auto& acceptor = impl->acceptor;
  acceptor.open(endpoint.protocol(), ec);
  if (!ec) acceptor.set_option(net::socket_base::reuse_address(true), ec);
  if (!ec) acceptor.bind(endpoint, ec);
  if (!ec) acceptor.listen(net::socket_base::max_listen_connections, ec);
  if (ec)
    return ioError("cannot listen on {} port {}: {}", impl->options.address, impl->options.port,
                   ec.message());
  impl->accept();
  for (int i = 0; i < impl->options.threads; ++i)
    impl->threads.emplace_back([ioc = &impl->ioc] { ioc->run(); });
  return std::unique_ptr<Server>(new Server(std::move(impl)));
}

Server::Server(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

Server::~Server() {
  impl_->ioc.stop();
  for (std::thread& t : impl_->threads) t.join();
  // No handler runs now: stop the live run's and the replays' threads (which post to the
  // sessions) before the io_context destroys the sessions.
  (void)impl_->live->remove();
  std::lock_guard lock(impl_->context->mutex);
  for (const auto& weak : impl_->context->streams)
    if (auto s = weak.lock()) s->stopReplay();
}

unsigned short Server::port() const {
  return impl_->acceptor.local_endpoint().port();
}

const std::vector<std::unique_ptr<Recording>>& Server::recordings() const {
  return impl_->recordings;
}

}  // namespace cdff::serve
