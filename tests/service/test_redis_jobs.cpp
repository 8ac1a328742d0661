// server/http/redis_jobs.{h,cpp}: the queue URL (what --queue-url / LIPMAP_QUEUE_URL accepts and refuses),
// and resolve()'s checks of the shared-queue settings. The queue itself needs a Redis: tests/cluster/.
#include "server/http/redis_jobs.h"

#include <gtest/gtest.h>

#include <limits>
#include <string>
#include <vector>

#include "server/http/http_server.h"

namespace lipmap::server {
namespace {

TEST(RedisUrl, HostPortAndDatabase) {
  struct Case {
    std::string url, host;
    int port, db;
  };
  const std::vector<Case> cases = {
      {"redis://127.0.0.1:6379", "127.0.0.1", 6379, 0},
      {"redis://redis", "redis", 6379, 0},
      {"redis://redis/", "redis", 6379, 0},
      {"redis://lipmap-redis:6380/3", "lipmap-redis", 6380, 3},
      {"redis://localhost:1/15", "localhost", 1, 15},
      {"redis://h:65535", "h", 65535, 0},
  };
  for (const Case& c : cases) {
    const RedisUrl u = parse_redis_url(c.url);
    EXPECT_EQ(u.host, c.host) << c.url;
    EXPECT_EQ(u.port, c.port) << c.url;
    EXPECT_EQ(u.db, c.db) << c.url;
  }
}

TEST(RedisUrl, RefusesWhatItCannotUse) {
  for (const std::string bad :
       {"", "redis:/h", "http://h:6379", "rediss://h:6379", "redis://", "redis://:6379", "redis://h:", "redis://h:0",
        "redis://h:65536", "redis://h:12a", "redis://h:6379/x", "redis://h:6379/-1", "redis://user:pw@h:6379",
        "redis://h:99999999999"}) {
    EXPECT_THROW(parse_redis_url(bad), std::invalid_argument) << bad;
    ServerConfig c;
    c.queue_url = bad;
    if (!bad.empty()) EXPECT_THROW(resolve(c), std::invalid_argument) << bad;
  }
}

TEST(RedisUrl, ResolveChecksTheSharedQueueSettings) {
  ServerConfig c;
  c.queue_url = "redis://127.0.0.1:6379/0";
  EXPECT_NO_THROW(resolve(c));
  for (double v : {0.0, 0.1, -1.0, std::numeric_limits<double>::infinity()}) {
    ServerConfig d = c;
    d.queue_visibility_seconds = v;
    EXPECT_THROW(resolve(d), std::invalid_argument) << v;
  }
  ServerConfig e = c;
  e.max_result_bytes = 0;
  EXPECT_THROW(resolve(e), std::invalid_argument);
}

}  // namespace
}  // namespace lipmap::server
