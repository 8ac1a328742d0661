// libFuzzer target: the glTF reader (server/codec/gltf_codec.h), gltf::Asset::read on arbitrary bytes, both
// sniffed and with each expected format, and with a position weld when the first byte asks for it.
// GltfError and the validate stage's InputError are the documented answers; anything else escapes.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string_view>

#include "engine/error.h"
#include "server/codec/gltf_codec.h"

namespace gltf = lipmap::gltf;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  // The first byte picks the reading mode (bit 0: weld; (byte >> 1) % 3: sniffed, glb, gltf); the rest is
  // the file. The seed corpus files start with a 0 byte (sniffed, no weld) followed by a real .glb/.gltf.
  const std::uint8_t mode = data[0];
  const std::string_view bytes(reinterpret_cast<const char*>(data) + 1, size - 1);
  gltf::Selection selection;
  if (mode & 1) selection.weld = gltf::Weld::position;
  std::optional<gltf::Format> expected;
  if ((mode >> 1) % 3 == 1) expected = gltf::Format::glb;
  if ((mode >> 1) % 3 == 2) expected = gltf::Format::gltf;
  try {
    const gltf::Asset asset = gltf::Asset::read(bytes, selection, expected);
    (void)asset.attribute_names();
    if (!asset.attribute("TEXCOORD_0")) return 0;
    (void)asset.texcoord_boundary(0);
  } catch (const lipmap::InputError&) {
  }
  return 0;
}
