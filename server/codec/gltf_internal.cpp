// The tinygltf glue of the glTF codec (gltf_internal.h): accessor layout, Value <-> json, callbacks.
#include "server/codec/gltf_internal.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <limits>

namespace lipmap::gltf::internal {

using nlohmann::json;

void fail(const std::string& code, const std::string& message, const std::string& pointer) {
  throw GltfError(code, message, pointer);
}

std::string ptr(const std::string& collection, long long index) { return "/" + collection + "/" + std::to_string(index); }

bool starts_with(const std::string& s, const char* prefix) { return s.rfind(prefix, 0) == 0; }

std::string hex_bytes(std::string_view b, std::size_t n) {
  static const char* digits = "0123456789abcdef";
  std::string out;
  for (std::size_t i = 0; i < std::min(n, b.size()); ++i) {
    if (i) out += ' ';
    const auto c = static_cast<unsigned char>(b[i]);
    out += digits[c >> 4];
    out += digits[c & 15];
  }
  return out.empty() ? "nothing" : out;
}


int component_size(int ct) {
  switch (ct) {
    case kByte: case kUByte: return 1;
    case kShort: case kUShort: return 2;
    case kUInt: case kFloat: return 4;
    default: return 0;
  }
}

const char* component_name(int ct) {
  switch (ct) {
    case kByte: return "BYTE";
    case kUByte: return "UNSIGNED_BYTE";
    case kShort: return "SHORT";
    case kUShort: return "UNSIGNED_SHORT";
    case kUInt: return "UNSIGNED_INT";
    case kFloat: return "FLOAT";
    default: return "an unknown component type";
  }
}

// Components and, for matrices, rows (columns = components / rows); 0 for an unknown type.
int type_components(int type) {
  switch (type) {
    case TINYGLTF_TYPE_SCALAR: return 1;
    case TINYGLTF_TYPE_VEC2: return 2;
    case TINYGLTF_TYPE_VEC3: return 3;
    case TINYGLTF_TYPE_VEC4: return 4;
    case TINYGLTF_TYPE_MAT2: return 4;
    case TINYGLTF_TYPE_MAT3: return 9;
    case TINYGLTF_TYPE_MAT4: return 16;
    default: return 0;
  }
}
int matrix_rows(int type) {
  switch (type) {
    case TINYGLTF_TYPE_MAT2: return 2;
    case TINYGLTF_TYPE_MAT3: return 3;
    case TINYGLTF_TYPE_MAT4: return 4;
    default: return 0;
  }
}
const char* type_name(int type) {
  switch (type) {
    case TINYGLTF_TYPE_SCALAR: return "SCALAR";
    case TINYGLTF_TYPE_VEC2: return "VEC2";
    case TINYGLTF_TYPE_VEC3: return "VEC3";
    case TINYGLTF_TYPE_VEC4: return "VEC4";
    case TINYGLTF_TYPE_MAT2: return "MAT2";
    case TINYGLTF_TYPE_MAT3: return "MAT3";
    case TINYGLTF_TYPE_MAT4: return "MAT4";
    default: return "an unknown type";
  }
}
int type_for_components(int n) {
  switch (n) {
    case 1: return TINYGLTF_TYPE_SCALAR;
    case 2: return TINYGLTF_TYPE_VEC2;
    case 3: return TINYGLTF_TYPE_VEC3;
    case 4: return TINYGLTF_TYPE_VEC4;
    case 9: return TINYGLTF_TYPE_MAT3;
    case 16: return TINYGLTF_TYPE_MAT4;
    default: return TINYGLTF_TYPE_VEC4;
  }
}

// Bytes of one element, with the column padding of 1- and 2-byte matrices.
std::size_t element_size(int type, int ct) {
  const int rows = matrix_rows(type), cs = component_size(ct);
  if (rows == 0) return static_cast<std::size_t>(type_components(type) * cs);
  const std::size_t column = (static_cast<std::size_t>(rows * cs) + 3) / 4 * 4;
  return column * static_cast<std::size_t>(rows);
}
// Byte offset of component c inside an element.
std::size_t component_offset(int type, int ct, int c) {
  const int rows = matrix_rows(type), cs = component_size(ct);
  if (rows == 0) return static_cast<std::size_t>(c * cs);
  const std::size_t column = (static_cast<std::size_t>(rows * cs) + 3) / 4 * 4;
  return column * static_cast<std::size_t>(c / rows) + static_cast<std::size_t>((c % rows) * cs);
}

double read_component(const unsigned char* p, int ct, bool normalized) {
  switch (ct) {
    case kByte: {
      const double v = static_cast<std::int8_t>(p[0]);
      return normalized ? std::max(v / 127.0, -1.0) : v;
    }
    case kUByte: return normalized ? p[0] / 255.0 : p[0];
    case kShort: {
      std::int16_t v;
      std::memcpy(&v, p, 2);
      return normalized ? std::max(v / 32767.0, -1.0) : v;
    }
    case kUShort: {
      std::uint16_t v;
      std::memcpy(&v, p, 2);
      return normalized ? v / 65535.0 : v;
    }
    case kUInt: {
      std::uint32_t v;
      std::memcpy(&v, p, 4);
      return normalized ? v / 4294967295.0 : v;
    }
    case kFloat: {
      float v;
      std::memcpy(&v, p, 4);
      return v;
    }
    default: return 0;
  }
}

bool is_float_semantic(const std::string& name) {
  return name == "POSITION" || name == "NORMAL" || name == "TANGENT" || starts_with(name, "TEXCOORD_") ||
         starts_with(name, "COLOR_") || starts_with(name, "WEIGHTS_");
}

// ---- tinygltf callbacks: never touch the file system, keep image bytes as they are ------------------------

namespace {

bool no_file_exists(const std::string&, void*) { return false; }
std::string no_expand(const std::string& path, void*) { return path; }
bool no_read(std::vector<unsigned char>*, std::string* err, const std::string& path, void*) {
  if (err) *err += "external file '" + path + "' is not read (lipmap takes self-contained glTF only)\n";
  return false;
}
bool no_write(std::string* err, const std::string&, const std::vector<unsigned char>&, void*) {
  if (err) *err += "lipmap writes no files through tinygltf\n";
  return false;
}

}  // namespace

tinygltf::FsCallbacks no_file_system() { return {&no_file_exists, &no_expand, &no_read, &no_write, nullptr}; }

bool keep_image_bytes(tinygltf::Image* image, const int, std::string*, std::string*, int, int,
                      const unsigned char* bytes, int size, void*) {
  image->image.assign(bytes, bytes + size);
  image->as_is = true;
  return true;
}

namespace {
std::string sniff_image_mime(const std::vector<unsigned char>& b) {
  if (b.size() >= 8 && b[0] == 0x89 && b[1] == 'P' && b[2] == 'N' && b[3] == 'G') return "image/png";
  if (b.size() >= 3 && b[0] == 0xff && b[1] == 0xd8 && b[2] == 0xff) return "image/jpeg";
  return "application/octet-stream";
}
}  // namespace

bool embed_image_bytes(const std::string*, const std::string*, const tinygltf::Image* image, bool,
                       std::string* out_uri, void*) {
  if (!image->uri.empty() || image->bufferView >= 0) return false;  // kept as the input had it
  const std::string mime = image->mimeType.empty() ? sniff_image_mime(image->image) : image->mimeType;
  *out_uri = "data:" + mime + ";base64," +
             base64_encode(std::string_view(reinterpret_cast<const char*>(image->image.data()), image->image.size()));
  return true;
}

// ---- tinygltf::Value <-> json ------------------------------------------------------------------------

json to_json(const tinygltf::Value& v) {
  switch (v.Type()) {
    case tinygltf::BOOL_TYPE: return v.Get<bool>();
    case tinygltf::INT_TYPE: return v.Get<int>();
    case tinygltf::REAL_TYPE: return v.Get<double>();
    case tinygltf::STRING_TYPE: return v.Get<std::string>();
    case tinygltf::ARRAY_TYPE: {
      json a = json::array();
      for (std::size_t i = 0; i < v.ArrayLen(); ++i) a.push_back(to_json(v.Get(static_cast<int>(i))));
      return a;
    }
    case tinygltf::OBJECT_TYPE: {
      json o = json::object();
      for (const auto& [k, x] : v.Get<tinygltf::Value::Object>()) o[k] = to_json(x);
      return o;
    }
    default: return nullptr;
  }
}

tinygltf::Value to_value(const json& j) {
  switch (j.type()) {
    case json::value_t::boolean: return tinygltf::Value(j.get<bool>());
    case json::value_t::number_integer:
    case json::value_t::number_unsigned: {
      const double d = j.get<double>();
      if (d >= std::numeric_limits<int>::min() && d <= std::numeric_limits<int>::max())
        return tinygltf::Value(static_cast<int>(j.get<long long>()));
      return tinygltf::Value(d);
    }
    case json::value_t::number_float: {
      const double d = j.get<double>();
      return std::isfinite(d) ? tinygltf::Value(d) : tinygltf::Value();
    }
    case json::value_t::string: return tinygltf::Value(j.get<std::string>());
    case json::value_t::array: {
      tinygltf::Value::Array a;
      for (const json& x : j) a.push_back(to_value(x));
      return tinygltf::Value(std::move(a));
    }
    case json::value_t::object: {
      tinygltf::Value::Object o;
      for (auto it = j.begin(); it != j.end(); ++it) o[it.key()] = to_value(it.value());
      return tinygltf::Value(std::move(o));
    }
    default: return tinygltf::Value();
  }
}

}  // namespace lipmap::gltf::internal
