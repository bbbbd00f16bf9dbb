#include "service/http/server.h"

#include <arpa/inet.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/resource.h>
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
#include <limits>
#include <mutex>
#include <optional>
#include <queue>
#include <random>
#include <stdexcept>
#include <thread>
#include <unordered_map>
#include <utility>
#include <vector>

#include "service/http/response_writer.h"

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
constexpr int kReadsPerEvent = 16;          ///< fairness: at most this many recv()s per wake-up
constexpr int kFlushTimeoutMs = 2'000;      ///< an error answer must go out within this
constexpr int kDrainMs = 1'000;             ///< after our FIN, unread input is discarded this long
constexpr int kMinWriteTimeoutMs = 10'000;  ///< workers give up on a client not reading its answer
constexpr std::size_t kMaxRejecting = 64;   ///< turned-away connections being answered at once
constexpr int kMaxPollWaitMs = 1'000;
constexpr int kMaxEventsPerWait = 256;
// epoll data of the two non-connection descriptors; connection ids start above them.
constexpr std::uint64_t kWakeId = 0;
constexpr std::uint64_t kListenId = 1;
constexpr std::uint64_t kFirstConnectionId = 2;
constexpr std::size_t kMaxClientRequestId = 64;

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

/// ISO-8601 UTC with milliseconds, e.g. "2024-05-01T12:34:56.789Z". The part up to the seconds
/// is formatted once per second per thread.
std::string IsoTime(std::chrono::system_clock::time_point t) {
  thread_local std::time_t cached_secs = -1;
  thread_local std::string cached;  // "2024-05-01T12:34:56."
  const std::time_t secs = std::chrono::system_clock::to_time_t(t);
  if (secs != cached_secs) {
    const std::tm tm = UtcTm(t);
    char buf[64];
    std::snprintf(buf, sizeof buf, "%04d-%02d-%02dT%02d:%02d:%02d.", tm.tm_year + 1900,
                  tm.tm_mon + 1, tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec);
    cached = buf;
    cached_secs = secs;
  }
  auto ms = std::chrono::duration_cast<milliseconds>(t.time_since_epoch()).count() % 1000;
  if (ms < 0) ms += 1000;
  std::string out = cached;
  out += {static_cast<char>('0' + ms / 100), static_cast<char>('0' + ms / 10 % 10),
          static_cast<char>('0' + ms % 10), 'Z'};
  return out;
}

