// Bad glTF input: every corruption is refused with a GltfError (or InputError) whose code the error table
// answers with a 4xx, never another exception, and without a large allocation on the way (the peak resident
// set is measured around each read, independently of the reader).
#include <cstdint>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/error.h"
#include "server/codec/error_table.h"
#include "tests/codec/gltf_test_util.h"

namespace lipmap::gltfcodectest {
namespace {

// ---- the peak resident set, from /proc (Linux) ----------------------------------------------------------

long status_kb(const char* key) {
  std::ifstream in("/proc/self/status");
  std::string line;
  const std::string k = std::string(key) + ":";
  while (std::getline(in, line))
    if (line.rfind(k, 0) == 0) return std::stol(line.substr(k.size()));
  return -1;
}

// Resets VmHWM to the current resident set (clear_refs "5"); false when the kernel does not allow it.
bool reset_peak() {
  std::ofstream f("/proc/self/clear_refs");
  if (!f) return false;
  f << "5";
  f.flush();
  return static_cast<bool>(f);
}

// How much the peak resident set rose while f ran, in MiB (0 when /proc cannot tell).
double peak_growth_mib(const std::function<void()>& f) {
  const bool reset = reset_peak();
  const long before = reset ? status_kb("VmRSS") : status_kb("VmHWM");
  f();
  const long after = status_kb("VmHWM");
  if (before < 0 || after < 0) return 0;
  return (after - before) / 1024.0;
}

// A read of bytes that must be refused: a GltfError or InputError with a 4xx code, a peak resident-set
// growth under 64 MiB (these documents are a few KiB; the mesh they describe is a few vertices). Under
// AddressSanitizer freed blocks wait in its quarantine (256 MiB) and every block has redzones, so what a read
// maps depends on what ran before it in the process (65.7 MiB once, after a 217k-triangle test): the bound
// there is 256 MiB, still far below the gigabytes an absurd size would allocate.
#if defined(__SANITIZE_ADDRESS__)
constexpr double kMaxGrowthMiB = 256;
#else
constexpr double kMaxGrowthMiB = 64;
#endif

struct Outcome {
  bool refused = false;
  std::string code, message;
};

Outcome read_refused(const std::string& bytes, const std::string& what) {
  Outcome out;
  const double growth = peak_growth_mib([&] {
    try {
      Asset::read(bytes);
      out.message = "accepted";
    } catch (const InputError& e) {  // GltfError included
      out.refused = true;
      out.code = e.code();
      out.message = e.what();
    } catch (const std::exception& e) {
      out.message = std::string("unexpected exception: ") + e.what();
    } catch (...) {
      out.message = "unexpected exception of an unknown type";
    }
  });
  EXPECT_TRUE(out.refused) << what << ": " << out.message;
  if (out.refused) {
    EXPECT_TRUE(codec::has_error_info(out.code)) << what << ": code " << out.code << " is not in the error table";
    const int status = codec::error_info(out.code).status;
    EXPECT_TRUE(status >= 400 && status < 500) << what << ": " << out.code << " answers " << status << ": " << out.message;
  }
  EXPECT_LT(growth, kMaxGrowthMiB) << what << ": the peak resident set grew by " << growth << " MiB";
  return out;
}

// The JSON of a document in either form, and the document rebuilt in the same form.
std::string rebuild(const std::string& original, const json& doc) {
  return original.compare(0, 4, "glTF") == 0 ? gltftest::replace_glb_json(original, doc) : doc.dump();
}

// The base documents: a small grid with normals, colours, two texcoord sets, a skin, a morph target and a
// second mesh, plus a sparse morph target (one POSITION delta over the first index) so that the sparse
// fields are there to corrupt.
std::vector<std::string> bases() {
  const Mesh m = grid(3);
  FixtureOptions o;
  o.skin = true;
  o.morph = true;
  std::vector<std::string> out;
  for (bool binary : {true, false}) {
    const std::string bytes = make_gltf(m.vertices, m.faces, o, binary);
    json doc = gltftest::document_json(bytes);
    json& prim = doc["meshes"][0]["primitives"][0];
    const int position_view = doc["accessors"][prim["attributes"]["POSITION"].get<int>()]["bufferView"];
    const int index_view = doc["accessors"][prim["indices"].get<int>()]["bufferView"];
    json sparse = {{"componentType", 5126},
                   {"count", m.vertices.size()},
                   {"type", "VEC3"},
                   {"sparse", {{"count", 1},
                               {"indices", {{"bufferView", index_view}, {"componentType", 5125}}},
                               {"values", {{"bufferView", position_view}}}}}};
    doc["accessors"].push_back(sparse);
    prim["targets"].push_back({{"POSITION", doc["accessors"].size() - 1}});
    doc["meshes"][0]["weights"].push_back(0.25);
    out.push_back(rebuild(bytes, doc));
  }
  return out;
}

// A refusal the report names: a glTF code answered 400 (the bytes are not a valid glTF 2.0 document).
void expect_malformed_gltf(const Outcome& o, const std::string& what) {
  if (!o.refused) return;  // read_refused said so
  EXPECT_EQ(o.code.rfind("gltf_", 0), 0u) << what << ": " << o.code;
  EXPECT_EQ(codec::error_info(o.code).status, 400) << what << ": " << o.code << ": " << o.message;
}

const char* form(const std::string& bytes) { return bytes.compare(0, 4, "glTF") == 0 ? "glb" : "gltf"; }

// Values no integer field of these documents may take: negative, beyond any index or size in them, beyond
// 32 and 53 bits, not integers, not numbers.
std::vector<json> absurd_values() {
  return {-1, -4, -7, -2147483648LL, 2147483648LL, 4294967299LL, 1LL << 25, 1LL << 28, 9007199254740993LL,
          1e300, 0.5, -0.0001, "3", nullptr, true};
}

}  // namespace

TEST(GltfBadInput, BaseDocumentsAreRead) {
  // The sweeps below corrupt these; read as they are, they are accepted.
  for (const std::string& bytes : bases()) {
    Asset a = Asset::read(bytes);
    EXPECT_EQ(a.primitive_vertices(), 9u) << form(bytes);
  }
}

// An accessor without a bufferView is all zeros: its count alone once sized a vector of count * components
// doubles (2^25 VEC3: 800 MB) before any limit applied.
TEST(GltfBadInput, UnbackedAccessorCountIsRefusedBeforeAllocating) {
  for (const std::string& base : bases())
    for (long long count : {1LL << 22, 1LL << 25, 1LL << 28, (1LL << 32) - 1}) {
      json doc = gltftest::document_json(base);
      json& a = doc["accessors"][doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"].get<int>()];
      a.erase("bufferView");
      a["count"] = count;
      read_refused(rebuild(base, doc), std::string(form(base)) + " POSITION without bufferView, count " + std::to_string(count));
      // The sparse accessor (no bufferView of its own) with a huge count.
      json doc2 = gltftest::document_json(base);
      doc2["accessors"].back()["count"] = count;
      read_refused(rebuild(base, doc2), std::string(form(base)) + " sparse accessor count " + std::to_string(count));
    }
}

TEST(GltfBadInput, ZeroAndNegativeBufferByteLengthAreRefused) {
  for (const std::string& base : bases())
    for (json v : {json(0), json(-1), json(-4096)}) {
      json doc = gltftest::document_json(base);
      doc["buffers"][0]["byteLength"] = v;
      const std::string what = std::string(form(base)) + " buffers[0].byteLength " + v.dump();
      expect_malformed_gltf(read_refused(rebuild(base, doc), what), what);
    }
}

TEST(GltfBadInput, SpecViolationsNamedInTheReportAreRefused) {
  for (const std::string& base : bases()) {
    const std::string f = form(base);
    const json doc0 = gltftest::document_json(base);
    const int pos = doc0["meshes"][0]["primitives"][0]["attributes"]["POSITION"];
    {
      json doc = doc0;
      doc["accessors"][pos]["byteOffset"] = -4;
      expect_malformed_gltf(read_refused(rebuild(base, doc), f + " POSITION byteOffset -4"), f + " POSITION byteOffset -4");
    }
    {
      json doc = doc0;
      doc["accessors"][pos]["bufferView"] = -7;
      expect_malformed_gltf(read_refused(rebuild(base, doc), f + " POSITION bufferView -7"), f + " POSITION bufferView -7");
    }
    {
      json doc = doc0;
      doc["meshes"][0]["primitives"][0]["mode"] = -5;
      expect_malformed_gltf(read_refused(rebuild(base, doc), f + " mode -5"), f + " mode -5");
    }
    {
      json doc = doc0;
      doc["extensionsUsed"] = {"EXT_lipmap_unknown"};
      doc["extensionsRequired"] = {"EXT_lipmap_unknown"};
      const Outcome o = read_refused(rebuild(base, doc), f + " unknown required extension");
      EXPECT_EQ(o.code, "gltf_unsupported_extension") << o.message;
      // Used but not required: a loader may ignore it.
      doc.erase("extensionsRequired");
      EXPECT_NO_THROW(Asset::read(rebuild(base, doc))) << f;
      // Required extensions that do not change the meaning of the geometry are read.
      doc["extensionsUsed"] = {"KHR_materials_emissive_strength", "KHR_mesh_quantization"};
      doc["extensionsRequired"] = {"KHR_materials_emissive_strength", "KHR_mesh_quantization"};
      EXPECT_NO_THROW(Asset::read(rebuild(base, doc))) << f;
      doc["extensionsRequired"] = "KHR_mesh_quantization";  // not an array
      expect_malformed_gltf(read_refused(rebuild(base, doc), f + " extensionsRequired not an array"), f);
    }
  }
  // A NUL after the JSON of a .gltf is not JSON (in a GLB, the JSON chunk is padded with spaces).
  const std::string text = bases()[1];
  for (const std::string& tail : {std::string(1, '\0'), std::string("\n\0", 2), std::string("\0\0\0\0", 4)})
    expect_malformed_gltf(read_refused(text + tail, "a .gltf followed by " + std::to_string(tail.size()) + " byte(s) ending in NUL"), "NUL");
  std::string nul_inside = text;
  nul_inside.insert(1, 1, '\0');
  read_refused(nul_inside, "a .gltf with a NUL after its '{'");
  EXPECT_NO_THROW(Asset::read(text + " \n\t\r\n"));
}

// Every integer field of every accessor, sparse accessor, bufferView, buffer and primitive set to each
// absurd value, in both forms.
TEST(GltfBadInput, EveryIntegerFieldSetToAnAbsurdValueIsRefused) {
  std::size_t cases = 0;
  for (const std::string& base : bases()) {
    const json doc0 = gltftest::document_json(base);
    std::vector<json::json_pointer> fields;
    for (std::size_t i = 0; i < doc0["accessors"].size(); ++i) {
      const std::string a = "/accessors/" + std::to_string(i);
      for (const char* k : {"bufferView", "byteOffset", "componentType", "count"}) fields.emplace_back(a + "/" + k);
      if (doc0["accessors"][i].contains("sparse"))
        for (const char* k : {"/sparse/count", "/sparse/indices/bufferView", "/sparse/indices/byteOffset",
                              "/sparse/indices/componentType", "/sparse/values/bufferView", "/sparse/values/byteOffset"})
          fields.emplace_back(a + k);
    }
    for (std::size_t i = 0; i < doc0["bufferViews"].size(); ++i)
      for (const char* k : {"buffer", "byteOffset", "byteLength", "byteStride"})
        fields.emplace_back("/bufferViews/" + std::to_string(i) + "/" + k);
    fields.emplace_back("/buffers/0/byteLength");
    for (std::size_t m = 0; m < doc0["meshes"].size(); ++m) {
      const json& prims = doc0["meshes"][m]["primitives"];
      for (std::size_t p = 0; p < prims.size(); ++p) {
        const std::string pp = "/meshes/" + std::to_string(m) + "/primitives/" + std::to_string(p);
        fields.emplace_back(pp + "/mode");
        if (prims[p].contains("indices")) fields.emplace_back(pp + "/indices");
        for (const auto& [name, _] : prims[p]["attributes"].items())
          fields.emplace_back(pp + "/attributes/" + name);
        if (prims[p].contains("targets"))
          for (std::size_t t = 0; t < prims[p]["targets"].size(); ++t)
            for (const auto& [name, _] : prims[p]["targets"][t].items())
              fields.emplace_back(pp + "/targets/" + std::to_string(t) + "/" + name);
      }
    }
    for (const json::json_pointer& field : fields)
      for (const json& v : absurd_values()) {
        json doc = doc0;
        doc[field] = v;
        read_refused(rebuild(base, doc), std::string(form(base)) + " " + field.to_string() + " = " + v.dump());
        ++cases;
        if (::testing::Test::HasFailure()) return;  // one clear failure, not thousands
      }
  }
  EXPECT_GT(cases, 1000u);
}

// A GLB whose buffer claims more bytes than its BIN chunk holds, and views and accessors that reach past
// what is there, with every other field intact.
TEST(GltfBadInput, SizesBeyondTheBytesPresentAreRefused) {
  for (const std::string& base : bases()) {
    const json doc0 = gltftest::document_json(base);
    const long long length = doc0["buffers"][0]["byteLength"];
    {
      json doc = doc0;
      doc["buffers"][0]["byteLength"] = length + 4;
      read_refused(rebuild(base, doc), std::string(form(base)) + " buffer longer than its bytes");
    }
    for (std::size_t v = 0; v < doc0["bufferViews"].size(); ++v) {
      json doc = doc0;
      doc["bufferViews"][v]["byteLength"] = length - doc0["bufferViews"][v].value("byteOffset", 0LL) + 4;
      read_refused(rebuild(base, doc), std::string(form(base)) + " bufferView " + std::to_string(v) + " past its buffer");
    }
    for (std::size_t a = 0; a + 1 < doc0["accessors"].size(); ++a) {
      json doc = doc0;
      doc["accessors"][a]["count"] = doc0["accessors"][a]["count"].get<long long>() + 1;
      read_refused(rebuild(base, doc), std::string(form(base)) + " accessor " + std::to_string(a) + " one element past its view");
    }
  }
}

}  // namespace lipmap::gltfcodectest
