#pragma once
/// The socket side: an epoll loop that accepts and parses connections with limits and timeouts,
/// a bounded work queue and a fixed worker pool, graceful shutdown. Knows nothing of grasps.

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "service/http/message.h"
#include "service/http/parser.h"

namespace softgrasp::http {

struct ServerOptions {
  std::string host = "127.0.0.1";
  uint16_t port = 8080;                  ///< 0 picks a free port; see Server::port()
  int num_workers = 2;                   ///< fixed worker pool size
  std::size_t queue_capacity = 64;       ///< complete requests waiting for a worker; full -> 503
  std::size_t max_connections = 10'000;  ///< open connections; over the cap -> 503 and close
  /// Open connections from one client address (IPv4, or IPv6); over it -> 503 and close. 0 = no
  /// per-client limit (behind a balancer every client has the balancer's address).
  std::size_t max_connections_per_client = 0;
  int retry_after_s = 1;  ///< Retry-After on 503
  /// The request line and header block must arrive within this from the request's first byte
  /// (408 otherwise): a client trickling header lines cannot hold a connection for long.
  int header_timeout_ms = 10'000;
  /// The body must arrive within this from the end of the header block (408 otherwise).
  int body_timeout_ms = 30'000;
  int keep_alive_timeout_ms = 5'000;  ///< idle keep-alive connections close silently after this
  Limits limits;
  /// Requests for which this returns true are answered on the I/O thread, never queued: only for
  /// handlers that take microseconds and never block (health checks, constant answers). They
  /// keep answering while every worker is busy and skip two thread hand-offs. Default: none.
  std::function<bool(const Request&)> answer_inline;
  /// Receives one access-log line per answered request:
  /// "<ISO time> <request id> <method> <path> <status> <body bytes> <ms>ms". Default: stderr.
  std::function<void(const std::string&)> access_log;
  /// Receives one line per exception that escaped the handler (the client gets a plain 500):
  /// "<ISO time> <request id> <method> <path> handler failed: <message>". Default: stderr.
  std::function<void(const std::string&)> error_log;
};

/// Raises this process's soft limit on open descriptors to at least `wanted` where the hard limit
/// allows (never lowers it). Returns the soft limit in force afterwards. Each connection takes
/// one descriptor, so a server meant to hold N connections needs N plus its own few.
std::size_t RaiseOpenFileLimit(std::size_t wanted);

class Server {
 public:
  /// `handler` is called on worker threads, concurrently. Anything it throws becomes a 500 JSON
  /// error and a line in the error log; the process never dies of a request.
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
