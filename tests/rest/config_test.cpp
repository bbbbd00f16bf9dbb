#include <cstdlib>

#include <gtest/gtest.h>

#include "service/rest/config.h"

namespace softgrasp::rest {
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
  EXPECT_EQ(c.value().default_gripper.opening_stroke_mm, 85.0);
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

}  // namespace
}  // namespace softgrasp::rest
