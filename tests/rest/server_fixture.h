#pragma once
// Starts the real softgrasp server (router + http::Server) on 127.0.0.1:0 and talks HTTP to it
// over a real socket. One request per connection.

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <fstream>
#include <functional>
#include <iterator>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "service/http/message.h"
#include "service/http/server.h"
#include "service/rest/api.h"
#include "service/rest/config.h"
#include "tests/support/test_data.h"

namespace softgrasp::rest::testing {

struct HttpReply {
  int status = 0;
  http::Headers headers;
  std::string body;
  std::optional<std::string_view> header(std::string_view name) const {
    return http::FindHeader(headers, name);
  }
};

inline std::string ReadFileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

using softgrasp::testing::TestData;  // tests/data, the real frames kept with the tests

/// Sends raw bytes, reads one response (Content-Length framed) and closes.
inline HttpReply Exchange(uint16_t port, const std::string& raw) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) throw std::runtime_error("socket");
  timeval timeout{20, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port);
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    ::close(fd);
    throw std::runtime_error("connect");
  }
  std::size_t sent = 0;
  while (sent < raw.size()) {
    const ssize_t n = ::send(fd, raw.data() + sent, raw.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) break;  // the server may answer early (413) and close
    sent += static_cast<std::size_t>(n);
  }
  std::string in;
  char buffer[65536];
  HttpReply reply;
  std::size_t header_end = std::string::npos;
  std::size_t content_length = 0;
  for (;;) {
    const ssize_t n = ::recv(fd, buffer, sizeof buffer, 0);
    if (n <= 0) break;
    in.append(buffer, static_cast<std::size_t>(n));
    if (header_end == std::string::npos) {
      header_end = in.find("\r\n\r\n");
      if (header_end == std::string::npos) continue;
      const std::string head = in.substr(0, header_end);
      reply.status = std::stoi(head.substr(9, 3));
      std::size_t line = head.find("\r\n");
      while (line != std::string::npos) {
        const std::size_t next = head.find("\r\n", line + 2);
        const std::string field =
            head.substr(line + 2, next == std::string::npos ? std::string::npos : next - line - 2);
        const std::size_t colon = field.find(':');
        if (colon != std::string::npos) {
          std::string value = field.substr(colon + 1);
          while (!value.empty() && value.front() == ' ') value.erase(0, 1);
          reply.headers.emplace_back(field.substr(0, colon), value);
        }
        line = next;
      }
      content_length = std::stoul(std::string(reply.header("Content-Length").value_or("0")));
    }
    if (in.size() >= header_end + 4 + content_length) break;
  }
  ::close(fd);
  if (header_end != std::string::npos) reply.body = in.substr(header_end + 4, content_length);
  return reply;
}

struct FormPart {
  std::string name;
  std::string data;
  std::string filename;  // empty: a plain field
};

inline std::string MultipartRequest(const std::string& target, const std::vector<FormPart>& parts,
                                    const std::string& extra_headers = "") {
  const std::string boundary = "----softgrasp-test-boundary";
  std::string body;
  for (const auto& p : parts) {
    body += "--" + boundary + "\r\nContent-Disposition: form-data; name=\"" + p.name + "\"";
    if (!p.filename.empty()) body += "; filename=\"" + p.filename + "\"";
    body += "\r\n";
    if (!p.filename.empty()) body += "Content-Type: application/octet-stream\r\n";
    body += "\r\n" + p.data + "\r\n";
  }
  body += "--" + boundary + "--\r\n";
  return "POST " + target + " HTTP/1.1\r\nHost: test\r\nConnection: close\r\n" + extra_headers +
         "Content-Type: multipart/form-data; boundary=" + boundary +
         "\r\nContent-Length: " + std::to_string(body.size()) + "\r\n\r\n" + body;
}

inline std::string RawRequest(const std::string& method, const std::string& target,
                              const std::string& content_type = "", const std::string& body = "",
                              const std::string& extra_headers = "") {
  std::string r =
      method + " " + target + " HTTP/1.1\r\nHost: test\r\nConnection: close\r\n" + extra_headers;
  if (!content_type.empty()) r += "Content-Type: " + content_type + "\r\n";
  if (!body.empty() || method == "POST")
    r += "Content-Length: " + std::to_string(body.size()) + "\r\n";
  return r + "\r\n" + body;
}

/// The shipped pix2stiffness model (models/pix2stiffness.pt), loaded once per test program.
inline std::shared_ptr<const models::StiffnessModel> ShippedStiffnessModel() {
  static const std::shared_ptr<const models::StiffnessModel> model = [] {
    auto loaded =
        models::StiffnessModel::Load(std::string(SOFTGRASP_SOURCE_DIR) + "/models/pix2stiffness.pt");
    if (!loaded.ok()) throw std::runtime_error(loaded.error().message);
    return std::make_shared<const models::StiffnessModel>(std::move(loaded).value());
  }();
  return model;
}

/// The shipped segmentation model (models/segmentation.pt), loaded once per test program.
inline std::shared_ptr<const models::SegmentationModel> ShippedSegmentationModel() {
  static const std::shared_ptr<const models::SegmentationModel> model = [] {
    auto loaded = models::SegmentationModel::Load(std::string(SOFTGRASP_SOURCE_DIR) +
                                                  "/models/segmentation.pt");
    if (!loaded.ok()) throw std::runtime_error(loaded.error().message);
    return std::make_shared<const models::SegmentationModel>(std::move(loaded).value());
  }();
  return model;
}

/// A running server for one test.
class RunningServer {
 public:
  explicit RunningServer(ServiceConfig config = {},
                         std::shared_ptr<robot::CommandTracker> robot = nullptr,
                         std::function<void(const std::string&)> access_log = nullptr,
                         std::shared_ptr<const models::StiffnessModel> stiffness_model = nullptr,
                         std::shared_ptr<const models::SegmentationModel> segmentation_model =
                             nullptr)
      : config_(std::move(config)) {
    config_.server.host = "127.0.0.1";
    config_.server.port = 0;
    config_.server.access_log = access_log ? std::move(access_log) : [](const std::string&) {};
    router_ = BuildRouter(config_, std::move(robot), std::move(stiffness_model),
                          std::move(segmentation_model));
    server_ = std::make_unique<http::Server>(
        config_.server, [this](http::Request& r) { return router_.Dispatch(r); });
    server_->Start();
  }
  ~RunningServer() { server_->Stop(); }
  uint16_t port() const { return server_->port(); }
  HttpReply Send(const std::string& raw) const { return Exchange(port(), raw); }

 private:
  ServiceConfig config_;
  http::Router router_;
  std::unique_ptr<http::Server> server_;
};

}  // namespace softgrasp::rest::testing
