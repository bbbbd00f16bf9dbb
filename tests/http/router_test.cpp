#include "service/http/router.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>

namespace softgrasp::http {
namespace {

Request MakeRequest(std::string method, std::string target) {
  Request request;
  request.method = std::move(method);
  request.target = target;
  request.path = *PercentDecode(target.substr(0, target.find('?')), false);
  return request;
}

/// A handler that answers "<tag>" plus its captured parameters.
Handler Answer(std::string tag) {
  return [tag](const Request& request) {
    std::string body = tag;
    for (const auto& [name, value] : request.path_params) body += " " + name + "=" + value;
    return Response::Bytes(200, "text/plain", body);
  };
}

class HttpRouter : public ::testing::Test {
 protected:
  void SetUp() override {
    router_.Add("GET", "/", Answer("root"));
    router_.Add("GET", "/v1/grasps", Answer("list"));
    router_.Add("POST", "/v1/grasps", Answer("create"));
    router_.Add("GET", "/v1/grasps/{id}", Answer("get"));
    router_.Add("DELETE", "/v1/grasps/{id}", Answer("delete"));
    router_.Add("GET", "/v1/grasps/latest", Answer("latest"));
    router_.Add("GET", "/v1/robots/{robot}/grasps/{id}", Answer("nested"));
    router_.Add("HEAD", "/v1/explicit-head", Answer("head"));
    router_.Add("GET", "/v1/explicit-head", Answer("get-for-head"));
  }

  Response Dispatch(const std::string& method, const std::string& target) {
    Request request = MakeRequest(method, target);
    return router_.Dispatch(request);
  }

