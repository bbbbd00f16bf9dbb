// softgrasp-server: wiring and configuration only.
#include <csignal>
#include <cstdio>
#include <exception>
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
  const rest::ServiceConfig& config = command_line.value().config;
  std::cerr << "config " << rest::ConfigToJson(config) << "\n";

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
