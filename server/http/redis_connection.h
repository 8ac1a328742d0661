// One connection to the Redis of the shared job queue (server/http/redis_jobs.h), through hiredis only
// (redisCommandArgv: no protocol code here), and the queue URL redis://HOST[:PORT][/DB].
#pragma once

#include <chrono>
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include <hiredis/hiredis.h>

#include "server/http/job_store.h"

namespace lipmap::server {

struct RedisUrl {
  std::string host;
  int port = 6379;
  int db = 0;
};
// redis://HOST[:PORT][/DB]; throws std::invalid_argument naming what is wrong.
RedisUrl parse_redis_url(const std::string& url);

struct ReplyDeleter {
  void operator()(redisReply* r) const {
    if (r) freeReplyObject(r);
  }
};
using Reply = std::unique_ptr<redisReply, ReplyDeleter>;

// An error reply of Redis (e.g. NOGROUP): the connection itself is fine.
class ReplyError : public QueueUnavailable {
public:
  using QueueUnavailable::QueueUnavailable;
};

// A string, status or integer reply as text ("" for anything else).
std::string str(const redisReply* r);
// An integer reply, or a string one holding a number (0 for anything else).
long long integer(const redisReply* r);
inline bool is_array(const redisReply* r, std::size_t min_elements = 0) {
  return r && r->type == REDIS_REPLY_ARRAY && r->elements >= min_elements;
}

class RedisConnection {
public:
  // Throws QueueUnavailable when Redis cannot be reached within `timeout` (also each command's timeout).
  RedisConnection(const RedisUrl& url, std::chrono::milliseconds timeout);
  ~RedisConnection();
  RedisConnection(const RedisConnection&) = delete;
  RedisConnection& operator=(const RedisConnection&) = delete;

  // Throws QueueUnavailable (the connection is then broken for good) or ReplyError.
  Reply command(const std::vector<std::string>& args);
  // Several commands in one round trip (hiredis' pipelining: all sent, then all replies read), replies in
  // order. Every reply is read before an error is thrown (ReplyError for the first error reply), so that the
  // connection stays usable. On a busy machine each round trip to another process can cost a scheduling
  // slice; a job's few Redis steps are each one round trip.
  // With last_may_fail, an error reply to the last command is returned instead (a command that only helps).
  std::vector<Reply> pipeline(const std::vector<std::vector<std::string>>& commands, bool last_may_fail = false);
  bool broken() const { return broken_; }

private:
  redisContext* c_ = nullptr;
  bool broken_ = false;
};

}  // namespace lipmap::server
