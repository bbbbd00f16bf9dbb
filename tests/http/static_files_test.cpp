#include "service/http/static_files.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "service/http/router.h"
#include "tests/support/temp_dir.h"

namespace softgrasp::http {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

void WriteFile(const fs::path& path, const std::string& bytes) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << bytes;
}

Request MakeRequest(std::string method, const std::string& target) {
  Request request;
  request.method = std::move(method);
  request.target = target;
  request.path = PercentDecode(target.substr(0, target.find('?')), false).value_or(target);
  return request;
}

void ExpectNotFoundJson(const Response& response) {
  EXPECT_EQ(response.status, 404);
  const json body = json::parse(response.body);
  EXPECT_EQ(body["error"]["code"], "not_found");
  EXPECT_EQ(FindHeader(response.headers, "Content-Type").value_or(""), "application/json");
}

// A scratch tree:  <sandbox>/web/{index.html, assets/app-3KX7Q2ZB.js, assets/logo.svg, .env,
// sub/}  and  <sandbox>/secret.txt  outside the served root.
class StaticFilesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    sandbox_ = temp_.path();
    root_ = sandbox_ / "web";
    WriteFile(root_ / "index.html", "<!doctype html><title>t</title>");
    WriteFile(root_ / "assets" / "app-3KX7Q2ZB.js", "console.log(1);");
    WriteFile(root_ / "assets" / "logo.svg", "<svg/>");
    WriteFile(root_ / ".env", "TOKEN=x");
    fs::create_directories(root_ / "sub");
    WriteFile(sandbox_ / "secret.txt", "secret");
    files_ = std::make_unique<StaticFiles>(StaticFilesOptions{root_.string()});
  }

  Response Get(const std::vector<std::string>& segments, const std::string& if_none_match = "",
               const std::string& method = "GET") {
    Request request = MakeRequest(method, "/x");
    if (!if_none_match.empty()) request.headers.emplace_back("If-None-Match", if_none_match);
    return files_->Serve(request, segments);
  }

  softgrasp::testing::TempDir temp_{"static"};
  fs::path sandbox_;
  fs::path root_;
  std::unique_ptr<StaticFiles> files_;
};

TEST(StaticFilesContentType, ByExtensionCaseInsensitive) {
  EXPECT_EQ(ContentTypeForFile("index.html"), "text/html; charset=utf-8");
  EXPECT_EQ(ContentTypeForFile("app-ABCDEFGH.js"), "text/javascript; charset=utf-8");
  EXPECT_EQ(ContentTypeForFile("app.CSS"), "text/css; charset=utf-8");
  EXPECT_EQ(ContentTypeForFile("app.js.map"), "application/json");
  EXPECT_EQ(ContentTypeForFile("logo.svg"), "image/svg+xml");
  EXPECT_EQ(ContentTypeForFile("shot.png"), "image/png");
  EXPECT_EQ(ContentTypeForFile("font.woff2"), "font/woff2");
  EXPECT_EQ(ContentTypeForFile("mesh.bin"), "application/octet-stream");
  EXPECT_EQ(ContentTypeForFile("README"), "application/octet-stream");
  EXPECT_EQ(ContentTypeForFile(".html"), "application/octet-stream");
}

TEST(StaticFilesEntityTag, DependsOnContentAndIsQuoted) {
  const std::string a = EntityTagFor("abc");
  EXPECT_EQ(a, EntityTagFor("abc"));
  EXPECT_NE(a, EntityTagFor("abd"));
  EXPECT_NE(EntityTagFor(""), EntityTagFor(std::string(1, '\0')));
  ASSERT_GE(a.size(), 3u);
  EXPECT_EQ(a.front(), '"');
  EXPECT_EQ(a.back(), '"');
  // FNV-1a 64 of "" is its offset basis.
  EXPECT_EQ(EntityTagFor(""), "\"cbf29ce484222325-0\"");
}

