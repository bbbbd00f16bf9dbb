#include "service/http/server.h"

#include <arpa/inet.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <deque>
#include <mutex>
#include <random>
#include <stdexcept>
#include <thread>
#include <unordered_map>
#include <utility>
#include <vector>

// Threads: one I/O thread owns the listening socket and every connection that is not being served;
// it accepts, reads, parses, answers protocol errors itself and queues complete requests. A
// fixed pool of workers runs the handler, writes the response on the socket and hands the
// connection back to the I/O thread (through `handbacks` and the eventfd), which then parses any
// pipelined bytes or closes it. Only the I/O thread closes sockets, so a descriptor number is
// never reused while a worker still writes to it.

namespace softgrasp::http {
namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

constexpr std::size_t kReadChunk = 64 * 1024;
constexpr int kReadsPerEvent = 16;         ///< fairness: at most this many recv()s per wake-up
constexpr int kFlushTimeoutMs = 2'000;     ///< an error answer must go out within this
constexpr int kDrainMs = 1'000;            ///< after our FIN, unread input is discarded this long
constexpr int kMinWriteTimeoutMs = 10'000; ///< workers give up on a client not reading its answer
constexpr std::size_t kMaxRejecting = 64;  ///< turned-away connections being answered at once
constexpr int kMaxPollWaitMs = 1'000;
constexpr std::size_t kMaxClientRequestId = 64;

char ToLowerAscii(char c) { return (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c; }

bool EqualsIgnoreCase(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return ToLowerAscii(x) == ToLowerAscii(y);
         });
}

/// Header fields the server writes itself; a handler's copies are dropped.
bool IsServerOwnedHeader(std::string_view name) {
  for (const char* owned :
       {"Content-Length", "Transfer-Encoding", "Connection", "Date", "X-Request-Id"}) {
    if (EqualsIgnoreCase(name, owned)) return true;
  }
  return false;
}

/// A handler header that could break the response framing (CR, LF, NUL, or a bad name) is dropped.
bool IsSafeHeader(std::string_view name, std::string_view value) {
  const auto is_bad_name_char = [](char c) {
    return static_cast<unsigned char>(c) <= 0x20 || c == ':' || c == 0x7f;
  };
  return !name.empty() && std::none_of(name.begin(), name.end(), is_bad_name_char) &&
         value.find_first_of(std::string_view("\r\n\0", 3)) == std::string_view::npos;
}

bool IsPrintableId(std::string_view id) {
  return !id.empty() && id.size() <= kMaxClientRequestId &&
         std::all_of(id.begin(), id.end(), [](char c) { return c > 0x20 && c < 0x7f; });
}

/// Access-log field: visible ASCII as is, anything else (spaces, controls, UTF-8) as %XX, so a
/// log line always has exactly seven space-separated fields.
std::string LogField(std::string_view s) {
  if (s.empty()) return "-";
  std::string out;
  for (const char c : s) {
    const auto u = static_cast<unsigned char>(c);
    if (u > 0x20 && u < 0x7f) {
      out.push_back(c);
    } else {
      static constexpr char kHex[] = "0123456789ABCDEF";
      out += {'%', kHex[u >> 4], kHex[u & 15]};
    }
  }
  return out;
}

std::tm UtcTm(std::chrono::system_clock::time_point t) {
  const std::time_t secs = std::chrono::system_clock::to_time_t(t);
  std::tm tm{};
  gmtime_r(&secs, &tm);
  return tm;
}

/// IMF-fixdate for the Date header, e.g. "Sun, 06 Nov 1994 08:49:37 GMT".
std::string HttpDate(std::chrono::system_clock::time_point t) {
  static constexpr const char* kDays[] = {"Sun", "Mon", "Tue", "Wed", "Thu", "Fri", "Sat"};
  static constexpr const char* kMonths[] = {"Jan", "Feb", "Mar", "Apr", "May", "Jun",
                                            "Jul", "Aug", "Sep", "Oct", "Nov", "Dec"};
  const std::tm tm = UtcTm(t);
  char buf[64];
  std::snprintf(buf, sizeof buf, "%s, %02d %s %04d %02d:%02d:%02d GMT", kDays[tm.tm_wday % 7],
                tm.tm_mday, kMonths[tm.tm_mon % 12], tm.tm_year + 1900, tm.tm_hour, tm.tm_min,
                tm.tm_sec);
  return buf;
}

