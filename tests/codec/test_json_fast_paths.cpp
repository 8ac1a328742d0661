// server/codec/json_codec: the DOM-free paths give what the DOM paths give, over many generated cases.
//   parametrize_request_from_text(text) == parametrize_request_from_json(parse_json(text)) for every body it
//   accepts, and for a body the DOM path refuses it either declines (nullopt) or throws the same error;
//   parametrize_result_to_text(r, pretty) == dump(parametrize_result_to_json(r), pretty), byte for byte.
// The reference is nlohmann's own DOM and serializer, independent of the code checked.
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/pipeline.h"
#include "server/codec/json_codec.h"

namespace {

using nlohmann::json;
namespace codec = lipmap::codec;

// A double drawn over the whole range: random bits (finite only), ordinary decimals, whole numbers, tiny and
// huge powers of ten, signed zeros, the extremes.
double any_double(std::mt19937_64& rng) {
  switch (rng() % 8) {
    case 0: {
      for (;;) {
        const std::uint64_t bits = rng();
        double d;
        std::memcpy(&d, &bits, sizeof d);
        if (std::isfinite(d)) return d;
      }
    }
    case 1: return std::uniform_real_distribution<double>(-1, 1)(rng);
    case 2: return static_cast<double>(static_cast<long long>(rng() % 2000001) - 1000000);
    case 3: return std::ldexp(std::uniform_real_distribution<double>(0.5, 1)(rng), static_cast<int>(rng() % 120) - 60);
    case 4: return std::pow(10.0, static_cast<int>(rng() % 40) - 20) * ((rng() & 1) ? 1 : -1);
    case 5: {
      const double special[] = {0.0, -0.0, 1e15, 1e16, 1e-4, 1e-5, 123456789012345.0, 1234567890123456.0,
                                std::numeric_limits<double>::min(), std::numeric_limits<double>::denorm_min(),
                                std::numeric_limits<double>::max(), 0.1, 0.3, 5e-324, 9007199254740993.0};
      return special[rng() % (sizeof special / sizeof special[0])];
    }
    default: return std::uniform_real_distribution<double>(-1000, 1000)(rng);
  }
}

// Where two texts part, with some context, for a readable failure.
std::string first_difference(const std::string& a, const std::string& b) {
  std::size_t i = 0;
  while (i < a.size() && i < b.size() && a[i] == b[i]) ++i;
  if (i == a.size() && i == b.size()) return "";
  const std::size_t from = i < 60 ? 0 : i - 60;
  return "at byte " + std::to_string(i) + ": got ..." + a.substr(from, 120) + "... expected ..." + b.substr(from, 120) + "...";
}

lipmap::ParametrizeResult random_result(std::mt19937_64& rng, std::size_t nv, std::size_t nf, std::size_t ni) {
  lipmap::ParametrizeResult r;
  r.classification.verdict = lipmap::Verdict::simple;
  r.classification.turning_number = 1;
  r.classification.rotation_indices = {0, 0, 0};
  r.boundary_loop = {0, 1, 2};
  for (std::size_t v = 0; v < nv; ++v) {
    r.map.vertices.push_back({any_double(rng), any_double(rng), any_double(rng)});
    r.map.uv.push_back({any_double(rng), any_double(rng)});
  }
  for (std::size_t f = 0; f < nf; ++f)
    r.map.faces.push_back({static_cast<int>(rng() % 1000000), static_cast<int>(rng() % 7), static_cast<int>(rng())});
  for (std::size_t i = 0; i < ni; ++i)
    r.map.inserted.push_back({static_cast<int>(rng() % 1000), static_cast<int>(rng() % 100000), any_double(rng)});
  r.distortion.bin_edges = {1.0, 1.1, 1.25, 1.5, 2.0, 3.0, 5.0, 10.0, std::numeric_limits<double>::infinity()};
  r.distortion.counts.assign(8, 1);
  r.distortion.max = any_double(rng);
  r.distortion.mean = (rng() & 1) ? std::numeric_limits<double>::infinity() : any_double(rng);
  r.timings.total = any_double(rng);
  return r;
}

TEST(JsonFastPaths, AnswerTextIsTheDomDumpByteForByte) {
  std::mt19937_64 rng(20261201);
  int cases = 0;
  for (int round = 0; round < 300; ++round) {
    const std::size_t nv = round < 20 ? round % 3 : rng() % 200, nf = round < 20 ? round % 2 : rng() % 100,
                      ni = round < 20 ? (round / 2) % 2 : rng() % 30;
    const lipmap::ParametrizeResult r = random_result(rng, nv, nf, ni);
    for (bool pretty : {false, true}) {
      const std::string expected = codec::dump(codec::parametrize_result_to_json(r), pretty);
      const std::string got = codec::parametrize_result_to_text(r, pretty);
      ASSERT_EQ(first_difference(got, expected), "") << "round " << round << (pretty ? " pretty" : " compact");
      ++cases;
    }
  }
  EXPECT_EQ(cases, 600);
}

TEST(JsonFastPaths, EveryDoubleIsWrittenAsNlohmannWritesIt) {
  // Many doubles per answer: the number formatting is where the two writers could part.
  std::mt19937_64 rng(7);
  for (int round = 0; round < 20; ++round) {
    const lipmap::ParametrizeResult r = random_result(rng, 5000, 1, 0);
    ASSERT_EQ(first_difference(codec::parametrize_result_to_text(r), codec::dump(codec::parametrize_result_to_json(r))), "")
        << round;
  }
}

TEST(JsonFastPaths, AnswerWrittenOnSeveralThreadsIsTheDomDumpByteForByte) {
  // Big enough for the parallel way (kParallelAnswerRows), which cuts every big array into spans of rows
  // and joins them: the seams (separators, indents, the first row of each array) are where it could differ.
  std::mt19937_64 rng(31);
  for (int threads : {2, 3, 5}) {
    const std::size_t nv = codec::kParallelAnswerRows / 3 + rng() % 5000, nf = codec::kParallelAnswerRows / 3 + rng() % 5000;
    const lipmap::ParametrizeResult r = random_result(rng, nv, nf, threads == 3 ? 0 : 1 + rng() % 40);
    ASSERT_GE(r.map.vertices.size() + r.map.faces.size() + r.map.uv.size(), codec::kParallelAnswerRows);
    for (bool pretty : {false, true}) {
      const std::string expected = codec::dump(codec::parametrize_result_to_json(r), pretty);
      ASSERT_EQ(first_difference(codec::parametrize_result_to_text(r, pretty, threads), expected), "")
          << threads << " threads" << (pretty ? " pretty" : " compact");
    }
  }
}

// The mesh's rows formatted ahead from the request (MeshRowsAhead) are used only where the answer holds the
// request's rows unchanged: whatever the answer did to them (nothing, a vertex moved by a bit, -0 for +0,
// vertices or faces added, faces renumbered, a request with a quad), its text is the DOM's dump. With the
// ahead thread finished first (every block ready) and not (the answer races it).
TEST(JsonFastPaths, AnswerWithTheMeshFormattedAheadIsTheDomDumpByteForByte) {
  std::mt19937_64 rng(43);
  int cases = 0;
  for (int round = 0; round < 12; ++round) {
    const std::size_t nv = codec::kParallelAnswerRows / 3 + rng() % 20000, nf = codec::kParallelAnswerRows / 3 + rng() % 20000;
    lipmap::ParametrizeResult r = random_result(rng, nv, nf, 0);
    lipmap::RawMesh request;
    request.vertices = r.map.vertices;
    for (const lipmap::Triangle& t : r.map.faces) request.faces.push_back(t);
    switch (round % 6) {
      case 0: break;  // the answer's mesh is the request's
      case 1: {       // one vertex moved by one bit, one zero's sign changed
        double& x = r.map.vertices[rng() % nv].y;
        x = std::nextafter(x, 1e300);
        request.vertices[rng() % nv].z = 0.0;
        r.map.vertices[rng() % nv].z = -0.0;
        break;
      }
      case 2:  // vertices and faces inserted (a refined mesh), one face renumbered
        for (int k = 0; k < 9000; ++k) r.map.vertices.push_back({any_double(rng), any_double(rng), any_double(rng)});
        for (int k = 0; k < 5000; ++k) r.map.faces.push_back({k, k + 1, k + 2});
        r.map.faces[rng() % nf][1] += 1;
        r.map.uv.resize(r.map.vertices.size(), {0.5, -0.25});
        break;
      case 3:  // a request with fewer vertices and faces than its answer, not ending on a block's edge
        request.vertices.resize(nv - 1);
        request.faces.pop_back();
        break;
      case 4:  // a quad among the request's faces: the faces are never taken
        request.faces.replace(rng() % nf, {1, 2, 3, 4});
        break;
      default:  // more rows in the request than in the answer
        request.vertices.push_back({1, 2, 3});
        request.faces.push_back({0, 1, 2});
        break;
    }
    const std::string expected = codec::dump(codec::parametrize_result_to_json(r));
    for (bool finished_first : {true, false}) {
      for (int threads : {1, 2}) {
        codec::MeshRowsAhead ahead(request);
        if (finished_first) ahead.wait();
        ASSERT_EQ(first_difference(codec::parametrize_result_to_text(r, false, threads, &ahead), expected), "")
            << "round " << round << ", " << threads << " threads" << (finished_first ? ", finished first" : "");
        ++cases;
      }
    }
    // Pretty text never takes the compact rows.
    codec::MeshRowsAhead ahead(request);
    ahead.wait();
    ASSERT_EQ(first_difference(codec::parametrize_result_to_text(r, true, 2, &ahead),
                               codec::dump(codec::parametrize_result_to_json(r), true)), "") << "round " << round;
  }
  EXPECT_EQ(cases, 48);
}

// ---- requests ----------------------------------------------------------------------------------------

std::string number_text(std::mt19937_64& rng, double d) {
  switch (rng() % 4) {
    case 0: return json(d).dump();
    case 1: {
      char buf[64];
      std::snprintf(buf, sizeof buf, "%.17g", d);
      return buf;
    }
    case 2: {
      char buf[64];
      std::snprintf(buf, sizeof buf, "%.3e", d);
      return buf;
    }
    default: return std::to_string(static_cast<long long>(std::fmod(d, 1e6)));
  }
}

std::string random_body(std::mt19937_64& rng) {
  const int nv = 3 + static_cast<int>(rng() % 8), nf = 1 + static_cast<int>(rng() % 8);
  std::string v = "[", f = "[", p = "[";
  for (int i = 0; i < nv; ++i) {
    v += i ? ", [" : "[";
    for (int c = 0; c < 3; ++c) v += (c ? "," : "") + number_text(rng, any_double(rng));
    v += "]";
  }
  v += "]";
  for (int i = 0; i < nf; ++i) {
    const int corners = rng() % 10 ? 3 : static_cast<int>(rng() % 5);
    f += i ? ",[" : "[";
    for (int c = 0; c < corners; ++c) f += (c ? ", " : "") + std::to_string(static_cast<long long>(rng() % 12) - 1);
    f += "]";
  }
  f += "]";
  const int nb = 3 + static_cast<int>(rng() % 4);
  for (int i = 0; i < nb; ++i) p += (i ? ",[" : "[") + number_text(rng, any_double(rng)) + "," + number_text(rng, any_double(rng)) + "]";
  p += "]";
  std::string boundary = "{";
  std::vector<std::string> members;
  if (rng() % 4) members.push_back(R"("positions": )" + p);
  if (rng() % 3 == 0) members.push_back(R"("vertices": [0, 1, 2])");
  if (rng() % 3 == 0) members.push_back(R"("rotation_indices": [0, 0, 1])");
  for (std::size_t i = 0; i < members.size(); ++i) std::swap(members[i], members[rng() % members.size()]);
  for (std::size_t i = 0; i < members.size(); ++i) boundary += (i ? ", " : "") + members[i];
  boundary += "}";
  std::vector<std::string> top;
  if (rng() % 8) top.push_back(R"("mesh": {"vertices": )" + v + R"(, "faces": )" + f + "}");
  if (rng() % 8) top.push_back(R"("boundary": )" + boundary);
  const char* options[] = {R"({"method": "tutte"})", R"({"refine": false, "target_density": 2.5})", "{}",
                           R"({"method": "nope"})", R"({"target_density": -1})", R"({"refine": 1})", "[1]",
                           R"({"method": "harmonic", "method": "tutte"})", R"({"unknown": {"deep": [1, [2]]}})"};
  if (rng() % 2) top.push_back(std::string(R"("options": )") + options[rng() % (sizeof options / sizeof options[0])]);
  for (std::size_t i = 0; i < top.size(); ++i) std::swap(top[i], top[rng() % top.size()]);
  std::string body = "{";
  for (std::size_t i = 0; i < top.size(); ++i) body += (i ? ", " : "") + top[i];
  return body + "}";
}

// A body with one fault: a character changed, inserted or removed, or a member repeated.
std::string mutate(std::mt19937_64& rng, std::string s) {
  const char alphabet[] = "[]{},:\"0123456789.eE+-tfnul xyz";
  const std::size_t at = rng() % s.size();
  switch (rng() % 5) {
    case 0: s[at] = alphabet[rng() % (sizeof alphabet - 1)]; break;
    case 1: s.insert(at, 1, alphabet[rng() % (sizeof alphabet - 1)]); break;
    case 2: s.erase(at, 1); break;
    case 3: {
      const std::string keys[] = {R"("faces": )", R"("vertices": )", R"("positions": )", R"("mesh": )"};
      const std::string& k = keys[rng() % 4];
      const auto p = s.find(k);
      if (p != std::string::npos) s.insert(p, k + "[], ");
      break;
    }
    default: s.insert(s.size() - 1, R"(, "gltf_base64": "")"); break;
  }
  return s;
}

struct Outcome {
  std::optional<codec::ParametrizeRequest> request;
  std::string code, pointer, message;
};

template <class F>
Outcome outcome(F&& f) {
  Outcome o;
  try {
    o.request = f();
  } catch (const codec::JsonError& e) {
    o.code = e.code(), o.pointer = e.pointer(), o.message = e.what();
  }
  return o;
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

void expect_same_request(const codec::ParametrizeRequest& a, const codec::ParametrizeRequest& b, const std::string& body) {
  ASSERT_EQ(a.mesh.vertices.size(), b.mesh.vertices.size()) << body;
  for (std::size_t i = 0; i < a.mesh.vertices.size(); ++i) {
    ASSERT_TRUE(same_bits(a.mesh.vertices[i].x, b.mesh.vertices[i].x)) << body;
    ASSERT_TRUE(same_bits(a.mesh.vertices[i].y, b.mesh.vertices[i].y)) << body;
    ASSERT_TRUE(same_bits(a.mesh.vertices[i].z, b.mesh.vertices[i].z)) << body;
  }
  ASSERT_EQ(a.mesh.faces, b.mesh.faces) << body;
  ASSERT_EQ(a.boundary.positions.size(), b.boundary.positions.size()) << body;
  for (std::size_t i = 0; i < a.boundary.positions.size(); ++i) {
    ASSERT_TRUE(same_bits(a.boundary.positions[i].x, b.boundary.positions[i].x)) << body;
    ASSERT_TRUE(same_bits(a.boundary.positions[i].y, b.boundary.positions[i].y)) << body;
  }
  ASSERT_EQ(a.boundary.vertices, b.boundary.vertices) << body;
  ASSERT_EQ(a.boundary.rotation_indices, b.boundary.rotation_indices) << body;
  ASSERT_EQ(a.options.method, b.options.method) << body;
  ASSERT_EQ(a.options.refine, b.options.refine) << body;
  ASSERT_TRUE(same_bits(a.options.target_density, b.options.target_density)) << body;
}

// Read in place (the string's spare room zeroed as simdjson's padding, as the service and the command line
// read their bodies), a body has the same outcome as read from a padded copy.
void expect_same_read_in_place(const Outcome& copied, const std::string& body) {
  std::string text = body;
  text.reserve(body.size() + codec::kJsonReadPadding);
  const std::size_t padding = codec::pad_for_reading(text);
  ASSERT_EQ(padding, codec::kJsonReadPadding);
  ASSERT_EQ(text, body);
  // And with the mesh's first big array read by a helper thread, in place and from a copy.
  for (const auto& [pad, threads] : {std::pair<std::size_t, int>{padding, 1}, {padding, 2}, {0, 2}}) {
    const Outcome other = outcome([&] { return codec::parametrize_request_from_text(text, pad, threads); });
    ASSERT_EQ(other.request.has_value(), copied.request.has_value()) << threads << " threads: " << body;
    if (copied.request) expect_same_request(*copied.request, *other.request, body);
    ASSERT_EQ(other.code, copied.code) << body;
    ASSERT_EQ(other.pointer, copied.pointer) << body;
    ASSERT_EQ(other.message, copied.message) << body;
  }
}

TEST(JsonFastPaths, RequestFromTextAgreesWithTheDomPath) {
  std::mt19937_64 rng(13);
  int accepted = 0, declined = 0, same_error = 0;
  for (int round = 0; round < 4000; ++round) {
    std::string body = random_body(rng);
    if (round % 2) body = mutate(rng, body);
    const Outcome dom = outcome([&] { return codec::parametrize_request_from_json(codec::parse_json(body)); });
    const Outcome fast = outcome([&] { return codec::parametrize_request_from_text(body); });
    expect_same_read_in_place(fast, body);
    if (dom.request) {
      if (!fast.request) {
        // Declining a valid body is allowed (e.g. a float written where an index goes), never an error.
        ASSERT_TRUE(fast.code.empty()) << body << "\n" << fast.message;
        ++declined;
        continue;
      }
      expect_same_request(*dom.request, *fast.request, body);
      ++accepted;
    } else if (fast.request) {
      FAIL() << "the DOM path refuses (" << dom.code << " " << dom.pointer << ") what the fast path accepts: " << body;
    } else if (!fast.code.empty()) {
      ASSERT_EQ(fast.code, dom.code) << body;
      ASSERT_EQ(fast.pointer, dom.pointer) << body;
      ASSERT_EQ(fast.message, dom.message) << body;
      ++same_error;
    } else {
      ++declined;
    }
  }
  // The generator reaches every branch.
  EXPECT_GT(accepted, 500);
  EXPECT_GT(same_error, 100);
  EXPECT_GT(declined, 500);
}

// What follows or precedes the root object, and structure the generator's mutations do not reach (they never
// write past the closing brace): the fast path never accepts a text the DOM path refuses, and what both
// accept is the same request.
TEST(JsonFastPaths, TextAroundAndInsideTheBodyIsJudgedAsTheDomJudgesIt) {
  std::mt19937_64 rng(29);
  const std::string around[][2] = {{"", " x"}, {"", "{}"}, {"", " []"}, {"", "\n\t "}, {"", " 1"}, {"", ","},
                                   {"", "}"}, {"", "\"s\""}, {" \r\n", ""}, {"[", "]"}, {"\xEF\xBB\xBF", ""},
                                   {"", std::string(1, '\0')}};
  int accepted = 0, refused = 0;
  for (int round = 0; round < 40; ++round) {
    const std::string body = random_body(rng);
    for (const auto& [before, after] : around) {
      const std::string text = before + body + after;
      const Outcome dom = outcome([&] { return codec::parametrize_request_from_json(codec::parse_json(text)); });
      const Outcome fast = outcome([&] { return codec::parametrize_request_from_text(text); });
      const Outcome two = outcome([&] { return codec::parametrize_request_from_text(text, 0, 2); });
      if (!dom.request) {
        ASSERT_FALSE(fast.request) << "the fast path accepts what the DOM path refuses: " << text;
        ASSERT_FALSE(two.request) << "the fast path on 2 threads accepts what the DOM path refuses: " << text;
        ++refused;
      } else if (fast.request) {
        expect_same_request(*dom.request, *fast.request, text);
        ASSERT_TRUE(two.request) << text;
        expect_same_request(*dom.request, *two.request, text);
        ++accepted;
      }
    }
  }
  EXPECT_GT(accepted, 20);  // valid bodies with whitespace around them (some generated bodies are invalid)
  EXPECT_GT(refused, 200);
}

// A map made by the engine, written both ways, compact and pretty.
TEST(JsonFastPaths, PipelineAnswerTextIsTheDomDump) {
  lipmap::RawMesh mesh;
  const int n = 12;
  for (int y = 0; y <= n; ++y)
    for (int x = 0; x <= n; ++x) mesh.vertices.push_back({x / double(n), y / double(n), 0.1 * std::sin(x + y)});
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const long long a = y * (n + 1) + x, b = a + 1, c = a + n + 1, d = c + 1;
      mesh.faces.push_back({a, b, d});
      mesh.faces.push_back({a, d, c});
    }
  // The boundary loop from vertex 0 with the interior on the left, onto a wavy square (not convex).
  std::vector<long long> loop;
  for (int x = 0; x < n; ++x) loop.push_back(x);
  for (int y = 0; y < n; ++y) loop.push_back(y * (n + 1) + n);
  for (int x = n; x > 0; --x) loop.push_back(n * (n + 1) + x);
  for (int y = n; y > 0; --y) loop.push_back(y * (n + 1));
  lipmap::RawBoundary boundary;
  boundary.vertices = loop;
  for (std::size_t k = 0; k < loop.size(); ++k) {
    const lipmap::Point3& p = mesh.vertices[static_cast<std::size_t>(loop[k])];
    boundary.positions.push_back({p.x + 0.05 * std::sin(7 * p.y), p.y + 0.05 * std::sin(5 * p.x)});
  }
  const lipmap::ParametrizeResult r = lipmap::parametrize(mesh, boundary, {});
  for (bool pretty : {false, true})
    EXPECT_EQ(first_difference(codec::parametrize_result_to_text(r, pretty),
                               codec::dump(codec::parametrize_result_to_json(r), pretty)),
              "");
}

}  // namespace
