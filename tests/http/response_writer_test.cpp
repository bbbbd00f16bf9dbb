#include "service/http/response_writer.h"

#include <gtest/gtest.h>

#include <string>

namespace softgrasp::http {
namespace {

std::string Serialize(const Response& response, ResponseFraming framing = {"req-1", true, false},
                      std::size_t* body_bytes_out = nullptr) {
  std::size_t body_bytes = 12345;
  std::string out = SerializeResponse(response, framing, &body_bytes);
  if (body_bytes_out != nullptr) *body_bytes_out = body_bytes;
  return out;
}

std::string HeadBlock(const std::string& bytes) {
  return bytes.substr(0, bytes.find("\r\n\r\n") + 2);
}

TEST(ResponseWriter, FramesStatusHeadersAndBody) {
  Response response = Response::Bytes(201, "text/plain", "hello");
  response.set_header("X-Extra", "1");
  std::size_t body_bytes = 0;
  const std::string out = Serialize(response, {"req-1", true, false}, &body_bytes);
  EXPECT_EQ(out.rfind("HTTP/1.1 201 Created\r\n", 0), 0u) << out;
  EXPECT_NE(out.find("\r\nX-Extra: 1\r\n"), std::string::npos);
  EXPECT_NE(out.find("\r\nContent-Length: 5\r\n"), std::string::npos);
  EXPECT_NE(out.find("\r\nConnection: keep-alive\r\n"), std::string::npos);
  EXPECT_NE(out.find("\r\nX-Request-Id: req-1\r\n"), std::string::npos);
  EXPECT_NE(out.find("\r\nDate: "), std::string::npos);
  EXPECT_EQ(out.substr(out.size() - 9), "\r\n\r\nhello");
  EXPECT_EQ(body_bytes, 5u);
  EXPECT_NE(Serialize(response, {"r", false, false}).find("\r\nConnection: close\r\n"),
            std::string::npos);
}

TEST(ResponseWriter, DropsTheHandlersCopiesOfServerHeaders) {
  Response response = Response::Bytes(200, "text/plain", "abc");
  for (const char* name :
       {"content-length", "Transfer-Encoding", "CONNECTION", "Date", "x-request-id"}) {
    response.headers.emplace_back(name, "999");
  }
  const std::string head = HeadBlock(Serialize(response));
  EXPECT_EQ(head.find("999"), std::string::npos) << head;
  EXPECT_NE(head.find("Content-Length: 3\r\n"), std::string::npos);
}

TEST(ResponseWriter, DropsHeadersThatCouldBreakTheFraming) {
  Response response = Response::Bytes(200, "text/plain", "abc");
  response.headers.emplace_back("X-Injected", "a\r\nSet-Cookie: evil");
  response.headers.emplace_back("X-Lf", "a\nb");
  response.headers.emplace_back("X-Nul", std::string("a\0b", 3));
  response.headers.emplace_back("Bad Name", "v");
  response.headers.emplace_back("Bad:Name", "v");
  response.headers.emplace_back("", "v");
  response.headers.emplace_back("X-Kept", "fine value");
  const std::string head = HeadBlock(Serialize(response));
  EXPECT_EQ(head.find("evil"), std::string::npos) << head;
  for (const char* gone : {"X-Lf", "X-Nul", "Bad Name", "Bad:Name", "\r\n: v"}) {
    EXPECT_EQ(head.find(gone), std::string::npos) << gone;
  }
  EXPECT_NE(head.find("\r\nX-Kept: fine value\r\n"), std::string::npos);
}

TEST(ResponseWriter, AnUnsafeRequestIdIsLeftOut) {
  const Response response = Response::Bytes(200, "text/plain", "");
  EXPECT_EQ(Serialize(response, {"a\r\nX-Evil: 1", true, false}).find("X-Evil"), std::string::npos);
  EXPECT_EQ(Serialize(response, {"", true, false}).find("X-Request-Id"), std::string::npos);
}

TEST(ResponseWriter, HeadGetsTheLengthButNoBody) {
  std::size_t body_bytes = 99;
  const std::string out =
      Serialize(Response::Bytes(200, "text/plain", "hello"), {"r", true, true}, &body_bytes);
  EXPECT_NE(out.find("\r\nContent-Length: 5\r\n"), std::string::npos);
  EXPECT_EQ(out.substr(out.size() - 4), "\r\n\r\n");
  EXPECT_EQ(body_bytes, 0u);
}

TEST(ResponseWriter, BodilessStatusesHaveNeitherLengthNorBody) {
  for (const int status : {101, 204, 304}) {
    std::size_t body_bytes = 99;
    const std::string out = Serialize(Response::Bytes(status, "text/plain", "ignored"),
                                      {"r", true, false}, &body_bytes);
    EXPECT_EQ(out.find("Content-Length"), std::string::npos) << status;
    EXPECT_EQ(out.substr(out.size() - 4), "\r\n\r\n") << status;
    EXPECT_EQ(body_bytes, 0u) << status;
  }
}

TEST(ResponseWriter, HttpDateIsTheImfFixdate) {
  // RFC 9110's own example: 784111777 s after the epoch.
  const auto time = std::chrono::system_clock::time_point(std::chrono::seconds(784111777));
  EXPECT_EQ(HttpDate(time), "Sun, 06 Nov 1994 08:49:37 GMT");
  EXPECT_EQ(HttpDate(time + std::chrono::milliseconds(999)), "Sun, 06 Nov 1994 08:49:37 GMT");
  EXPECT_EQ(HttpDate(time + std::chrono::seconds(86400 * 365)), "Mon, 06 Nov 1995 08:49:37 GMT");
}

}  // namespace
}  // namespace softgrasp::http