/// ISO-8601 UTC with milliseconds, e.g. "2024-05-01T12:34:56.789Z".
std::string IsoTime(std::chrono::system_clock::time_point t) {
  const std::tm tm = UtcTm(t);
  const auto ms = std::chrono::duration_cast<milliseconds>(t.time_since_epoch()).count() % 1000;
  char buf[64];
  std::snprintf(buf, sizeof buf, "%04d-%02d-%02dT%02d:%02d:%02d.%03dZ", tm.tm_year + 1900,
                tm.tm_mon + 1, tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec, static_cast<int>(ms));
  return buf;
}

const char* ErrorCodeFor(int status) {
  switch (status) {
    case 400: return "bad_request";
    case 408: return "request_timeout";
    case 413: return "payload_too_large";
    case 414: return "uri_too_long";
    case 431: return "header_fields_too_large";
    case 501: return "not_implemented";
    case 503: return "service_unavailable";
    case 505: return "http_version_not_supported";
    default: return "internal";
  }
}

/// Whether a response with this status carries no body (and so no Content-Length either, except
/// for 304 where it would describe the 200 and we have none to give).
bool StatusHasNoBody(int status) { return status < 200 || status == 204 || status == 304; }

/// Status line, the handler's headers, the server's headers, and the body unless `head`.
/// `*body_bytes` receives the number of body bytes included.
std::string SerializeResponse(const Response& response, const std::string& request_id,
                              bool keep_alive, bool head, std::size_t* body_bytes) {
  std::string out = "HTTP/1.1 " + std::to_string(response.status) + " " +
                    ReasonPhrase(response.status) + "\r\n";
  for (const auto& [name, value] : response.headers) {
    if (IsServerOwnedHeader(name) || !IsSafeHeader(name, value)) continue;
    out += name + ": " + value + "\r\n";
  }
  const bool no_body = StatusHasNoBody(response.status);
  if (!no_body) out += "Content-Length: " + std::to_string(response.body.size()) + "\r\n";
  out += "Date: " + HttpDate(std::chrono::system_clock::now()) + "\r\n";
  out += keep_alive ? "Connection: keep-alive\r\n" : "Connection: close\r\n";
  out += "X-Request-Id: " + request_id + "\r\n\r\n";
  *body_bytes = (no_body || head) ? 0 : response.body.size();
  out.append(response.body, 0, *body_bytes);
  return out;
}

/// Blocking-style send on a non-blocking socket, waiting for writability up to `timeout_ms`.
bool SendAll(int fd, std::string_view data, int timeout_ms) {
  const auto deadline = Clock::now() + milliseconds(timeout_ms);
  while (!data.empty()) {
    const ssize_t n = ::send(fd, data.data(), data.size(), MSG_NOSIGNAL);
    if (n > 0) {
      data.remove_prefix(static_cast<std::size_t>(n));
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
      const auto left = std::chrono::duration_cast<milliseconds>(deadline - Clock::now()).count();
      if (left <= 0) return false;
      pollfd p{fd, POLLOUT, 0};
      if (::poll(&p, 1, static_cast<int>(left)) < 0 && errno != EINTR) return false;
      continue;
    }
    return false;
  }
  return true;
}

std::string Errno(const std::string& what) { return what + ": " + std::strerror(errno); }

std::string RandomHex32() {
  std::uint32_t value = 0;
  try {
    std::random_device device;
    value = device();
  } catch (const std::exception&) {
    value = static_cast<std::uint32_t>(Clock::now().time_since_epoch().count());
  }
  char buf[16];
  std::snprintf(buf, sizeof buf, "%08x", static_cast<unsigned>(value));
  return buf;
}

}  // namespace

