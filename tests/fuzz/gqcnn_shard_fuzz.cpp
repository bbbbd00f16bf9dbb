// Fuzz target: GQ-CNN dataset shards and indexes read from disk (service/gqcnn/dataset_format.h).
// Whatever is accepted must re-encode to the same bytes.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "service/gqcnn/dataset_format.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  const auto shard = softgrasp::gqcnn::DecodeShard(bytes);
  if (shard.ok() && softgrasp::gqcnn::EncodeShard(shard.value()) != bytes) std::abort();
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
