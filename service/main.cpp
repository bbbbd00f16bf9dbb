// softgrasp-server: wiring and configuration only.
#include <csignal>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "service/http/server.h"
#include "service/rest/api.h"
#include "service/rest/config.h"

namespace {

// Blocks SIGINT/SIGTERM in every thread (the server's threads inherit the mask) so that the
// main thread can wait for them synchronously and shut down gracefully.
sigset_t BlockShutdownSignals() {
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  return signals;
}

// The running executable's path, for finding the built web page next to it.
std::string ExecutablePath(const char* argv0) {
  std::error_code error;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", error);
  return error ? std::string(argv0) : self.string();
}

}  // namespace

int main(int argc, char** argv) {
  using namespace softgrasp;
  auto command_line = rest::ParseCommandLine(std::vector<std::string>(argv + 1, argv + argc));
  if (!command_line.ok()) {
    std::cerr << "softgrasp-server: " << command_line.error().message << "\n" << rest::UsageText();
    return 2;
  }
  if (command_line.value().help) {
    std::cout << rest::UsageText();
    return 0;
  }
  rest::ServiceConfig& config = command_line.value().config;
  if (config.web_root.empty()) config.web_root = rest::DefaultWebRoot(ExecutablePath(argv[0]));
  std::cerr << "config " << rest::ConfigToJson(config) << "\n";
  if (std::error_code error;
      !std::filesystem::is_regular_file(std::filesystem::path(config.web_root) / "index.html",
                                        error)) {
    std::cerr << "softgrasp-server: no web page in " << config.web_root
              << " (GET / answers 404): run scripts/build.sh or pass --web-root\n";
  }

  const sigset_t signals = BlockShutdownSignals();
  try {
    http::Router router = rest::BuildRouter(config);
    http::Server server(config.server,
                        [&router](http::Request& request) { return router.Dispatch(request); });
    server.Start();
    const bool ipv6 = config.server.host.find(':') != std::string::npos;
    std::cout << "listening on http://" << (ipv6 ? "[" : "") << config.server.host
              << (ipv6 ? "]" : "") << ":" << server.port() << std::endl;

    int received = 0;
    sigwait(&signals, &received);
    std::cerr << "softgrasp-server: " << (received == SIGINT ? "SIGINT" : "SIGTERM")
              << ", finishing in-flight requests\n";
    server.Stop();
  } catch (const std::exception& e) {
    std::cerr << "softgrasp-server: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