struct Server::Impl {
  struct Connection {
    enum class Phase {
      kReading,   ///< owned by the I/O thread, waiting for (more of) a request
      kBusy,      ///< a request of it is queued or in a worker; the I/O thread leaves it alone
      kClosing,   ///< a final answer is in `out`; then kDraining
      kDraining,  ///< our side is shut down; unread input is discarded until EOF or the deadline
      kClosed,    ///< socket closed; removed at the end of the loop iteration
    };
    Connection(std::uint64_t id_in, int fd_in, const Limits& limits)
        : id(id_in), fd(fd_in), parser(limits) {}

    std::uint64_t id;
    int fd;
    RequestParser parser;
    Phase phase = Phase::kReading;
    bool rejected = false;       ///< over the connection cap: answered 503, not counted
    bool sent_continue = false;  ///< "100 Continue" already queued for the current request
    std::string out;             ///< bytes the I/O thread still has to write
    Clock::time_point idle_since;     ///< accepted, or last answer handed back
    Clock::time_point request_start;  ///< first byte of the request being read
    Clock::time_point deadline;       ///< kClosing / kDraining: close by then
  };

  struct WorkItem {
    std::uint64_t connection_id = 0;
    int fd = -1;
    Request request;
    bool keep_alive = false;
    Clock::time_point start;
  };

  struct Handback {
    std::uint64_t connection_id = 0;
    bool keep_open = false;  ///< keep-alive: read the next request
    bool write_ok = false;   ///< false: close at once, nothing left to drain politely
  };

  Impl(ServerOptions options_in, std::function<Response(Request&)> handler_in)
      : options(std::move(options_in)), handler(std::move(handler_in)), id_prefix(RandomHex32()) {
    options.num_workers = std::max(options.num_workers, 1);
    options.queue_capacity = std::max<std::size_t>(options.queue_capacity, 1);
  }

  // ---- set-up ----
  void Bind();
  void Wake();

  // ---- I/O thread ----
  void IoLoop();
  void IoIteration();
  void BeginStop();
  bool StopComplete() const;
  void ProcessHandbacks();
  void ExpireTimeouts(Clock::time_point now);
  int PollTimeoutMs(Clock::time_point now) const;
  void AcceptAll();
  void OnEvent(Connection& c, short revents);
  void ReadAndParse(Connection& c);
  void Advance(Connection& c);
  void Dispatch(Connection& c);
  void SendFinal(Connection& c, Response response, const std::string& request_id,
                 std::string_view method, std::string_view path, Clock::time_point start);
  void SendError(Connection& c, int status, std::string_view message);
  bool FlushOut(Connection& c);
  void StartDrain(Connection& c);
  void Discard(Connection& c);
  void Close(Connection& c);

  // ---- workers ----
  void WorkerLoop();
  void Serve(WorkItem& item);
  Response CallHandler(Request& request);

  // ---- shared ----
  std::string RequestIdFor(const Request& request);
  void Log(const std::string& request_id, std::string_view method, std::string_view path,
           int status, std::size_t body_bytes, Clock::time_point start);

  ServerOptions options;
  std::function<Response(Request&)> handler;
  const std::string id_prefix;
  std::atomic<std::uint64_t> request_counter{0};
  std::atomic<bool> stopping{false};

  int listen_fd = -1;
  int wake_fd = -1;
  uint16_t bound_port = 0;
  std::thread io_thread;
  std::vector<std::thread> workers;

  std::mutex lifecycle_mu;  ///< serializes Start() and Stop()
  bool started = false;
  bool stopped = false;

  std::mutex mu;  ///< guards queue, handbacks, workers_exit
  std::condition_variable queue_cv;
  std::deque<WorkItem> queue;
  std::vector<Handback> handbacks;
  bool workers_exit = false;

  std::mutex log_mu;

