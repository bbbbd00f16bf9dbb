// Holds many slow HTTP clients open against a server and measures how fast a health check on a
// fresh connection is answered meanwhile. Prints one JSON object. Used by scripts/bench-http.sh to
// compare softgrasp-server with nginx in the same run (docs/performance.md).
//
//   http_slow_clients --port P [--host 127.0.0.1] [--path /healthz] [--slow 1000]
//                     [--idle 0] [--seconds 5] [--probe-interval-ms 100]
//                     [--line-interval-ms 1000]
//
// Each slow client sends a request line, then one more header line every --line-interval-ms
// (staggered across clients), and never ends its header block: the classic "slowloris" pattern.
// Slow clients that get any answer or are closed by the server are counted as `slow_answered`.
// Idle clients connect and send nothing.

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

struct Options {
  std::string host = "127.0.0.1";
  int port = 0;
  std::string path = "/healthz";
  int slow = 1000;
  int idle = 0;
  double seconds = 5.0;
  int probe_interval_ms = 100;
  int line_interval_ms = 1000;
};

[[noreturn]] void Usage(const char* message) {
  std::fprintf(stderr,
               "http_slow_clients: %s\nusage: http_slow_clients --port P [--host H] [--path P] "
               "[--slow N] [--idle N] [--seconds S] [--probe-interval-ms MS] "
               "[--line-interval-ms MS]\n",
               message);
  std::exit(2);
}

Options Parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if (i + 1 >= argc) Usage(("missing value for " + flag).c_str());
    const char* value = argv[++i];
    if (flag == "--host") {
      o.host = value;
    } else if (flag == "--port") {
      o.port = std::atoi(value);
    } else if (flag == "--path") {
      o.path = value;
    } else if (flag == "--slow") {
      o.slow = std::atoi(value);
    } else if (flag == "--idle") {
      o.idle = std::atoi(value);
    } else if (flag == "--seconds") {
      o.seconds = std::atof(value);
    } else if (flag == "--probe-interval-ms") {
      o.probe_interval_ms = std::atoi(value);
    } else if (flag == "--line-interval-ms") {
      o.line_interval_ms = std::atoi(value);
    } else {
      Usage(("unknown flag " + flag).c_str());
    }
  }
  if (o.port <= 0 || o.port > 65535) Usage("--port must be in [1, 65535]");
  if (o.slow < 0 || o.slow > 100000) Usage("--slow must be in [0, 100000]");
  if (o.idle < 0 || o.idle > 100000) Usage("--idle must be in [0, 100000]");
  if (!(o.seconds > 0 && o.seconds <= 3600)) Usage("--seconds must be in (0, 3600]");
  if (o.probe_interval_ms < 1 || o.line_interval_ms < 1) Usage("intervals must be >= 1 ms");
  return o;
}

int Connect(const Options& o) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return -1;
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(o.port));
  if (::inet_pton(AF_INET, o.host.c_str(), &addr.sin_addr) != 1 ||
      ::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
    ::close(fd);
    return -1;
  }
  const int one = 1;
  ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  return fd;
}

bool SendAll(int fd, const std::string& bytes) {
  std::size_t sent = 0;
  while (sent < bytes.size()) {
    const ssize_t n = ::send(fd, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) return false;
    sent += static_cast<std::size_t>(n);
  }
  return true;
}

/// One health check on a fresh connection: milliseconds until the whole status line and header
/// block arrived with a 200, or a negative value on failure (refused, error status, 2 s timeout).
double Probe(const Options& o) {
  const auto start = Clock::now();
  const int fd = Connect(o);
  if (fd < 0) return -1;
  const std::string request =
      "GET " + o.path + " HTTP/1.1\r\nHost: bench\r\nConnection: close\r\n\r\n";
  std::string got;
  bool ok = SendAll(fd, request);
  while (ok && got.find("\r\n\r\n") == std::string::npos) {
    pollfd p{fd, POLLIN, 0};
    const auto left = milliseconds(2000) - (Clock::now() - start);
    if (left <= milliseconds(0) ||
        ::poll(&p, 1, static_cast<int>(std::chrono::duration_cast<milliseconds>(left).count())) <=
            0) {
      ok = false;
      break;
    }
    char buf[4096];
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n <= 0) {
      ok = false;
      break;
    }
    got.append(buf, static_cast<std::size_t>(n));
  }
  ::close(fd);
  if (!ok || got.compare(0, 12, "HTTP/1.1 200") != 0) return -1;
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

double Percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  const auto index = static_cast<std::size_t>(q * static_cast<double>(values.size() - 1) + 0.5);
  return values[std::min(index, values.size() - 1)];
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = Parse(argc, argv);
  rlimit limit{};
  if (::getrlimit(RLIMIT_NOFILE, &limit) == 0 && limit.rlim_cur < limit.rlim_max) {
    limit.rlim_cur = limit.rlim_max;
    ::setrlimit(RLIMIT_NOFILE, &limit);
  }

  struct Slow {
    int fd = -1;
    Clock::time_point next_line;
    bool answered = false;  ///< got bytes or EOF from the server
  };
  std::vector<Slow> slow;
  int connect_failures = 0;
  const auto opened_at = Clock::now();
  for (int i = 0; i < o.slow; ++i) {
    Slow s;
    s.fd = Connect(o);
    if (s.fd < 0 || !SendAll(s.fd, "GET /slow HTTP/1.1\r\nHost: bench\r\n")) {
      if (s.fd >= 0) ::close(s.fd);
      ++connect_failures;
      continue;
    }
    s.next_line = opened_at + milliseconds(o.line_interval_ms * i / std::max(o.slow, 1));
    slow.push_back(s);
  }

  std::vector<int> idle;
  for (int i = 0; i < o.idle; ++i) {
    const int fd = Connect(o);
    if (fd < 0) {
      ++connect_failures;
    } else {
      idle.push_back(fd);
    }
  }

  std::vector<double> latencies_ms;
  int probe_failures = 0;
  int lines_sent = 0;
  const auto end = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                      std::chrono::duration<double>(o.seconds));
  auto next_probe = Clock::now();
  while (Clock::now() < end) {
    const auto now = Clock::now();
    for (Slow& s : slow) {
      if (s.answered || now < s.next_line) continue;
      if (!SendAll(s.fd, "X-Slow: " + std::to_string(lines_sent) + "\r\n")) s.answered = true;
      ++lines_sent;
      s.next_line += milliseconds(o.line_interval_ms);
    }
    if (now >= next_probe) {
      const double ms = Probe(o);
      if (ms < 0) {
        ++probe_failures;
      } else {
        latencies_ms.push_back(ms);
      }
      next_probe = now + milliseconds(o.probe_interval_ms);
    }
    std::this_thread::sleep_for(milliseconds(5));
  }
  // Any answer (an early 408 or 503) or EOF on a slow socket counts it as answered.
  std::vector<pollfd> fds;
  for (const Slow& s : slow) fds.push_back({s.fd, POLLIN, 0});
  if (!fds.empty()) ::poll(fds.data(), fds.size(), 0);
  int slow_answered = 0;
  for (std::size_t i = 0; i < slow.size(); ++i) {
    if (slow[i].answered || fds[i].revents != 0) ++slow_answered;
    ::close(slow[i].fd);
  }
  for (const int fd : idle) ::close(fd);

  std::printf(
      "{\"slow_clients\": %d, \"idle_clients\": %zu, \"connect_failures\": %d, "
      "\"slow_answered\": %d, "
      "\"header_lines_sent\": %d, \"probes_ok\": %zu, \"probes_failed\": %d, "
      "\"probe_ms\": {\"p50\": %.3f, \"p99\": %.3f, \"max\": %.3f}}\n",
      static_cast<int>(slow.size()), idle.size(), connect_failures, slow_answered, lines_sent,
      latencies_ms.size(), probe_failures, Percentile(latencies_ms, 0.5),
      Percentile(latencies_ms, 0.99),
      latencies_ms.empty() ? 0.0 : *std::max_element(latencies_ms.begin(), latencies_ms.end()));
  return probe_failures == 0 ? 0 : 1;
}
