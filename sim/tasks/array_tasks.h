#pragma once
/// Batch commands split into array tasks (Slurm `sbatch --array`, or any scheduler): task K of N
/// makes a contiguous part of the items, each item from its own seed exactly as one process
/// would, and writes a partial index; merging the N partial indexes writes the index.json that
/// one process would have written, byte for byte. docs/slurm.md.
///
/// A partial index is the whole index with only the task's entries, plus a "task" object
/// {"index": K, "of": N, "first": i, "end": j, "entries_key": "..."}; it is named
/// index.task-K-of-N.json. Merging drops "task", checks that the N parts agree on everything
/// else and cover every item once, and concatenates the entries in task order.

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "service/core/status.h"

namespace softgrasp::sim {

struct ArrayTask {
  int index = 0;  ///< K, 0-based
  int count = 1;  ///< N; 1 = the whole batch in one process
};

/// "" if `task` is usable for `items` items (1 <= N <= items, 0 <= K < N), else why not.
std::string CheckArrayTask(const ArrayTask& task, int items);

/// The items [first, end) of task K: N contiguous ranges whose sizes differ by at most one.
struct ItemRange {
  int first = 0;
  int end = 0;
};
ItemRange TaskItems(const ArrayTask& task, int items);

/// "index.json" for a whole batch, "index.task-K-of-N.json" for task K of N > 1.
std::string IndexFileName(const ArrayTask& task);

/// Writes `index` (its `entries_key` array holding this task's entries only) as DIR/IndexFileName,
/// adding the "task" object when N > 1. The bytes are index.dump(2) + "\n", as the batch commands
/// write a whole index. Returns the path.
core::Result<std::filesystem::path> WriteTaskIndex(const std::filesystem::path& dir,
                                                   nlohmann::json index, const ArrayTask& task,
                                                   const ItemRange& items,
                                                   const std::string& entries_key);

/// The partial indexes DIR/index.task-K-of-N.json, K = 0..N-1 in order. Errors: kNotFound naming
/// the missing tasks (re-run those alone) or when there is none; kInvalidArgument when the folder
/// mixes parts of different N.
core::Result<std::vector<std::filesystem::path>> FindTaskIndexes(const std::filesystem::path& dir);

/// Merges DIR/index.task-K-of-N.json (K = 0..N-1) into DIR/index.json. Errors (nothing written):
/// kNotFound naming the missing tasks (re-run those alone), kInvalidArgument for parts that are
/// unreadable, made with other arguments, or of different N. The partial indexes are kept.
core::Result<std::filesystem::path> MergeTaskIndexes(const std::filesystem::path& dir);

}  // namespace softgrasp::sim
