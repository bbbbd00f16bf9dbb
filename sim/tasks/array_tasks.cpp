#include "sim/tasks/array_tasks.h"

#include <charconv>
#include <map>
#include <optional>
#include <string_view>
#include <system_error>
#include <vector>

#include "service/cli/files.h"

namespace softgrasp::sim {
namespace {

using core::ErrorCode;
using core::MakeError;
using nlohmann::json;

constexpr const char* kTaskKey = "task";

/// K and N of a file named index.task-K-of-N.json (decimal, no sign), else nullopt.
std::optional<ArrayTask> ParseTaskIndexName(std::string_view name) {
  constexpr std::string_view kPrefix = "index.task-";
  constexpr std::string_view kSuffix = ".json";
  constexpr std::string_view kOf = "-of-";
  if (!name.starts_with(kPrefix) || !name.ends_with(kSuffix)) return std::nullopt;
  name.remove_prefix(kPrefix.size());
  name.remove_suffix(kSuffix.size());
  const std::size_t of = name.find(kOf);
  if (of == std::string_view::npos) return std::nullopt;
  const auto number = [](std::string_view digits, int* out) {
    if (digits.empty() || digits.size() > 7 || digits.front() < '0' || digits.front() > '9') {
      return false;
    }
    const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), *out);
    return ec == std::errc() && end == digits.data() + digits.size();
  };
  ArrayTask task;
  if (!number(name.substr(0, of), &task.index) ||
      !number(name.substr(of + kOf.size()), &task.count)) {
    return std::nullopt;
  }
  return task;
}

}  // namespace

std::string CheckArrayTask(const ArrayTask& task, int items) {
  if (task.count < 1) return "--tasks must be >= 1";
  if (task.count > items) {
    return "--tasks " + std::to_string(task.count) + " is more than the " + std::to_string(items) +
           " items to make";
  }
  if (task.index < 0 || task.index >= task.count) {
    return "--task must be in 0.." + std::to_string(task.count - 1);
  }
  return "";
}

ItemRange TaskItems(const ArrayTask& task, int items) {
  const long long n = task.count;
  const long long k = task.index;
  return {static_cast<int>(k * items / n), static_cast<int>((k + 1) * items / n)};
}

std::string IndexFileName(const ArrayTask& task) {
  if (task.count == 1) return "index.json";
  return "index.task-" + std::to_string(task.index) + "-of-" + std::to_string(task.count) + ".json";
}

core::Result<std::filesystem::path> WriteTaskIndex(const std::filesystem::path& dir, json index,
                                                   const ArrayTask& task, const ItemRange& items,
                                                   const std::string& entries_key) {
  if (task.count > 1) {
    index[kTaskKey] = {{"index", task.index},
                       {"of", task.count},
                       {"first", items.first},
                       {"end", items.end},
                       {"entries_key", entries_key}};
  }
  const std::filesystem::path path = dir / IndexFileName(task);
  if (auto error = cli::WriteFile(path, index.dump(2) + "\n")) {
    return MakeError(ErrorCode::kInvalidArgument, error->message, "out");
  }
  return path;
}

core::Result<std::vector<std::filesystem::path>> FindTaskIndexes(const std::filesystem::path& dir) {
  std::map<int, std::filesystem::path> parts;
  int of = 0;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(dir, ec)) {
    const auto named = ParseTaskIndexName(entry.path().filename().string());
    if (!named) continue;
    const int n = named->count;
    if (of != 0 && n != of) {
      return MakeError(ErrorCode::kInvalidArgument,
                       dir.string() + " holds partial indexes of " + std::to_string(of) + " and " +
                           std::to_string(n) + " tasks: remove the stale ones",
                       "dir");
    }
    of = n;
    const int k = named->index;
    if (k >= n) {
      return MakeError(ErrorCode::kInvalidArgument,
                       entry.path().string() + " names no task of " + std::to_string(n), "dir");
    }
    parts[k] = entry.path();
  }
  if (ec) {
    return MakeError(ErrorCode::kNotFound, "cannot list " + dir.string() + ": " + ec.message(),
                     "dir");
  }
  if (of == 0) {
    return MakeError(ErrorCode::kNotFound,
                     "no partial index (index.task-K-of-N.json) in " + dir.string(), "dir");
  }
  std::string missing;
  for (int k = 0; k < of; ++k) {
    if (parts.count(k) == 0) missing += (missing.empty() ? "" : ",") + std::to_string(k);
  }
  if (!missing.empty()) {
    return MakeError(ErrorCode::kNotFound,
                     "of " + std::to_string(of) + " tasks, these have not written their index: " +
                         missing + "; re-run them alone (sbatch --array=" + missing + ")",
                     "dir");
  }
  std::vector<std::filesystem::path> ordered;
  for (const auto& [k, path] : parts) ordered.push_back(path);
  return ordered;
}

core::Result<std::filesystem::path> MergeTaskIndexes(const std::filesystem::path& dir) {
  auto found = FindTaskIndexes(dir);
  if (!found.ok()) return found.error();
  const std::vector<std::filesystem::path>& parts = found.value();
  const int of = static_cast<int>(parts.size());
  json merged;
  std::string entries_key;
  int next_item = 0;
  json entries = json::array();
  for (int k = 0; k < of; ++k) {
    const std::filesystem::path& path = parts[static_cast<std::size_t>(k)];
    auto text = cli::ReadFile(path);
    if (!text.ok()) return MakeError(ErrorCode::kInvalidArgument, text.error().message, "dir");
    json part = json::parse(text.value(), nullptr, /*allow_exceptions=*/false);
    const auto bad = [&](const std::string& why) {
      return MakeError(ErrorCode::kInvalidArgument, path.string() + ": " + why, "dir");
    };
    if (!part.is_object() || !part.contains(kTaskKey) || !part[kTaskKey].is_object()) {
      return bad("not a partial index");
    }
    const json task = part[kTaskKey];
    part.erase(kTaskKey);
    if (!task.value("entries_key", json()).is_string() ||
        !task.value("first", json()).is_number_integer() ||
        !task.value("end", json()).is_number_integer() || task.value("index", -1) != k ||
        task.value("of", -1) != of) {
      return bad("its \"task\" object does not match its name");
    }
    const std::string key = task["entries_key"].get<std::string>();
    if (!part.contains(key) || !part[key].is_array()) return bad("no \"" + key + "\" array");
    json part_entries = part[key];
    part.erase(key);
    if (k == 0) {
      merged = part;
      entries_key = key;
    } else if (part != merged || key != entries_key) {
      return bad("made with other arguments than task 0");
    }
    const int first = task["first"].get<int>();
    const int end = task["end"].get<int>();
    if (first != next_item || end < first || static_cast<int>(part_entries.size()) != end - first) {
      return bad("covers items " + std::to_string(first) + ".." + std::to_string(end) + " with " +
                 std::to_string(part_entries.size()) + " entries; expected to start at " +
                 std::to_string(next_item));
    }
    next_item = end;
    for (auto& e : part_entries) entries.push_back(std::move(e));
  }
  merged[entries_key] = std::move(entries);
  const std::filesystem::path path = dir / "index.json";
  if (auto error = cli::WriteFile(path, merged.dump(2) + "\n")) {
    return MakeError(ErrorCode::kInvalidArgument, error->message, "dir");
  }
  return path;
}

}  // namespace softgrasp::sim
