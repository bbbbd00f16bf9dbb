#include "service/cli/args.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

namespace softgrasp::cli {
namespace {

std::string FinishMessage(const Args& args) {
  const auto error = args.Finish();
  return error ? error->message : "";
}

TEST(CliArgs, OptionsAndFlagsAreTakenOutAndWhatIsLeftIsUnknown) {
  Args args({"--data", "d", "extra", "--resume", "--out", "m.pt", "--what", "1"});
  std::string data, out;
  EXPECT_TRUE(args.Text("--data", &data));
  EXPECT_TRUE(args.Flag("--resume"));
  EXPECT_TRUE(args.Required("--out", "MODEL", &out));
  EXPECT_EQ(data, "d");
  EXPECT_EQ(out, "m.pt");
  EXPECT_TRUE(args.ok());
  EXPECT_EQ(args.remaining(), (std::vector<std::string>{"extra", "--what", "1"}));
  const auto error = args.Finish();
  ASSERT_TRUE(error);
  EXPECT_EQ(error->message, "unknown argument extra");
  EXPECT_EQ(error->code, core::ErrorCode::kInvalidArgument);
}

TEST(CliArgs, AbsentOptionsLeaveTheirDefaults) {
  Args args({});
  int steps = 7;
  double lr = 0.5;
  std::string text = "default";
  EXPECT_FALSE(args.Int("--steps", 1, 100, &steps));
  EXPECT_FALSE(args.Number("--lr", Bounds::Above(0), &lr));
  EXPECT_FALSE(args.Text("--name", &text));
  EXPECT_FALSE(args.Flag("--resume"));
  EXPECT_TRUE(args.All("--user-mesh").empty());
  EXPECT_EQ(steps, 7);
  EXPECT_EQ(lr, 0.5);
  EXPECT_EQ(text, "default");
  EXPECT_FALSE(args.Finish());
}

TEST(CliArgs, MissingValuesAndRequiredOptions) {
  {
    Args args({"--steps"});
    int steps = 0;
    EXPECT_FALSE(args.Int("--steps", 1, 10, &steps));
    EXPECT_EQ(FinishMessage(args), "--steps needs a value");
    EXPECT_EQ(args.Finish()->field, "steps");
  }
  {
    // A token that starts with "--" is the next option, never a value.
    Args args({"--data", "--out", "m"});
    std::string data;
    EXPECT_FALSE(args.Text("--data", &data));
    EXPECT_EQ(FinishMessage(args), "--data needs a value");
  }
  {
    Args args({"--out", "m"});
    std::string data;
    EXPECT_FALSE(args.Required("--data", "DIR", &data));
    EXPECT_EQ(FinishMessage(args), "--data DIR is required");
    EXPECT_EQ(args.Finish()->field, "data");
  }
  {
    // Values may start with one dash, and may be empty.
    Args args({"--lr", "-1", "--name", ""});
    double lr = 0;
    std::string name = "x";
    EXPECT_TRUE(args.Number("--lr", Bounds::Any(), &lr));
    EXPECT_TRUE(args.Text("--name", &name));
    EXPECT_EQ(lr, -1.0);
    EXPECT_EQ(name, "");
    EXPECT_FALSE(args.Finish());
  }
}

TEST(CliArgs, IntegersAndCountsInRange) {
  const struct {
    std::vector<std::string> argv;
    std::string message;  // "" when accepted
  } cases[] = {
      {{"--steps", "5"}, ""},
      {{"--steps", "1"}, ""},
      {{"--steps", "10"}, ""},
      {{"--steps", "0"}, "--steps must be an integer in 1..10"},
      {{"--steps", "11"}, "--steps must be an integer in 1..10"},
      {{"--steps", "ten"}, "--steps must be an integer in 1..10"},
      {{"--steps", "5x"}, "--steps must be an integer in 1..10"},
      {{"--steps", "5.0"}, "--steps must be an integer in 1..10"},
      {{"--steps", ""}, "--steps must be an integer in 1..10"},
      {{"--steps", " 5"}, "--steps must be an integer in 1..10"},
      {{"--steps", "99999999999999999999999"}, "--steps must be an integer in 1..10"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.argv[1]);
    Args args(c.argv);
    int steps = -1;
    EXPECT_EQ(args.Int("--steps", 1, 10, &steps), c.message.empty());
    EXPECT_EQ(FinishMessage(args), c.message);
    EXPECT_EQ(steps, c.message.empty() ? std::stoi(c.argv[1]) : -1);
  }
  {
    Args args({"--grasp-scenes", "x"});
    int n = 0;
    EXPECT_FALSE(args.Count("--grasp-scenes", &n));
    EXPECT_EQ(FinishMessage(args), "--grasp-scenes must be a count in 0..1000000");
  }
  {
    Args args({"--bins", "0", "--scenes", "-1"});
    int bins = 5, scenes = 5;
    EXPECT_TRUE(args.Count("--bins", &bins));
    EXPECT_EQ(bins, 0);
    EXPECT_FALSE(args.Count("--scenes", &scenes, 100));
    EXPECT_EQ(FinishMessage(args), "--scenes must be a count in 0..100");
  }
  {
    // No upper limit: ">= lo", narrowed to what the target holds.
    Args args({"--seed", "-1"});
    std::uint64_t seed = 0;
    EXPECT_FALSE(args.Int("--seed", 0, kNoLimit, &seed));
    EXPECT_EQ(FinishMessage(args), "--seed must be an integer >= 0");
  }
  {
    Args args({"--seed", "4611686018427387904"});
    std::uint64_t seed = 0;
    EXPECT_TRUE(args.Int("--seed", 0, kNoLimit, &seed));
    EXPECT_EQ(seed, 4611686018427387904ull);
  }
  {
    Args args({"--port", "-1"});
    unsigned short port = 0;
    EXPECT_FALSE(args.Int("--port", -5, 70000, &port));
    EXPECT_EQ(FinishMessage(args), "--port must be an integer in 0..65535");
  }
  {
    Args args({"--threads", "3000000000"});
    int threads = 0;
    EXPECT_FALSE(args.Int("--threads", 1, kNoLimit, &threads));
    EXPECT_EQ(FinishMessage(args), "--threads must be an integer in 1..2147483647");
  }
}

TEST(CliArgs, NumbersInRange) {
  const struct {
    std::string value;
    Bounds bounds;
    std::string message;  // "" when accepted
  } cases[] = {
      {"0.5", Bounds::Closed(0, 1), ""},
      {"0", Bounds::Closed(0, 1), ""},
      {"1", Bounds::Closed(0, 1), ""},
      {"2", Bounds::Closed(0, 1), "--x must be a number in [0, 1]"},
      {"", Bounds::Closed(0, 1), "--x must be a number in [0, 1]"},
      {"1x", Bounds::AtLeast(0), "--x must be a number >= 0"},
      {"inf", Bounds::AtLeast(0), "--x must be a number >= 0"},
      {"nan", Bounds::Any(), "--x must be a number"},
      {"-1", Bounds::AtLeast(0), "--x must be a number >= 0"},
      {"0", Bounds::Above(0), "--x must be a number > 0"},
      {"1e-3", Bounds::Above(0), ""},
      {"0.05", Bounds::LeftOpen(0.05, 5), "--x must be a number in (0.05, 5]"},
      {"5", Bounds::LeftOpen(0.05, 5), ""},
      {"-3.5", Bounds::Any(), ""},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.value);
    Args args({"--x", c.value});
    double x = 42;
    EXPECT_EQ(args.Number("--x", c.bounds, &x), c.message.empty());
    EXPECT_EQ(FinishMessage(args), c.message);
    if (!c.message.empty()) {
      EXPECT_EQ(x, 42);
    }
  }
  Args args({"--threshold", "0.25"});
  float threshold = 0;
  EXPECT_TRUE(args.Number("--threshold", Bounds::Closed(0, 1), &threshold));
  EXPECT_EQ(threshold, 0.25f);
}

TEST(CliArgs, SpansAndChoices) {
  {
    Args args({"--objects", "3-8", "--maps", "4"});
    int lo = 0, hi = 0, maps_lo = 0, maps_hi = 0;
    EXPECT_TRUE(args.Span("--objects", 1, 40, &lo, &hi));
    EXPECT_TRUE(args.Span("--maps", 1, 32, &maps_lo, &maps_hi));
    EXPECT_EQ(lo, 3);
    EXPECT_EQ(hi, 8);
    EXPECT_EQ(maps_lo, 4);
    EXPECT_EQ(maps_hi, 4);
    EXPECT_FALSE(args.Finish());
  }
  for (const char* bad : {"0-3", "5-3", "1-41", "a-b", "3-", "-", ""}) {
    SCOPED_TRACE(bad);
    Args args({"--objects", bad});
    int lo = 0, hi = 0;
    EXPECT_FALSE(args.Span("--objects", 1, 40, &lo, &hi));
    EXPECT_EQ(FinishMessage(args), "--objects must be N or MIN-MAX within 1-40");
  }
  enum class Split { kTrain, kVal };
  {
    Args args({"--split", "val"});
    Split split = Split::kTrain;
    EXPECT_TRUE(
        args.Choice<Split>("--split", {{"train", Split::kTrain}, {"val", Split::kVal}}, &split));
    EXPECT_EQ(split, Split::kVal);
  }
  {
    Args args({"--split", "test"});
    Split split = Split::kTrain;
    EXPECT_FALSE(
        args.Choice<Split>("--split", {{"train", Split::kTrain}, {"val", Split::kVal}}, &split));
    EXPECT_EQ(FinishMessage(args), "--split must be one of train, val");
    EXPECT_EQ(split, Split::kTrain);
  }
}

TEST(CliArgs, RepeatedOptionsAreProblemsUnlessTakenWithAll) {
  {
    Args args({"--steps", "1", "--steps", "2"});
    int steps = 0;
    EXPECT_FALSE(args.Int("--steps", 1, 10, &steps));
    EXPECT_EQ(FinishMessage(args), "--steps given twice");
  }
  {
    Args args({"--resume", "--resume"});
    EXPECT_FALSE(args.Flag("--resume"));
    EXPECT_EQ(FinishMessage(args), "--resume given twice");
  }
  {
    Args args({"--user-mesh", "a.obj", "--seed", "1", "--user-mesh", "b.obj:0.8"});
    EXPECT_EQ(args.All("--user-mesh"), (std::vector<std::string>{"a.obj", "b.obj:0.8"}));
    EXPECT_EQ(args.remaining(), (std::vector<std::string>{"--seed", "1"}));
  }
  {
    Args args({"--user-mesh", "a.obj", "--user-mesh"});
    EXPECT_TRUE(args.All("--user-mesh").empty());
    EXPECT_EQ(FinishMessage(args), "--user-mesh needs a value");
  }
}

TEST(CliArgs, TheFirstProblemSticks) {
  Args args({"--steps", "0", "--batch", "999", "--lr", "0.1", "--what"});
  int steps = 3, batch = 4;
  double lr = 1;
  EXPECT_FALSE(args.Int("--steps", 1, 10, &steps));
  EXPECT_FALSE(args.Int("--batch", 1, 256, &batch));
  EXPECT_FALSE(args.Number("--lr", Bounds::Above(0), &lr));  // valid, but after a problem
  EXPECT_FALSE(args.Fail("a later problem"));
  EXPECT_FALSE(args.ok());
  EXPECT_EQ(steps, 3);
  EXPECT_EQ(batch, 4);
  EXPECT_EQ(lr, 1);
  EXPECT_EQ(FinishMessage(args), "--steps must be an integer in 1..10");
}

TEST(CliArgs, CallersRecordTheirOwnProblems) {
  Args args({"--peak-window", "4"});
  int window = 0;
  EXPECT_TRUE(args.Int("--peak-window", 1, 99, &window));
  if (window % 2 == 0) args.Fail("--peak-window must be odd, 1..99", "--peak-window");
  const auto error = args.Finish();
  ASSERT_TRUE(error);
  EXPECT_EQ(error->message, "--peak-window must be odd, 1..99");
  EXPECT_EQ(error->field, "peak-window");
}

TEST(CliArgs, ParsersOfSingleValues) {
  long long n = 0;
  EXPECT_TRUE(ParseInteger("-12", &n));
  EXPECT_EQ(n, -12);
  EXPECT_FALSE(ParseInteger("", &n));
  EXPECT_FALSE(ParseInteger("1.5", &n));
  EXPECT_FALSE(ParseInteger("12 ", &n));
  double x = 0;
  EXPECT_TRUE(ParseNumber("0.25", &x));
  EXPECT_EQ(x, 0.25);
  EXPECT_FALSE(ParseNumber("1e999", &x));
  EXPECT_FALSE(ParseNumber("-inf", &x));
  EXPECT_FALSE(ParseNumber("0.5,", &x));
}

}  // namespace
}  // namespace softgrasp::cli
