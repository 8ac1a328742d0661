// server/http/routes.{h,cpp}: the route table against the public contract, proto/openapi.json (every path
// there is in the table with the same methods, and nothing else is), the table's matching against a
// segment matcher written here, and a real `lipmap serve` answering every method the table does not list
// with 405 and exactly the table's methods in Allow.
#include "server/http/routes.h"

#include <gtest/gtest.h>

#include <map>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "server/http/http_server.h"
#include "tests/support/data_dir.h"
#include "tests/support/read_text.h"

// Last: with its OpenSSL support cpp-httplib pulls in <resolv.h>, whose `_res` macro breaks Eigen's headers.
#include <httplib.h>

namespace lipmap::server {
namespace {

std::set<std::string> split_methods(const std::string& allow) {
  std::set<std::string> out;
  std::istringstream in(allow);
  std::string m;
  while (std::getline(in, m, ',')) {
    m.erase(0, m.find_first_not_of(' '));
    out.insert(m);
  }
  return out;
}

// The methods of each path of proto/openapi.json, upper case. HEAD is implied by GET (RFC 9110 9.3.2: the
// same answer without its body), which the document does not spell out per path.
std::map<std::string, std::set<std::string>> openapi_methods() {
  const auto api = nlohmann::json::parse(read_text(lipmap::source_dir() + "/proto/openapi.json"));
  std::map<std::string, std::set<std::string>> out;
  for (const auto& [path, item] : api.at("paths").items()) {
    std::set<std::string>& methods = out[path];
    for (const auto& [key, _] : item.items()) {
      static const std::set<std::string> verbs{"get", "put", "post", "delete", "options", "head", "patch", "trace"};
      if (!verbs.count(key)) continue;
      std::string m = key;
      for (char& c : m) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
      methods.insert(m);
      if (m == "GET") methods.insert("HEAD");
    }
  }
  return out;
}

TEST(Routes, TheTableIsTheOpenApiDocumentsPathsAndMethods) {
  const auto api = openapi_methods();
  std::map<std::string, std::set<std::string>> table;
  for (const Route& r : routes()) {
    EXPECT_FALSE(table.count(r.path)) << "twice in the table: " << r.path;
    table[r.path] = split_methods(r.allow);
    EXPECT_EQ(r.operations.size() + std::count_if(r.operations.begin(), r.operations.end(),
                                                  [](const Operation& o) { return o.method == Method::get; }),
              table[r.path].size())
        << r.path;
    for (const Operation& op : r.operations) EXPECT_NE(op.handler, nullptr) << r.path;
  }
  for (const auto& [path, methods] : api) {
    ASSERT_TRUE(table.count(path)) << "proto/openapi.json has " << path << ", the route table does not";
    EXPECT_EQ(table[path], methods) << path;
  }
  for (const auto& [path, methods] : table) EXPECT_TRUE(api.count(path)) << "not in proto/openapi.json: " << path;
}

// An independent matcher: a path matches a template when it has the same segments, literal text equal and
// each {parameter} standing for a non-empty run of characters other than '/' (for {schema}: [a-z0-9-]).
bool template_matches(const std::string& tmpl, const std::string& path) {
  std::size_t t = 0, p = 0;
  while (t < tmpl.size()) {
    if (tmpl[t] == '{') {
      const std::size_t close = tmpl.find('}', t);
      const std::string name = tmpl.substr(t + 1, close - t - 1);
      const std::string rest = tmpl.substr(close + 1, tmpl.find('/', close) == std::string::npos
                                                          ? std::string::npos
                                                          : tmpl.find('/', close) - close - 1);
      // The parameter runs to the end of its segment minus the literal suffix after it.
      const std::size_t seg_end = path.find('/', p) == std::string::npos ? path.size() : path.find('/', p);
      if (seg_end < p + rest.size() + 1) return false;
      const std::string value = path.substr(p, seg_end - rest.size() - p);
      if (path.compare(seg_end - rest.size(), rest.size(), rest) != 0) return false;
      for (char c : value) {
        const bool ok = name == "schema" ? (std::islower(static_cast<unsigned char>(c)) ||
                                            std::isdigit(static_cast<unsigned char>(c)) || c == '-')
                                         : c != '/';
        if (!ok) return false;
      }
      t = close + 1 + rest.size();
      p = seg_end;
      continue;
    }
    if (p >= path.size() || path[p] != tmpl[t]) return false;
    ++t, ++p;
  }
  return p == path.size();
}

std::string random_segment(std::mt19937& rng, const std::string& alphabet) {
  std::string s;
  const int n = 1 + static_cast<int>(rng() % 12);
  for (int i = 0; i < n; ++i) s += alphabet[rng() % alphabet.size()];
  return s;
}

std::string instantiate(const std::string& tmpl, std::mt19937& rng, const std::string& alphabet) {
  std::string out;
  for (std::size_t i = 0; i < tmpl.size();) {
    if (tmpl[i] == '{') {
      const std::size_t close = tmpl.find('}', i);
      out += random_segment(rng, alphabet);
      i = close + 1;
    } else {
      out += tmpl[i++];
    }
  }
  return out;
}

TEST(Routes, MatchingAgreesWithASegmentMatcher) {
  std::mt19937 rng(99);
  const std::vector<std::string> alphabets = {"abcdef0123456789", "a-z.", "ABC_x.y", "v1jobs/"};
  const std::vector<std::string> pieces = {"/v1", "/jobs", "/result", "/preview.svg", "/parametrize", "/polygons",
                                           "/classify", "/healthz", "/readyz", "/metrics", "/version", "/x",
                                           "/openapi.json", "/problem.schema.json", "/a.schema.json", "/", ".json"};
  std::vector<std::string> paths;
  for (const Route& r : routes())
    for (int i = 0; i < 200; ++i) {
      const std::string p = instantiate(r.path, rng, alphabets[rng() % alphabets.size()]);
      paths.push_back(p);
      paths.push_back(p + "/x");
      paths.push_back(p.substr(0, p.size() - 1));
    }
  for (int i = 0; i < 5000; ++i) {
    std::string p;
    const int n = 1 + static_cast<int>(rng() % 4);
    for (int k = 0; k < n; ++k) p += pieces[rng() % pieces.size()];
    paths.push_back(p);
  }
  int matched = 0;
  for (const std::string& path : paths) {
    const Route* want = nullptr;
    for (const Route& r : routes())
      if (template_matches(r.path, path)) {
        ASSERT_EQ(want, nullptr) << path << " matches two templates";
        want = &r;
      }
    ASSERT_EQ(route_of(path), want) << path << " (table: " << (route_of(path) ? route_of(path)->path : "none")
                                    << ", segments: " << (want ? want->path : "none") << ")";
    matched += want != nullptr;
  }
  EXPECT_GT(matched, 2000);
  EXPECT_EQ(route_of("/v1/jobs/" + std::string(600, 'a')), nullptr);  // absurdly long paths match nothing
}

// A real service on a free loopback port: every method on every route.
TEST(Routes, TheServiceAnswers405WithExactlyTheTablesMethods) {
  ServerConfig config;
  config.port = 0;
  config.workers = 1;
  config.queue_capacity = 4;
  HttpServer server(config, nullptr);
  const int port = server.bind();
  server.start();
  httplib::Client client("127.0.0.1", port);
  client.set_read_timeout(20, 0);
  const auto api = openapi_methods();
  const std::vector<std::string> all_methods = {"GET", "HEAD", "POST", "PUT", "PATCH", "DELETE"};
  std::mt19937 rng(1);
  int checked = 0;
  for (const Route& r : routes()) {
    // A real schema name, so that GET reaches a document; random job ids (404 job_not_found from the handler).
    std::string path = instantiate(r.path, rng, "0123456789abcdef");
    if (r.path == "/v1/{schema}.schema.json") path = "/v1/problem.schema.json";
    const std::set<std::string>& allowed = api.at(r.path);
    for (const std::string& method : all_methods) {
      httplib::Result res = [&] {
        if (method == "GET") return client.Get(path.c_str());
        if (method == "HEAD") return client.Head(path.c_str());
        if (method == "POST") return client.Post(path.c_str(), "{}", "application/json");
        if (method == "PUT") return client.Put(path.c_str(), "{}", "application/json");
        if (method == "PATCH") return client.Patch(path.c_str(), "{}", "application/json");
        return client.Delete(path.c_str());
      }();
      ASSERT_TRUE(res) << method << " " << path;
      ++checked;
      if (allowed.count(method)) {
        EXPECT_NE(res->status, 405) << method << " " << path;
        if (res->status == 404 && method != "HEAD")  // a HEAD answer has no body to tell the two 404s apart
          EXPECT_NE(res->body.find("job_not_found"), std::string::npos) << method << " " << path;
        continue;
      }
      EXPECT_EQ(res->status, 405) << method << " " << path;
      EXPECT_EQ(split_methods(res->get_header_value("Allow")), allowed) << method << " " << path;
      if (method != "HEAD") {
        const auto problem = nlohmann::json::parse(res->body);
        EXPECT_EQ(problem.at("code"), "method_not_allowed");
        EXPECT_EQ(problem.at("status"), 405);
      }
    }
  }
  EXPECT_EQ(checked, static_cast<int>(routes().size() * all_methods.size()));
  EXPECT_TRUE(server.shutdown());
}

}  // namespace
}  // namespace lipmap::server