  // I/O-thread state.
  std::unordered_map<std::uint64_t, std::unique_ptr<Connection>> connections;
  std::uint64_t next_connection_id = 1;
  std::size_t open_count = 0;       ///< connections counted against max_connections
  std::size_t rejecting_count = 0;  ///< connections being turned away with 503
  Clock::time_point accept_paused_until{};
  std::vector<char> read_buffer = std::vector<char>(kReadChunk);
};

// ---- set-up ----

void Server::Impl::Bind() {
  std::string host = options.host;
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') {
    host = host.substr(1, host.size() - 2);  // "[::1]"
  }
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE | AI_NUMERICSERV;
  addrinfo* found = nullptr;
  const std::string port_text = std::to_string(options.port);
  const int rc = ::getaddrinfo(host.empty() ? nullptr : host.c_str(), port_text.c_str(), &hints,
                               &found);
  if (rc != 0) {
    throw std::runtime_error("cannot resolve listen address '" + options.host +
                             "': " + ::gai_strerror(rc));
  }
  std::string error = "no usable address";
  for (addrinfo* ai = found; ai != nullptr && listen_fd < 0; ai = ai->ai_next) {
    const int fd = ::socket(ai->ai_family, ai->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC,
                            ai->ai_protocol);
    if (fd < 0) {
      error = Errno("socket");
      continue;
    }
    const int one = 1;
    ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    if (::bind(fd, ai->ai_addr, ai->ai_addrlen) != 0 || ::listen(fd, SOMAXCONN) != 0) {
      error = Errno("bind/listen");
      ::close(fd);
      continue;
    }
    listen_fd = fd;
  }
  ::freeaddrinfo(found);
  if (listen_fd < 0) {
    throw std::runtime_error("cannot listen on " + options.host + ":" + port_text + ": " + error);
  }
  sockaddr_storage addr{};
  socklen_t len = sizeof addr;
  if (::getsockname(listen_fd, reinterpret_cast<sockaddr*>(&addr), &len) == 0) {
    if (addr.ss_family == AF_INET6) {
      bound_port = ntohs(reinterpret_cast<const sockaddr_in6*>(&addr)->sin6_port);
    } else {
      bound_port = ntohs(reinterpret_cast<const sockaddr_in*>(&addr)->sin_port);
    }
  }
  wake_fd = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (wake_fd < 0) {
    const std::string message = Errno("eventfd");
    ::close(listen_fd);
    listen_fd = -1;
    throw std::runtime_error(message);
  }
}

void Server::Impl::Wake() {
  const std::uint64_t one = 1;
  // Can only fail when the counter is about to overflow, in which case a wake-up is pending.
  [[maybe_unused]] const ssize_t n = ::write(wake_fd, &one, sizeof one);
}

// ---- I/O thread ----

void Server::Impl::IoLoop() {
  while (true) {
    try {
      IoIteration();
    } catch (const std::exception& e) {
      // Nothing here is expected to throw but allocation; keep serving the other connections.
      std::fprintf(stderr, "softgrasp http: I/O loop error: %s\n", e.what());
      std::this_thread::sleep_for(milliseconds(10));
    }
    if (stopping.load() && StopComplete()) break;
  }
  for (auto& [id, c] : connections) Close(*c);
  connections.clear();
  if (listen_fd >= 0) ::close(listen_fd);
  listen_fd = -1;
}

