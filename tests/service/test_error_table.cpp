// server/codec/error_table.{h,cpp}: every code the sources emit has an entry, and each entry agrees with what
// is independent of the table: the public contract (proto/openapi.json names the status each code is
// answered with; proto/problem.schema.json's examples), the glTF codec's own 400/422 split, the kind of
// exception a code is thrown as (an engine InputError is the caller's fault: 422; a codec JsonError: 400),
// and the command line's exit-code rule (4xx: 1, usage: 2, otherwise 3).
#include "server/codec/error_table.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <regex>
#include <set>
#include <string>

#include <nlohmann/json.hpp>

#include "server/codec/gltf_codec.h"
#include "tests/support/data_dir.h"
#include "tests/support/read_text.h"

namespace lipmap::codec {
namespace {

namespace fs = std::filesystem;

// The codes thrown or printed in the .cpp files of `folder` (and its subfolders): the first argument of the
// calls that make an error with a code. Each call form is listed with what throws it.
std::map<std::string, std::set<std::string>> emitted_codes(const std::string& folder) {
  static const std::regex call(
      R"(\b(InputError|JsonError|GltfError|reject|fail|stop|MapFailure|error_line|problem_answer|problem)\((?:err,\s*)?\"([a-z][a-z0-9]*(?:_[a-z0-9]+)*)\")");
  std::map<std::string, std::set<std::string>> by_call;  // call name -> codes
  for (const auto& entry : fs::recursive_directory_iterator(fs::path(lipmap::source_dir()) / folder)) {
    if (entry.path().extension() != ".cpp") continue;
    const std::string text = read_text(entry.path());
    for (auto it = std::sregex_iterator(text.begin(), text.end(), call); it != std::sregex_iterator(); ++it)
      by_call[(*it)[1]].insert((*it)[2]);
  }
  return by_call;
}

std::set<std::string> all_of(const std::map<std::string, std::set<std::string>>& by_call) {
  std::set<std::string> out;
  for (const auto& [call, codes] : by_call) out.insert(codes.begin(), codes.end());
  return out;
}

TEST(ErrorTable, EntriesAreUniqueAndWellFormed) {
  std::set<std::string_view> seen;
  for (const ErrorInfo& e : error_table()) {
    EXPECT_TRUE(seen.insert(e.code).second) << "twice: " << e.code;
    EXPECT_TRUE(std::regex_match(std::string(e.code), std::regex("^[a-z][a-z0-9_]*$"))) << e.code;  // problem.schema.json
    EXPECT_GE(e.status, 400) << e.code;
    EXPECT_LE(e.status, 599) << e.code;
    EXPECT_FALSE(e.title.empty()) << e.code;
    // The exit-code rule of the command line.
    const int want = e.code == "usage" ? kExitUsageError : e.status < 500 && e.code != "cancelled" ? kExitInputError
                                                                                                     : kExitInternalError;
    EXPECT_EQ(e.exit_code, want) << e.code;
    EXPECT_TRUE(has_error_info(e.code));
    EXPECT_EQ(&error_info(e.code), &e);
  }
}

TEST(ErrorTable, UnknownCodesGetTheDocumentedFallback) {
  for (const char* code : {"", "no_such_code", "internal", "http_999", "INVALID_JSON"}) {
    EXPECT_FALSE(has_error_info(code)) << code;
    const ErrorInfo& e = error_info(code);
    EXPECT_EQ(e.code, "internal_error");
    EXPECT_EQ(e.status, 500);
    EXPECT_EQ(e.exit_code, kExitInternalError);
  }
}

TEST(ErrorTable, EveryEngineCodeIsTheCallersFault) {
  const auto by_call = emitted_codes("engine");
  const std::set<std::string> codes = all_of(by_call);
  // The engine reports errors through InputError and validate's reject(); if these call forms change, this
  // list must follow (it would be empty, not wrong).
  ASSERT_GE(codes.size(), 25u) << "the engine's error call forms changed: update emitted_codes()";
  for (const std::string& code : codes) {
    ASSERT_TRUE(has_error_info(code)) << "engine code without an entry: " << code;
    EXPECT_EQ(error_info(code).status, 422) << code;
    EXPECT_EQ(error_info(code).exit_code, kExitInputError) << code;
  }
}

TEST(ErrorTable, EveryCodecCodeHasItsCodecsStatus) {
  const auto by_call = emitted_codes("server/codec");
  ASSERT_GE(all_of(by_call).size(), 30u) << "the codecs' error call forms changed: update emitted_codes()";
  for (const std::string& code : all_of(by_call)) {
    ASSERT_TRUE(has_error_info(code)) << "codec code without an entry: " << code;
    const ErrorInfo& e = error_info(code);
    if (code.rfind("gltf_", 0) == 0) {
      // 422 for a well-formed glTF that cannot be mapped, 400 for one that is not a well-formed,
      // self-contained glTF 2.0 document (the split documented at gltf::GltfError).
      static const std::set<std::string> not_mappable = {
          "gltf_mesh_not_found", "gltf_primitive_not_found", "gltf_unsupported_mode",      "gltf_no_position",
          "gltf_no_triangles",   "gltf_texcoord_missing",    "gltf_unsupported_extension", "gltf_non_finite"};
      EXPECT_EQ(e.status, not_mappable.count(code) ? 422 : 400) << code;
    } else {
      EXPECT_EQ(e.status, 400) << code;  // codec::JsonError: the request document's shape
    }
  }
}

TEST(ErrorTable, EveryCodeOfTheServiceAndTheCommandLineHasAnEntry) {
  for (const char* folder : {"server/http", "server/app"}) {
    const std::set<std::string> codes = all_of(emitted_codes(folder));
    ASSERT_GE(codes.size(), 4u) << folder;
    for (const std::string& code : codes) {
      EXPECT_TRUE(has_error_info(code)) << folder << " code without an entry: " << code;
    }
  }
}

// The error answers of proto/openapi.json (status >= 400, shared ones resolved) name their codes in their
// descriptions: each named code must have that status. Snake-case words that are problem members
// (limit_bytes, retry_after_seconds ...) are not codes.
TEST(ErrorTable, AgreesWithTheOpenApiDocument) {
  const fs::path proto = fs::path(lipmap::source_dir()) / "proto";
  const auto api = nlohmann::json::parse(read_text(proto / "openapi.json"));
  const auto problem_schema = nlohmann::json::parse(read_text(proto / "problem.schema.json"));
  std::set<std::string> members;
  for (const auto& [name, _] : problem_schema.at("properties").items()) members.insert(name);
  const std::regex word(R"(\b[a-z][a-z0-9]*(?:_[a-z0-9]+)+\b)");
  std::map<std::string, std::set<int>> named;  // code -> statuses it is named under
  for (const auto& [path, item] : api.at("paths").items()) {
    for (const auto& [method, op] : item.items()) {
      if (!op.is_object() || !op.contains("responses")) continue;
      for (const auto& [status, response] : op.at("responses").items()) {
        if (std::stoi(status) < 400) continue;
        nlohmann::json r = response;
        if (r.contains("$ref")) {
          const std::string ref = r.at("$ref");
          r = api.at("components").at("responses").at(ref.substr(ref.rfind('/') + 1));
        }
        const std::string text = r.at("description");
        for (auto it = std::sregex_iterator(text.begin(), text.end(), word); it != std::sregex_iterator(); ++it)
          if (!members.count(it->str())) named[it->str()].insert(std::stoi(status));
      }
    }
  }
  ASSERT_GE(named.size(), 30u);
  for (const auto& [code, statuses] : named) {
    ASSERT_TRUE(has_error_info(code)) << "proto/openapi.json names " << code << ", the table does not";
    EXPECT_EQ(statuses, std::set<int>{error_info(code).status}) << code;
  }
  // The examples of problem.schema.json.
  ASSERT_TRUE(problem_schema.contains("examples"));
  for (const auto& example : problem_schema.at("examples")) {
    const std::string code = example.at("code");
    ASSERT_TRUE(has_error_info(code)) << code;
    EXPECT_EQ(example.at("status").get<int>(), error_info(code).status) << code;
    EXPECT_EQ(example.at("title").get<std::string>(), error_info(code).title) << code;
  }
}

}  // namespace
}  // namespace lipmap::codec
