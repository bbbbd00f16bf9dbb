#pragma once
/// Whole files in and out, for the command-line tools and the simulator's writers.
///
///   auto text = cli::ReadFile("scene.json");        // "cannot read scene.json: No such file..."
///   if (!text.ok()) return Fail(text.error().message);
///   if (auto error = cli::WriteFile("out/index.json", bytes, cli::Parents::kCreate)) {
///     return Fail(error->message);                   // "cannot write out/index.json: ..."
///   }
///
/// WriteFile never leaves a half-written file at `path`: it writes a hidden temporary file in the
/// same folder (".NAME.tmp-PID-N"), flushes it to the disk and renames it over `path`, so `path`
/// holds either what it held before or all of `bytes`. Only a process killed between those steps
/// can leave the temporary file behind; `path` itself is never touched until the rename. A
/// symbolic link at `path` is replaced by the file, not written through. The new file takes the
/// permissions of the file it replaces, or 0666 less the umask when there was none.

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "service/core/status.h"

namespace softgrasp::cli {

/// The whole file. Errors, their message naming the path and the reason: kNotFound when the file
/// or a folder on its path does not exist, kUnprocessable when it cannot be read (permissions,
/// a folder, an I/O error).
core::Result<std::string> ReadFile(const std::filesystem::path& path);

/// Whether WriteFile creates missing folders on the way to the file.
enum class Parents { kMustExist, kCreate };

/// Writes `bytes` as the whole of `path` (see above). Errors, their message naming the path and
/// the reason: kNotFound when the folder does not exist (with Parents::kMustExist) or a file
/// stands where a folder should be; kInvalidArgument when `path` names no file ("", "dir/");
/// kUnprocessable for every other failure (permissions, a full disk, `path` is a folder).
std::optional<core::Error> WriteFile(const std::filesystem::path& path, std::string_view bytes,
                                     Parents parents = Parents::kMustExist);

}  // namespace softgrasp::cli