void Server::Impl::IoIteration() {
  if (stopping.load()) BeginStop();
  ProcessHandbacks();

  std::vector<pollfd> fds;
  std::vector<Connection*> owners;  // owners[i] for fds[i]; nullptr for the wake and listen fds
  fds.push_back({wake_fd, POLLIN, 0});
  owners.push_back(nullptr);
  const bool accepting = listen_fd >= 0 && Clock::now() >= accept_paused_until;
  if (accepting) {
    fds.push_back({listen_fd, POLLIN, 0});
    owners.push_back(nullptr);
  }
  for (auto& [id, c] : connections) {
    short events = 0;
    switch (c->phase) {
      case Connection::Phase::kReading:
        // A complete request waiting for "100 Continue" to go out needs no more input yet.
        if (c->parser.state() == RequestParser::State::kNeedMore) events |= POLLIN;
        if (!c->out.empty()) events |= POLLOUT;
        break;
      case Connection::Phase::kClosing: events = POLLOUT; break;
      case Connection::Phase::kDraining: events = POLLIN; break;
      case Connection::Phase::kBusy:
      case Connection::Phase::kClosed: break;
    }
    if (events == 0) continue;
    fds.push_back({c->fd, events, 0});
    owners.push_back(c.get());
  }

  const int ready = ::poll(fds.data(), fds.size(), PollTimeoutMs(Clock::now()));
  if (ready < 0) {
    if (errno != EINTR) throw std::runtime_error(Errno("poll"));
    return;
  }
  if ((fds[0].revents & POLLIN) != 0) {
    std::uint64_t count = 0;
    [[maybe_unused]] const ssize_t n = ::read(wake_fd, &count, sizeof count);
  }
  if (accepting && fds[1].revents != 0) AcceptAll();
  for (std::size_t i = 0; i < fds.size(); ++i) {
    if (owners[i] == nullptr || fds[i].revents == 0) continue;
    try {
      OnEvent(*owners[i], fds[i].revents);
    } catch (const std::exception&) {
      Close(*owners[i]);
    }
  }
  // After reading, so that bytes which did arrive in time are never mistaken for silence.
  ExpireTimeouts(Clock::now());
  std::erase_if(connections, [](const auto& entry) {
    return entry.second->phase == Connection::Phase::kClosed;
  });
}

void Server::Impl::BeginStop() {
  if (listen_fd >= 0) {
    ::close(listen_fd);
    listen_fd = -1;
  }
  // Idle connections and requests still arriving are closed; answers in flight go out.
  for (auto& [id, c] : connections) {
    if (c->phase == Connection::Phase::kReading) Close(*c);
  }
}

bool Server::Impl::StopComplete() const {
  return std::all_of(connections.begin(), connections.end(), [](const auto& entry) {
    return entry.second->phase == Connection::Phase::kClosed;
  });
}

void Server::Impl::ProcessHandbacks() {
  std::vector<Handback> batch;
  {
    std::lock_guard<std::mutex> lock(mu);
    batch.swap(handbacks);
  }
  const auto now = Clock::now();
  for (const Handback& back : batch) {
    const auto it = connections.find(back.connection_id);
    if (it == connections.end()) continue;
    Connection& c = *it->second;
    if (!back.write_ok) {
      Close(c);
    } else if (!back.keep_open || stopping.load()) {
      StartDrain(c);
    } else {
      c.phase = Connection::Phase::kReading;
      c.idle_since = now;
      c.parser.Feed("");  // pipelined bytes already received
      if (c.parser.in_progress()) c.request_start = now;
      Advance(c);
    }
  }
}

void Server::Impl::ExpireTimeouts(Clock::time_point now) {
  const auto read_timeout = milliseconds(options.read_timeout_ms);
  const auto idle_timeout = milliseconds(options.keep_alive_timeout_ms);
  for (auto& [id, c] : connections) {
    switch (c->phase) {
      case Connection::Phase::kReading:
        if (c->parser.state() != RequestParser::State::kNeedMore) break;
        if (c->parser.in_progress()) {
          if (now - c->request_start >= read_timeout) {
            SendError(*c, 408, "request not received within " +
                                   std::to_string(options.read_timeout_ms) + " ms");
          }
        } else if (now - c->idle_since >= idle_timeout) {
          Close(*c);  // idle keep-alive: silently
        }
        break;
      case Connection::Phase::kClosing:
      case Connection::Phase::kDraining:
        if (now >= c->deadline) Close(*c);
        break;
      case Connection::Phase::kBusy:
      case Connection::Phase::kClosed:
        break;
    }
  }
}

