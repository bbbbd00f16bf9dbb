#pragma once
/// The socket side: accept loop, per-connection parsing with limits and timeouts, a bounded work
/// queue and a fixed worker pool, graceful shutdown. Knows nothing of grasps.

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "service/http/message.h"
#include "service/http/parser.h"

namespace softgrasp::http {

struct ServerOptions {
  std::string host = "127.0.0.1";
  uint16_t port = 8080;               ///< 0 picks a free port; see Server::port()
  int num_workers = 2;                ///< fixed worker pool size
  std::size_t queue_capacity = 64;    ///< complete requests waiting for a worker; full -> 503
  std::size_t max_connections = 256;  ///< open connections; over the cap -> 503 and close
  int retry_after_s = 1;              ///< Retry-After on 503
  int read_timeout_ms = 10'000;       ///< a started request must keep arriving (408 otherwise)
  int keep_alive_timeout_ms = 5'000;  ///< idle keep-alive connections close silently after this
  Limits limits;
  /// Receives one access-log line per answered request:
  /// "<ISO time> <request id> <method> <path> <status> <body bytes> <ms>ms". Default: stderr.
  std::function<void(const std::string&)> access_log;
};

class Server {
 public:
  /// `handler` is called on worker threads, concurrently. Anything it throws becomes a 500 JSON
  /// error; the process never dies of a request.
  Server(ServerOptions options, std::function<Response(Request&)> handler);
  ~Server();  ///< Stop()s if still running
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  /// Binds and starts the I/O thread and workers. @throws std::runtime_error if it cannot bind.
  void Start();
  /// The bound port (after Start()).
  uint16_t port() const;

  /// Graceful stop: stops accepting, lets in-flight requests finish and their answers go out,
  /// closes idle connections, joins all threads. Safe to call more than once and from any thread
  /// except a worker.
  void Stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace softgrasp::http