const char* ErrorCodeFor(int status) {
  switch (status) {
    case 400:
      return "bad_request";
    case 408:
      return "request_timeout";
    case 413:
      return "payload_too_large";
    case 414:
      return "uri_too_long";
    case 431:
      return "header_fields_too_large";
    case 501:
      return "not_implemented";
    case 503:
      return "service_unavailable";
    case 505:
      return "http_version_not_supported";
    default:
      return "internal";
  }
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

/// The client's address as raw bytes (4 for IPv4, IPv4-mapped IPv6 included; 16 for IPv6), the
/// key of the per-client connection count; empty for other families.
std::string PeerKey(const sockaddr_storage& addr) {
  if (addr.ss_family == AF_INET) {
    const auto& v4 = reinterpret_cast<const sockaddr_in&>(addr);
    return std::string(reinterpret_cast<const char*>(&v4.sin_addr), sizeof v4.sin_addr);
  }
  if (addr.ss_family == AF_INET6) {
    const auto& v6 = reinterpret_cast<const sockaddr_in6&>(addr);
    const auto* bytes = reinterpret_cast<const char*>(&v6.sin6_addr);
    if (IN6_IS_ADDR_V4MAPPED(&v6.sin6_addr)) return std::string(bytes + 12, 4);
    return std::string(bytes, sizeof v6.sin6_addr);
  }
  return {};
}

/// True on a server's I/O thread (set by IoLoop): its access-log lines are batched.
thread_local bool t_on_io_thread = false;

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
    Connection(std::uint64_t id_in, int fd_in, std::string peer_in, const Limits& limits)
        : id(id_in), fd(fd_in), peer(std::move(peer_in)), parser(limits) {}

    std::uint64_t id;
    int fd;
    std::string peer;  ///< the client's address bytes (per-client limit); empty if unknown
    RequestParser parser;
    Phase phase = Phase::kReading;
    bool rejected = false;            ///< over a connection cap: answered 503, not counted
    bool sent_continue = false;       ///< "100 Continue" already queued for the current request
    bool body_started = false;        ///< the current request's header block is complete
    std::string out;                  ///< bytes the I/O thread still has to write
    Clock::time_point idle_since;     ///< accepted, or last answer handed back
    Clock::time_point request_start;  ///< first byte of the request being read
    Clock::time_point body_start;     ///< end of the current request's header block
    Clock::time_point deadline;       ///< kClosing / kDraining: close by then
    std::uint32_t watched = 0;        ///< epoll events registered; 0 = not in the epoll set
    /// The earliest time this connection has in the timer heap (max: none).
    Clock::time_point armed = Clock::time_point::max();
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

  /// (when, connection id): a connection's deadline in the timer heap. Entries are never removed
  /// early; one that no longer matches its connection's `armed` time is skipped when it comes up.
  using Timer = std::pair<Clock::time_point, std::uint64_t>;

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
  void ProcessHandbacks();
  void WatchListener(Clock::time_point now);
  int WaitTimeoutMs(Clock::time_point now);
  void ExpireDue(Clock::time_point now);
  std::optional<Clock::time_point> DeadlineOf(const Connection& c) const;
  void Expire(Connection& c, Clock::time_point now);
  void Refresh(Connection& c);
  void AcceptAll();
  void OnEvent(Connection& c, std::uint32_t events);
  void ReadAndParse(Connection& c);
  void Advance(Connection& c);
  bool Dispatch(Connection& c);
  void AnswerInline(Connection& c, WorkItem& item);
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
  void FlushIoLog();
  /// "<ISO time> <request id> <method> <path> handler failed: <message>" to the error log.
  void LogError(const Request& request, std::string_view what);
  /// One line to `sink`, or to stderr when it is empty; a throwing sink is ignored.
  void WriteLogLine(const std::function<void(const std::string&)>& sink, std::string line);

  ServerOptions options;
  std::function<Response(Request&)> handler;
  const std::string id_prefix;
  std::atomic<std::uint64_t> request_counter{0};
  std::atomic<bool> stopping{false};

  int listen_fd = -1;
  int wake_fd = -1;
  int epoll_fd = -1;
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
  std::string io_log;  ///< access-log lines of the I/O thread not yet written (default sink)

  // I/O-thread state.
  std::unordered_map<std::uint64_t, std::unique_ptr<Connection>> connections;
  std::vector<std::uint64_t> closed_ids;  ///< closed this iteration; erased at its end
  std::unordered_map<std::string, std::size_t> per_client;  ///< counted connections per peer
  std::priority_queue<Timer, std::vector<Timer>, std::greater<>> timers;
  std::uint64_t next_connection_id = kFirstConnectionId;
  std::size_t open_count = 0;       ///< connections counted against max_connections
  std::size_t rejecting_count = 0;  ///< connections being turned away with 503
  Clock::time_point accept_paused_until{};
  bool listener_watched = false;
  std::vector<char> read_buffer = std::vector<char>(kReadChunk);
  std::vector<epoll_event> ready_events = std::vector<epoll_event>(kMaxEventsPerWait);
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
  const int rc =
      ::getaddrinfo(host.empty() ? nullptr : host.c_str(), port_text.c_str(), &hints, &found);
  if (rc != 0) {
    throw std::runtime_error("cannot resolve listen address '" + options.host +
                             "': " + ::gai_strerror(rc));
  }
  std::string error = "no usable address";
  for (addrinfo* ai = found; ai != nullptr && listen_fd < 0; ai = ai->ai_next) {
    const int fd =
        ::socket(ai->ai_family, ai->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC, ai->ai_protocol);
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
  epoll_fd = ::epoll_create1(EPOLL_CLOEXEC);
  epoll_event wake_event{};
  wake_event.events = EPOLLIN;
  wake_event.data.u64 = kWakeId;
  if (wake_fd < 0 || epoll_fd < 0 ||
      ::epoll_ctl(epoll_fd, EPOLL_CTL_ADD, wake_fd, &wake_event) != 0) {
    const std::string message = Errno("eventfd/epoll");
    for (int* fd : {&listen_fd, &wake_fd, &epoll_fd}) {
      if (*fd >= 0) ::close(*fd);
      *fd = -1;
    }
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
  t_on_io_thread = true;
  while (true) {
    try {
      IoIteration();
    } catch (const std::exception& e) {
      // Nothing here is expected to throw but allocation; keep serving the other connections.
      std::fprintf(stderr, "softgrasp http: I/O loop error: %s\n", e.what());
      std::this_thread::sleep_for(milliseconds(10));
    }
    if (stopping.load() && connections.empty()) break;
  }
  FlushIoLog();
  if (listen_fd >= 0) ::close(listen_fd);
  listen_fd = -1;
}

void Server::Impl::IoIteration() {
  if (stopping.load()) BeginStop();
  ProcessHandbacks();
  WatchListener(Clock::now());
  FlushIoLog();  // before waiting: no line waits for the next event

  const int ready =
      ::epoll_wait(epoll_fd, ready_events.data(), static_cast<int>(ready_events.size()),
                   WaitTimeoutMs(Clock::now()));
  if (ready < 0 && errno != EINTR) throw std::runtime_error(Errno("epoll_wait"));
  for (int i = 0; i < ready; ++i) {
    const epoll_event& event = ready_events[static_cast<std::size_t>(i)];
    if (event.data.u64 == kWakeId) {
      std::uint64_t count = 0;
      [[maybe_unused]] const ssize_t n = ::read(wake_fd, &count, sizeof count);
      continue;
    }
    if (event.data.u64 == kListenId) {
      if (listen_fd >= 0) AcceptAll();
      continue;
    }
    const auto it = connections.find(event.data.u64);
    if (it == connections.end()) continue;
    Connection& c = *it->second;
    try {
      OnEvent(c, event.events);
    } catch (const std::exception&) {
      Close(c);
    }
    Refresh(c);
  }
  // After reading, so that bytes which did arrive in time are never mistaken for silence.
  ExpireDue(Clock::now());
  for (const std::uint64_t id : closed_ids) connections.erase(id);
  closed_ids.clear();
}

void Server::Impl::BeginStop() {
  if (listen_fd >= 0) {
    ::close(listen_fd);  // leaves the epoll set with it
    listen_fd = -1;
    listener_watched = false;
  }
  // Idle connections and requests still arriving are closed; answers in flight go out.
  for (auto& [id, c] : connections) {
    if (c->phase == Connection::Phase::kReading) Close(*c);
  }
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
    Refresh(c);
  }
}

void Server::Impl::WatchListener(Clock::time_point now) {
  const bool want = listen_fd >= 0 && now >= accept_paused_until;
  if (want == listener_watched) return;
  epoll_event event{};
  event.events = EPOLLIN;
  event.data.u64 = kListenId;
  if (::epoll_ctl(epoll_fd, want ? EPOLL_CTL_ADD : EPOLL_CTL_DEL, listen_fd, &event) == 0) {
    listener_watched = want;
  }
}

int Server::Impl::WaitTimeoutMs(Clock::time_point now) {
  Clock::time_point next = now + milliseconds(kMaxPollWaitMs);
  if (listen_fd >= 0 && !listener_watched) next = std::min(next, accept_paused_until);
  if (!timers.empty()) next = std::min(next, timers.top().first);
  if (next <= now) return 0;
  // Round up so that a deadline is not waited for repeatedly just before it passes.
  return static_cast<int>(std::chrono::ceil<milliseconds>(next - now).count());
}

void Server::Impl::ExpireDue(Clock::time_point now) {
  while (!timers.empty() && timers.top().first <= now) {
    const auto [when, id] = timers.top();
    timers.pop();
    const auto it = connections.find(id);
    if (it == connections.end()) continue;
    Connection& c = *it->second;
    if (c.armed != when) continue;  // superseded by an earlier entry that already came up
    c.armed = Clock::time_point::max();
    Expire(c, now);
    Refresh(c);  // arms the connection's next deadline, if it has one
  }
}

std::optional<Clock::time_point> Server::Impl::DeadlineOf(const Connection& c) const {
  switch (c.phase) {
    case Connection::Phase::kReading:
      if (c.parser.state() != RequestParser::State::kNeedMore) return std::nullopt;
      if (c.body_started) return c.body_start + milliseconds(options.body_timeout_ms);
      if (c.parser.in_progress()) return c.request_start + milliseconds(options.header_timeout_ms);
      return c.idle_since + milliseconds(options.keep_alive_timeout_ms);
    case Connection::Phase::kClosing:
    case Connection::Phase::kDraining:
      return c.deadline;
    case Connection::Phase::kBusy:
    case Connection::Phase::kClosed:
      break;
  }
  return std::nullopt;
}

void Server::Impl::Expire(Connection& c, Clock::time_point now) {
  const auto deadline = DeadlineOf(c);
  if (!deadline || *deadline > now) return;
  if (c.phase != Connection::Phase::kReading) {
    Close(c);  // an answer that could not go out, or a drain that did not end, in time
  } else if (c.body_started) {
    SendError(
        c, 408,
        "request body not received within " + std::to_string(options.body_timeout_ms) + " ms");
  } else if (c.parser.in_progress()) {
    SendError(
        c, 408,
        "request header not received within " + std::to_string(options.header_timeout_ms) + " ms");
  } else {
    Close(c);  // idle keep-alive: silently
  }
}

void Server::Impl::Refresh(Connection& c) {
  if (c.phase == Connection::Phase::kClosed) return;
  // The header deadline ends and the body deadline starts when the header block is complete.
  if (c.phase == Connection::Phase::kReading && c.parser.reading_body()) {
    if (!c.body_started) {
      c.body_started = true;
      c.body_start = Clock::now();
    }
  } else if (c.phase == Connection::Phase::kReading) {
    c.body_started = false;
  }

  std::uint32_t want = 0;
  switch (c.phase) {
    case Connection::Phase::kReading:
      // A complete request waiting for "100 Continue" to go out needs no more input yet.
      if (c.parser.state() == RequestParser::State::kNeedMore) want |= EPOLLIN;
      if (!c.out.empty()) want |= EPOLLOUT;
      break;
    case Connection::Phase::kClosing:
      want = EPOLLOUT;
      break;
    case Connection::Phase::kDraining:
      want = EPOLLIN;
      break;
    case Connection::Phase::kBusy:  // a worker owns the socket: not even its errors are watched
    case Connection::Phase::kClosed:
      break;
  }
  if (want != c.watched) {
    epoll_event event{};
    event.events = want;
    event.data.u64 = c.id;
    const int op = want == 0 ? EPOLL_CTL_DEL : (c.watched == 0 ? EPOLL_CTL_ADD : EPOLL_CTL_MOD);
    if (::epoll_ctl(epoll_fd, op, c.fd, &event) != 0) {
      Close(c);  // out of kernel memory for the epoll set: nothing would ever wake this one
      return;
    }
    c.watched = want;
  }

  if (const auto deadline = DeadlineOf(c); deadline && *deadline < c.armed) {
    timers.emplace(*deadline, c.id);
    c.armed = *deadline;
  }
}

void Server::Impl::AcceptAll() {
  while (true) {
    sockaddr_storage addr{};
    socklen_t addr_len = sizeof addr;
    const int fd = ::accept4(listen_fd, reinterpret_cast<sockaddr*>(&addr), &addr_len,
                             SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) {
      if (errno == EINTR || errno == ECONNABORTED) continue;
      if (errno == EMFILE || errno == ENFILE || errno == ENOBUFS || errno == ENOMEM) {
        accept_paused_until = Clock::now() + milliseconds(100);  // out of descriptors: back off
        WatchListener(Clock::now());
      }
      return;  // EAGAIN: accepted everything pending
    }
    const int one = 1;
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    std::string peer = PeerKey(addr);
    const char* refusal = nullptr;
    if (open_count >= options.max_connections) {
      refusal = "too many connections; retry later";
    } else if (options.max_connections_per_client > 0 && !peer.empty()) {
      const auto it = per_client.find(peer);
      if (it != per_client.end() && it->second >= options.max_connections_per_client) {
        refusal = "too many connections from this address; retry later";
      }
    }
    if (refusal != nullptr && rejecting_count >= kMaxRejecting) {
      ::close(fd);  // flooded: not even a 503
      continue;
    }
    auto owned =
        std::make_unique<Connection>(next_connection_id++, fd, std::move(peer), options.limits);
    Connection& c = *owned;
    connections.emplace(c.id, std::move(owned));
    c.idle_since = c.request_start = Clock::now();
    if (refusal != nullptr) {
      c.rejected = true;
      ++rejecting_count;
      Response busy = ErrorResponse(503, "service_unavailable", refusal);
      busy.set_header("Retry-After", std::to_string(options.retry_after_s));
      SendFinal(c, std::move(busy), RequestIdFor(Request{}), "-", "-", c.request_start);
    } else {
      ++open_count;
      if (!c.peer.empty()) ++per_client[c.peer];
    }
    Refresh(c);
  }
}

void Server::Impl::OnEvent(Connection& c, std::uint32_t events) {
  switch (c.phase) {
    case Connection::Phase::kReading:
      if ((events & EPOLLOUT) != 0 && !FlushOut(c)) return;
      if ((events & (EPOLLIN | EPOLLHUP | EPOLLERR)) != 0) {
        ReadAndParse(c);
      } else {
        Advance(c);  // an answer flushed: a complete request may now be dispatched
      }
      break;
    case Connection::Phase::kClosing:
      if ((events & EPOLLERR) != 0) {
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
      if (static_cast<std::size_t>(n) < read_buffer.size()) break;  // the socket is drained
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
  // Loops over pipelined requests that are answered here on the I/O thread.
  while (c.phase == Connection::Phase::kReading) {
    switch (c.parser.state()) {
      case RequestParser::State::kError:
        SendError(c, c.parser.error_status(), c.parser.error_message());
        return;
      case RequestParser::State::kNeedMore:
        if (c.parser.expects_continue() && !c.sent_continue) {
          c.sent_continue = true;
          c.out += "HTTP/1.1 100 Continue\r\n\r\n";
          FlushOut(c);
        }
        return;
      case RequestParser::State::kComplete:
        // Else after "100 Continue" or the previous answer has gone out.
        if (!c.out.empty() || !Dispatch(c)) return;
        break;
    }
  }
}

bool Server::Impl::Dispatch(Connection& c) {
  WorkItem item;
  item.connection_id = c.id;
  item.fd = c.fd;
  item.request = c.parser.Take();
  item.keep_alive = c.parser.keep_alive();
  item.start = c.request_start;
  item.request.request_id = RequestIdFor(item.request);
  c.sent_continue = false;
  c.body_started = false;

  if (options.answer_inline && options.answer_inline(item.request)) {
    AnswerInline(c, item);
    return c.phase == Connection::Phase::kReading;
  }
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
    return false;
  }
  Response busy = ErrorResponse(503, "service_unavailable", "server busy; retry later");
  busy.set_header("Retry-After", std::to_string(options.retry_after_s));
  SendFinal(c, std::move(busy), item.request.request_id, item.request.method, item.request.path,
            item.start);
  return false;
}

void Server::Impl::AnswerInline(Connection& c, WorkItem& item) {
  Response response = CallHandler(item.request);
  const bool keep_open = item.keep_alive && !stopping.load();
  if (!keep_open) {
    SendFinal(c, std::move(response), item.request.request_id, item.request.method,
              item.request.path, item.start);
    return;
  }
  std::size_t body_bytes = 0;
  c.out += SerializeResponse(
      response, {item.request.request_id, true, item.request.method == "HEAD"}, &body_bytes);
  Log(item.request.request_id, item.request.method, item.request.path, response.status, body_bytes,
      item.start);
  if (!FlushOut(c)) return;
  const auto now = Clock::now();
  c.idle_since = now;
  c.parser.Feed("");  // pipelined bytes already received
  if (c.parser.in_progress()) c.request_start = now;
}

void Server::Impl::SendFinal(Connection& c, Response response, const std::string& request_id,
                             std::string_view method, std::string_view path,
                             Clock::time_point start) {
  std::size_t body_bytes = 0;
  c.out += SerializeResponse(response, {request_id, false, method == "HEAD"}, &body_bytes);
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
  ::close(c.fd);  // leaves the epoll set with it
  c.fd = -1;
  c.watched = 0;
  c.phase = Connection::Phase::kClosed;
  closed_ids.push_back(c.id);
  if (c.rejected) {
    --rejecting_count;
    return;
  }
  --open_count;
  if (const auto it = per_client.find(c.peer); it != per_client.end() && --it->second == 0) {
    per_client.erase(it);
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
    const std::string bytes = SerializeResponse(
        response, {item.request.request_id, keep_open, item.request.method == "HEAD"}, &body_bytes);
    back.write_ok = SendAll(item.fd, bytes, std::max(options.body_timeout_ms, kMinWriteTimeoutMs));
    back.keep_open = keep_open && back.write_ok;
    Log(item.request.request_id, item.request.method, item.request.path, response.status,
        body_bytes, item.start);
  } catch (const std::exception&) {
    back.write_ok = false;  // out of memory while answering: drop the connection
  }
  bool wake = false;
  {
    std::lock_guard<std::mutex> lock(mu);
    wake = handbacks.empty();  // else a wake-up for the earlier ones is pending
    handbacks.push_back(back);
  }
  if (wake) Wake();
}

Response Server::Impl::CallHandler(Request& request) {
  try {
    Response response = handler(request);
    if (response.status < 200 || response.status > 599) {
      return ErrorResponse(500, "internal",
                           "handler returned invalid status " + std::to_string(response.status));
    }
    return response;
  } catch (const std::exception& e) {
    // Deliberately not echoing what() to the client: it may carry internals. The log has it.
    LogError(request, e.what());
  } catch (...) {
    LogError(request, "an exception that is not a std::exception");
  }
  return ErrorResponse(500, "internal", "internal server error");
}

void Server::Impl::LogError(const Request& request, std::string_view what) {
  std::string line = IsoTime(std::chrono::system_clock::now()) + " " +
                     LogField(request.request_id) + " " + LogField(request.method) + " " +
                     LogField(request.path) + " handler failed: ";
  // One line whatever the message holds.
  for (const char c : what) line.push_back(c == '\n' || c == '\r' ? ' ' : c);
  WriteLogLine(options.error_log, std::move(line));
}

void Server::Impl::WriteLogLine(const std::function<void(const std::string&)>& sink,
                                std::string line) {
  std::lock_guard<std::mutex> lock(log_mu);  // the sink need not be thread-safe
  try {
    if (sink) {
      sink(line);
    } else {
      line.push_back('\n');
      std::fwrite(line.data(), 1, line.size(), stderr);
    }
  } catch (...) {
    // A failing log sink must not take the server down.
  }
}

// ---- shared ----

std::string Server::Impl::RequestIdFor(const Request& request) {
  if (const auto id = request.header("X-Request-Id"); id && IsPrintableId(*id)) {
    return std::string(*id);
  }
  // "<prefix>-" and the request number as 12 (or more) lower-case hex digits.
  std::uint64_t number = ++request_counter;
  char digits[16];
  int count = 0;
  do {
    digits[count++] = "0123456789abcdef"[number & 15];
    number >>= 4;
  } while (number != 0);
  std::string id = id_prefix;
  id.reserve(id.size() + 1 + static_cast<std::size_t>(std::max(count, 12)));
  id += '-';
  id.append(static_cast<std::size_t>(std::max(12 - count, 0)), '0');
  while (count > 0) id += digits[--count];
  return id;
}

void Server::Impl::Log(const std::string& request_id, std::string_view method,
                       std::string_view path, int status, std::size_t body_bytes,
                       Clock::time_point start) {
  const auto ms = std::chrono::duration_cast<milliseconds>(Clock::now() - start).count();
  std::string line = IsoTime(std::chrono::system_clock::now()) + " " + LogField(request_id) + " " +
                     LogField(method) + " " + LogField(path) + " " + std::to_string(status) + " " +
                     std::to_string(body_bytes) + " " + std::to_string(ms) + "ms";
  if (!options.access_log && t_on_io_thread) {
    // Written with the rest of this loop iteration's lines (FlushIoLog): one write per batch.
    io_log += line;
    io_log += '\n';
    return;
  }
  WriteLogLine(options.access_log, std::move(line));
}

void Server::Impl::FlushIoLog() {
  if (io_log.empty()) return;
  std::lock_guard<std::mutex> lock(log_mu);
  std::fwrite(io_log.data(), 1, io_log.size(), stderr);
  io_log.clear();
}

// ---- Server ----

std::size_t RaiseOpenFileLimit(std::size_t wanted) {
  rlimit limit{};
  if (::getrlimit(RLIMIT_NOFILE, &limit) != 0) return 0;
  if (limit.rlim_cur != RLIM_INFINITY && limit.rlim_cur < wanted) {
    const rlim_t target = limit.rlim_max == RLIM_INFINITY
                              ? static_cast<rlim_t>(wanted)
                              : std::min<rlim_t>(limit.rlim_max, static_cast<rlim_t>(wanted));
    rlimit raised = limit;
    raised.rlim_cur = target;
    if (target > limit.rlim_cur && ::setrlimit(RLIMIT_NOFILE, &raised) == 0) limit = raised;
  }
  return limit.rlim_cur == RLIM_INFINITY ? std::numeric_limits<std::size_t>::max()
                                         : static_cast<std::size_t>(limit.rlim_cur);
}

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
  ::close(impl_->epoll_fd);
  impl_->epoll_fd = -1;
}

}  // namespace softgrasp::http
