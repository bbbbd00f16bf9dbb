// Fuzz target: GQ-CNN dataset shards and indexes read from disk (service/gqcnn/dataset_format.h).
// Whatever is accepted must re-encode to the same bytes; a version 1 shard re-encodes as the
// current version, which must then read back and re-encode to itself.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "service/gqcnn/dataset_format.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  const auto shard = softgrasp::gqcnn::DecodeShard(bytes);
  if (shard.ok()) {
    const std::string again = softgrasp::gqcnn::EncodeShard(shard.value());
    if (again != bytes) {
      if (bytes[8] != 1) std::abort();  // only a version 1 shard may change
      const auto reread = softgrasp::gqcnn::DecodeShard(again);
      if (!reread.ok() || softgrasp::gqcnn::EncodeShard(reread.value()) != again) std::abort();
    }
  }
  const nlohmann::json json = nlohmann::json::parse(bytes, nullptr, false);
  if (!json.is_discarded()) {
    const auto index = softgrasp::gqcnn::IndexFromJson(json);
    if (index.ok()) {
      const auto again =
          softgrasp::gqcnn::IndexFromJson(softgrasp::gqcnn::IndexToJson(index.value()));
      if (!again.ok()) std::abort();
    }
  }
  return 0;
}
