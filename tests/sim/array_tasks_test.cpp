// Array tasks: the split of a batch into N contiguous parts, the partial indexes, and their merge
// into the index one process writes (byte for byte), with the errors a half-finished or mixed-up
// array job gives.
#include "sim/tasks/array_tasks.h"

#include <gtest/gtest.h>

#include <string>

#include "service/cli/files.h"
#include "tests/support/temp_dir.h"

namespace softgrasp::sim {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::string Slurp(const fs::path& p) { return cli::ReadFile(p).value(); }

// An index like the batch commands write: a header and one entry per item.
json IndexOf(int first, int end, int total, int seed = 7) {
  json entries = json::array();
  for (int i = first; i < end; ++i) entries.push_back({{"file", "item_" + std::to_string(i)}});
  return {{"generator", "test"}, {"seed", seed}, {"count", total}, {"models", entries}};
}

// Writes the partial indexes of tasks `which` of N into `dir`.
void WriteParts(const fs::path& dir, int total, int n, std::initializer_list<int> which,
                int seed = 7) {
  for (int k : which) {
    const ArrayTask task{k, n};
    const ItemRange items = TaskItems(task, total);
    ASSERT_TRUE(
        WriteTaskIndex(dir, IndexOf(items.first, items.end, total, seed), task, items, "models")
            .ok());
  }
}

TEST(ArrayTasks, SplitsIntoContiguousPartsOfAlmostEqualSize) {
  for (int items : {1, 2, 7, 10, 101}) {
    for (int n = 1; n <= std::min(items, 12); ++n) {
      int next = 0;
      for (int k = 0; k < n; ++k) {
        const ItemRange r = TaskItems({k, n}, items);
        EXPECT_EQ(r.first, next) << items << " items, task " << k << " of " << n;
        const int size = r.end - r.first;
        EXPECT_TRUE(size == items / n || size == items / n + 1);
        next = r.end;
      }
      EXPECT_EQ(next, items);
    }
  }
}

TEST(ArrayTasks, ChecksTheTaskAgainstTheBatch) {
  EXPECT_EQ(CheckArrayTask({0, 1}, 5), "");
  EXPECT_EQ(CheckArrayTask({4, 5}, 5), "");
  EXPECT_NE(CheckArrayTask({5, 5}, 5), "");
  EXPECT_NE(CheckArrayTask({-1, 2}, 5), "");
  EXPECT_NE(CheckArrayTask({0, 0}, 5), "");
  EXPECT_NE(CheckArrayTask({0, 6}, 5).find("more than the 5 items"), std::string::npos);
  EXPECT_EQ(IndexFileName({0, 1}), "index.json");
  EXPECT_EQ(IndexFileName({2, 3}), "index.task-2-of-3.json");
}

TEST(ArrayTasks, MergedPartsAreTheBytesOfOneProcess) {
  const softgrasp::testing::TempDir whole("array-tasks-whole");
  const softgrasp::testing::TempDir split("array-tasks-split");
  ASSERT_TRUE(WriteTaskIndex(whole.path(), IndexOf(0, 10, 10), {0, 1}, {0, 10}, "models").ok());
  WriteParts(split.path(), 10, 4, {3, 1, 0, 2});  // in any order
  const json part = json::parse(Slurp(split / "index.task-1-of-4.json"));
  EXPECT_EQ(part["task"],
            json({{"index", 1}, {"of", 4}, {"first", 2}, {"end", 5}, {"entries_key", "models"}}));
  auto merged = MergeTaskIndexes(split.path());
  ASSERT_TRUE(merged.ok()) << merged.error().message;
  EXPECT_EQ(merged.value(), split / "index.json");
  EXPECT_EQ(Slurp(split / "index.json"), Slurp(whole / "index.json"));
}

TEST(ArrayTasks, AMissingTaskIsNamedAndNothingIsWritten) {
  const softgrasp::testing::TempDir dir("array-tasks-missing");
  WriteParts(dir.path(), 10, 4, {0, 2});
  auto merged = MergeTaskIndexes(dir.path());
  ASSERT_FALSE(merged.ok());
  EXPECT_EQ(merged.error().code, core::ErrorCode::kNotFound);
  EXPECT_NE(merged.error().message.find("have not written their index: 1,3"), std::string::npos)
      << merged.error().message;
  EXPECT_FALSE(fs::exists(dir / "index.json"));
  // Re-running the missing tasks alone completes it.
  WriteParts(dir.path(), 10, 4, {1, 3});
  EXPECT_TRUE(MergeTaskIndexes(dir.path()).ok());
}

TEST(ArrayTasks, PartsOfDifferentRunsAreRefused) {
  {
    const softgrasp::testing::TempDir dir("array-tasks-seed");
    WriteParts(dir.path(), 10, 2, {0});
    WriteParts(dir.path(), 10, 2, {1}, /*seed=*/8);
    auto merged = MergeTaskIndexes(dir.path());
    ASSERT_FALSE(merged.ok());
    EXPECT_NE(merged.error().message.find("other arguments than task 0"), std::string::npos);
  }
  {
    const softgrasp::testing::TempDir dir("array-tasks-n");
    WriteParts(dir.path(), 10, 2, {0, 1});
    WriteParts(dir.path(), 10, 3, {0});
    auto merged = MergeTaskIndexes(dir.path());
    ASSERT_FALSE(merged.ok());
    EXPECT_NE(merged.error().message.find("remove the stale ones"), std::string::npos)
        << merged.error().message;
  }
  {
    const softgrasp::testing::TempDir dir("array-tasks-broken");
    WriteParts(dir.path(), 10, 2, {0});
    ASSERT_FALSE(cli::WriteFile(dir / "index.task-1-of-2.json", "{\"task\": 3").has_value());
    auto merged = MergeTaskIndexes(dir.path());
    ASSERT_FALSE(merged.ok());
    EXPECT_EQ(merged.error().code, core::ErrorCode::kInvalidArgument);
    EXPECT_NE(merged.error().message.find("not a partial index"), std::string::npos);
  }
  {
    const softgrasp::testing::TempDir dir("array-tasks-gap");
    WriteParts(dir.path(), 10, 2, {0});
    // Task 1's part claims other items than the split gives it.
    json bad = IndexOf(6, 10, 10);
    ASSERT_TRUE(WriteTaskIndex(dir.path(), bad, {1, 2}, {6, 10}, "models").ok());
    auto merged = MergeTaskIndexes(dir.path());
    ASSERT_FALSE(merged.ok());
    EXPECT_NE(merged.error().message.find("expected to start at 5"), std::string::npos)
        << merged.error().message;
  }
  {
    // Names that only look like parts are not parts; a part beyond N is refused.
    const softgrasp::testing::TempDir dir("array-tasks-names");
    WriteParts(dir.path(), 10, 2, {0, 1});
    for (const char* stray : {"index.task-x-of-2.json", "index.task-1-of-2.json.tmp",
                              "index.task--1-of-2.json", "index.task-1-of-.json"}) {
      ASSERT_FALSE(cli::WriteFile(dir / stray, "{}").has_value());
    }
    EXPECT_TRUE(MergeTaskIndexes(dir.path()).ok());
    ASSERT_FALSE(cli::WriteFile(dir / "index.task-2-of-2.json", "{}").has_value());
    auto merged = MergeTaskIndexes(dir.path());
    ASSERT_FALSE(merged.ok());
    EXPECT_NE(merged.error().message.find("names no task of 2"), std::string::npos)
        << merged.error().message;
  }
  const softgrasp::testing::TempDir empty("array-tasks-empty");
  EXPECT_EQ(MergeTaskIndexes(empty.path()).error().code, core::ErrorCode::kNotFound);
  EXPECT_EQ(MergeTaskIndexes(empty / "absent").error().code, core::ErrorCode::kNotFound);
}

}  // namespace
}  // namespace softgrasp::sim
