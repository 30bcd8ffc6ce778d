// cdff serve [RECORDING...] [--port N] [--listen ADDR] [--app-dir DIR] [--graph FILE...]
//
// The ground-station web application (docs/web-ui.md): replay of the given MCAP recordings in a
// browser, and a live run of a DFPC graph on one of them (the graphs of ./dfpcs/ and those given
// with --graph). Listens on 127.0.0.1 unless --listen names another address, and then every request
// must carry the token printed at start. Stops on SIGINT or SIGTERM.
#include <algorithm>
#include <csignal>
#include <filesystem>
#include <memory>

#include <fmt/format.h>

#include "cdff/serve/server.hpp"
#include "commands.hpp"

namespace cdff::app {

namespace {

struct ServeOptions {
  std::vector<std::string> recordings;
  int port = 8765;
  std::string listen;
  std::string app_dir;
  std::vector<std::string> graphs;
};

// The graphs a live run may use: dfpcs/*.yaml of the working directory (the repository's, whose
// graphs name their model files relative to it), then those given, each once.
std::vector<std::string> servedGraphs(const std::vector<std::string>& given) {
  std::vector<std::string> graphs;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator("dfpcs", ec))
    if (entry.is_regular_file() && entry.path().extension() == ".yaml")
      graphs.push_back("dfpcs/" + entry.path().filename().string());
  std::sort(graphs.begin(), graphs.end());
  for (const std::string& g : given)
    if (std::find(graphs.begin(), graphs.end(), g) == graphs.end()) graphs.push_back(g);
  return graphs;
}

// The bundle the build writes next to the command: <build>/web/dist for <build>/apps/cdff.
std::filesystem::path defaultAppDir() {
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::filesystem::path("web/dist") : exe.parent_path().parent_path() / "web/dist";
}

int serve(const ServeOptions& o) {
  serve::ServerOptions options;
  options.recordings = o.recordings;
  options.graphs = servedGraphs(o.graphs);
  options.port = static_cast<unsigned short>(o.port);
  options.app_dir = o.app_dir.empty() ? defaultAppDir() : std::filesystem::path(o.app_dir);
  if (!o.listen.empty()) {
    options.address = o.listen;
    options.token = serve::randomToken();
  }
  // The signals are blocked before the server's threads start (they inherit the mask) and
  // waited for here.
  sigset_t stop;
  sigemptyset(&stop);
  sigaddset(&stop, SIGINT);
  sigaddset(&stop, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop, nullptr);
  Result<std::unique_ptr<serve::Server>> server = serve::Server::start(options);
  if (!server) {
    pthread_sigmask(SIG_UNBLOCK, &stop, nullptr);
    fmt::print(stderr, "error: {}\n", server.status().message());
    return 1;
  }
  const std::string host = options.address.find(':') != std::string::npos
                               ? fmt::format("[{}]", options.address)
                               : options.address;
  for (const auto& r : (*server)->recordings())
    for (const std::string& d : r->damages())
      fmt::print(stderr, "warning: {} is damaged: {}\n", r->path(), d);
  fmt::print(
      "cdff serve: {} recording(s), {} graph(s) for a live run, the web application from {}\n",
      (*server)->recordings().size(), options.graphs.size(), options.app_dir.string());
  if (options.token.empty())
    fmt::print("cdff serve: listening on http://{}:{}/\n", host, (*server)->port());
  else
    fmt::print("cdff serve: listening on http://{}:{}/?token={}\n", host, (*server)->port(),
               options.token);
  std::fflush(stdout);
  int signal = 0;
  sigwait(&stop, &signal);
  server->reset();
  pthread_sigmask(SIG_UNBLOCK, &stop, nullptr);
  fmt::print("cdff serve: stopped ({})\n", signal == SIGINT ? "SIGINT" : "SIGTERM");
  return 0;
}

}  // namespace

void addServeCommand(CLI::App& root, int& exit_code) {
  auto options = std::make_shared<ServeOptions>();
  CLI::App* cmd = root.add_subcommand(
      "serve",
      "The web application: replay MCAP recordings in a browser, run a DFPC graph live on one "
      "(docs/web-ui.md)");
  cmd->add_option("RECORDING", options->recordings, "MCAP files to offer for replay and live runs")
      ->check(CLI::ExistingFile);
  cmd->add_option("--port", options->port, "TCP port (0: any free port, printed at start)")
      ->check(CLI::Range(0, 65535))
      ->capture_default_str();
  cmd->add_option("--listen", options->listen,
                  "Listen on this IP address instead of 127.0.0.1; every request then needs the "
                  "token printed at start");
  cmd->add_option("--app-dir", options->app_dir,
                  "The bundled web application (default: web/dist of the build tree)");
  cmd->add_option("--graph", options->graphs,
                  "A DFPC graph a live run may use, besides dfpcs/*.yaml of the working directory "
                  "(repeatable)")
      ->check(CLI::ExistingFile);
  cmd->callback([options, &exit_code] { exit_code = serve(*options); });
}

}  // namespace cdff::app
