// server/json_codec: every error class with its code and JSON pointer, and lossless round trips.
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "server/codec/json_codec.h"

namespace {

using lipmap::Classification;
using lipmap::Verdict;
using lipmap::codec::JsonError;
using nlohmann::json;
namespace codec = lipmap::codec;

struct Caught {
  std::string code, pointer, message;
  std::optional<long long> offset;
};

template <class F>
Caught catch_json_error(F&& f) {
  try {
    f();
  } catch (const JsonError& e) {
    return Caught{e.code(), e.pointer(), e.what(), e.byte_offset()};
  } catch (const std::exception& e) {
    ADD_FAILURE() << "expected JsonError, got another exception: " << e.what();
    return {};
  }
  ADD_FAILURE() << "expected JsonError, nothing was thrown";
  return {};
}

Caught classify_error(const std::string& text) {
  return catch_json_error([&] { codec::classify_request_from_json(codec::parse_json(text)); });
}

Caught parametrize_error(const std::string& text) {
  return catch_json_error([&] { codec::parametrize_request_from_json(codec::parse_json(text)); });
}

const char* kSquare = R"({"polygon": [[0,0],[1,0],[1,1],[0,1]]})";

// A valid parametrize body with one fault spliced in.
std::string parametrize_body(const std::string& vertices = "[[0,0,0],[1,0,0],[0,1,0]]",
                             const std::string& faces = "[[0,1,2]]",
                             const std::string& boundary = R"({"positions": [[0,0],[1,0],[0,1]]})",
                             const std::string& extra = "") {
  return R"({"mesh": {"vertices": )" + vertices + R"(, "faces": )" + faces + R"(}, "boundary": )" + boundary + extra +
         "}";
}

// ---- parse_json: syntax-level errors ---------------------------------------------------------------------

TEST(JsonCodecParse, AcceptsValidDocument) {
  json j = codec::parse_json(R"({"a": [1, 2.5, -3, true, null, "s", {"b": []}]})");
  ASSERT_TRUE(j.is_object());
  EXPECT_EQ(j["a"].size(), 7u);
  EXPECT_EQ(j["a"][1].get<double>(), 2.5);
  EXPECT_TRUE(j["a"][6]["b"].is_array());
}

TEST(JsonCodecParse, InvalidJsonSyntax) {
  Caught c = catch_json_error([] { codec::parse_json(R"({"polygon": [[0,0],[1 0]]})"); });
  EXPECT_EQ(c.code, "invalid_json");
  EXPECT_EQ(c.pointer, "/polygon/1/1");  // where the parser was: second point, its second coordinate
  ASSERT_TRUE(c.offset.has_value());
  EXPECT_EQ(*c.offset, 23);  // characters read when the parser stopped
  EXPECT_EQ(c.message.find("[json.exception"), std::string::npos) << c.message;
}

TEST(JsonCodecParse, EmptyAndTruncatedAndTrailingGarbage) {
  EXPECT_EQ(catch_json_error([] { codec::parse_json(""); }).code, "invalid_json");
  EXPECT_EQ(catch_json_error([] { codec::parse_json("  \n "); }).code, "invalid_json");
  EXPECT_EQ(catch_json_error([] { codec::parse_json(R"({"polygon": [[0,0])"); }).code, "invalid_json");
  EXPECT_EQ(catch_json_error([] { codec::parse_json(R"({} {})"); }).code, "invalid_json");
  EXPECT_EQ(catch_json_error([] { codec::parse_json("[NaN]"); }).code, "invalid_json");
  EXPECT_EQ(catch_json_error([] { codec::parse_json("[Infinity]"); }).code, "invalid_json");
}

TEST(JsonCodecParse, InvalidUtf8IsInvalidJson) {
  std::string text = "{\"polygon\": \"\xff\xfe\"}";
  Caught c = catch_json_error([&] { codec::parse_json(text); });
  EXPECT_EQ(c.code, "invalid_json");
  EXPECT_EQ(c.pointer, "/polygon");
}

TEST(JsonCodecParse, NumberThatOverflowsADoubleIsNonFinite) {
  Caught c = catch_json_error([] { codec::parse_json(R"({"polygon": [[0,0],[1,0],[1,1e999]]})"); });
  EXPECT_EQ(c.code, "non_finite_number");
  EXPECT_EQ(c.pointer, "/polygon/2/1");
  EXPECT_NE(c.message.find("1e999"), std::string::npos) << c.message;
}

TEST(JsonCodecParse, DuplicateKey) {
  Caught c = catch_json_error([] { codec::parse_json(R"({"mesh": {"faces": [], "faces": []}})"); });
  EXPECT_EQ(c.code, "duplicate_key");
  EXPECT_EQ(c.pointer, "/mesh/faces");
}

TEST(JsonCodecParse, NestingTooDeep) {
  std::string deep(codec::kMaxNesting + 1, '[');
  deep += std::string(codec::kMaxNesting + 1, ']');
  EXPECT_EQ(catch_json_error([&] { codec::parse_json(deep); }).code, "nesting_too_deep");
  std::string ok(codec::kMaxNesting, '[');
  ok += std::string(codec::kMaxNesting, ']');
  EXPECT_NO_THROW(codec::parse_json(ok));
}

TEST(JsonCodecParse, PointerTokensAreEscaped) {
  EXPECT_EQ(codec::escape_pointer_token("a/b~c"), "a~1b~0c");
  Caught c = catch_json_error([] { codec::parse_json(R"({"a/b": 1, "a/b": 2})"); });
  EXPECT_EQ(c.pointer, "/a~1b");
}

TEST(JsonCodecParse, ErrorsAreInputErrors) {
  try {
    codec::parse_json("{");
    FAIL();
  } catch (const lipmap::InputError& e) {
    EXPECT_EQ(e.code(), "invalid_json");
    EXPECT_EQ(e.element(), "field");
  }
}

// ---- classify request ---------------------------------------------------------------------------------

TEST(JsonCodecClassifyRequest, ParsesPolygonAndRotationIndices) {
  lipmap::BoundaryPolygon p = codec::classify_request_from_json(codec::parse_json(kSquare));
  ASSERT_EQ(p.vertices.size(), 4u);
  EXPECT_EQ(p.vertices[2], (lipmap::Point2{1, 1}));
  EXPECT_FALSE(p.rotation_indices.has_value());

  p = codec::classify_request_from_json(
      codec::parse_json(R"({"polygon": [[0.5,-2],[1e-300,0],[3,4]], "rotation_indices": [0, 1, 2.0]})"));
  ASSERT_TRUE(p.rotation_indices.has_value());
  EXPECT_EQ(*p.rotation_indices, (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(p.vertices[1].x, 1e-300);
}

TEST(JsonCodecClassifyRequest, ShapeIsLeftToTheEngine) {
  // Too few vertices and negative rotation indices are validate_polygon's to name, not the codec's.
  lipmap::BoundaryPolygon p =
      codec::classify_request_from_json(codec::parse_json(R"({"polygon": [[0,0]], "rotation_indices": [-1, 7]})"));
  EXPECT_EQ(p.vertices.size(), 1u);
  EXPECT_EQ(*p.rotation_indices, (std::vector<int>{-1, 7}));
}

TEST(JsonCodecClassifyRequest, BodyNotAnObject) {
  Caught c = classify_error("[[0,0],[1,0],[1,1]]");
  EXPECT_EQ(c.code, "wrong_type");
  EXPECT_EQ(c.pointer, "");
}

TEST(JsonCodecClassifyRequest, MissingPolygon) {
  Caught c = classify_error(R"({"rotation_indices": []})");
  EXPECT_EQ(c.code, "missing_field");
  EXPECT_EQ(c.pointer, "/polygon");
}

TEST(JsonCodecClassifyRequest, UnknownField) {
  Caught c = classify_error(R"({"polygon": [[0,0],[1,0],[1,1]], "rotation_index": [0,0,0]})");
  EXPECT_EQ(c.code, "unknown_field");
  EXPECT_EQ(c.pointer, "/rotation_index");
}

TEST(JsonCodecClassifyRequest, WrongTypes) {
  Caught c = classify_error(R"({"polygon": {"x": 1}})");
  EXPECT_EQ(c.code, "wrong_type");
  EXPECT_EQ(c.pointer, "/polygon");
  c = classify_error(R"({"polygon": [[0,0],[1,"0"],[1,1]]})");
  EXPECT_EQ(c.code, "wrong_type");
  EXPECT_EQ(c.pointer, "/polygon/1/1");
  EXPECT_NE(c.message.find("expected a number, got a string"), std::string::npos) << c.message;
  c = classify_error(R"({"polygon": [[0,0],[1,0],[true,1]]})");
  EXPECT_EQ(c.code, "wrong_type");
  EXPECT_EQ(c.pointer, "/polygon/2/0");
  c = classify_error(R"({"polygon": [[0,0],[1,0],null]})");
  EXPECT_EQ(c.code, "wrong_type");
  EXPECT_EQ(c.pointer, "/polygon/2");
  c = classify_error(R"({"polygon": [[0,0],[1,0],[1,1]], "rotation_indices": null})");
  EXPECT_EQ(c.code, "wrong_type");
  EXPECT_EQ(c.pointer, "/rotation_indices");
}

TEST(JsonCodecClassifyRequest, WrongLength) {
  Caught c = classify_error(R"({"polygon": [[0,0],[1,0,0],[1,1]]})");
  EXPECT_EQ(c.code, "wrong_length");
  EXPECT_EQ(c.pointer, "/polygon/1");
  c = classify_error(R"({"polygon": [[0,0],[1,0],[1]]})");
  EXPECT_EQ(c.code, "wrong_length");
  EXPECT_EQ(c.pointer, "/polygon/2");
}

TEST(JsonCodecClassifyRequest, RotationIndexNotAnInteger) {
  Caught c = classify_error(R"({"polygon": [[0,0],[1,0],[1,1]], "rotation_indices": [0, 0.5, 0]})");
  EXPECT_EQ(c.code, "not_an_integer");
  EXPECT_EQ(c.pointer, "/rotation_indices/1");
}

TEST(JsonCodecClassifyRequest, RotationIndexOutOfRange) {
  Caught c = classify_error(R"({"polygon": [[0,0],[1,0],[1,1]], "rotation_indices": [0, 0, 4294967296]})");
  EXPECT_EQ(c.code, "integer_out_of_range");
  EXPECT_EQ(c.pointer, "/rotation_indices/2");
  c = classify_error(R"({"polygon": [[0,0],[1,0],[1,1]], "rotation_indices": [18446744073709551615, 0, 0]})");
  EXPECT_EQ(c.code, "integer_out_of_range");
  EXPECT_EQ(c.pointer, "/rotation_indices/0");
  c = classify_error(R"({"polygon": [[0,0],[1,0],[1,1]], "rotation_indices": [0, 1e300, 0]})");
  EXPECT_EQ(c.code, "integer_out_of_range");
  EXPECT_EQ(c.pointer, "/rotation_indices/1");
}

TEST(JsonCodecClassifyRequest, NonFiniteValueBuiltInCode) {
  // parse_json cannot produce one, but a json built in code (e.g. by a future glTF reader) can.
  json body = {{"polygon", {{0.0, 0.0}, {1.0, std::numeric_limits<double>::quiet_NaN()}, {1.0, 1.0}}}};
  Caught c = catch_json_error([&] { codec::classify_request_from_json(body); });
  EXPECT_EQ(c.code, "non_finite_number");
  EXPECT_EQ(c.pointer, "/polygon/1/1");
}

TEST(JsonCodecClassifyRequest, MessagesStayOnOneLine) {
  Caught c = classify_error("{\"polygon\": [[0,0],[1,0],[1,1]], \"a\\nb\": 1}");
  EXPECT_EQ(c.code, "unknown_field");
  EXPECT_EQ(c.pointer, "/a\nb");
  EXPECT_EQ(c.message.find('\n'), std::string::npos) << c.message;
}

TEST(JsonCodecClassifyRequest, RoundTrip) {
  lipmap::BoundaryPolygon p;
  p.vertices = {{0.1, -0.0}, {1e-310, 2.0 / 3.0}, {-1e300, 123456789.125}, {std::nextafter(1.0, 2.0), 5}};
  p.rotation_indices = std::vector<int>{0, 1, 0, 6};
  std::string text = codec::classify_request_to_json(p).dump();
  lipmap::BoundaryPolygon q = codec::classify_request_from_json(codec::parse_json(text));
  ASSERT_EQ(q.vertices.size(), p.vertices.size());
  for (std::size_t i = 0; i < p.vertices.size(); ++i) {
    // bit for bit, including the sign of zero
    EXPECT_EQ(std::memcmp(&p.vertices[i], &q.vertices[i], sizeof(lipmap::Point2)), 0) << i;
  }
  EXPECT_EQ(q.rotation_indices, p.rotation_indices);
}

// ---- parametrize request ---------------------------------------------------------------------------------

TEST(JsonCodecParametrizeRequest, ParsesTheDesignShape) {
  auto r = codec::parametrize_request_from_json(codec::parse_json(parametrize_body(
      "[[0,0,0],[1,0,0],[0,1,0],[1,1,0.5]]", "[[0,1,2],[1,3,2]]",
      R"({"vertices": [0,1,3,2], "positions": [[0,0],[1,0],[1,1],[0,1]], "rotation_indices": [0,0,0,0]})",
      R"(, "options": {"method": "harmonic", "refine": false, "target_density": 2.5})")));
  ASSERT_EQ(r.mesh.vertices.size(), 4u);
  EXPECT_EQ(r.mesh.vertices[3], (lipmap::Point3{1, 1, 0.5}));
  ASSERT_EQ(r.mesh.faces.size(), 2u);
  EXPECT_EQ(r.mesh.faces[1], (std::vector<long long>{1, 3, 2}));
  EXPECT_EQ(*r.boundary.vertices, (std::vector<long long>{0, 1, 3, 2}));
  EXPECT_EQ(r.boundary.positions.size(), 4u);
  EXPECT_EQ(*r.boundary.rotation_indices, (std::vector<long long>{0, 0, 0, 0}));
  EXPECT_EQ(r.options.method, lipmap::MapMethod::harmonic);
  EXPECT_FALSE(r.options.refine);
  EXPECT_EQ(r.options.target_density, 2.5);
}

TEST(JsonCodecParametrizeRequest, DefaultsWithoutOptions) {
  auto r = codec::parametrize_request_from_json(codec::parse_json(parametrize_body()));
  EXPECT_EQ(r.options.method, lipmap::MapMethod::harmonic);  // docs/api.md: harmonic is the default
  EXPECT_TRUE(r.options.refine);
  EXPECT_EQ(r.options.target_density, 1.0);
  EXPECT_FALSE(r.boundary.vertices.has_value());
  EXPECT_FALSE(r.boundary.rotation_indices.has_value());
}

TEST(JsonCodecParametrizeRequest, FaceFaultsAreLeftToValidate) {
  // Quads, negative and huge indices reach validate_mesh, which names them with its own codes.
  auto r = codec::parametrize_request_from_json(
      codec::parse_json(parametrize_body("[[0,0,0],[1,0,0],[0,1,0]]", "[[0,1,2,-5], [9007199254740993, 0, 1]]")));
  EXPECT_EQ(r.mesh.faces[0].size(), 4u);
  EXPECT_EQ(r.mesh.faces[0][3], -5);
  EXPECT_EQ(r.mesh.faces[1][0], 9007199254740993LL);  // beyond 2^53: kept exact, not rounded through double
}

TEST(JsonCodecParametrizeRequest, MissingFields) {
  Caught c = parametrize_error(R"({"boundary": {"positions": []}})");
  EXPECT_EQ(c.code, "missing_field");
  EXPECT_EQ(c.pointer, "/mesh");
  c = parametrize_error(R"({"mesh": {"vertices": []}, "boundary": {"positions": []}})");
  EXPECT_EQ(c.code, "missing_field");
  EXPECT_EQ(c.pointer, "/mesh/faces");
  c = parametrize_error(parametrize_body("[]", "[]", R"({"vertices": [0]})"));
  EXPECT_EQ(c.code, "missing_field");
  EXPECT_EQ(c.pointer, "/boundary/positions");
  c = parametrize_error(R"({"mesh": {"vertices": [], "faces": []}})");
  EXPECT_EQ(c.code, "missing_field");
  EXPECT_EQ(c.pointer, "/boundary");
}

TEST(JsonCodecParametrizeRequest, WrongTypesWithPointers) {
  Caught c = parametrize_error(parametrize_body("[[0,0,0],[1,0,0],[0,1,0]]", R"([[0,1,2],[1,"2",0]])"));
  EXPECT_EQ(c.code, "wrong_type");
  EXPECT_EQ(c.pointer, "/mesh/faces/1/1");
  c = parametrize_error(parametrize_body("[[0,0,0],[1,0,0],[0,1,0]]", R"([[0,1,2],7])"));
  EXPECT_EQ(c.code, "wrong_type");
  EXPECT_EQ(c.pointer, "/mesh/faces/1");
  c = parametrize_error(parametrize_body("{}"));
  EXPECT_EQ(c.code, "wrong_type");
  EXPECT_EQ(c.pointer, "/mesh/vertices");
  c = parametrize_error(parametrize_body("[[0,0,0],[1,0,0],[0,1,0]]", "[[0,1,2]]", R"({"positions": [[0,0],[1,0],[0,{}]]})"));
  EXPECT_EQ(c.code, "wrong_type");
  EXPECT_EQ(c.pointer, "/boundary/positions/2/1");
  c = parametrize_error(parametrize_body("[[0,0,0],[1,0,0],[0,1,0]]", "[[0,1,2]]", R"([])"));
  EXPECT_EQ(c.code, "wrong_type");
  EXPECT_EQ(c.pointer, "/boundary");
  c = parametrize_error(parametrize_body() + "x");
  EXPECT_EQ(c.code, "invalid_json");
  c = parametrize_error(parametrize_body("[[0,0,0],[1,0,0],[0,1,0]]", "[[0,1,2]]",
                                         R"({"positions": [[0,0],[1,0],[0,1]]})", R"(, "options": {"refine": "yes"})"));
  EXPECT_EQ(c.code, "wrong_type");
  EXPECT_EQ(c.pointer, "/options/refine");
}

TEST(JsonCodecParametrizeRequest, WrongLengths) {
  Caught c = parametrize_error(parametrize_body("[[0,0,0],[1,0],[0,1,0]]"));
  EXPECT_EQ(c.code, "wrong_length");
  EXPECT_EQ(c.pointer, "/mesh/vertices/1");
  c = parametrize_error(
      parametrize_body("[[0,0,0],[1,0,0],[0,1,0]]", "[[0,1,2]]", R"({"positions": [[0,0],[1,0,0],[0,1]]})"));
  EXPECT_EQ(c.code, "wrong_length");
  EXPECT_EQ(c.pointer, "/boundary/positions/1");
}

TEST(JsonCodecParametrizeRequest, IndicesMustBeIntegers) {
  Caught c = parametrize_error(parametrize_body("[[0,0,0],[1,0,0],[0,1,0]]", "[[0,1,2],[0,1.5,2]]"));
  EXPECT_EQ(c.code, "not_an_integer");
  EXPECT_EQ(c.pointer, "/mesh/faces/1/1");
  c = parametrize_error(parametrize_body("[[0,0,0],[1,0,0],[0,1,0]]", "[[0,1,2]]",
                                         R"({"vertices": [0, 1, 2.25], "positions": [[0,0],[1,0],[0,1]]})"));
  EXPECT_EQ(c.code, "not_an_integer");
  EXPECT_EQ(c.pointer, "/boundary/vertices/2");
  c = parametrize_error(parametrize_body("[[0,0,0],[1,0,0],[0,1,0]]", "[[0,1,2]]",
                                         R"({"positions": [[0,0],[1,0],[0,1]], "rotation_indices": [0, 0, 0.5]})"));
  EXPECT_EQ(c.code, "not_an_integer");
  EXPECT_EQ(c.pointer, "/boundary/rotation_indices/2");
  c = parametrize_error(parametrize_body("[[0,0,0],[1,0,0],[0,1,0]]", "[[0,1,18446744073709551615]]"));
  EXPECT_EQ(c.code, "integer_out_of_range");
  EXPECT_EQ(c.pointer, "/mesh/faces/0/2");
}

TEST(JsonCodecParametrizeRequest, NonFiniteCoordinate) {
  Caught c = parametrize_error(parametrize_body("[[0,0,0],[1,0,-1e400],[0,1,0]]"));
  EXPECT_EQ(c.code, "non_finite_number");
  EXPECT_EQ(c.pointer, "/mesh/vertices/1/2");
}

TEST(JsonCodecParametrizeRequest, UnknownFieldsAnywhere) {
  Caught c = parametrize_error(parametrize_body() .insert(1, R"("meta": 1, )"));
  EXPECT_EQ(c.code, "unknown_field");
  EXPECT_EQ(c.pointer, "/meta");
  c = parametrize_error(R"({"mesh": {"vertices": [], "faces": [], "normals": []}, "boundary": {"positions": []}})");
  EXPECT_EQ(c.code, "unknown_field");
  EXPECT_EQ(c.pointer, "/mesh/normals");
  c = parametrize_error(parametrize_body("[[0,0,0],[1,0,0],[0,1,0]]", "[[0,1,2]]",
                                         R"({"positions": [[0,0],[1,0],[0,1]]})", R"(, "options": {"methd": "tutte"})"));
  EXPECT_EQ(c.code, "unknown_field");
  EXPECT_EQ(c.pointer, "/options/methd");
}

TEST(JsonCodecParametrizeRequest, InvalidOptionValues) {
  const std::string b = R"({"positions": [[0,0],[1,0],[0,1]]})";
  const std::string v = "[[0,0,0],[1,0,0],[0,1,0]]";
  Caught c = parametrize_error(parametrize_body(v, "[[0,1,2]]", b, R"(, "options": {"method": "lscm"})"));
  EXPECT_EQ(c.code, "invalid_value");
  EXPECT_EQ(c.pointer, "/options/method");
  c = parametrize_error(parametrize_body(v, "[[0,1,2]]", b, R"(, "options": {"target_density": 0})"));
  EXPECT_EQ(c.code, "invalid_value");
  EXPECT_EQ(c.pointer, "/options/target_density");
  c = parametrize_error(parametrize_body(v, "[[0,1,2]]", b, R"(, "options": {"target_density": -1})"));
  EXPECT_EQ(c.code, "invalid_value");
}

TEST(JsonCodecParametrizeRequest, RoundTrip) {
  codec::ParametrizeRequest r;
  r.mesh.vertices = {{0, 0, 0.1}, {1, -0.0, 1e-320}, {0.3, 1, 7}};
  r.mesh.faces = {{0, 1, 2}, {2, 1, 0, 5}};
  r.boundary.vertices = std::vector<long long>{0, 1, 2};
  r.boundary.positions = {{0, 0}, {1.0 / 3.0, 0}, {0, 1}};
  r.boundary.rotation_indices = std::vector<long long>{0, 1, 0};
  r.options.method = lipmap::MapMethod::harmonic;
  r.options.refine = false;
  r.options.target_density = 0.75;
  auto s = codec::parametrize_request_from_json(codec::parse_json(codec::parametrize_request_to_json(r).dump()));
  ASSERT_EQ(s.mesh.vertices.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i)
    EXPECT_EQ(std::memcmp(&s.mesh.vertices[i], &r.mesh.vertices[i], sizeof(lipmap::Point3)), 0) << i;
  EXPECT_EQ(s.mesh.faces, r.mesh.faces);
  EXPECT_EQ(s.boundary.vertices, r.boundary.vertices);
  EXPECT_EQ(s.boundary.positions, r.boundary.positions);
  EXPECT_EQ(s.boundary.rotation_indices, r.boundary.rotation_indices);
  EXPECT_EQ(s.options.method, r.options.method);
  EXPECT_EQ(s.options.refine, r.options.refine);
  EXPECT_EQ(s.options.target_density, r.options.target_density);
}

// ---- classify answer -----------------------------------------------------------------------------------

Classification sample_classification() {
  Classification c;
  c.verdict = Verdict::weakly_self_overlapping;
  c.turning_number = 2;
  c.triangulation = {{0, 1, 2}, {0, 2, 3}, {0, 3, 4}};
  c.rotation_indices = {1, 0, 0, 0, 0};
  c.singular_vertices = {0};
  c.stats.input_vertices = 5;
  c.stats.ears_clipped = 1;
  c.stats.reduced_vertices = 4;
  c.stats.free_rotation_search = true;
  c.stats.table_bytes = 4096;
  c.stats.ear_clipping_ms = 0.01;
  c.stats.table_ms = 0.25;
  c.stats.total_ms = 0.3;
  return c;
}

TEST(JsonCodecAnswer, ShapeAndMemberOrder) {
  nlohmann::ordered_json j = codec::classification_to_json(sample_classification());
  std::vector<std::string> keys;
  for (const auto& [k, v] : j.items()) keys.push_back(k);
  EXPECT_EQ(keys, (std::vector<std::string>{"verdict", "turning_number", "triangulation", "rotation_indices",
                                            "singular_vertices", "diagnostics"}));
  EXPECT_EQ(j["verdict"], "weakly_self_overlapping");
  EXPECT_EQ(j["triangulation"][1], nlohmann::ordered_json({0, 2, 3}));
  EXPECT_EQ(j["diagnostics"]["table_bytes"], 4096);
  EXPECT_EQ(j["diagnostics"]["timings_ms"]["table"], 0.25);
  EXPECT_FALSE(j.contains("reason"));
}

TEST(JsonCodecAnswer, ReasonOnlyWhenGiven) {
  Classification c;
  c.verdict = Verdict::not_self_overlapping;
  c.turning_number = -1;
  c.reason = "turning number -1: a self-overlapping polygon turns at least once counterclockwise";
  nlohmann::ordered_json j = codec::classification_to_json(c);
  EXPECT_EQ(j["verdict"], "not_self_overlapping");
  EXPECT_EQ(j["reason"], c.reason);
  EXPECT_TRUE(j["triangulation"].is_array());
  EXPECT_TRUE(j["triangulation"].empty());
}

TEST(JsonCodecAnswer, VerdictNames) {
  for (Verdict v : {Verdict::simple, Verdict::self_overlapping, Verdict::weakly_self_overlapping,
                    Verdict::not_self_overlapping})
    EXPECT_EQ(codec::verdict_from_name(codec::verdict_name(v)), v);
  EXPECT_FALSE(codec::verdict_from_name("Simple").has_value());
}

TEST(JsonCodecAnswer, RoundTrip) {
  for (Verdict v : {Verdict::simple, Verdict::self_overlapping, Verdict::weakly_self_overlapping,
                    Verdict::not_self_overlapping}) {
    Classification c = sample_classification();
    c.verdict = v;
    if (v == Verdict::not_self_overlapping) c.reason = "no positive triangulation";
    std::string text = codec::classification_to_json(c).dump();
    Classification d = codec::classification_from_json(codec::parse_json(text));
    EXPECT_EQ(d.verdict, c.verdict);
    EXPECT_EQ(d.turning_number, c.turning_number);
    EXPECT_EQ(d.triangulation, c.triangulation);
    EXPECT_EQ(d.rotation_indices, c.rotation_indices);
    EXPECT_EQ(d.singular_vertices, c.singular_vertices);
    EXPECT_EQ(d.reason, c.reason);
    EXPECT_EQ(d.stats.input_vertices, c.stats.input_vertices);
    EXPECT_EQ(d.stats.ears_clipped, c.stats.ears_clipped);
    EXPECT_EQ(d.stats.reduced_vertices, c.stats.reduced_vertices);
    EXPECT_EQ(d.stats.free_rotation_search, c.stats.free_rotation_search);
    EXPECT_EQ(d.stats.table_bytes, c.stats.table_bytes);
    EXPECT_EQ(d.stats.ear_clipping_ms, c.stats.ear_clipping_ms);
    EXPECT_EQ(d.stats.table_ms, c.stats.table_ms);
    EXPECT_EQ(d.stats.total_ms, c.stats.total_ms);
    // and the text itself is a fixed point
    EXPECT_EQ(codec::classification_to_json(d).dump(), text);
  }
}

TEST(JsonCodecAnswer, DumpCompactAndPretty) {
  nlohmann::ordered_json j = codec::classification_to_json(sample_classification());
  j["reason"] = "bad \xff byte";  // invalid UTF-8 is replaced, not thrown
  std::string compact = codec::dump(j);
  EXPECT_EQ(compact.find('\n'), std::string::npos);
  std::string pretty = codec::dump(j, true);
  EXPECT_NE(pretty.find("\n    [0, 2, 3],\n"), std::string::npos) << pretty;
  EXPECT_NE(pretty.find("\"rotation_indices\": [1, 0, 0, 0, 0],\n"), std::string::npos) << pretty;
  EXPECT_NE(pretty.find("\"singular_vertices\": [0],"), std::string::npos) << pretty;
  EXPECT_EQ(json::parse(pretty), json::parse(compact));
  EXPECT_EQ(codec::dump(nlohmann::ordered_json::object(), true), "{}");
  EXPECT_EQ(codec::dump(nlohmann::ordered_json::array(), true), "[]");
}

TEST(JsonCodecAnswer, StrictInverse) {
  std::string text = codec::classification_to_json(sample_classification()).dump();
  json j = json::parse(text);
  j["verdict"] = "maybe";
  Caught c = catch_json_error([&] { codec::classification_from_json(j); });
  EXPECT_EQ(c.code, "invalid_value");
  EXPECT_EQ(c.pointer, "/verdict");
  j = json::parse(text);
  j["triangulation"][2] = {0, 3};
  c = catch_json_error([&] { codec::classification_from_json(j); });
  EXPECT_EQ(c.code, "wrong_length");
  EXPECT_EQ(c.pointer, "/triangulation/2");
  j = json::parse(text);
  j["diagnostics"].erase("timings_ms");
  c = catch_json_error([&] { codec::classification_from_json(j); });
  EXPECT_EQ(c.code, "missing_field");
  EXPECT_EQ(c.pointer, "/diagnostics/timings_ms");
}

// ---- errors -------------------------------------------------------------------------------------------

TEST(JsonCodecErrors, EngineErrorPointers) {
  using lipmap::InputError;
  EXPECT_EQ(codec::classify_error_pointer(InputError("rotation_index_out_of_range", "m", "polygon_vertex", 3)),
            "/rotation_indices/3");
  EXPECT_EQ(codec::classify_error_pointer(InputError("rotation_indices_length", "m")), "/rotation_indices");
  EXPECT_EQ(codec::classify_error_pointer(InputError("polygon_zero_length_edge", "m", "polygon_vertex", 2)),
            "/polygon/2");
  EXPECT_EQ(codec::classify_error_pointer(InputError("polygon_too_small", "m")), "/polygon");
  EXPECT_EQ(codec::classify_error_pointer(JsonError("wrong_type", "m", "/polygon/0/1")), "/polygon/0/1");

  EXPECT_EQ(codec::parametrize_error_pointer(InputError("face_index_out_of_range", "m", "face", 12)), "/mesh/faces/12");
  EXPECT_EQ(codec::parametrize_error_pointer(InputError("unreferenced_vertex", "m", "vertex", 4)), "/mesh/vertices/4");
  EXPECT_EQ(codec::parametrize_error_pointer(InputError("boundary_vertex_not_on_boundary", "m", "boundary", 1)),
            "/boundary/vertices/1");
  EXPECT_EQ(codec::parametrize_error_pointer(InputError("boundary_position_non_finite", "m", "boundary", 0)),
            "/boundary/positions/0");
  EXPECT_EQ(codec::parametrize_error_pointer(InputError("not_a_disk", "m")), std::nullopt);
  EXPECT_EQ(codec::parametrize_error_pointer(InputError("non_manifold_edge", "m", "edge", 7)), std::nullopt);
}

TEST(JsonCodecErrors, ProblemJson) {
  nlohmann::ordered_json p =
      codec::problem_json(400, "Malformed request", "wrong_type", "expected a number, got a string", "/polygon/1/1");
  EXPECT_EQ(p["type"], "urn:lipmap:problem:wrong_type");
  EXPECT_EQ(p["title"], "Malformed request");
  EXPECT_EQ(p["status"], 400);
  EXPECT_EQ(p["detail"], "expected a number, got a string");
  EXPECT_EQ(p["code"], "wrong_type");
  EXPECT_EQ(p["pointer"], "/polygon/1/1");
  EXPECT_FALSE(p.contains("index"));
  EXPECT_FALSE(p.contains("element"));
  p = codec::problem_json(422, "Invalid mesh", "non_manifold_edge", "edge (3, 4) has 3 faces", std::nullopt, "edge", 17);
  EXPECT_EQ(p["index"], 17);
  EXPECT_EQ(p["element"], "edge");
  EXPECT_FALSE(p.contains("pointer"));
}

}  // namespace
