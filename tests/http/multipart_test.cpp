#include <gtest/gtest.h>

#include <string>

#include "service/http/message.h"

namespace softgrasp::http {
namespace {

std::string Part(const std::string& boundary, const std::string& headers, const std::string& data) {
  return "--" + boundary + "\r\n" + headers + "\r\n" + data + "\r\n";
}

TEST(HttpMultipart, ParsesPartsWithQuotedBoundary) {
  const std::string body =
      Part("b 1", "Content-Disposition: form-data; name=\"meta\"\r\n", R"({"k":1})") +
      Part("b 1",
           "Content-Disposition: form-data; name=\"depth\"; filename=\"d.png\"\r\n"
           "Content-Type: image/png\r\n",
           "PNGDATA") +
      "--b 1--\r\n";
  const auto result = ParseMultipart("multipart/form-data; boundary=\"b 1\"", body);
  ASSERT_TRUE(result.ok()) << result.error;
  ASSERT_EQ(result.parts.size(), 2u);
  EXPECT_EQ(result.parts[0].name, "meta");
  EXPECT_EQ(result.parts[0].filename, "");
  EXPECT_EQ(result.parts[0].content_type, "");
  EXPECT_EQ(result.parts[0].data, R"({"k":1})");
  EXPECT_EQ(result.parts[1].name, "depth");
  EXPECT_EQ(result.parts[1].filename, "d.png");
  EXPECT_EQ(result.parts[1].content_type, "image/png");
  EXPECT_EQ(result.parts[1].data, "PNGDATA");
  EXPECT_EQ(result.parts[1].headers.size(), 2u);
}

TEST(HttpMultipart, UnquotedBoundaryAndCaseInsensitiveNames) {
  const std::string body =
      Part("XyZ", "content-disposition: FORM-DATA; NAME=a\r\n", "1") + "--XyZ--";
  const auto result = ParseMultipart("Multipart/Form-Data;charset=utf-8;  Boundary=XyZ", body);
  ASSERT_TRUE(result.ok()) << result.error;
  ASSERT_EQ(result.parts.size(), 1u);
  EXPECT_EQ(result.parts[0].name, "a");
  EXPECT_EQ(result.parts[0].data, "1");
}

TEST(HttpMultipart, BinaryDataWithCrlfAndBoundaryLookalikes) {
  std::string data = "\r\n\r\n--bound\r--boundary\r\n--boundaryX\r\n--boundary-\r\n";
  data += std::string("\0\xff\x01\r\n", 5);
  const std::string body =
      Part("boundary", "Content-Disposition: form-data; name=\"bin\"\r\n", data) + "--boundary--";
  const auto result = ParseMultipart("multipart/form-data; boundary=boundary", body);
  ASSERT_TRUE(result.ok()) << result.error;
  ASSERT_EQ(result.parts.size(), 1u);
  EXPECT_EQ(result.parts[0].data, data);
}

TEST(HttpMultipart, PreambleEpilogueAndTransportPadding) {
  const std::string body =
      "This is the preamble.\r\n--b  \t\r\n"
      "Content-Disposition: form-data; name=x\r\n\r\nvalue\r\n"
      "--b--  \r\nThis is the epilogue.\r\n--b\r\nnot a part";
  const auto result = ParseMultipart("multipart/form-data; boundary=b", body);
  ASSERT_TRUE(result.ok()) << result.error;
  ASSERT_EQ(result.parts.size(), 1u);
  EXPECT_EQ(result.parts[0].data, "value");
}

TEST(HttpMultipart, EmptyDataAndEscapedQuotes) {
  const std::string body =
      Part("b", "Content-Disposition: form-data; name=\"a\\\"q\"; filename=\"x;y.bin\"\r\n", "") +
      "--b--";
  const auto result = ParseMultipart("multipart/form-data; boundary=b", body);
  ASSERT_TRUE(result.ok()) << result.error;
  ASSERT_EQ(result.parts.size(), 1u);
  EXPECT_EQ(result.parts[0].name, "a\"q");
  EXPECT_EQ(result.parts[0].filename, "x;y.bin");
  EXPECT_EQ(result.parts[0].data, "");
}

TEST(HttpMultipart, NoPartsIsNotAnError) {
  const auto result = ParseMultipart("multipart/form-data; boundary=b", "--b--\r\n");
  EXPECT_TRUE(result.ok()) << result.error;
  EXPECT_TRUE(result.parts.empty());
}

struct BadMultipart {
  const char* name;
  std::string content_type;
  std::string body;
};

class HttpMultipartRejects : public ::testing::TestWithParam<BadMultipart> {};

TEST_P(HttpMultipartRejects, WithAMessage) {
  const auto result = ParseMultipart(GetParam().content_type, GetParam().body);
  EXPECT_FALSE(result.ok());
  EXPECT_FALSE(result.error.empty());
  EXPECT_TRUE(result.parts.empty());
}

const std::string kType = "multipart/form-data; boundary=b";
const std::string kGoodPart = Part("b", "Content-Disposition: form-data; name=a\r\n", "1");

INSTANTIATE_TEST_SUITE_P(
    Malformed, HttpMultipartRejects,
    ::testing::Values(
        BadMultipart{"missing_final_boundary", kType, kGoodPart},
        BadMultipart{"truncated_final_boundary", kType, kGoodPart + "--b-"},
        BadMultipart{"missing_boundary_param", "multipart/form-data", kGoodPart + "--b--"},
        BadMultipart{"empty_boundary", "multipart/form-data; boundary=\"\"", "----\r\n"},
        BadMultipart{"boundary_too_long", "multipart/form-data; boundary=" + std::string(71, 'b'),
                     "--" + std::string(71, 'b') + "--"},
        BadMultipart{"unterminated_quote", "multipart/form-data; boundary=\"b",
                     kGoodPart + "--b--"},
        BadMultipart{"not_form_data", "multipart/mixed; boundary=b", kGoodPart + "--b--"},
        BadMultipart{"not_multipart", "application/json", "{}"},
        BadMultipart{"no_opening_boundary", kType, "just some bytes"},
        BadMultipart{"empty_body", kType, ""},
        BadMultipart{"no_disposition", kType,
                     Part("b", "Content-Type: text/plain\r\n", "1") + "--b--"},
        BadMultipart{"no_name", kType,
                     Part("b", "Content-Disposition: form-data; filename=f\r\n", "1") + "--b--"},
        BadMultipart{"attachment", kType,
                     Part("b", "Content-Disposition: attachment; name=a\r\n", "1") + "--b--"},
        BadMultipart{"headers_not_terminated", kType,
                     "--b\r\nContent-Disposition: form-data; name=a\r\n--b--"},
        BadMultipart{
            "bad_header_line", kType,
            Part("b", "Content-Disposition: form-data; name=a\r\nno colon\r\n", "1") + "--b--"},
        BadMultipart{"folded_header", kType,
                     Part("b", "Content-Disposition: form-data;\r\n name=a\r\n", "1") + "--b--"}),
    [](const ::testing::TestParamInfo<BadMultipart>& param_info) {
      return std::string(param_info.param.name);
    });

}  // namespace
}  // namespace softgrasp::http
