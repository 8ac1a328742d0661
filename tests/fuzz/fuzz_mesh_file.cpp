// libFuzzer target: the OBJ and OFF readers (engine/mesh_io.h), then the validate stage on what they read,
// as `lipmap map MESH` does. read_mesh_file takes a path, so each input is written to a scratch file and
// read once as .obj and once as .off. InputError (mesh_file_unreadable, validate's codes) is the documented
// answer; anything else escapes.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "engine/error.h"
#include "engine/mesh_io.h"
#include "engine/validate.h"

namespace {

// One scratch folder per fuzzing process (libFuzzer's -jobs/-fork run several side by side).
const std::string& scratch_dir() {
  static const std::string dir = [] {
    const char* base = std::getenv("TMPDIR");
    std::string pattern = std::string(base && *base ? base : "/tmp") + "/lipmap-fuzz-mesh-XXXXXX";
    if (!mkdtemp(pattern.data())) std::abort();
    return pattern;
  }();
  return dir;
}

void write_file(const std::string& path, const std::uint8_t* data, std::size_t size) {
  std::FILE* file = std::fopen(path.c_str(), "wb");
  if (!file) std::abort();
  if (size > 0 && std::fwrite(data, 1, size, file) != size) std::abort();
  if (std::fclose(file) != 0) std::abort();
}

void read_and_validate(const std::string& path) {
  try {
    const lipmap::RawMesh mesh = lipmap::read_mesh_file(path);
    (void)lipmap::validate_mesh(mesh);
  } catch (const lipmap::InputError&) {
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  for (const char* extension : {".obj", ".off"}) {
    const std::string path = scratch_dir() + "/input" + extension;
    write_file(path, data, size);
    read_and_validate(path);
  }
  return 0;
}
