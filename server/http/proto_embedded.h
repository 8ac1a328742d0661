// proto/ embedded into the binary at build time (server/http/embed_proto.cmake writes the definitions), so that
// `lipmap serve` answers GET /v1/openapi.json and the JSON Schemas it references without any file beside it.
#pragma once

#include <cstddef>
#include <string_view>

namespace lipmap::server {

struct EmbeddedFile {
  const char* name;  // file name in proto/, e.g. "openapi.json", "problem.schema.json"
  const unsigned char* data;
  std::size_t size;
  std::string_view text() const { return {reinterpret_cast<const char*>(data), size}; }
};

extern const EmbeddedFile kProtoFiles[];
extern const std::size_t kProtoFileCount;

// nullptr when proto/ has no such file.
const EmbeddedFile* find_proto_file(std::string_view name);

}  // namespace lipmap::server
