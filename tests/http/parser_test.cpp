#include "service/http/parser.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace softgrasp::http {
namespace {

using State = RequestParser::State;

/// Everything a parser produced from one byte stream.
struct Outcome {
  std::vector<Request> requests;
  std::vector<bool> keep_alive;  ///< keep_alive() right after each Take()
  State state = State::kNeedMore;
  int status = 0;
};

/// Feeds `chunks` in order, taking every complete request as soon as it is there.
Outcome FeedChunks(const std::vector<std::string_view>& chunks, Limits limits = {}) {
  RequestParser parser(limits);
  Outcome out;
  for (const std::string_view chunk : chunks) {
    parser.Feed(chunk);
    while (parser.state() == State::kComplete) {
      out.requests.push_back(parser.Take());
      out.keep_alive.push_back(parser.keep_alive());
      parser.Feed("");
    }
  }
  out.state = parser.state();
  out.status = parser.error_status();
  return out;
}

Outcome FeedWhole(std::string_view bytes, Limits limits = {}) {
  return FeedChunks({bytes}, limits);
}

Outcome FeedSplitAt(std::string_view bytes, std::size_t at, Limits limits = {}) {
  return FeedChunks({bytes.substr(0, at), bytes.substr(at)}, limits);
}

Outcome FeedBytewise(std::string_view bytes, Limits limits = {}) {
  std::vector<std::string_view> chunks;
  for (std::size_t i = 0; i < bytes.size(); ++i) chunks.push_back(bytes.substr(i, 1));
  return FeedChunks(chunks, limits);
}

void ExpectSameOutcome(const Outcome& expected, const Outcome& actual, const std::string& what) {
  SCOPED_TRACE(what);
  ASSERT_EQ(expected.requests.size(), actual.requests.size());
  EXPECT_EQ(expected.state, actual.state);
  EXPECT_EQ(expected.status, actual.status);
  EXPECT_EQ(expected.keep_alive, actual.keep_alive);
  for (std::size_t i = 0; i < expected.requests.size(); ++i) {
    const Request& a = expected.requests[i];
    const Request& b = actual.requests[i];
    EXPECT_EQ(a.method, b.method);
    EXPECT_EQ(a.target, b.target);
    EXPECT_EQ(a.path, b.path);
    EXPECT_EQ(a.query, b.query);
    EXPECT_EQ(a.headers, b.headers);
    EXPECT_EQ(a.body, b.body);
  }
}

/// Same outcome for the whole stream, every two-piece split and byte-by-byte feeding.
void ExpectSplitInvariant(std::string_view bytes, Limits limits = {}) {
  const Outcome whole = FeedWhole(bytes, limits);
  for (std::size_t at = 0; at <= bytes.size(); ++at) {
    ExpectSameOutcome(whole, FeedSplitAt(bytes, at, limits), "split at " + std::to_string(at));
  }
  ExpectSameOutcome(whole, FeedBytewise(bytes, limits), "byte by byte");
}

const char kGet[] =
    "GET /v1/grasps%20x?format=png&name=a+b%26c&flag HTTP/1.1\r\n"
    "Host: localhost\r\n"
    "Accept:  application/json \r\n"
    "X-Empty:\r\n"
    "\r\n";

const char kPost[] =
    "POST /upload HTTP/1.1\r\n"
    "Host: x\r\n"
    "Content-Length: 11\r\n"
    "\r\n"
    "hello\r\nworl";

const char kChunked[] =
    "POST /c HTTP/1.1\r\n"
    "Host: x\r\n"
    "Transfer-Encoding: chunked\r\n"
    "\r\n"
    "5;name=value\r\nhello\r\n"
    "6 ; quoted=\"a b\"\r\n world\r\n"
    "A\r\n0123456789\r\n"
    "0\r\n"
    "X-Trailer: t\r\n"
    "Content-Length: 3\r\n"
    "\r\n";

TEST(HttpParser, ParsesGetWithQueryAndHeaders) {
  const Outcome out = FeedWhole(kGet);
  ASSERT_EQ(out.requests.size(), 1u);
  const Request& r = out.requests[0];
  EXPECT_EQ(r.method, "GET");
  EXPECT_EQ(r.target, "/v1/grasps%20x?format=png&name=a+b%26c&flag");
  EXPECT_EQ(r.path, "/v1/grasps x");
  EXPECT_EQ(r.query_string, "format=png&name=a+b%26c&flag");
  ASSERT_EQ(r.query.size(), 3u);
  EXPECT_EQ(r.query[1], (std::pair<std::string, std::string>("name", "a b&c")));
  EXPECT_EQ(r.query[2], (std::pair<std::string, std::string>("flag", "")));
  EXPECT_EQ(r.query_param("format"), "png");
  EXPECT_EQ(r.header("accept"), "application/json");  // OWS trimmed, name case-insensitive
  EXPECT_EQ(r.header("X-EMPTY"), "");
  EXPECT_EQ(r.headers.size(), 3u);
  EXPECT_TRUE(r.body.empty());
  EXPECT_TRUE(out.keep_alive[0]);
  EXPECT_EQ(out.state, State::kNeedMore);
}

TEST(HttpParser, ParsesContentLengthBody) {
  const Outcome out = FeedWhole(kPost);
  ASSERT_EQ(out.requests.size(), 1u);
  EXPECT_EQ(out.requests[0].body, "hello\r\nworl");
}

TEST(HttpParser, ParsesChunkedBodyAndDropsTrailers) {
  const Outcome out = FeedWhole(kChunked);
  ASSERT_EQ(out.requests.size(), 1u);
  EXPECT_EQ(out.requests[0].body, "hello world0123456789");
  EXPECT_FALSE(out.requests[0].header("X-Trailer").has_value());
  EXPECT_FALSE(out.requests[0].header("Content-Length").has_value());
}

TEST(HttpParser, SplitAtEveryByteGivesTheSameRequests) {
  for (const char* request : {kGet, kPost, kChunked}) {
    SCOPED_TRACE(request);
    ExpectSplitInvariant(request);
    EXPECT_EQ(FeedBytewise(request).requests.size(), 1u);
  }
}

TEST(HttpParser, PipelinedRequestsComeOutInOrder) {
  const std::string stream = std::string(kGet) + kPost + kChunked + kGet;
  const Outcome out = FeedWhole(stream);
  ASSERT_EQ(out.requests.size(), 4u);
  EXPECT_EQ(out.requests[0].method, "GET");
  EXPECT_EQ(out.requests[1].body, "hello\r\nworl");
  EXPECT_EQ(out.requests[2].body, "hello world0123456789");
  EXPECT_EQ(out.requests[3].path, "/v1/grasps x");
  ExpectSplitInvariant(stream);
}

TEST(HttpParser, PipelinedBytesWaitForTake) {
  RequestParser parser;
  EXPECT_EQ(parser.Feed(std::string(kPost) + "GET /second HTTP/1.1\r\nHost: x\r\n"),
            State::kComplete);
  EXPECT_EQ(parser.Feed("\r\n"), State::kComplete);  // kept, not parsed yet
  EXPECT_EQ(parser.Take().path, "/upload");
  EXPECT_EQ(parser.state(), State::kNeedMore);
  EXPECT_EQ(parser.Feed(""), State::kComplete);
  EXPECT_EQ(parser.Take().path, "/second");
  EXPECT_EQ(parser.Feed(""), State::kNeedMore);
  EXPECT_FALSE(parser.in_progress());
}

TEST(HttpParser, TakeWithoutCompleteRequestThrows) {
  RequestParser parser;
  parser.Feed("GET / HTTP/1.1\r\n");
  EXPECT_THROW(parser.Take(), std::logic_error);
}

TEST(HttpParser, InProgressTellsIdleFromStarted) {
  RequestParser parser;
  EXPECT_FALSE(parser.in_progress());
  parser.Feed("G");
  EXPECT_TRUE(parser.in_progress());
  parser.Feed("ET / HTTP/1.1\r\nHost: x\r\n\r\n");
  parser.Take();
  parser.Feed("");
  EXPECT_FALSE(parser.in_progress());
}

TEST(HttpParser, KeepAliveRules) {
  const auto keep_alive = [](const std::string& version, const std::string& connection) {
    std::string request = "GET / " + version + "\r\nHost: x\r\n";
    if (!connection.empty()) request += "Connection: " + connection + "\r\n";
    const Outcome out = FeedWhole(request + "\r\n");
    EXPECT_EQ(out.requests.size(), 1u) << request;
    return !out.keep_alive.empty() && out.keep_alive[0];
  };
  EXPECT_TRUE(keep_alive("HTTP/1.1", ""));
  EXPECT_FALSE(keep_alive("HTTP/1.1", "close"));
  EXPECT_FALSE(keep_alive("HTTP/1.1", "Upgrade, CLOSE"));
  EXPECT_TRUE(keep_alive("HTTP/1.1", "keep-alive"));
  EXPECT_FALSE(keep_alive("HTTP/1.0", ""));
  EXPECT_TRUE(keep_alive("HTTP/1.0", "Keep-Alive"));
  EXPECT_FALSE(keep_alive("HTTP/1.0", "keep-alive, close"));
}

TEST(HttpParser, Http10NeedsNoHost) {
  const Outcome out = FeedWhole("GET /old HTTP/1.0\r\n\r\n");
  ASSERT_EQ(out.requests.size(), 1u);
  EXPECT_EQ(out.requests[0].path, "/old");
}

TEST(HttpParser, ExpectContinueUntilTheBodyArrives) {
  RequestParser parser;
  parser.Feed("PUT /x HTTP/1.1\r\nHost: x\r\nExpect: 100-continue\r\nContent-Length: 3\r\n\r\n");
  EXPECT_EQ(parser.state(), State::kNeedMore);
  EXPECT_TRUE(parser.expects_continue());
  parser.Feed("a");
  EXPECT_FALSE(parser.expects_continue());
  EXPECT_EQ(parser.Feed("bc"), State::kComplete);

  RequestParser no_body;  // nothing to continue with
  no_body.Feed("GET /x HTTP/1.1\r\nHost: x\r\nExpect: 100-continue\r\n\r\n");
  EXPECT_EQ(no_body.state(), State::kComplete);
  EXPECT_FALSE(no_body.expects_continue());
}

TEST(HttpParser, SkipsEmptyLinesBeforeARequest) {
  const Outcome out = FeedWhole(std::string("\r\n\r\n") + kGet);
  ASSERT_EQ(out.requests.size(), 1u);
  EXPECT_EQ(out.requests[0].method, "GET");
}

TEST(HttpParser, AcceptsAbsoluteFormAndAsteriskForm) {
  Outcome out = FeedWhole("GET http://example.com:8080/a%2Fb?q=1 HTTP/1.1\r\nHost: e\r\n\r\n");
  ASSERT_EQ(out.requests.size(), 1u);
  EXPECT_EQ(out.requests[0].path, "/a/b");
  EXPECT_EQ(out.requests[0].query_param("q"), "1");
  out = FeedWhole("GET HTTPS://example.com HTTP/1.1\r\nHost: e\r\n\r\n");
  ASSERT_EQ(out.requests.size(), 1u);
  EXPECT_EQ(out.requests[0].path, "/");
  out = FeedWhole("OPTIONS * HTTP/1.1\r\nHost: e\r\n\r\n");
  ASSERT_EQ(out.requests.size(), 1u);
  EXPECT_EQ(out.requests[0].path, "*");
}

TEST(HttpParser, ZeroContentLengthAndEmptyChunkedBody) {
  Outcome out = FeedWhole("POST / HTTP/1.1\r\nHost: x\r\nContent-Length: 000\r\n\r\n");
  ASSERT_EQ(out.requests.size(), 1u);
  EXPECT_TRUE(out.requests[0].body.empty());
  out = FeedWhole("POST / HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: Chunked\r\n\r\n0\r\n\r\n");
  ASSERT_EQ(out.requests.size(), 1u);
  EXPECT_TRUE(out.requests[0].body.empty());
}

// ---- limits ----

TEST(HttpParser, HeaderBlockOverLimitIs431) {
  Limits limits;
  limits.max_header_bytes = 200;
  const std::string head = "GET / HTTP/1.1\r\nHost: x\r\nX-Big: ";
  // Just at the limit passes; one more byte fails.
  const std::string at_limit = head + std::string(200 - head.size() - 4, 'a') + "\r\n\r\n";
  ASSERT_EQ(at_limit.size(), 200u);
  EXPECT_EQ(FeedWhole(at_limit, limits).requests.size(), 1u);
  const std::string over = head + std::string(200 - head.size() - 3, 'a') + "\r\n\r\n";
  EXPECT_EQ(FeedWhole(over, limits).status, 431);
  ExpectSplitInvariant(over, limits);

  // A header block that never ends fails as soon as it is over the limit.
  RequestParser parser(limits);
  parser.Feed(head);
  for (int i = 0; i < 300 && parser.state() == State::kNeedMore; ++i) parser.Feed("a");
  EXPECT_EQ(parser.state(), State::kError);
  EXPECT_EQ(parser.error_status(), 431);
  EXPECT_FALSE(parser.keep_alive());
}

TEST(HttpParser, ManyHeaderLinesCountTowardsTheLimit) {
  Limits limits;
  limits.max_header_bytes = 1024;
  std::string request = "GET / HTTP/1.1\r\nHost: x\r\n";
  for (int i = 0; i < 200; ++i) request += "A: b\r\n";
  EXPECT_EQ(FeedWhole(request + "\r\n", limits).status, 431);
}

TEST(HttpParser, UriOverLimitIs414) {
  Limits limits;
  limits.max_uri_bytes = 64;
  const std::string ok = "GET /" + std::string(63, 'u') + " HTTP/1.1\r\nHost: x\r\n\r\n";
  EXPECT_EQ(FeedWhole(ok, limits).requests.size(), 1u);
  const std::string over = "GET /" + std::string(64, 'u') + " HTTP/1.1\r\nHost: x\r\n\r\n";
  EXPECT_EQ(FeedWhole(over, limits).status, 414);
  ExpectSplitInvariant(over, limits);

  // Detected before the request line ends.
  RequestParser parser(limits);
  EXPECT_EQ(parser.Feed("GET /" + std::string(100, 'u')), State::kError);
  EXPECT_EQ(parser.error_status(), 414);
}

TEST(HttpParser, BodyOverLimitByContentLengthIs413BeforeTheBody) {
  Limits limits;
  limits.max_body_bytes = 10;
  RequestParser parser(limits);
  EXPECT_EQ(parser.Feed("POST / HTTP/1.1\r\nHost: x\r\nContent-Length: 11\r\n\r\n"), State::kError);
  EXPECT_EQ(parser.error_status(), 413);
  EXPECT_EQ(
      FeedWhole("POST / HTTP/1.1\r\nHost: x\r\nContent-Length: 99999999999999999999999\r\n\r\n")
          .status,
      413);
  EXPECT_EQ(FeedWhole("POST / HTTP/1.1\r\nHost: x\r\nContent-Length: 10\r\n\r\n0123456789", limits)
                .requests.size(),
            1u);
}

TEST(HttpParser, BodyOverLimitWhileDechunkingIs413) {
  Limits limits;
  limits.max_body_bytes = 10;
  const std::string head = "POST / HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\n\r\n";
  EXPECT_EQ(FeedWhole(head + "6\r\nabcdef\r\n4\r\nghij\r\n0\r\n\r\n", limits).requests.size(), 1u);
  RequestParser parser(limits);
  parser.Feed(head + "6\r\nabcdef\r\n");
  EXPECT_EQ(parser.state(), State::kNeedMore);
  EXPECT_EQ(parser.Feed("5\r\n"), State::kError);  // before the chunk data arrives
  EXPECT_EQ(parser.error_status(), 413);
  EXPECT_EQ(FeedWhole(head + "FFFFFFFFFFFF\r\n", limits).status, 413);
}

// ---- malformed requests ----

struct BadCase {
  const char* name;
  std::string bytes;
  int status;
};

class HttpParserRejects : public ::testing::TestWithParam<BadCase> {};

TEST_P(HttpParserRejects, WithStatus) {
  const BadCase& c = GetParam();
  const Outcome out = FeedWhole(c.bytes);
  EXPECT_EQ(out.state, State::kError);
  EXPECT_EQ(out.status, c.status);
  EXPECT_TRUE(out.requests.empty());
  EXPECT_EQ(FeedBytewise(c.bytes).status, c.status);  // independent of how bytes arrive
  RequestParser parser;
  parser.Feed(c.bytes);
  EXPECT_FALSE(parser.error_message().empty());
  EXPECT_EQ(parser.Feed("GET / HTTP/1.1\r\nHost: x\r\n\r\n"), State::kError);  // stays failed
}

const std::string kHost = "Host: x\r\n";
const std::string kChunkedHead = "POST / HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\n\r\n";

INSTANTIATE_TEST_SUITE_P(
    Malformed, HttpParserRejects,
    ::testing::Values(
        // request line
        BadCase{"no_target", "GET\r\n\r\n", 400}, BadCase{"no_version", "GET /\r\n\r\n", 400},
        BadCase{"double_space", "GET  / HTTP/1.1\r\n" + kHost + "\r\n", 400},
        BadCase{"trailing_space", "GET / HTTP/1.1 \r\n" + kHost + "\r\n", 400},
        BadCase{"bad_method", "G(T / HTTP/1.1\r\n" + kHost + "\r\n", 400},
        BadCase{"lowercase_version", "GET / http/1.1\r\n" + kHost + "\r\n", 400},
        BadCase{"short_version", "GET / HTTP/1\r\n" + kHost + "\r\n", 400},
        BadCase{"relative_target", "GET foo HTTP/1.1\r\n" + kHost + "\r\n", 400},
        BadCase{"fragment", "GET /a#b HTTP/1.1\r\n" + kHost + "\r\n", 400},
        BadCase{"bad_escape", "GET /%zz HTTP/1.1\r\n" + kHost + "\r\n", 400},
        BadCase{"truncated_escape_in_query", "GET /?a=%2 HTTP/1.1\r\n" + kHost + "\r\n", 400},
        BadCase{"nul_in_path", "GET /a%00 HTTP/1.1\r\n" + kHost + "\r\n", 400},
        BadCase{"control_in_target", "GET /a\x01 HTTP/1.1\r\n" + kHost + "\r\n", 400},
        BadCase{"asterisk_not_options", "GET * HTTP/1.1\r\n" + kHost + "\r\n", 400},
        BadCase{"bare_lf_request_line", "GET / HTTP/1.1\n" + kHost + "\r\n", 400},
        BadCase{"lone_lf", "\n", 400}, BadCase{"bare_cr", "GET / HTTP/1.1\rHost: x\r\n\r\n", 400},
        // header fields
        BadCase{"no_colon", "GET / HTTP/1.1\r\nHost x\r\n\r\n", 400},
        BadCase{"space_before_colon", "GET / HTTP/1.1\r\nHost : x\r\n\r\n", 400},
        BadCase{"empty_name", "GET / HTTP/1.1\r\n" + kHost + ": x\r\n\r\n", 400},
        BadCase{"obs_fold", "GET / HTTP/1.1\r\n" + kHost + "X-A: a\r\n  b\r\n\r\n", 400},
        BadCase{"bare_lf_header", "GET / HTTP/1.1\r\nHost: x\n\r\n", 400},
        BadCase{"bare_lf_end", "GET / HTTP/1.1\r\nHost: x\r\n\n", 400},
        BadCase{"nul_in_value", "GET / HTTP/1.1\r\nHost: x" + std::string(1, '\0') + "y\r\n\r\n",
                400},
        BadCase{"missing_host", "GET / HTTP/1.1\r\n\r\n", 400},
        BadCase{"two_hosts", "GET / HTTP/1.1\r\n" + kHost + kHost + "\r\n", 400},
        // framing
        BadCase{"cl_and_te",
                "POST / HTTP/1.1\r\n" + kHost +
                    "Content-Length: 5\r\nTransfer-Encoding: chunked\r\n\r\n0\r\n\r\n",
                400},
        BadCase{
            "te_and_cl_unsupported_te",
            "POST / HTTP/1.1\r\n" + kHost + "Transfer-Encoding: gzip\r\nContent-Length: 1\r\n\r\n",
            400},
        BadCase{"cl_not_number", "POST / HTTP/1.1\r\n" + kHost + "Content-Length: abc\r\n\r\n",
                400},
        BadCase{"cl_negative", "POST / HTTP/1.1\r\n" + kHost + "Content-Length: -1\r\n\r\n", 400},
        BadCase{"cl_plus", "POST / HTTP/1.1\r\n" + kHost + "Content-Length: +1\r\n\r\n", 400},
        BadCase{"cl_list", "POST / HTTP/1.1\r\n" + kHost + "Content-Length: 1, 1\r\n\r\n", 400},
        BadCase{"cl_empty", "POST / HTTP/1.1\r\n" + kHost + "Content-Length:\r\n\r\n", 400},
        BadCase{"two_cl",
                "POST / HTTP/1.1\r\n" + kHost + "Content-Length: 1\r\nContent-Length: 2\r\n\r\n",
                400},
        BadCase{"te_in_http10", "POST / HTTP/1.0\r\nTransfer-Encoding: chunked\r\n\r\n0\r\n\r\n",
                400},
        BadCase{"te_empty", "POST / HTTP/1.1\r\n" + kHost + "Transfer-Encoding: \r\n\r\n", 400},
        // chunked body
        BadCase{"chunk_size_not_hex", kChunkedHead + "zz\r\n", 400},
        BadCase{"chunk_size_negative", kChunkedHead + "-1\r\n", 400},
        BadCase{"chunk_size_empty", kChunkedHead + "\r\n", 400},
        BadCase{"chunk_size_junk", kChunkedHead + "5 x\r\nhello\r\n0\r\n\r\n", 400},
        BadCase{"chunk_size_0x", kChunkedHead + "0x5\r\nhello\r\n0\r\n\r\n", 400},
        BadCase{"chunk_size_overflow", kChunkedHead + "fffffffffffffffffffff\r\n", 400},
        BadCase{"chunk_size_bare_lf", kChunkedHead + "5\nhello\r\n0\r\n\r\n", 400},
        BadCase{"chunk_data_too_long", kChunkedHead + "5\r\nhelloXX\r\n0\r\n\r\n", 400},
        BadCase{"chunk_ext_control", kChunkedHead + "5;a=\x01\r\nhello\r\n0\r\n\r\n", 400},
        BadCase{"chunk_line_too_long", kChunkedHead + "5;" + std::string(5000, 'e') + "\r\n", 400},
        BadCase{"bad_trailer", kChunkedHead + "0\r\nno colon\r\n\r\n", 400},
        // unsupported
        BadCase{"te_gzip", "POST / HTTP/1.1\r\n" + kHost + "Transfer-Encoding: gzip\r\n\r\n", 501},
        BadCase{"te_gzip_chunked",
                "POST / HTTP/1.1\r\n" + kHost + "Transfer-Encoding: gzip, chunked\r\n\r\n", 501},
        BadCase{"te_chunked_twice",
                "POST / HTTP/1.1\r\n" + kHost +
                    "Transfer-Encoding: chunked\r\nTransfer-Encoding: chunked\r\n\r\n",
                501},
        BadCase{"te_identity",
                "POST / HTTP/1.1\r\n" + kHost + "Transfer-Encoding: identity\r\n\r\n", 501},
        BadCase{"http2", "GET / HTTP/2.0\r\n" + kHost + "\r\n", 505},
        BadCase{"http12", "GET / HTTP/1.2\r\n" + kHost + "\r\n", 505},
        BadCase{"http09", "GET / HTTP/0.9\r\n\r\n", 505}),
    [](const ::testing::TestParamInfo<BadCase>& param_info) {
      return std::string(param_info.param.name);
    });

TEST(HttpParser, RejectedStreamsAreSplitInvariant) {
  Limits limits;
  limits.max_header_bytes = 80;
  limits.max_uri_bytes = 30;
  limits.max_body_bytes = 8;
  for (const std::string& bytes : {
           std::string("GET /") + std::string(40, 'a') + " HTTP/1.1\r\n\r\n",
           std::string("GET /a HTTP/1.1\r\nX: ") + std::string(80, 'b') + "\r\n\r\n",
           std::string("GET /") + std::string(40, 'a') + std::string(60, ' '),
           std::string(90, 'G'),
           kChunkedHead + "9\r\n",
           std::string("GET /a HTTP/1.1\r\nHost: x\r\n\r\nGARBAGE\r\n\r\n"),
       }) {
    SCOPED_TRACE(bytes);
    ExpectSplitInvariant(bytes, limits);
    EXPECT_EQ(FeedWhole(bytes, limits).state, State::kError);
  }
}

}  // namespace
}  // namespace softgrasp::http
