#pragma once
/// Writing and reading the libtorch archives the three model files are (network.h,
/// segmentation_network.h, gqcnn_network.h): the parts every format shares. Internal to
/// softgrasp::models_net; includes torch.

#include <torch/torch.h>

#include <filesystem>
#include <functional>
#include <string>

#include "service/core/status.h"

namespace softgrasp::models {

/// Writes `archive` to `path` through `path`.tmp and a rename: a crash never leaves a
/// half-written model file.
void SaveModelArchive(torch::serialize::OutputArchive& archive, const std::filesystem::path& path);

/// "cannot read <kind> model <path>: <why>" (kUnprocessable, field "model").
using ModelFileError = std::function<core::Error(const std::string& why)>;

/// Opens the model file at `path` and hands the archive to `read` with the error maker above.
/// Never throws: no file there is kNotFound ("no <kind> model file at <path>"), and libtorch's
/// exceptions (a truncated zip, missing keys, tensors of the wrong shape) become the error
/// maker's, with their first line as the reason.
template <class T>
core::Result<T> LoadModelArchive(
    const std::filesystem::path& path, const std::string& kind,
    const std::function<core::Result<T>(torch::serialize::InputArchive&, const ModelFileError&)>&
        read) {
  const ModelFileError fail = [&](const std::string& why) {
    return core::MakeError(core::ErrorCode::kUnprocessable,
                           "cannot read " + kind + " model " + path.string() + ": " + why, "model");
  };
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    return core::MakeError(core::ErrorCode::kNotFound,
                           "no " + kind + " model file at " + path.string(), "model");
  }
  try {
    torch::serialize::InputArchive archive;
    archive.load_from(path.string());
    return read(archive, fail);
  } catch (const std::exception& e) {
    // c10::Error derives from std::exception.
    std::string what = e.what();
    if (const auto nl = what.find('\n'); nl != std::string::npos) what.resize(nl);
    return fail(what);
  }
}

}  // namespace softgrasp::models
