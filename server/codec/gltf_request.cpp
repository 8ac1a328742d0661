// glTF requests (see gltf_codec.h): a bare model with boundary=texcoord:N, the JSON envelope with
// gltf_base64, and multipart/form-data; their problem answers; base64.
#include <algorithm>
#include <cstdint>
#include <iterator>

#include "server/codec/gltf_internal.h"
#include "server/codec/json_codec.h"

namespace lipmap::gltf {

using nlohmann::json;
using nlohmann::ordered_json;
using namespace internal;

namespace {

int parse_index(const std::string& text, const char* what) {
  const std::string t = trim(text);
  if (t.empty() || t.size() > 9 || !std::all_of(t.begin(), t.end(), [](char c) { return c >= '0' && c <= '9'; }))
    fail("gltf_invalid_request", std::string(what) + " must be a non-negative integer, got '" + text.substr(0, 40) + "'");
  return std::stoi(t);
}

Weld parse_weld(const std::string& text) {
  if (text == "none") return Weld::none;
  if (text == "position") return Weld::position;
  fail("gltf_invalid_request", "weld must be \"none\" or \"position\", got '" + text.substr(0, 40) + "'");
}

// Merges an envelope member and a parameter that must agree.
template <class T>
std::optional<T> agree(const std::optional<T>& member, const std::optional<T>& param, const char* what) {
  if (member && param && !(*member == *param))
    fail("gltf_invalid_request", std::string(what) + " is given both in the body and as a parameter, with different values");
  return member ? member : param;
}

Selection selection_of(const Params& p, std::optional<int> mesh, std::optional<int> primitive, std::optional<Weld> weld) {
  Selection s;
  std::optional<int> pm, pp;
  std::optional<Weld> pw;
  if (p.mesh) pm = parse_index(*p.mesh, "mesh");
  if (p.primitive) pp = parse_index(*p.primitive, "primitive");
  if (p.weld) pw = parse_weld(*p.weld);
  s.mesh = agree(mesh, pm, "mesh").value_or(0);
  s.primitive = agree(primitive, pp, "primitive").value_or(0);
  s.weld = agree(weld, pw, "weld").value_or(Weld::none);
  return s;
}

// Boundary and options through the parametrize codec (same rules and pointers as a parametrize body).
codec::ParametrizeRequest parse_rest(const json* boundary, const json* options) {
  json body = {{"mesh", {{"vertices", json::array()}, {"faces", json::array()}}},
               {"boundary", boundary ? *boundary : json{{"positions", json::array()}}}};
  if (options) body["options"] = *options;
  return codec::parametrize_request_from_json(body);
}

Request finish(Asset asset, const std::optional<int>& texcoord, const json* boundary, const json* options,
               const Params& params) {
  const std::optional<int> metric = params.metric ? parse_metric_spec(*params.metric) : std::nullopt;
  if (!texcoord && !boundary)
    fail("gltf_invalid_request", "no boundary: send it as JSON (a \"boundary\" member or multipart part) or ask for boundary=texcoord:N");
  if (texcoord && boundary)
    fail("gltf_invalid_request", "two boundaries: boundary=texcoord:N and a boundary object; send one");
  Request r{std::move(asset), parse_rest(boundary, options), texcoord};
  r.request.mesh = r.asset.mesh();
  if (texcoord) r.request.boundary = r.asset.texcoord_boundary(*texcoord);
  if (metric) {
    if (r.request.options.metric)
      fail("gltf_invalid_request", "two metrics: metric=texcoord:N and options.metric; send one");
    r.request.options.metric = r.asset.texcoord_uv(*metric);
  }
  return r;
}

}  // namespace

std::optional<int> parse_texcoord_spec(std::string_view spec) {
  const std::string s = trim(spec);
  if (s.rfind("texcoord:", 0) != 0) return std::nullopt;
  return parse_index(s.substr(9), "the N of boundary=texcoord:N");
}

std::optional<int> parse_metric_spec(std::string_view spec) {
  const std::string s = trim(spec);
  if (s == "surface") return std::nullopt;
  if (const std::optional<int> n = parse_texcoord_spec(s)) return n;
  fail("gltf_invalid_request", "the metric parameter must be texcoord:N or surface, got '" + s.substr(0, 40) + "'");
}

bool is_envelope(const nlohmann::json& body) { return body.is_object() && body.contains("gltf_base64"); }

Request request_from_model(std::string_view bytes, Format format, const Params& params) {
  std::optional<int> texcoord;
  if (params.boundary) {
    texcoord = parse_texcoord_spec(*params.boundary);
    if (!texcoord)
      fail("gltf_invalid_request", "the boundary parameter must be texcoord:N; a boundary polygon comes as JSON (multipart part "
                                   "\"boundary\" or the JSON envelope)");
  } else {
    fail("gltf_invalid_request", "a bare glTF body needs boundary=texcoord:N; a boundary polygon comes as JSON (multipart/form-data "
                                 "with parts \"model\" and \"boundary\", or the JSON envelope {\"gltf_base64\", \"boundary\"})");
  }
  Asset asset = Asset::read(bytes, selection_of(params, std::nullopt, std::nullopt, std::nullopt), format);
  return finish(std::move(asset), texcoord, nullptr, nullptr, params);
}

Request request_from_envelope(const nlohmann::json& body, const Params& params) {
  if (!body.is_object()) fail("gltf_invalid_request", "the glTF envelope must be a JSON object");
  for (auto it = body.begin(); it != body.end(); ++it) {
    static const char* known[] = {"gltf_base64", "boundary", "options", "mesh", "primitive", "weld"};
    if (std::find_if(std::begin(known), std::end(known), [&](const char* k) { return it.key() == k; }) == std::end(known))
      throw codec::JsonError("unknown_field", "unknown member \"" + it.key() + "\" (the glTF envelope has gltf_base64, boundary, options, mesh, primitive, weld)",
                             "/" + codec::escape_pointer_token(it.key()));
  }
  const json& b64 = body["gltf_base64"];
  if (!b64.is_string()) throw codec::JsonError("wrong_type", "gltf_base64 must be a string (the .glb or .gltf, base64)", "/gltf_base64");
  auto index_member = [&](const char* key) -> std::optional<int> {
    const auto it = body.find(key);
    if (it == body.end()) return std::nullopt;
    if (!it->is_number_integer() || it->get<long long>() < 0 || it->get<long long>() > 999999999)
      throw codec::JsonError("wrong_type", std::string(key) + " must be a non-negative integer", std::string("/") + key);
    return it->get<int>();
  };
  std::optional<Weld> weld;
  if (const auto it = body.find("weld"); it != body.end()) {
    if (!it->is_string()) throw codec::JsonError("wrong_type", "weld must be \"none\" or \"position\"", "/weld");
    weld = parse_weld(it->get<std::string>());
  }
  const Selection sel = selection_of(params, index_member("mesh"), index_member("primitive"), weld);
  const std::string bytes = base64_decode(b64.get<std::string>());
  const json* boundary = nullptr;
  std::optional<int> texcoord;
  if (const auto it = body.find("boundary"); it != body.end()) {
    if (it->is_string()) {
      texcoord = parse_texcoord_spec(it->get<std::string>());
      if (!texcoord) throw codec::JsonError("invalid_value", "boundary must be an object or \"texcoord:N\"", "/boundary");
    } else {
      boundary = &*it;
    }
  }
  if (params.boundary) {
    const std::optional<int> p = parse_texcoord_spec(*params.boundary);
    if (!p) fail("gltf_invalid_request", "the boundary parameter must be texcoord:N");
    texcoord = agree(texcoord, p, "boundary");
  }
  const json* options = body.contains("options") ? &body["options"] : nullptr;
  // Shape errors of boundary/options before the (possibly large) model is read.
  parse_rest(boundary, options);
  Asset asset = Asset::read(bytes, sel);
  return finish(std::move(asset), texcoord, boundary, options, params);
}

Request request_from_parts(const std::map<std::string, Part>& parts, const Params& params) {
  for (const auto& [name, part] : parts)
    if (name != "model" && name != "boundary" && name != "options")
      fail("gltf_invalid_request", "unknown multipart part \"" + name.substr(0, 40) + "\" (parts: model, boundary, options)");
  const auto model = parts.find("model");
  if (model == parts.end()) fail("gltf_invalid_request", "the multipart body has no \"model\" part (the .glb or .gltf)");
  std::optional<Format> format = format_from_media_type(model->second.content_type);
  json boundary_json, options_json;
  const json* boundary = nullptr;
  const json* options = nullptr;
  std::optional<int> texcoord;
  if (const auto b = parts.find("boundary"); b != parts.end()) {
    if (const auto t = parse_texcoord_spec(b->second.content)) {
      texcoord = t;
    } else {
      try {
        boundary_json = codec::parse_json(b->second.content);
      } catch (const codec::JsonError& e) {
        throw codec::JsonError(e.code(), std::string("multipart part \"boundary\": ") + e.what(), "/boundary" + e.pointer(), e.byte_offset());
      }
      boundary = &boundary_json;
    }
  }
  if (params.boundary) {
    const std::optional<int> p = parse_texcoord_spec(*params.boundary);
    if (!p) fail("gltf_invalid_request", "the boundary parameter must be texcoord:N");
    texcoord = agree(texcoord, p, "boundary");
  }
  if (const auto o = parts.find("options"); o != parts.end()) {
    try {
      options_json = codec::parse_json(o->second.content);
    } catch (const codec::JsonError& e) {
      throw codec::JsonError(e.code(), std::string("multipart part \"options\": ") + e.what(), "/options" + e.pointer(), e.byte_offset());
    }
    options = &options_json;
  }
  parse_rest(boundary, options);
  Asset asset = Asset::read(model->second.content, selection_of(params, std::nullopt, std::nullopt, std::nullopt), format);
  return finish(std::move(asset), texcoord, boundary, options, params);
}

// ---- base64 -------------------------------------------------------------------------------------------

std::string base64_encode(std::string_view bytes) {
  static const char* table = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const std::uint32_t n = static_cast<unsigned char>(bytes[i]) << 16 | static_cast<unsigned char>(bytes[i + 1]) << 8 |
                            static_cast<unsigned char>(bytes[i + 2]);
    out += table[n >> 18];
    out += table[(n >> 12) & 63];
    out += table[(n >> 6) & 63];
    out += table[n & 63];
  }
  if (i < bytes.size()) {
    std::uint32_t n = static_cast<unsigned char>(bytes[i]) << 16;
    if (i + 1 < bytes.size()) n |= static_cast<unsigned char>(bytes[i + 1]) << 8;
    out += table[n >> 18];
    out += table[(n >> 12) & 63];
    out += i + 1 < bytes.size() ? table[(n >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

std::string base64_decode(std::string_view text, const std::string& what) {
  auto value = [](char c) -> int {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    if (c == '+' || c == '-') return 62;
    if (c == '/' || c == '_') return 63;
    return -1;
  };
  std::string out;
  out.reserve(text.size() / 4 * 3);
  std::uint32_t acc = 0;
  int n = 0, pad = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == ' ' || c == '\n' || c == '\r' || c == '\t') continue;
    if (c == '=') {
      ++pad;
      continue;
    }
    const int v = value(c);
    if (v < 0 || pad > 0)
      fail("gltf_invalid_base64", what + " is not base64: " + (pad > 0 ? "data after '=' padding" : "character " + hex_bytes(text.substr(i, 1), 1)) +
                                      " at offset " + std::to_string(i));
    acc = acc << 6 | static_cast<std::uint32_t>(v);
    if (++n == 4) {
      out += static_cast<char>(acc >> 16);
      out += static_cast<char>((acc >> 8) & 255);
      out += static_cast<char>(acc & 255);
      acc = 0;
      n = 0;
    }
  }
  if (n == 1 || pad > 2) fail("gltf_invalid_base64", what + " is not base64: its length does not fit the encoding");
  if (n == 2) out += static_cast<char>(acc >> 4);
  if (n == 3) {
    out += static_cast<char>(acc >> 10);
    out += static_cast<char>((acc >> 2) & 255);
  }
  return out;
}

}  // namespace lipmap::gltf
