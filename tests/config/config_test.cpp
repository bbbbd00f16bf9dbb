#include "service/config/config.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

namespace softgrasp::config {
namespace {

TEST(ConfigTest, JsonOverridesDefaults) {
  auto c = ApplyConfigJson(ServiceConfig{},
                           R"({"server": {"port": 9001, "max_body_bytes": 1000},
                               "gripper": {"opening_stroke_mm": 85},
                               "camera": {"fx": 600, "fy": 600, "cx": 320, "cy": 240},
                               "fge": {"num_angles": 12}, "depth": {"png_unit_m": 0.0001}})");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c.value().server.port, 9001);
  EXPECT_EQ(c.value().server.limits.max_body_bytes, 1000u);
  EXPECT_DOUBLE_EQ(c.value().default_gripper.opening_stroke_m, 0.085);
  EXPECT_EQ(c.value().default_camera.fx, 600.0);
  EXPECT_EQ(c.value().fge.num_angles, 12);
  EXPECT_EQ(c.value().png_unit_m, 0.0001);
}

TEST(ConfigTest, RejectsUnknownKeysWrongTypesAndRanges) {
  EXPECT_EQ(ApplyConfigJson({}, R"({"server": {"prot": 1}})").error().field, "server.prot");
  EXPECT_EQ(ApplyConfigJson({}, R"({"srv": {}})").error().field, "srv");
  EXPECT_EQ(ApplyConfigJson({}, R"({"server": {"port": "80"}})").error().field, "server.port");
  EXPECT_EQ(ApplyConfigJson({}, R"({"server": {"port": 70000}})").error().field, "server.port");
  EXPECT_EQ(ApplyConfigJson({}, R"({"fge": {"num_angles": 2.5}})").error().field, "fge.num_angles");
  EXPECT_FALSE(ApplyConfigJson({}, "{not json").ok());
  EXPECT_FALSE(ApplyConfigJson({}, "[1]").ok());
}

TEST(ConfigTest, FlagsBeatEnvironment) {
  ::setenv("SOFTGRASP_PORT", "7000", 1);
  auto from_env = ParseCommandLine({});
  ASSERT_TRUE(from_env.ok());
  EXPECT_EQ(from_env.value().config.server.port, 7000);
  auto from_flag = ParseCommandLine({"--port", "0", "--host", "::1"});
  ASSERT_TRUE(from_flag.ok());
  EXPECT_EQ(from_flag.value().config.server.port, 0);
  EXPECT_EQ(from_flag.value().config.server.host, "::1");
  ::setenv("SOFTGRASP_PORT", "eighty", 1);
  EXPECT_FALSE(ParseCommandLine({}).ok());
  ::unsetenv("SOFTGRASP_PORT");
}

TEST(ConfigTest, BadCommandLinesAreErrors) {
  EXPECT_FALSE(ParseCommandLine({"--port"}).ok());
  EXPECT_FALSE(ParseCommandLine({"--port", "99999"}).ok());
  EXPECT_FALSE(ParseCommandLine({"--bogus"}).ok());
  EXPECT_FALSE(ParseCommandLine({"--config", "/nonexistent/softgrasp.json"}).ok());
  EXPECT_TRUE(ParseCommandLine({"--help"}).value().help);
}

TEST(ConfigTest, RobotSectionTokensAndWorkspace) {
  auto c = ApplyConfigJson(ServiceConfig{}, R"({"robot": {
      "enabled": true, "domain_id": 7, "tokens": ["0123456789abcdef-secret"],
      "workspace": {"frame_id": "base", "min_m": [-1, -1, 0], "max_m": [1, 1, 2]},
      "command_timeout_s": 5, "journal_dir": "/tmp/j", "default_force_n": 4.5}})");
  ASSERT_TRUE(c.ok()) << c.error().message;
  const RobotConfig& r = c.value().robot;
  EXPECT_EQ(r.domain_id, 7);
  EXPECT_EQ(r.tokens, std::vector<std::string>{"0123456789abcdef-secret"});
  EXPECT_EQ(r.workspace.frame_id, "base");
  EXPECT_EQ(r.workspace.max_m[2], 2.0);
  EXPECT_EQ(r.command_timeout_s, 5.0);
  EXPECT_EQ(r.default_force_n, 4.5);
  EXPECT_EQ(RobotDisabledReason(r), "");
  // The effective config printed at start-up never shows a token.
  const std::string printed = ConfigToJson(c.value());
  EXPECT_EQ(printed.find("secret"), std::string::npos);
  EXPECT_NE(printed.find("\"tokens\":[\"***\"]"), std::string::npos) << printed;

  for (const char* bad :
       {R"({"robot": {"tokens": ["short"]}})",
        R"({"robot": {"tokens": ["has a space in it, 123456"]}})",
        R"({"robot": {"tokens": "0123456789abcdef"}})", R"({"robot": {"domain_id": 233}})",
        R"({"robot": {"workspace": {"min_m": [0, 0, 1], "max_m": [1, 1, 1]}}})",
        R"({"robot": {"workspace": {"min_m": [0, 0]}}})", R"({"robot": {"enabled": "yes"}})"}) {
    auto e = ApplyConfigJson(ServiceConfig{}, bad);
    ASSERT_FALSE(e.ok()) << bad;
    EXPECT_EQ(e.error().message.find("short"), std::string::npos);  // the token is not echoed
    EXPECT_EQ(e.error().field.rfind("robot.", 0), 0u) << e.error().field;
  }
  EXPECT_NE(RobotDisabledReason(RobotConfig{}).find("no tokens"), std::string::npos);
  RobotConfig off;
  off.enabled = false;
  off.tokens = {"0123456789abcdef"};
  EXPECT_NE(RobotDisabledReason(off).find("robot.enabled"), std::string::npos);
}