TEST(StaticFilesIfNoneMatch, ListsWildcardAndWeakComparison) {
  const std::string tag = "\"abc-3\"";
  EXPECT_TRUE(IfNoneMatchHits("\"abc-3\"", tag));
  EXPECT_TRUE(IfNoneMatchHits("W/\"abc-3\"", tag));
  EXPECT_TRUE(IfNoneMatchHits("\"x\", \"abc-3\"", tag));
  EXPECT_TRUE(IfNoneMatchHits(" * ", tag));
  EXPECT_FALSE(IfNoneMatchHits("\"abc-4\"", tag));
  EXPECT_FALSE(IfNoneMatchHits("", tag));
  EXPECT_FALSE(IfNoneMatchHits("abc-3", tag));  // unquoted is not the same tag
}

TEST(StaticFilesSegments, RefusesWhatCouldLeaveOrHide) {
  EXPECT_TRUE(IsSafePathSegment("index.html"));
  EXPECT_TRUE(IsSafePathSegment("a..b"));
  const std::vector<std::string> bad_segments = {"",    ".",    "..",   ".env",
                                                 "a/b", "/etc", "a\\b", std::string("a\0b", 3)};
  for (const std::string& bad : bad_segments) {
    EXPECT_FALSE(IsSafePathSegment(bad)) << bad;
  }
}

TEST_F(StaticFilesTest, ServesIndexWithRevalidationAndEtag) {
  const Response response = Get({"index.html"});
  ASSERT_EQ(response.status, 200);
  EXPECT_EQ(response.body, "<!doctype html><title>t</title>");
  EXPECT_EQ(FindHeader(response.headers, "Content-Type").value_or(""), "text/html; charset=utf-8");
  EXPECT_EQ(FindHeader(response.headers, "Cache-Control").value_or(""), "no-cache");
  EXPECT_EQ(FindHeader(response.headers, "ETag").value_or(""), EntityTagFor(response.body));
  EXPECT_EQ(FindHeader(response.headers, "X-Content-Type-Options").value_or(""), "nosniff");
}

TEST_F(StaticFilesTest, HashedAssetsAreImmutable) {
  const Response js = Get({"assets", "app-3KX7Q2ZB.js"});
  ASSERT_EQ(js.status, 200);
  EXPECT_EQ(js.body, "console.log(1);");
  EXPECT_EQ(FindHeader(js.headers, "Content-Type").value_or(""), "text/javascript; charset=utf-8");
  EXPECT_EQ(FindHeader(js.headers, "Cache-Control").value_or(""),
            "public, max-age=31536000, immutable");
  EXPECT_EQ(FindHeader(Get({"assets", "logo.svg"}).headers, "Content-Type").value_or(""),
            "image/svg+xml");
}

TEST_F(StaticFilesTest, IfNoneMatchAnswers304WithoutBody) {
  const std::string etag(FindHeader(Get({"index.html"}).headers, "ETag").value());
  const Response cached = Get({"index.html"}, etag);
  EXPECT_EQ(cached.status, 304);
  EXPECT_TRUE(cached.body.empty());
  EXPECT_EQ(FindHeader(cached.headers, "ETag").value_or(""), etag);
  EXPECT_EQ(FindHeader(cached.headers, "Cache-Control").value_or(""), "no-cache");
  EXPECT_EQ(Get({"index.html"}, "\"stale\"").status, 200);

  // A rebuilt file gets a new tag, so the old one no longer matches.
  WriteFile(root_ / "index.html", "<!doctype html><title>new</title>");
  const Response rebuilt = Get({"index.html"}, etag);
  EXPECT_EQ(rebuilt.status, 200);
  EXPECT_NE(FindHeader(rebuilt.headers, "ETag").value_or(""), etag);
}

TEST_F(StaticFilesTest, HeadAnswersLikeGet) {
  const Response get = Get({"index.html"});
  const Response head = Get({"index.html"}, "", "HEAD");
  EXPECT_EQ(head.status, 200);
  EXPECT_EQ(head.headers, get.headers);  // the server drops HEAD bodies on the wire
}