  Router router_;
};

TEST_F(HttpRouter, MatchesLiteralRoutes) {
  EXPECT_EQ(Dispatch("GET", "/").body, "root");
  EXPECT_EQ(Dispatch("GET", "/v1/grasps").body, "list");
  EXPECT_EQ(Dispatch("POST", "/v1/grasps").body, "create");
  EXPECT_EQ(Dispatch("GET", "/v1/grasps?limit=3").body, "list");
}

TEST_F(HttpRouter, CapturesDecodedParameters) {
  EXPECT_EQ(Dispatch("GET", "/v1/grasps/42").body, "get id=42");
  EXPECT_EQ(Dispatch("DELETE", "/v1/grasps/a%20b").body, "delete id=a b");
  // An encoded slash stays inside its segment.
  EXPECT_EQ(Dispatch("GET", "/v1/grasps/a%2Fb").body, "get id=a/b");
  EXPECT_EQ(Dispatch("GET", "/v1/robots/r1/grasps/g2").body, "nested id=g2 robot=r1");

  Request request = MakeRequest("GET", "/v1/grasps/7");
  request.path_params["stale"] = "x";
  router_.Dispatch(request);
  EXPECT_EQ(request.path_params.size(), 1u);
  EXPECT_EQ(request.path_params.at("id"), "7");
}

TEST_F(HttpRouter, LiteralSegmentsWinOverCaptures) {
  EXPECT_EQ(Dispatch("GET", "/v1/grasps/latest").body, "latest");
}

TEST_F(HttpRouter, UnknownPathIs404Json) {
  for (const char* target : {"/nope", "/v1/grasps/1/extra", "/v1/grasps/", "/v1"}) {
    SCOPED_TRACE(target);
    const Response response = Dispatch("GET", target);
    EXPECT_EQ(response.status, 404);
    EXPECT_EQ(FindHeader(response.headers, "Content-Type"), "application/json");
    EXPECT_EQ(nlohmann::json::parse(response.body)["error"]["code"], "not_found");
  }
}

TEST_F(HttpRouter, WrongMethodIs405WithAllow) {
  Response response = Dispatch("PUT", "/v1/grasps");
  EXPECT_EQ(response.status, 405);
  EXPECT_EQ(FindHeader(response.headers, "Allow"), "GET, POST, HEAD");
  EXPECT_EQ(nlohmann::json::parse(response.body)["error"]["code"], "method_not_allowed");

  response = Dispatch("POST", "/v1/grasps/5");
  EXPECT_EQ(response.status, 405);
  EXPECT_EQ(FindHeader(response.headers, "Allow"), "GET, DELETE, HEAD");
}

TEST_F(HttpRouter, HeadFallsBackToGet) {
  EXPECT_EQ(Dispatch("HEAD", "/v1/grasps").body, "list");
  EXPECT_EQ(Dispatch("HEAD", "/v1/grasps/9").body, "get id=9");
  EXPECT_EQ(Dispatch("HEAD", "/v1/explicit-head").body, "head");
  EXPECT_EQ(Dispatch("HEAD", "/nope").status, 404);
}

TEST_F(HttpRouter, MethodsAreCaseSensitive) {
  EXPECT_EQ(Dispatch("get", "/v1/grasps").status, 405);
}

TEST_F(HttpRouter, WorksFromThePathAlone) {
  Request request;
  request.method = "GET";
  request.path = "/v1/grasps/x";
  EXPECT_EQ(router_.Dispatch(request).body, "get id=x");
}

TEST_F(HttpRouter, RoutesAreListedInRegistrationOrder) {
  const auto routes = router_.Routes();
  ASSERT_EQ(routes.size(), 9u);
  EXPECT_EQ(routes[0], (std::pair<std::string, std::string>("GET", "/")));
  EXPECT_EQ(routes[3], (std::pair<std::string, std::string>("GET", "/v1/grasps/{id}")));
}

TEST(HttpRouterInline, OnlyTheRoutesAddedInlineAnswerInline) {
  Router router;
  router.Add("GET", "/healthz", Answer("health"), Router::Execution::kInline);
  router.Add("POST", "/healthz", Answer("post"));
  router.Add("GET", "/v1/items/{id}", Answer("item"));
  router.Add("GET", "/v1/items/fast", Answer("fast"), Router::Execution::kInline);
  EXPECT_TRUE(router.AnswersInline(MakeRequest("GET", "/healthz")));
  EXPECT_TRUE(router.AnswersInline(MakeRequest("HEAD", "/healthz")));  // HEAD uses the GET route
  EXPECT_FALSE(router.AnswersInline(MakeRequest("POST", "/healthz")));
  EXPECT_TRUE(router.AnswersInline(MakeRequest("GET", "/v1/items/fast")));  // the literal wins
  EXPECT_FALSE(router.AnswersInline(MakeRequest("GET", "/v1/items/7")));
  EXPECT_FALSE(router.AnswersInline(MakeRequest("DELETE", "/healthz")));  // 405
  EXPECT_FALSE(router.AnswersInline(MakeRequest("GET", "/nowhere")));     // 404
  Request undecodable;
  undecodable.method = "GET";
  undecodable.target = undecodable.path = "/healthz%zz";
  EXPECT_FALSE(router.AnswersInline(undecodable));
  // Dispatch calls the same route either way.
  Request request = MakeRequest("GET", "/healthz");
  EXPECT_EQ(router.Dispatch(request).body, "health");
}

TEST(HttpRouterAdd, RejectsPatternsWithoutLeadingSlash) {
  Router router;
  EXPECT_THROW(router.Add("GET", "v1/x", Answer("x")), std::invalid_argument);
  EXPECT_THROW(router.Add("GET", "", Answer("x")), std::invalid_argument);
}

TEST(HttpRouterAdd, HandlerExceptionsPropagate) {
  Router router;
  router.Add("GET", "/boom", [](const Request&) -> Response { throw std::runtime_error("x"); });
  Request request = MakeRequest("GET", "/boom");
  EXPECT_THROW(router.Dispatch(request), std::runtime_error);  // the server turns this into 500
}

}  // namespace
}  // namespace softgrasp::http