TEST(ConfigTest, RobotEnvironment) {
  ::setenv("SOFTGRASP_ROBOT_TOKENS", " 0123456789abcdef-one , 0123456789abcdef-two,", 1);
  ::setenv("SOFTGRASP_ROBOT_DOMAIN_ID", "42", 1);
  ::setenv("SOFTGRASP_ROBOT_COMMAND_TIMEOUT_S", "2.5", 1);
  ::setenv("SOFTGRASP_ROBOT_ENABLED", "false", 1);
  auto c = ApplyEnvironment(ServiceConfig{});
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c.value().robot.tokens,
            (std::vector<std::string>{"0123456789abcdef-one", "0123456789abcdef-two"}));
  EXPECT_EQ(c.value().robot.domain_id, 42);
  EXPECT_EQ(c.value().robot.command_timeout_s, 2.5);
  EXPECT_FALSE(c.value().robot.enabled);
  ::setenv("SOFTGRASP_ROBOT_TOKENS", "0123456789abcdef,tiny", 1);
  auto bad = ApplyEnvironment(ServiceConfig{});
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().field, "SOFTGRASP_ROBOT_TOKENS");
  EXPECT_EQ(bad.error().message.find("tiny"), std::string::npos);
  for (const char* name : {"SOFTGRASP_ROBOT_TOKENS", "SOFTGRASP_ROBOT_DOMAIN_ID",
                           "SOFTGRASP_ROBOT_COMMAND_TIMEOUT_S", "SOFTGRASP_ROBOT_ENABLED"}) {
    ::unsetenv(name);
  }
}

// One table drives the file, the environment, the flags, the dump and the usage text.
TEST(ConfigTable, EverySettingIsNamedOnceAndReachesTheDumpAndTheUsage) {
  const nlohmann::json dump = nlohmann::json::parse(ConfigToJson(ServiceConfig{}));
  const std::string usage = UsageText();
  std::set<std::string> keys, envs, flags;
  for (const Setting& s : Settings()) {
    const std::string key = std::string(s.section) + "." + s.key;
    SCOPED_TRACE(key);
    EXPECT_TRUE(keys.insert(key).second);
    EXPECT_TRUE(dump.at(s.section).contains(s.key));
    EXPECT_LE(s.min, s.max);
    EXPECT_NE(std::string(s.help), "");
    if (s.env != nullptr) {
      EXPECT_TRUE(envs.insert(s.env).second);
      EXPECT_NE(usage.find(s.env), std::string::npos);
    }
    if (s.flag != nullptr) {
      EXPECT_TRUE(flags.insert(s.flag).second);
      EXPECT_NE(usage.find(s.flag), std::string::npos);
    }
  }
  EXPECT_EQ(SettingOf("server", "port").env, std::string("SOFTGRASP_PORT"));
  EXPECT_THROW(SettingOf("server", "nope"), std::invalid_argument);
}

TEST(ConfigTable, TheDefaultsReadBackThroughTheFile) {
  nlohmann::json dump = nlohmann::json::parse(ConfigToJson(ServiceConfig{}));
  dump["robot"].erase("tokens_configured");  // dump-only
  auto c = ApplyConfigJson(ServiceConfig{}, dump.dump());
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(ConfigToJson(c.value()), ConfigToJson(ServiceConfig{}));
}

TEST(ConfigTable, OneSetOfLimitsWhereverAValueComesFrom) {
  const Setting steps = SettingOf("fge", "num_height_steps");
  EXPECT_EQ(steps.max, core::kMaxHeightSteps);  // what the planner accepts
  EXPECT_TRUE(ApplyConfigJson({}, R"({"fge": {"num_height_steps": 40}})").ok());
  EXPECT_EQ(ApplyConfigJson({}, R"({"fge": {"num_height_steps": 41}})").error().field,
            "fge.num_height_steps");
  ::setenv("SOFTGRASP_MIN_DEPTH_M", "101", 1);
  auto env = ApplyEnvironment(ServiceConfig{});
  ::unsetenv("SOFTGRASP_MIN_DEPTH_M");
  ASSERT_FALSE(env.ok());
  EXPECT_EQ(env.error().field, "SOFTGRASP_MIN_DEPTH_M");
  EXPECT_NE(env.error().message.find("[0, 100]"), std::string::npos) << env.error().message;
  auto flag = ParseCommandLine({"--workers", "0"});
  ASSERT_FALSE(flag.ok());
  EXPECT_EQ(flag.error().field, "--workers");
  EXPECT_NE(flag.error().message.find("[1, 256]"), std::string::npos) << flag.error().message;
  EXPECT_FALSE(ParseCommandLine({"--port", "80x"}).ok());
}

}  // namespace
}  // namespace softgrasp::config
