// libFuzzer target: the JSON parametrize request parser (server/codec/json_codec.h), as the HTTP service and
// `lipmap map` use it: parse_json on arbitrary bytes, then parametrize_request_from_json on the document.
// InputError (JsonError included) is the documented answer to a bad body; any other exception escapes and
// libFuzzer reports it as a crash (uncaught exception -> abort).
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "engine/error.h"
#include "server/codec/json_codec.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    const nlohmann::json body = lipmap::codec::parse_json(text);
    const lipmap::codec::ParametrizeRequest request = lipmap::codec::parametrize_request_from_json(body);
    // A request that parsed must write back out (the codec's own inverse), without throwing.
    (void)lipmap::codec::parametrize_request_to_json(request);
  } catch (const lipmap::InputError&) {
  }
  return 0;
}