int Server::Impl::PollTimeoutMs(Clock::time_point now) const {
  Clock::time_point next = now + milliseconds(kMaxPollWaitMs);
  if (listen_fd >= 0 && accept_paused_until > now) next = std::min(next, accept_paused_until);
  for (const auto& [id, c] : connections) {
    switch (c->phase) {
      case Connection::Phase::kReading:
        if (c->parser.state() != RequestParser::State::kNeedMore) break;
        next = std::min(next, c->parser.in_progress()
                                  ? c->request_start + milliseconds(options.read_timeout_ms)
                                  : c->idle_since + milliseconds(options.keep_alive_timeout_ms));
        break;
      case Connection::Phase::kClosing:
      case Connection::Phase::kDraining:
        next = std::min(next, c->deadline);
        break;
      case Connection::Phase::kBusy:
      case Connection::Phase::kClosed:
        break;
    }
  }
  if (next <= now) return 0;
  // Round up so that a deadline is not polled for repeatedly just before it passes.
  return static_cast<int>(std::chrono::ceil<milliseconds>(next - now).count());
}

void Server::Impl::AcceptAll() {
  while (true) {
    const int fd = ::accept4(listen_fd, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) {
      if (errno == EINTR || errno == ECONNABORTED) continue;
      if (errno == EMFILE || errno == ENFILE || errno == ENOBUFS || errno == ENOMEM) {
        accept_paused_until = Clock::now() + milliseconds(100);  // out of descriptors: back off
      }
      return;  // EAGAIN: accepted everything pending
    }
    const int one = 1;
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    const bool over_cap = open_count >= options.max_connections;
    if (over_cap && rejecting_count >= kMaxRejecting) {
      ::close(fd);  // flooded: not even a 503
      continue;
    }
    auto owned = std::make_unique<Connection>(next_connection_id++, fd, options.limits);
    Connection& c = *owned;
    connections.emplace(c.id, std::move(owned));
    c.idle_since = c.request_start = Clock::now();
    if (over_cap) {
      c.rejected = true;
      ++rejecting_count;
      Response busy = ErrorResponse(503, "service_unavailable", "too many connections; retry later");
      busy.set_header("Retry-After", std::to_string(options.retry_after_s));
      SendFinal(c, std::move(busy), RequestIdFor(Request{}), "-", "-", c.request_start);
    } else {
      ++open_count;
    }
  }
}

void Server::Impl::OnEvent(Connection& c, short revents) {
  switch (c.phase) {
    case Connection::Phase::kReading:
      if ((revents & POLLOUT) != 0 && !FlushOut(c)) return;
      if ((revents & (POLLIN | POLLHUP | POLLERR)) != 0) {
        ReadAndParse(c);
      } else {
        Advance(c);  // "100 Continue" flushed: a complete request may now be dispatched
      }
      break;
    case Connection::Phase::kClosing:
      if ((revents & (POLLERR | POLLNVAL)) != 0) {
        Close(c);
      } else if (FlushOut(c) && c.out.empty()) {
        StartDrain(c);
      }
      break;
    case Connection::Phase::kDraining:
      Discard(c);
      break;
    case Connection::Phase::kBusy:
    case Connection::Phase::kClosed:
      break;
  }
}

void Server::Impl::ReadAndParse(Connection& c) {
  for (int i = 0; i < kReadsPerEvent && c.parser.state() == RequestParser::State::kNeedMore; ++i) {
    const ssize_t n = ::recv(c.fd, read_buffer.data(), read_buffer.size(), 0);
    if (n > 0) {
      if (!c.parser.in_progress()) c.request_start = Clock::now();
      c.parser.Feed(std::string_view(read_buffer.data(), static_cast<std::size_t>(n)));
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) break;
    Close(c);  // EOF (a partial request is abandoned) or a socket error
    return;
  }
  Advance(c);
}

void Server::Impl::Advance(Connection& c) {
  if (c.phase != Connection::Phase::kReading) return;
  switch (c.parser.state()) {
    case RequestParser::State::kError:
      SendError(c, c.parser.error_status(), c.parser.error_message());
      break;
    case RequestParser::State::kNeedMore:
      if (c.parser.expects_continue() && !c.sent_continue) {
        c.sent_continue = true;
        c.out += "HTTP/1.1 100 Continue\r\n\r\n";
        FlushOut(c);
      }
      break;
    case RequestParser::State::kComplete:
      if (c.out.empty()) Dispatch(c);  // else after "100 Continue" has gone out
      break;
  }
}

