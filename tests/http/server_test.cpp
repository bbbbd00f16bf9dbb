#include "service/http/server.h"

#include <gtest/gtest.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <future>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "tests/support/http_client.h"

namespace softgrasp::http {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

using softgrasp::testing::HttpClient;
using softgrasp::testing::HttpReply;

bool AllDigits(const std::string& s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
}

/// Splits an access-log line "<ISO time> <id> <method> <path> <status> <bytes> <ms>ms" into its
/// seven fields (the last without "ms"); nullopt when the line does not have that shape.
std::optional<std::vector<std::string>> ParseLogLine(const std::string& line) {
  std::vector<std::string> fields;
  for (std::size_t start = 0; start <= line.size();) {
    const std::size_t end = std::min(line.find(' ', start), line.size());
    fields.push_back(line.substr(start, end - start));
    start = end + 1;
  }
  if (fields.size() != 7) return std::nullopt;
  const std::string shape = "dddd-dd-ddTdd:dd:dd.dddZ";
  const std::string& time = fields[0];
  if (time.size() != shape.size()) return std::nullopt;
  for (std::size_t i = 0; i < shape.size(); ++i) {
    const bool ok = shape[i] == 'd' ? (time[i] >= '0' && time[i] <= '9') : time[i] == shape[i];
    if (!ok) return std::nullopt;
  }
  std::string& ms = fields[6];
  if (ms.size() < 3 || ms.substr(ms.size() - 2) != "ms") return std::nullopt;
  ms.resize(ms.size() - 2);
  if (fields[4].size() != 3 || !AllDigits(fields[4]) || !AllDigits(fields[5]) || !AllDigits(ms)) {
    return std::nullopt;
  }
  return fields;
}

std::string Get(const std::string& path, const std::string& extra_headers = "") {
  return "GET " + path + " HTTP/1.1\r\nHost: test\r\n" + extra_headers + "\r\n";
}

/// Collects access-log lines from any thread.
class LogSink {
 public:
  std::function<void(const std::string&)> Callback() {
    return [this](const std::string& line) {
      std::lock_guard<std::mutex> lock(mu_);
      lines_.push_back(line);
      cv_.notify_all();
    };
  }
  /// Waits (up to 5 s) until at least `n` lines arrived; returns a copy.
  std::vector<std::string> WaitFor(std::size_t n) {
    std::unique_lock<std::mutex> lock(mu_);
    cv_.wait_for(lock, 5s, [&] { return lines_.size() >= n; });
    return lines_;
  }

 private:
  std::mutex mu_;
  std::condition_variable cv_;
  std::vector<std::string> lines_;
};

/// One-shot gate a handler can block on.
class Gate {
 public:
  void Open() {
    std::lock_guard<std::mutex> lock(mu_);
    open_ = true;
    cv_.notify_all();
  }
  void Wait() {
    std::unique_lock<std::mutex> lock(mu_);
    cv_.wait_for(lock, 10s, [&] { return open_; });
  }
  bool WaitFor(std::chrono::milliseconds timeout) {
    std::unique_lock<std::mutex> lock(mu_);
    return cv_.wait_for(lock, timeout, [&] { return open_; });
  }

 private:
  std::mutex mu_;
  std::condition_variable cv_;
  bool open_ = false;
};

class HttpServer : public ::testing::Test {
 protected:
  ServerOptions Options() {
    ServerOptions options;
    options.host = "127.0.0.1";
    options.port = 0;
    options.access_log = log_.Callback();
    return options;
  }

  /// Echoes method and path; "/boom" throws a std::exception, "/boom-other" something else;
  /// "/block" waits for `release_`; "/slow" sleeps.
  Response Handle(Request& request) {
    ++handled_;
    if (request.path == "/boom") throw std::runtime_error("secret internals");
    if (request.path == "/boom-other") throw 42;
    if (request.path == "/block") {
      entered_.Open();
      release_.Wait();
    }
    if (request.path == "/slow") {
      entered_.Open();
      std::this_thread::sleep_for(300ms);
    }
    if (request.path == "/echo") return Response::Bytes(200, "text/plain", request.body);
    nlohmann::json body = {{"method", request.method}, {"path", request.path}};
    return Response::Json(200, body.dump());
  }

