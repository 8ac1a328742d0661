// server/http/replica_memory.h. LocalResults (the results a replica of the shared queue keeps in memory): random
// sequences of put, get and erase against a least-recently-used model written here, with both bounds (count and
// bytes; a result over the byte bound is not kept), and the retention time. Handoffs (the requests it accepted
// and parsed): random put and take against a first-in-first-out model, with the count bound.
#include "server/http/replica_memory.h"

#include <deque>
#include <map>

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <random>
#include <string>
#include <vector>

namespace lipmap::server {
namespace {

using namespace std::chrono_literals;

// Most recently used first; over a bound, the last goes.
struct Model {
  std::size_t max_entries, max_bytes;
  std::vector<std::pair<std::string, std::shared_ptr<const std::string>>> order;
  std::size_t bytes() const {
    std::size_t b = 0;
    for (const auto& e : order) b += e.second->size();
    return b;
  }
  auto find(const std::string& id) {
    return std::find_if(order.begin(), order.end(), [&](const auto& e) { return e.first == id; });
  }
  void put(const std::string& id, std::shared_ptr<const std::string> json) {
    if (auto it = find(id); it != order.end()) order.erase(it);
    if (json->size() > max_bytes) return;
    order.insert(order.begin(), {id, std::move(json)});
    while (!order.empty() && (order.size() > max_entries || bytes() > max_bytes)) order.pop_back();
  }
  std::shared_ptr<const std::string> get(const std::string& id) {
    auto it = find(id);
    if (it == order.end()) return nullptr;
    auto e = *it;
    order.erase(it);
    order.insert(order.begin(), e);
    return e.second;
  }
  void erase(const std::string& id) {
    if (auto it = find(id); it != order.end()) order.erase(it);
  }
};

TEST(LocalResults, RandomSequencesFollowTheLeastRecentlyUsedModel) {
  std::mt19937 rng(20261201);
  for (int trial = 0; trial < 300; ++trial) {
    const std::size_t max_entries = 1 + rng() % 6, max_bytes = 1 + rng() % 400;
    LocalResults cache(max_entries, max_bytes, 1h);
    Model model{max_entries, max_bytes, {}};
    for (int step = 0; step < 200; ++step) {
      const std::string id = "job" + std::to_string(rng() % 10);
      switch (rng() % 3) {
        case 0: {
          auto json = std::make_shared<const std::string>(rng() % 150, 'x');
          cache.put(id, ComputedResult{nullptr, nullptr, json});
          model.put(id, json);
          break;
        }
        case 1: {
          const std::optional<ComputedResult> got = cache.get(id);
          const std::shared_ptr<const std::string> expected = model.get(id);
          ASSERT_EQ(got.has_value(), expected != nullptr) << "trial " << trial << " step " << step << " " << id;
          if (got) ASSERT_EQ(got->json, expected);  // the very result that was put
          break;
        }
        default:
          cache.erase(id);
          model.erase(id);
      }
      ASSERT_EQ(cache.size(), model.order.size()) << "trial " << trial << " step " << step;
      ASSERT_LE(cache.size(), max_entries);
    }
  }
}

TEST(LocalResults, NothingOutlivesTheRetentionTime) {
  LocalResults cache(8, 1 << 20, 0ms);
  for (int i = 0; i < 5; ++i) {
    cache.put("job" + std::to_string(i), ComputedResult{nullptr, nullptr, std::make_shared<const std::string>("{}")});
    EXPECT_FALSE(cache.get("job" + std::to_string(i)).has_value());
    EXPECT_EQ(cache.size(), 0u);
  }
}

TEST(LocalResults, AResultLargerThanTheByteBoundIsNotKeptAndEvictsNothing) {
  LocalResults cache(8, 10, 1h);
  cache.put("small", ComputedResult{nullptr, nullptr, std::make_shared<const std::string>(10, 'x')});
  cache.put("large", ComputedResult{nullptr, nullptr, std::make_shared<const std::string>(11, 'x')});
  EXPECT_FALSE(cache.get("large").has_value());
  EXPECT_TRUE(cache.get("small").has_value());
}

TEST(Handoffs, RandomPutAndTakeAgainstAFifoModel) {
  std::mt19937 rng(7);
  for (std::size_t bound : {1u, 3u, 8u}) {
    Handoffs h(bound);
    std::deque<std::string> order;  // model: ids held, oldest first
    std::map<std::string, const codec::ParametrizeRequest*> held;
    int next = 0;
    for (int step = 0; step < 2000; ++step) {
      if (rng() % 2 == 0) {
        const std::string id = "job" + std::to_string(next++);
        auto request = std::make_shared<const codec::ParametrizeRequest>();
        held[id] = request.get();
        order.push_back(id);
        h.put(id, {request, nullptr});
        while (order.size() > bound) {
          held.erase(order.front());
          order.pop_front();
        }
      } else {
        // Take a held id, one taken or dropped before, or one never put.
        const int pick = next == 0 ? 0 : static_cast<int>(rng() % (next + 2));
        const std::string id = "job" + std::to_string(pick);
        const std::optional<Handoffs::Parsed> got = h.take(id);
        auto it = held.find(id);
        ASSERT_EQ(got.has_value(), it != held.end()) << id << " at step " << step;
        if (got) {
          EXPECT_EQ(got->request.get(), it->second);
          held.erase(it);
          order.erase(std::find(order.begin(), order.end(), id));
        }
      }
      ASSERT_EQ(h.size(), held.size()) << "step " << step;
    }
  }
}

}  // namespace
}  // namespace lipmap::server