void Server::Impl::Dispatch(Connection& c) {
  WorkItem item;
  item.connection_id = c.id;
  item.fd = c.fd;
  item.request = c.parser.Take();
  item.keep_alive = c.parser.keep_alive();
  item.start = c.request_start;
  item.request.request_id = RequestIdFor(item.request);
  c.sent_continue = false;

  bool queued = false;
  {
    std::lock_guard<std::mutex> lock(mu);
    if (queue.size() < options.queue_capacity) {
      queue.push_back(std::move(item));
      queued = true;
    }
  }
  if (queued) {
    c.phase = Connection::Phase::kBusy;
    queue_cv.notify_one();
    return;
  }
  Response busy = ErrorResponse(503, "service_unavailable", "server busy; retry later");
  busy.set_header("Retry-After", std::to_string(options.retry_after_s));
  SendFinal(c, std::move(busy), item.request.request_id, item.request.method, item.request.path,
            item.start);
}

void Server::Impl::SendFinal(Connection& c, Response response, const std::string& request_id,
                             std::string_view method, std::string_view path,
                             Clock::time_point start) {
  std::size_t body_bytes = 0;
  c.out += SerializeResponse(response, request_id, false, method == "HEAD", &body_bytes);
  Log(request_id, method, path, response.status, body_bytes, start);
  c.phase = Connection::Phase::kClosing;
  c.deadline = Clock::now() + milliseconds(kFlushTimeoutMs);
  if (FlushOut(c) && c.out.empty()) StartDrain(c);
}

void Server::Impl::SendError(Connection& c, int status, std::string_view message) {
  SendFinal(c, ErrorResponse(status, ErrorCodeFor(status), message), RequestIdFor(Request{}), "-",
            "-", c.request_start);
}