  std::unique_ptr<Server> StartServer(ServerOptions options) {
    auto server = std::make_unique<Server>(std::move(options),
                                           [this](Request& request) { return Handle(request); });
    server->Start();
    EXPECT_NE(server->port(), 0);
    return server;
  }

  LogSink log_;
  std::atomic<int> handled_{0};
  Gate entered_;
  Gate release_;
};

TEST_F(HttpServer, KeepAliveServesTwoRequestsOnOneConnection) {
  auto server = StartServer(Options());
  HttpClient client(server->port());
  for (const char* path : {"/first", "/second"}) {
    client.Send(Get(path));
    const auto response = client.Read();
    ASSERT_TRUE(response.has_value()) << path;
    EXPECT_EQ(response->status, 200);
    EXPECT_EQ(response->json()["path"], path);
    EXPECT_EQ(response->header("Connection"), "keep-alive");
    EXPECT_EQ(response->header("Content-Length"), std::to_string(response->body.size()));
    EXPECT_TRUE(response->header("Date").has_value());
    EXPECT_TRUE(response->header("X-Request-Id").has_value());
    EXPECT_EQ(response->header("Content-Type"), "application/json");
  }
}

TEST_F(HttpServer, ConnectionCloseIsHonoured) {
  auto server = StartServer(Options());
  HttpClient client(server->port());
  client.Send(Get("/x", "Connection: close\r\n"));
  const auto response = client.Read();
  ASSERT_TRUE(response.has_value());
  EXPECT_EQ(response->header("Connection"), "close");
  EXPECT_TRUE(client.ReadUntilClosed());
}

TEST_F(HttpServer, PipelinedRequestsAreAnsweredInOrder) {
  ServerOptions options = Options();
  options.num_workers = 4;
  auto server = StartServer(options);
  HttpClient client(server->port());
  client.Send(Get("/slow") + Get("/b") +
              "POST /echo HTTP/1.1\r\nHost: t\r\nContent-Length: 3\r\n\r\nxyz" +
              Get("/d", "Connection: close\r\n"));
  const auto a = client.Read();
  const auto b = client.Read();
  const auto c = client.Read();
  const auto d = client.Read();
  ASSERT_TRUE(a && b && c && d);
  EXPECT_EQ(a->json()["path"], "/slow");
  EXPECT_EQ(b->json()["path"], "/b");
  EXPECT_EQ(c->body, "xyz");
  EXPECT_EQ(d->json()["path"], "/d");
  EXPECT_TRUE(client.ReadUntilClosed());
}

TEST_F(HttpServer, HandlerExceptionIs500AndServingGoesOn) {
  ServerOptions options = Options();
  LogSink errors;
  options.error_log = errors.Callback();
  auto server = StartServer(options);
  HttpClient client(server->port());
  client.Send(Get("/boom", "X-Request-Id: boom-1\r\n"));
  const auto failed = client.Read();
  ASSERT_TRUE(failed.has_value());
  EXPECT_EQ(failed->status, 500);
  EXPECT_EQ(failed->json()["error"]["code"], "internal");
  EXPECT_EQ(failed->body.find("secret"), std::string::npos);
  // The message stays out of the answer but is in the error log, with the request id.
  const auto error_lines = errors.WaitFor(1);
  ASSERT_EQ(error_lines.size(), 1u);
  EXPECT_NE(error_lines[0].find(" boom-1 GET /boom handler failed: secret internals"),
            std::string::npos)
      << error_lines[0];
  client.Send(Get("/after"));
  const auto after = client.Read();
  ASSERT_TRUE(after.has_value());
  EXPECT_EQ(after->status, 200);
  HttpClient other(server->port());
  other.Send(Get("/other"));
  ASSERT_TRUE(other.Read().has_value());
}

TEST_F(HttpServer, HandlerExceptionOnTheIoThreadIsLoggedWithItsRequestIdToo) {
  ServerOptions options = Options();
  LogSink errors;
  options.error_log = errors.Callback();
  // Inline routes run on the I/O thread: what they throw is caught and logged the same way.
  options.answer_inline = [](const Request& request) {
    return request.path == "/boom" || request.path == "/boom-other";
  };
  auto server = StartServer(options);
  HttpClient client(server->port());
  client.Send(Get("/boom", "X-Request-Id: inline-1\r\n") +
              Get("/boom-other", "X-Request-Id: inline-2\r\n"));
  for (int i = 0; i < 2; ++i) {
    const auto failed = client.Read();
    ASSERT_TRUE(failed.has_value()) << i;
    EXPECT_EQ(failed->status, 500);
    EXPECT_EQ(failed->json()["error"]["code"], "internal");
    EXPECT_EQ(failed->body.find("secret"), std::string::npos);
  }
  const auto error_lines = errors.WaitFor(2);
  ASSERT_EQ(error_lines.size(), 2u);
  EXPECT_NE(error_lines[0].find(" inline-1 GET /boom handler failed: secret internals"),
            std::string::npos)
      << error_lines[0];
  EXPECT_NE(error_lines[1].find(" inline-2 GET /boom-other handler failed: an exception that is "
                                "not a std::exception"),
            std::string::npos)
      << error_lines[1];
  client.Send(Get("/after"));
  const auto after = client.Read();
  ASSERT_TRUE(after.has_value());
  EXPECT_EQ(after->status, 200);
}

TEST_F(HttpServer, SlowClientGets408AndIsClosed) {
  ServerOptions options = Options();
  options.header_timeout_ms = 200;
  auto server = StartServer(options);
  HttpClient client(server->port());
  const auto start = Clock::now();
  client.Send("GET /slowloris HTTP/1.1\r\nHost: t\r\n");  // never finished
  const auto response = client.Read();
  ASSERT_TRUE(response.has_value());
  EXPECT_GE(Clock::now() - start, 150ms);
  EXPECT_EQ(response->status, 408);
  EXPECT_EQ(response->json()["error"]["code"], "request_timeout");
  EXPECT_NE(response->json()["error"]["message"].get<std::string>().find("header"),
            std::string::npos);
  EXPECT_EQ(response->header("Connection"), "close");
  EXPECT_TRUE(client.ReadUntilClosed());
  const auto lines = log_.WaitFor(1);
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_NE(lines[0].find(" - - 408 "), std::string::npos) << lines[0];
}

TEST_F(HttpServer, IdleKeepAliveConnectionIsClosedSilently) {
  ServerOptions options = Options();
  options.keep_alive_timeout_ms = 150;
  auto server = StartServer(options);
  HttpClient client(server->port());
  client.Send(Get("/once"));
  ASSERT_TRUE(client.Read().has_value());
  const auto start = Clock::now();
  std::string rest;
  EXPECT_TRUE(client.ReadUntilClosed(&rest));
  EXPECT_TRUE(rest.empty()) << rest;
  EXPECT_GE(Clock::now() - start, 100ms);
  EXPECT_EQ(log_.WaitFor(1).size(), 1u);  // no line for the silent close
}

TEST_F(HttpServer, FullQueueIs503WithRetryAfterWithoutRunningTheHandler) {
  ServerOptions options = Options();
  options.num_workers = 1;
  options.queue_capacity = 1;
  options.retry_after_s = 7;
  auto server = StartServer(options);

  HttpClient busy(server->port());
  busy.Send(Get("/block"));
  ASSERT_TRUE(entered_.WaitFor(5s));  // the only worker is now blocked

  // One of these is queued, the other finds the queue full.
  HttpClient b(server->port());
  HttpClient c(server->port());
  b.Send(Get("/queued"));
  c.Send(Get("/queued"));
  pollfd fds[2] = {{b.fd(), POLLIN, 0}, {c.fd(), POLLIN, 0}};
  ASSERT_EQ(::poll(fds, 2, 5000), 1);  // exactly one answer while the worker is blocked
  HttpClient& rejected = (fds[0].revents != 0) ? b : c;
  HttpClient& queued = (fds[0].revents != 0) ? c : b;
  const auto unavailable = rejected.Read();
  ASSERT_TRUE(unavailable.has_value());
  EXPECT_EQ(unavailable->status, 503);
  EXPECT_EQ(unavailable->header("Retry-After"), "7");
  EXPECT_EQ(unavailable->json()["error"]["code"], "service_unavailable");
  EXPECT_TRUE(rejected.ReadUntilClosed());

  release_.Open();
  const auto first = busy.Read();
  const auto second = queued.Read();
  ASSERT_TRUE(first && second);
  EXPECT_EQ(first->status, 200);
  EXPECT_EQ(second->status, 200);
  EXPECT_EQ(second->json()["path"], "/queued");
  EXPECT_EQ(log_.WaitFor(3).size(), 3u);
  EXPECT_EQ(handled_.load(), 2);  // the rejected request never reached the handler
}

TEST_F(HttpServer, ConnectionsOverTheCapGet503) {
  ServerOptions options = Options();
  options.max_connections = 1;
  auto server = StartServer(options);
  auto first = std::make_unique<HttpClient>(server->port());
  first->Send(Get("/hold"));
  ASSERT_TRUE(first->Read().has_value());  // accepted and counted

  HttpClient second(server->port());
  const auto response = second.Read();
  ASSERT_TRUE(response.has_value());
  EXPECT_EQ(response->status, 503);
  EXPECT_EQ(response->header("Retry-After"), "1");
  EXPECT_TRUE(second.ReadUntilClosed());

  first.reset();  // frees the slot
  std::optional<HttpReply> later;
  for (int attempt = 0; attempt < 50 && !(later && later->status == 200); ++attempt) {
    std::this_thread::sleep_for(20ms);
    HttpClient third(server->port());
    third.Send(Get("/later"));
    later = third.Read();
  }
  ASSERT_TRUE(later.has_value());
  EXPECT_EQ(later->status, 200);
}

TEST_F(HttpServer, HeaderLinesTrickledInGet408AtTheHeaderDeadline) {
  ServerOptions options = Options();
  options.header_timeout_ms = 300;
  options.body_timeout_ms = 60'000;
  auto server = StartServer(options);
  HttpClient client(server->port());
  const auto start = Clock::now();
  client.Send("GET /slowloris HTTP/1.1\r\n");
  // A header line every 50 ms: the connection is never silent, but the block never ends.
  pollfd answer{client.fd(), POLLIN, 0};
  for (int i = 0; i < 40 && ::poll(&answer, 1, 50) == 0; ++i) {
    client.Send("X-Keep: " + std::to_string(i) + "\r\n");
  }
  const auto response = client.Read();
  ASSERT_TRUE(response.has_value());
  EXPECT_EQ(response->status, 408);
  EXPECT_GE(Clock::now() - start, 250ms);
  EXPECT_LT(Clock::now() - start, 1500ms);  // not the body deadline
  EXPECT_NE(response->json()["error"]["message"].get<std::string>().find("header"),
            std::string::npos);
  EXPECT_EQ(handled_.load(), 0);
}

TEST_F(HttpServer, BodyHasItsOwnDeadlineAfterTheHeaders) {
  ServerOptions options = Options();
  options.header_timeout_ms = 200;
  options.body_timeout_ms = 800;
  auto server = StartServer(options);

  // Headers in time, body later than the header deadline but within the body's: served.
  HttpClient patient(server->port());
  patient.Send("POST /echo HTTP/1.1\r\nHost: t\r\nContent-Length: 10\r\n\r\nhello");
  std::this_thread::sleep_for(400ms);
  patient.Send("world");
  const auto served = patient.Read();
  ASSERT_TRUE(served.has_value());
  EXPECT_EQ(served->status, 200);
  EXPECT_EQ(served->body, "helloworld");

  // A body that stops arriving: 408 at the body deadline, naming the body.
  HttpClient stalled(server->port());
  const auto start = Clock::now();
  stalled.Send("POST /echo HTTP/1.1\r\nHost: t\r\nContent-Length: 10\r\n\r\nhel");
  const auto timed_out = stalled.Read();
  ASSERT_TRUE(timed_out.has_value());
  EXPECT_EQ(timed_out->status, 408);
  EXPECT_GE(Clock::now() - start, 700ms);
  EXPECT_NE(timed_out->json()["error"]["message"].get<std::string>().find("body"),
            std::string::npos);
  EXPECT_EQ(handled_.load(), 1);
}

TEST_F(HttpServer, PerClientCapRefusesOnlyThatAddress) {
  ServerOptions options = Options();
  options.max_connections_per_client = 2;
  auto server = StartServer(options);
  HttpClient a(server->port());
  HttpClient b(server->port());
  for (HttpClient* held : {&a, &b}) {
    held->Send(Get("/hold"));
    ASSERT_TRUE(held->Read().has_value());  // accepted and counted
  }
  HttpClient third(server->port());
  const auto refused = third.Read();
  ASSERT_TRUE(refused.has_value());
  EXPECT_EQ(refused->status, 503);
  EXPECT_NE(refused->json()["error"]["message"].get<std::string>().find("this address"),
            std::string::npos);

  // Another client address: its own budget.
  HttpClient elsewhere(server->port(), {.source_ip = "127.0.0.2"});
  elsewhere.Send(Get("/other"));
  const auto served = elsewhere.Read();
  ASSERT_TRUE(served.has_value());
  EXPECT_EQ(served->status, 200);
}

TEST_F(HttpServer, InlineRoutesAnswerWhileEveryWorkerIsBusy) {
  ServerOptions options = Options();
  options.num_workers = 1;
  options.queue_capacity = 1;
  options.answer_inline = [](const Request& request) { return request.path == "/healthz"; };
  auto server = StartServer(options);
  HttpClient busy(server->port());
  busy.Send(Get("/block"));
  ASSERT_TRUE(entered_.WaitFor(5s));  // the only worker is blocked
  HttpClient queued(server->port());
  queued.Send(Get("/queued"));  // fills the queue

  // Three health checks on one keep-alive connection, pipelined, while the worker is blocked.
  HttpClient health(server->port());
  health.Send(Get("/healthz") + Get("/healthz") + Get("/healthz"));
  for (int i = 0; i < 3; ++i) {
    const auto response = health.Read();
    ASSERT_TRUE(response.has_value());
    EXPECT_EQ(response->status, 200);
    EXPECT_EQ(response->json()["path"], "/healthz");
  }
  pollfd pending{queued.fd(), POLLIN, 0};
  EXPECT_EQ(::poll(&pending, 1, 0), 0);  // the queued request still waits for the worker

  release_.Open();
  ASSERT_TRUE(busy.Read().has_value());
  const auto later = queued.Read();
  ASSERT_TRUE(later.has_value());
  EXPECT_EQ(later->status, 200);
  EXPECT_EQ(handled_.load(), 5);
}

TEST_F(HttpServer, AThousandSlowClientsDoNotLockOthersOut) {
  constexpr int kSlowClients = 1000;
  // Client and server sockets both live in this process.
  ASSERT_GE(RaiseOpenFileLimit(2 * kSlowClients + 256), 2u * kSlowClients + 256)
      << "the open-file hard limit is too low for this test";
  ServerOptions options = Options();
  options.answer_inline = [](const Request& request) { return request.path == "/healthz"; };
  auto server = StartServer(options);

  std::vector<std::unique_ptr<HttpClient>> slow;
  for (int i = 0; i < kSlowClients; ++i) {
    slow.push_back(std::make_unique<HttpClient>(server->port()));
    slow.back()->Send("GET /never-finished HTTP/1.1\r\nHost: t\r\n");
  }
  // A header line on every slow socket now and then, with health checks on fresh connections in
  // between: each is answered, none of the slow sockets is refused.
  for (int round = 0; round < 5; ++round) {
    for (int i = 0; i < kSlowClients; ++i) {
      slow[static_cast<std::size_t>(i)]->Send("X-Round: " + std::to_string(round) + "\r\n");
    }
    HttpClient health(server->port());
    health.Send(Get("/healthz"));
    const auto response = health.Read();
    ASSERT_TRUE(response.has_value()) << "round " << round;
    EXPECT_EQ(response->status, 200);
  }
  std::vector<pollfd> fds;
  for (const auto& client : slow) fds.push_back({client->fd(), POLLIN, 0});
  EXPECT_EQ(::poll(fds.data(), fds.size(), 0), 0);  // no slow socket got an answer (no 503)
  EXPECT_EQ(handled_.load(), 5);
}

TEST_F(HttpServer, StopLetsAnInFlightRequestFinish) {
  auto server = StartServer(Options());
  HttpClient idle(server->port());
  idle.Send(Get("/warm-up"));
  ASSERT_TRUE(idle.Read().has_value());

  const uint16_t port = server->port();
  auto in_flight = std::async(std::launch::async, [port] {
    HttpClient client(port);
    client.Send(Get("/slow"));
    auto response = client.Read();
    client.ReadUntilClosed();
    return response;
  });
  ASSERT_TRUE(entered_.WaitFor(5s));
  server->Stop();  // returns once the slow answer went out

  const auto response = in_flight.get();
  ASSERT_TRUE(response.has_value());
  EXPECT_EQ(response->status, 200);
  EXPECT_EQ(response->header("Connection"), "close");
  EXPECT_TRUE(idle.ReadUntilClosed());
  EXPECT_THROW(HttpClient refused(port), std::runtime_error);  // no longer listening
  server->Stop();                                              // idempotent
}

TEST_F(HttpServer, AccessLogHasOneLinePerAnswerAndNoHeaderValues) {
  auto server = StartServer(Options());
  HttpClient client(server->port());
  client.Send(Get("/v1/a%20b?token=secret-query",
                  "X-Request-Id: req-42\r\nAuthorization: Bearer secret-token\r\n"));
  const auto response = client.Read();
  ASSERT_TRUE(response.has_value());
  EXPECT_EQ(response->header("X-Request-Id"), "req-42");
  client.Send("BROKEN\r\n\r\n");
  ASSERT_TRUE(client.Read().has_value());

  const auto lines = log_.WaitFor(2);
  ASSERT_EQ(lines.size(), 2u);
  const auto first = ParseLogLine(lines[0]);
  ASSERT_TRUE(first.has_value()) << lines[0];
  EXPECT_EQ((*first)[1], "req-42");
  EXPECT_EQ((*first)[2], "GET");
  EXPECT_EQ((*first)[3], "/v1/a%20b");  // decoded path, re-escaped; no query string
  EXPECT_EQ((*first)[4], "200");
  EXPECT_EQ((*first)[5], std::to_string(response->body.size()));
  const auto second = ParseLogLine(lines[1]);
  ASSERT_TRUE(second.has_value()) << lines[1];
  EXPECT_EQ((*second)[2], "-");
  EXPECT_EQ((*second)[3], "-");
  EXPECT_EQ((*second)[4], "400");
  for (const auto& line : lines) {
    EXPECT_EQ(line.find("secret"), std::string::npos) << line;
  }
}

TEST_F(HttpServer, RequestIdIsGeneratedWhenMissingOrUnfit) {
  auto server = StartServer(Options());
  HttpClient client(server->port());
  client.Send(Get("/a") + Get("/b", "X-Request-Id: " + std::string(200, 'x') + "\r\n"));
  const auto a = client.Read();
  const auto b = client.Read();
  ASSERT_TRUE(a && b);
  const std::string id_a(*a->header("X-Request-Id"));
  const std::string id_b(*b->header("X-Request-Id"));
  EXPECT_FALSE(id_a.empty());
  EXPECT_NE(id_a, id_b);
  EXPECT_LT(id_b.size(), 64u);
}

TEST_F(HttpServer, HeadGetsHeadersWithoutBody) {
  auto server = StartServer(Options());
  HttpClient client(server->port());
  client.Send("HEAD /thing HTTP/1.1\r\nHost: t\r\n\r\n");
  const auto head = client.Read(/*head=*/true);
  ASSERT_TRUE(head.has_value());
  EXPECT_EQ(head->status, 200);
  EXPECT_NE(head->header("Content-Length"), "0");  // the length a GET would have
  // The next response must start right away: no stray body bytes in between.
  client.Send(Get("/next"));
  const auto next = client.Read();
  ASSERT_TRUE(next.has_value());
  EXPECT_EQ(next->json()["path"], "/next");
  const auto lines = log_.WaitFor(2);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_NE(lines[0].find(" HEAD /thing 200 0 "), std::string::npos) << lines[0];
}

TEST_F(HttpServer, ExpectContinueGets100First) {
  auto server = StartServer(Options());
  HttpClient client(server->port());
  client.Send(
      "POST /echo HTTP/1.1\r\nHost: t\r\nExpect: 100-continue\r\nContent-Length: 5\r\n\r\n");
  const auto interim = client.Read();
  ASSERT_TRUE(interim.has_value());
  EXPECT_EQ(interim->status, 100);
  client.Send("hello");
  const auto response = client.Read();
  ASSERT_TRUE(response.has_value());
  EXPECT_EQ(response->status, 200);
  EXPECT_EQ(response->body, "hello");
}

TEST_F(HttpServer, ProtocolErrorsAreJsonAndClose) {
  ServerOptions options = Options();
  options.limits.max_body_bytes = 100;
  auto server = StartServer(options);
  {
    HttpClient client(server->port());
    client.Send("POST /x HTTP/1.1\r\nHost: t\r\nContent-Length: 1000\r\n\r\n");  // body not sent
    const auto response = client.Read();
    ASSERT_TRUE(response.has_value());
    EXPECT_EQ(response->status, 413);
    EXPECT_EQ(response->json()["error"]["code"], "payload_too_large");
    EXPECT_TRUE(client.ReadUntilClosed());
  }
  {
    HttpClient client(server->port());
    client.Send("GET / HTTP/2.0\r\nHost: t\r\n\r\n" + Get("/never"));
    const auto response = client.Read();
    ASSERT_TRUE(response.has_value());
    EXPECT_EQ(response->status, 505);
    std::string rest;
    EXPECT_TRUE(client.ReadUntilClosed(&rest));
    EXPECT_TRUE(rest.empty());  // the pipelined request is not answered
  }
}

TEST_F(HttpServer, OversizedUploadGets413WhileTheClientIsStillSending) {
  ServerOptions options = Options();
  options.limits.max_body_bytes = 1000;
  auto server = StartServer(options);
  HttpClient client(server->port());
  const std::string body(4 << 20, 'x');
  client.Send("POST /echo HTTP/1.1\r\nHost: t\r\nContent-Length: " + std::to_string(body.size()) +
              "\r\n\r\n");
  auto uploader = std::async(std::launch::async, [&] {
    std::string_view rest = body;
    while (!rest.empty()) {  // stops when the server closes
      const ssize_t n = ::send(client.fd(), rest.data(), rest.size(), MSG_NOSIGNAL);
      if (n <= 0) return;
      rest.remove_prefix(static_cast<std::size_t>(n));
    }
  });
  const auto response = client.Read();
  uploader.wait();
  ASSERT_TRUE(response.has_value());
  EXPECT_EQ(response->status, 413);
  EXPECT_EQ(handled_.load(), 0);
}

TEST_F(HttpServer, StartFailsWhenThePortIsTaken) {
  auto server = StartServer(Options());
  ServerOptions options = Options();
  options.port = server->port();
  Server second(options, [](Request&) { return Response{}; });
  EXPECT_THROW(second.Start(), std::runtime_error);
  second.Stop();  // harmless
}

TEST_F(HttpServer, ListensOnIpv6) {
  ServerOptions options = Options();
  options.host = "::1";
  Server server(options, [](Request&) { return Response::Json(200, "{}"); });
  try {
    server.Start();
  } catch (const std::runtime_error& e) {
    GTEST_SKIP() << "no IPv6 loopback here: " << e.what();
  }
  HttpClient client(server.port(), {.host = "::1"});
  client.Send(Get("/v6", "Connection: close\r\n"));
  const auto response = client.Read();
  ASSERT_TRUE(response.has_value());
  EXPECT_EQ(response->status, 200);
}

TEST_F(HttpServer, DestructorStopsARunningServer) {
  uint16_t port = 0;
  {
    auto server = StartServer(Options());
    port = server->port();
    HttpClient client(port);
    client.Send(Get("/x"));
    ASSERT_TRUE(client.Read().has_value());
  }
  EXPECT_THROW(HttpClient refused(port), std::runtime_error);
}

}  // namespace
}  // namespace softgrasp::http
