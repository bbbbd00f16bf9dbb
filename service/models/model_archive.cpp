#include "service/models/model_archive.h"

namespace softgrasp::models {

void SaveModelArchive(torch::serialize::OutputArchive& archive, const std::filesystem::path& path) {
  const std::filesystem::path tmp = path.string() + ".tmp";
  archive.save_to(tmp.string());
  std::filesystem::rename(tmp, path);
}

}  // namespace softgrasp::models
