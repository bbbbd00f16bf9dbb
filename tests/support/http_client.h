#pragma once
/// A small blocking HTTP/1.1 client over a plain POSIX socket, for tests that talk to a real server
/// on the loopback interface: raw bytes out (so a test can also send broken or partial requests),
/// responses framed by Content-Length in, and whether the server closed the connection.

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

#include "service/http/message.h"

namespace softgrasp::testing {

struct HttpReply {
  int status = 0;  ///< 0: no response came
  http::Headers headers;
  std::string body;
  std::optional<std::string_view> header(std::string_view name) const {
    return http::FindHeader(headers, name);
  }
  nlohmann::json json() const { return nlohmann::json::parse(body); }
};

struct HttpClientOptions {
  std::string host = "127.0.0.1";         ///< an IPv4 or IPv6 address ("::1")
  const char* source_ip = nullptr;        ///< connect from this (IPv4 loopback) address when set
  std::chrono::seconds read_timeout{20};  ///< no read ever blocks longer than this
};

/// One connection; several requests may go over it (keep-alive, pipelining).
class HttpClient {
 public:
  /// Connects to host:port. Throws std::runtime_error when the connection is refused.
  explicit HttpClient(uint16_t port, const HttpClientOptions& options = {}) {
    sockaddr_storage addr{};
    socklen_t addr_len = 0;
    auto* v4 = reinterpret_cast<sockaddr_in*>(&addr);
    auto* v6 = reinterpret_cast<sockaddr_in6*>(&addr);
    if (::inet_pton(AF_INET, options.host.c_str(), &v4->sin_addr) == 1) {
      v4->sin_family = AF_INET;
      v4->sin_port = htons(port);
      addr_len = sizeof *v4;
    } else if (::inet_pton(AF_INET6, options.host.c_str(), &v6->sin6_addr) == 1) {
      v6->sin6_family = AF_INET6;
      v6->sin6_port = htons(port);
      addr_len = sizeof *v6;
    } else {
      throw std::runtime_error("not an IP address: " + options.host);
    }
    fd_ = ::socket(addr.ss_family, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd_ < 0) throw std::runtime_error("socket");
    timeval timeout{static_cast<time_t>(options.read_timeout.count()), 0};
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
    if (options.source_ip != nullptr) {
      sockaddr_in source{};
      source.sin_family = AF_INET;
      ::inet_pton(AF_INET, options.source_ip, &source.sin_addr);
      if (::bind(fd_, reinterpret_cast<const sockaddr*>(&source), sizeof source) != 0) {
        Close();
        throw std::runtime_error("bind to the source address failed");
      }
    }
    if (::connect(fd_, reinterpret_cast<const sockaddr*>(&addr), addr_len) != 0) {
      Close();
      throw std::runtime_error("connect failed");
    }
  }
  ~HttpClient() { Close(); }
  HttpClient(const HttpClient&) = delete;
  HttpClient& operator=(const HttpClient&) = delete;

  int fd() const { return fd_; }
  void Close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

  /// Sends all of `bytes`; throws when the server stops taking them.
  void Send(std::string_view bytes) {
    if (SendWhileAccepted(bytes) != bytes.size()) throw std::runtime_error("send failed");
  }

  /// Sends as much of `bytes` as the server takes (it may answer early, e.g. 413, and close);
  /// returns how many bytes went out.
  std::size_t SendWhileAccepted(std::string_view bytes) {
    std::size_t sent = 0;
    while (sent < bytes.size()) {
      const ssize_t n = ::send(fd_, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
      if (n <= 0) break;
      sent += static_cast<std::size_t>(n);
    }
    return sent;
  }

  /// Reads one response; its body by Content-Length unless `head` (the answer to a HEAD
  /// request). nullopt when the connection closes or the read times out first.
  std::optional<HttpReply> Read(bool head = false) {
    std::size_t end;
    while ((end = buffer_.find("\r\n\r\n")) == std::string::npos) {
      if (!Fill()) return std::nullopt;
    }
    HttpReply reply;
    const std::string block = buffer_.substr(0, end);
    buffer_.erase(0, end + 4);
    if (block.size() < 12) return std::nullopt;
    reply.status = std::stoi(block.substr(9, 3));
    std::size_t line = block.find("\r\n");
    while (line != std::string::npos) {
      const std::size_t next = block.find("\r\n", line + 2);
      const std::string field =
          block.substr(line + 2, next == std::string::npos ? std::string::npos : next - line - 2);
      const std::size_t colon = field.find(':');
      if (colon != std::string::npos) {
        std::string value = field.substr(colon + 1);
        while (!value.empty() && value.front() == ' ') value.erase(0, 1);
        reply.headers.emplace_back(field.substr(0, colon), value);
      }
      line = next;
    }
    std::size_t length = 0;
    if (const auto cl = reply.header("Content-Length"); cl && !head) {
      length = std::stoul(std::string(*cl));
    }
    while (buffer_.size() < length) {
      if (!Fill()) return std::nullopt;
    }
    reply.body = buffer_.substr(0, length);
    buffer_.erase(0, length);
    return reply;
  }

  /// Reads everything until the server closes (true) or the read times out (false); what came
  /// after the last response read goes to `rest`.
  bool ReadUntilClosed(std::string* rest = nullptr) {
    while (Fill()) {
    }
    if (rest != nullptr) *rest = buffer_;
    return closed_;
  }

 private:
  bool Fill() {
    char chunk[65536];
    const ssize_t n = ::recv(fd_, chunk, sizeof chunk, 0);
    if (n <= 0) {
      closed_ = n == 0 || errno == ECONNRESET;
      return false;
    }
    buffer_.append(chunk, static_cast<std::size_t>(n));
    return true;
  }

  int fd_ = -1;
  std::string buffer_;
  bool closed_ = false;
};

/// One request on a connection of its own: sends `raw` (as much as the server takes), reads one
/// response (without a body when `raw` is a HEAD request) and closes. A reply with status 0 when
/// no complete response came.
inline HttpReply HttpExchange(uint16_t port, const std::string& raw,
                              const HttpClientOptions& options = {}) {
  HttpClient client(port, options);
  client.SendWhileAccepted(raw);
  const bool head = raw.rfind("HEAD ", 0) == 0;
  return client.Read(head).value_or(HttpReply{});
}

}  // namespace softgrasp::testing