TEST_F(StaticFilesTest, OtherMethodsAre405) {
  const Response response = Get({"index.html"}, "", "POST");
  EXPECT_EQ(response.status, 405);
  EXPECT_EQ(FindHeader(response.headers, "Allow").value_or(""), "GET, HEAD");
}

TEST_F(StaticFilesTest, NoDirectoryListing) {
  ExpectNotFoundJson(Get({"assets"}));
  ExpectNotFoundJson(Get({"sub"}));
  ExpectNotFoundJson(Get({}));
}

TEST_F(StaticFilesTest, TraversalAndHiddenFilesAre404) {
  ExpectNotFoundJson(Get({"..", "secret.txt"}));
  ExpectNotFoundJson(Get({"assets", "..", "..", "secret.txt"}));
  ExpectNotFoundJson(Get({"../secret.txt"}));
  ExpectNotFoundJson(Get({(sandbox_ / "secret.txt").string()}));  // an absolute path
  ExpectNotFoundJson(Get({std::string("index.html\0.png", 15)}));
  ExpectNotFoundJson(Get({".env"}));
  ExpectNotFoundJson(Get({"missing.html"}));
}

TEST_F(StaticFilesTest, SymlinksLeavingTheRootAre404) {
  fs::create_symlink(sandbox_ / "secret.txt", root_ / "leak.txt");
  fs::create_directory_symlink(sandbox_, root_ / "up");
  fs::create_symlink(root_ / "index.html", root_ / "alias.html");  // stays inside: fine
  ExpectNotFoundJson(Get({"leak.txt"}));
  ExpectNotFoundJson(Get({"up", "secret.txt"}));
  EXPECT_EQ(Get({"alias.html"}).status, 200);
}

TEST_F(StaticFilesTest, SpecialFilesAndMissingRootAre404) {
  ASSERT_EQ(::mkfifo((root_ / "pipe.txt").c_str(), 0600), 0);
  ExpectNotFoundJson(Get({"pipe.txt"}));  // and does not block on open()

  StaticFiles nowhere(StaticFilesOptions{(sandbox_ / "not-built").string()});
  ExpectNotFoundJson(nowhere.Serve(MakeRequest("GET", "/"), {"index.html"}));
  StaticFiles unset(StaticFilesOptions{});
  ExpectNotFoundJson(unset.Serve(MakeRequest("GET", "/"), {"index.html"}));
}

TEST_F(StaticFilesTest, OversizedFileIs500NotAnAllocation) {
  StaticFilesOptions options{root_.string()};
  options.max_file_bytes = 4;
  const Response response = StaticFiles(options).Serve(MakeRequest("GET", "/"), {"index.html"});
  EXPECT_EQ(response.status, 500);
  EXPECT_EQ(json::parse(response.body)["error"]["code"], "internal");
}

// Through the router as the service wires it: a capture holds one decoded segment, so encoded
// dots and slashes arrive as a single segment that the file server refuses.
TEST_F(StaticFilesTest, EncodedTraversalThroughTheRouterIs404) {
  Router router;
  router.Add("GET", "/assets/{file}", [this](const Request& r) {
    return files_->Serve(r, {"assets", r.path_params.at("file")});
  });
  const auto dispatch = [&](const std::string& target) {
    Request request = MakeRequest("GET", target);
    return router.Dispatch(request);
  };
  EXPECT_EQ(dispatch("/assets/app-3KX7Q2ZB.js").status, 200);
  EXPECT_EQ(dispatch("/assets/app%2D3KX7Q2ZB.js").status, 200);  // %2D is '-'
  for (const char* target :
       {"/assets/%2e%2e", "/assets/%2E%2E%2Fsecret.txt", "/assets/..%2f..%2fsecret.txt",
        "/assets/%2fetc%2fpasswd", "/assets/logo.svg%00.js", "/assets/.."}) {
    SCOPED_TRACE(target);
    ExpectNotFoundJson(dispatch(target));
  }
}

}  // namespace
}  // namespace softgrasp::http
