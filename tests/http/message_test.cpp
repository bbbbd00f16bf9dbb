#include "service/http/message.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

namespace softgrasp::http {
namespace {

TEST(HttpMessage, FindHeaderIsCaseInsensitiveAndTakesTheFirst) {
  const Headers headers = {{"Content-Type", "a"}, {"X-Thing", "1"}, {"x-thing", "2"}};
  EXPECT_EQ(FindHeader(headers, "content-type"), "a");
  EXPECT_EQ(FindHeader(headers, "X-THING"), "1");
  EXPECT_FALSE(FindHeader(headers, "Content").has_value());
  EXPECT_FALSE(FindHeader({}, "x").has_value());
}

TEST(HttpMessage, QueryParamReturnsTheFirstMatch) {
  Request request;
  request.query = {{"a", "1"}, {"b", ""}, {"a", "2"}};
  EXPECT_EQ(request.query_param("a"), "1");
  EXPECT_EQ(request.query_param("b"), "");
  EXPECT_FALSE(request.query_param("A").has_value());  // keys are case-sensitive
}

TEST(HttpMessage, SetHeaderReplacesOrAppends) {
  Response response = Response::Bytes(201, "image/png", "PNG");
  EXPECT_EQ(response.status, 201);
  EXPECT_EQ(response.body, "PNG");
  response.set_header("content-type", "image/tiff").set_header("X-A", "1");
  ASSERT_EQ(response.headers.size(), 2u);
  EXPECT_EQ(FindHeader(response.headers, "Content-Type"), "image/tiff");
  EXPECT_EQ(FindHeader(response.headers, "x-a"), "1");
}

TEST(HttpMessage, JsonResponseHasJsonContentType) {
  const Response response = Response::Json(200, R"({"ok":true})");
  EXPECT_EQ(FindHeader(response.headers, "Content-Type"), "application/json");
  EXPECT_EQ(response.body, R"({"ok":true})");
}

TEST(HttpMessage, ErrorJsonShape) {
  const auto with_field = nlohmann::json::parse(ErrorJson("bad_request", "no \"x\"", "depth"));
  EXPECT_EQ(with_field["error"]["code"], "bad_request");
  EXPECT_EQ(with_field["error"]["message"], "no \"x\"");
  EXPECT_EQ(with_field["error"]["field"], "depth");
  EXPECT_EQ(with_field.size(), 1u);

  const auto without_field = nlohmann::json::parse(ErrorJson("not_found", "gone"));
  EXPECT_FALSE(without_field["error"].contains("field"));
  EXPECT_EQ(without_field["error"].size(), 2u);

  // Invalid UTF-8 from a request never makes the error body itself fail.
  EXPECT_NO_THROW(nlohmann::json::parse(ErrorJson("bad_request", "bad \xff\xfe bytes")));
}

TEST(HttpMessage, ErrorResponse) {
  const Response response = ErrorResponse(413, "payload_too_large", "too big", "body");
  EXPECT_EQ(response.status, 413);
  EXPECT_EQ(FindHeader(response.headers, "Content-Type"), "application/json");
  EXPECT_EQ(nlohmann::json::parse(response.body)["error"]["field"], "body");
}

TEST(HttpMessage, ReasonPhrases) {
  EXPECT_STREQ(ReasonPhrase(200), "OK");
  EXPECT_STREQ(ReasonPhrase(413), "Payload Too Large");
  EXPECT_STREQ(ReasonPhrase(431), "Request Header Fields Too Large");
  EXPECT_STREQ(ReasonPhrase(505), "HTTP Version Not Supported");
  EXPECT_STRNE(ReasonPhrase(299), "");
  EXPECT_STRNE(ReasonPhrase(999), "");
}

TEST(HttpMessage, PercentDecode) {
  EXPECT_EQ(PercentDecode("a%20b%2Fc%2f", false), "a b/c/");
  EXPECT_EQ(PercentDecode("a+b", false), "a+b");
  EXPECT_EQ(PercentDecode("a+b%2B", true), "a b+");
  EXPECT_EQ(PercentDecode("%C3%A9", false), "\xC3\xA9");
  EXPECT_EQ(PercentDecode("", true), "");
  EXPECT_EQ(PercentDecode("%00", false), std::string(1, '\0'));
  EXPECT_FALSE(PercentDecode("%G1", false).has_value());
  EXPECT_FALSE(PercentDecode("%1G", false).has_value());
  EXPECT_FALSE(PercentDecode("abc%", false).has_value());
  EXPECT_FALSE(PercentDecode("abc%4", true).has_value());
}

}  // namespace
}  // namespace softgrasp::http
