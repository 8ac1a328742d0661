#include "server/http/redis_connection.h"

#include <algorithm>
#include <cstdlib>
#include <stdexcept>

#include <nlohmann/json.hpp>

namespace lipmap::server {

using nlohmann::json;

// ---- the URL ----------------------------------------------------------------------------------------------

RedisUrl parse_redis_url(const std::string& url) {
  const std::string scheme = "redis://";
  auto bad = [&](const std::string& why) {
    throw std::invalid_argument("queue URL " + json(url).dump(-1, ' ', false, json::error_handler_t::replace) +
                                " " + why + " (expected redis://HOST[:PORT][/DB])");
  };
  if (url.compare(0, scheme.size(), scheme) != 0) bad("does not start with redis://");
  std::string rest = url.substr(scheme.size());
  RedisUrl u;
  if (const auto slash = rest.find('/'); slash != std::string::npos) {
    const std::string db = rest.substr(slash + 1);
    rest.resize(slash);
    if (!db.empty()) {
      if (db.size() > 4 || !std::all_of(db.begin(), db.end(), [](char c) { return c >= '0' && c <= '9'; }))
        bad("has a database that is not a number");
      u.db = std::stoi(db);
    }
  }
  if (rest.find('@') != std::string::npos) bad("has credentials, which are not supported");
  if (const auto colon = rest.rfind(':'); colon != std::string::npos && rest.find(']') == std::string::npos) {
    const std::string port = rest.substr(colon + 1);
    rest.resize(colon);
    if (port.empty() || port.size() > 5 ||
        !std::all_of(port.begin(), port.end(), [](char c) { return c >= '0' && c <= '9'; }))
      bad("has a port that is not a number");
    u.port = std::stoi(port);
    if (u.port < 1 || u.port > 65535) bad("has a port outside 1..65535");
  }
  if (rest.empty()) bad("has no host");
  u.host = rest;
  return u;
}


// ---- one connection ---------------------------------------------------------------------------------------

std::string str(const redisReply* r) {
  if (!r) return {};
  if (r->type == REDIS_REPLY_STRING || r->type == REDIS_REPLY_STATUS) return std::string(r->str, r->len);
  if (r->type == REDIS_REPLY_INTEGER) return std::to_string(r->integer);
  return {};
}

long long integer(const redisReply* r) {
  if (!r) return 0;
  if (r->type == REDIS_REPLY_INTEGER) return r->integer;
  if (r->type == REDIS_REPLY_STRING) return std::atoll(std::string(r->str, r->len).c_str());
  return 0;
}

RedisConnection::RedisConnection(const RedisUrl& url, std::chrono::milliseconds timeout) {
  timeval tv{static_cast<time_t>(timeout.count() / 1000), static_cast<suseconds_t>((timeout.count() % 1000) * 1000)};
  c_ = redisConnectWithTimeout(url.host.c_str(), url.port, tv);
  if (!c_) throw QueueUnavailable("cannot allocate a Redis connection");
  if (c_->err) {
    const std::string why = c_->errstr;
    redisFree(c_);
    c_ = nullptr;
    throw QueueUnavailable("cannot connect to Redis at " + url.host + ":" + std::to_string(url.port) + ": " + why);
  }
  redisSetTimeout(c_, tv);
  if (url.db != 0) command({"SELECT", std::to_string(url.db)});
}

RedisConnection::~RedisConnection() {
  if (c_) redisFree(c_);
}

Reply RedisConnection::command(const std::vector<std::string>& args) {
  std::vector<Reply> replies = pipeline({args});
  return std::move(replies.front());
}

std::vector<Reply> RedisConnection::pipeline(const std::vector<std::vector<std::string>>& commands,
                                             bool last_may_fail) {
  if (broken_) throw QueueUnavailable("the Redis connection is broken");
  auto fail = [this](const char* what) {
    broken_ = true;
    throw QueueUnavailable(std::string("Redis: ") + (c_->err ? c_->errstr : what));
  };
  for (const auto& args : commands) {
    std::vector<const char*> argv;
    std::vector<size_t> lengths;
    argv.reserve(args.size());
    lengths.reserve(args.size());
    for (const std::string& a : args) {
      argv.push_back(a.data());
      lengths.push_back(a.size());
    }
    if (redisAppendCommandArgv(c_, static_cast<int>(argv.size()), argv.data(), lengths.data()) != REDIS_OK)
      fail("cannot queue a command");
  }
  std::vector<Reply> replies;
  replies.reserve(commands.size());
  std::string first_error;
  for (const auto& args : commands) {
    void* raw = nullptr;
    if (redisGetReply(c_, &raw) != REDIS_OK || !raw) fail("no reply");
    Reply r(static_cast<redisReply*>(raw));
    if (r->type == REDIS_REPLY_ERROR && first_error.empty() && !(last_may_fail && replies.size() + 1 == commands.size()))
      first_error = "Redis " + args[0] + ": " + std::string(r->str, r->len);
    replies.push_back(std::move(r));
  }
  if (!first_error.empty()) throw ReplyError(first_error);
  return replies;
}

}  // namespace lipmap::server
