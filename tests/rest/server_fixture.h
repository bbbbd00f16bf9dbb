#pragma once
// Starts the real softgrasp server (router + http::Server) on 127.0.0.1:0 and talks HTTP to it
// over a real socket (tests/support/http_client.h). One request per connection.

#include <gtest/gtest.h>

#include <fstream>
#include <functional>
#include <iterator>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "service/config/config.h"
#include "service/http/message.h"
#include "service/http/server.h"
#include "service/rest/api.h"
#include "tests/support/http_client.h"
#include "tests/support/test_data.h"

namespace softgrasp::rest::testing {

using softgrasp::testing::HttpReply;
using softgrasp::testing::TestData;  // tests/data, the real frames kept with the tests

inline std::string ReadFileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
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
    auto loaded = models::StiffnessModel::Load(std::string(SOFTGRASP_SOURCE_DIR) +
                                               "/models/pix2stiffness.pt");
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

/// The shipped GQ-CNN (models/gqcnn.pt), loaded once per test program; null when none is shipped.
inline std::shared_ptr<const models::GqcnnModel> ShippedGqcnnModel() {
  static const std::shared_ptr<const models::GqcnnModel> model =
      []() -> std::shared_ptr<const models::GqcnnModel> {
    auto loaded = models::GqcnnModel::Load(std::string(SOFTGRASP_SOURCE_DIR) + "/models/gqcnn.pt");
    if (!loaded.ok()) return nullptr;
    return std::make_shared<const models::GqcnnModel>(std::move(loaded).value());
  }();
  return model;
}

/// A running server for one test.
class RunningServer {
 public:
  explicit RunningServer(
      config::ServiceConfig config = {}, std::shared_ptr<robot::CommandTracker> robot = nullptr,
      std::function<void(const std::string&)> access_log = nullptr,
      std::shared_ptr<const models::StiffnessModel> stiffness_model = nullptr,
      std::shared_ptr<const models::SegmentationModel> segmentation_model = nullptr,
      std::shared_ptr<const models::GqcnnModel> gqcnn_model = nullptr)
      : config_(std::move(config)) {
    config_.server.host = "127.0.0.1";
    config_.server.port = 0;
    config_.server.access_log = access_log ? std::move(access_log) : [](const std::string&) {};
    router_ = BuildRouter(config_, std::move(robot), std::move(stiffness_model),
                          std::move(segmentation_model), std::move(gqcnn_model));
    server_ = std::make_unique<http::Server>(
        config_.server, [this](http::Request& r) { return router_.Dispatch(r); });
    server_->Start();
  }
  ~RunningServer() { server_->Stop(); }
  uint16_t port() const { return server_->port(); }
  HttpReply Send(const std::string& raw) const {
    return softgrasp::testing::HttpExchange(port(), raw);
  }

 private:
  config::ServiceConfig config_;
  http::Router router_;
  std::unique_ptr<http::Server> server_;
};

}  // namespace softgrasp::rest::testing
