// Fuzzes the JSON codec's readers with bytes from outside (journal lines, manifests, request
// bodies): whatever parses as JSON goes to every reader, which must answer a value or an error,
// never crash. What a reader accepts must write and read back to the same JSON.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>
#include <vector>

#include "service/codec/json_codec.h"

namespace {

using softgrasp::codec::json;

template <class Result, class Reread>
void CheckRoundTrip(const Result& read, Reread reread) {
  if (!read.ok()) {
    if (read.error().message.empty() || read.error().field.empty()) std::abort();
    return;
  }
  const json written = softgrasp::codec::ToJson(read.value());
  const auto again = reread(written);
  if (!again.ok() || softgrasp::codec::ToJson(again.value()) != written) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace codec = softgrasp::codec;
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  const json j = json::parse(bytes, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return 0;
  // A document's members too, so one input can reach the readers' nested paths.
  std::vector<const json*> values{&j};
  if (j.is_object()) {
    for (const auto& [key, value] : j.items()) values.push_back(&value);
  }
  for (const json* v : values) {
    CheckRoundTrip(codec::CameraFromJson(*v, "camera"),
                   [](const json& x) { return codec::CameraFromJson(x, "camera"); });
    CheckRoundTrip(codec::PoseFromJson(*v, "pose"),
                   [](const json& x) { return codec::PoseFromJson(x, "pose"); });
    const softgrasp::bridge::Workspace base{"base", {-1, -1, 0}, {1, 1, 1}};
    CheckRoundTrip(codec::WorkspaceFromJson(*v, "workspace", base),
                   [&](const json& x) { return codec::WorkspaceFromJson(x, "workspace", base); });
    CheckRoundTrip(codec::CommandFromJson(*v, "command"),
                   [](const json& x) { return codec::CommandFromJson(x, "command"); });
    CheckRoundTrip(codec::ResultFromJson(*v, "result"),
                   [](const json& x) { return codec::ResultFromJson(x, "result"); });
  }
  return 0;
}