bool Server::Impl::FlushOut(Connection& c) {
  while (!c.out.empty()) {
    const ssize_t n = ::send(c.fd, c.out.data(), c.out.size(), MSG_NOSIGNAL);
    if (n > 0) {
      c.out.erase(0, static_cast<std::size_t>(n));
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return true;
    Close(c);
    return false;
  }
  return true;
}

void Server::Impl::StartDrain(Connection& c) {
  // Half-close, then read until the client closes too: closing with unread input would send a
  // RST that can destroy the answer before the client has read it.
  ::shutdown(c.fd, SHUT_WR);
  c.phase = Connection::Phase::kDraining;
  c.deadline = Clock::now() + milliseconds(kDrainMs);
}

void Server::Impl::Discard(Connection& c) {
  // A client still uploading a rejected body keeps us reading until its deadline.
  for (int i = 0; i < kReadsPerEvent; ++i) {
    const ssize_t n = ::recv(c.fd, read_buffer.data(), read_buffer.size(), 0);
    if (n > 0) continue;
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return;
    Close(c);  // EOF or error
    return;
  }
}

void Server::Impl::Close(Connection& c) {
  if (c.phase == Connection::Phase::kClosed) return;
  ::close(c.fd);
  c.fd = -1;
  c.phase = Connection::Phase::kClosed;
  if (c.rejected) {
    --rejecting_count;
  } else {
    --open_count;
  }
}

// ---- workers ----

void Server::Impl::WorkerLoop() {
  while (true) {
    WorkItem item;
    {
      std::unique_lock<std::mutex> lock(mu);
      queue_cv.wait(lock, [this] { return workers_exit || !queue.empty(); });
      if (queue.empty()) return;  // exiting, and nothing is left to serve
      item = std::move(queue.front());
      queue.pop_front();
    }
    Serve(item);
  }
}

void Server::Impl::Serve(WorkItem& item) {
  Handback back{item.connection_id, false, false};
  try {
    Response response = CallHandler(item.request);
    const bool keep_open = item.keep_alive && !stopping.load();
    std::size_t body_bytes = 0;
    const std::string bytes = SerializeResponse(response, item.request.request_id, keep_open,
                                                item.request.method == "HEAD", &body_bytes);
    back.write_ok = SendAll(item.fd, bytes, std::max(options.read_timeout_ms, kMinWriteTimeoutMs));
    back.keep_open = keep_open && back.write_ok;
    Log(item.request.request_id, item.request.method, item.request.path, response.status,
        body_bytes, item.start);
  } catch (const std::exception&) {
    back.write_ok = false;  // out of memory while answering: drop the connection
  }
  {
    std::lock_guard<std::mutex> lock(mu);
    handbacks.push_back(back);
  }
  Wake();
}

Response Server::Impl::CallHandler(Request& request) {
  try {
    Response response = handler(request);
    if (response.status < 200 || response.status > 599) {
      return ErrorResponse(500, "internal", "handler returned invalid status " +
                                                std::to_string(response.status));
    }
    return response;
  } catch (...) {
    // Deliberately not echoing what() to the client: it may carry internals.
    return ErrorResponse(500, "internal", "internal server error");
  }
}

// ---- shared ----

std::string Server::Impl::RequestIdFor(const Request& request) {
  if (const auto id = request.header("X-Request-Id"); id && IsPrintableId(*id)) {
    return std::string(*id);
  }
  char buf[32];
  std::snprintf(buf, sizeof buf, "%012llx",
                static_cast<unsigned long long>(++request_counter));
  return id_prefix + "-" + buf;
}

void Server::Impl::Log(const std::string& request_id, std::string_view method,
                       std::string_view path, int status, std::size_t body_bytes,
                       Clock::time_point start) {
  const auto ms = std::chrono::duration_cast<milliseconds>(Clock::now() - start).count();
  std::string line = IsoTime(std::chrono::system_clock::now()) + " " + LogField(request_id) + " " +
                     LogField(method) + " " + LogField(path) + " " + std::to_string(status) +
                     " " + std::to_string(body_bytes) + " " + std::to_string(ms) + "ms";
  std::lock_guard<std::mutex> lock(log_mu);  // the sink need not be thread-safe
  try {
    if (options.access_log) {
      options.access_log(line);
    } else {
      line.push_back('\n');
      std::fwrite(line.data(), 1, line.size(), stderr);
    }
  } catch (...) {
    // A failing log sink must not take the server down.
  }
}

// ---- Server ----

Server::Server(ServerOptions options, std::function<Response(Request&)> handler)
    : impl_(std::make_unique<Impl>(std::move(options), std::move(handler))) {}

Server::~Server() { Stop(); }

void Server::Start() {
  std::lock_guard<std::mutex> lock(impl_->lifecycle_mu);
  if (impl_->started) throw std::logic_error("Server::Start() called twice");
  impl_->Bind();
  impl_->started = true;
  impl_->io_thread = std::thread([impl = impl_.get()] { impl->IoLoop(); });
  for (int i = 0; i < impl_->options.num_workers; ++i) {
    impl_->workers.emplace_back([impl = impl_.get()] { impl->WorkerLoop(); });
  }
}

uint16_t Server::port() const { return impl_->bound_port; }

void Server::Stop() {
  std::lock_guard<std::mutex> lock(impl_->lifecycle_mu);
  if (!impl_->started || impl_->stopped) return;
  impl_->stopped = true;
  impl_->stopping = true;
  impl_->Wake();
  // The I/O thread returns once every queued or running request has been answered.
  if (impl_->io_thread.joinable()) impl_->io_thread.join();
  {
    std::lock_guard<std::mutex> queue_lock(impl_->mu);
    impl_->workers_exit = true;
  }
  impl_->queue_cv.notify_all();
  for (auto& worker : impl_->workers) {
    if (worker.joinable()) worker.join();
  }
  ::close(impl_->wake_fd);
  impl_->wake_fd = -1;
}

}  // namespace softgrasp::http
