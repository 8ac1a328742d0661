// What a replica of the shared queue keeps in its own memory (docs/cluster.md): the results it computed
// (LocalResults) and the requests it accepted and parsed, until its own worker starts them (Handoffs). Both are
// bounded and only spare Redis a read; Redis stays the truth for whether a job is still held.
#pragma once

#include <chrono>
#include <cstddef>
#include <list>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>

#include "server/http/job_store.h"

namespace lipmap::server {

// The results a replica computed, least recently used dropped first: at most `max_entries` and `max_bytes` of
// result JSON (a single larger one is not kept), each for at most `ttl` after it was put.
class LocalResults {
public:
  using Clock = std::chrono::steady_clock;
  LocalResults(std::size_t max_entries, std::size_t max_bytes, std::chrono::milliseconds ttl);
  void put(const std::string& id, ComputedResult result);
  std::optional<ComputedResult> get(const std::string& id);  // counts as a use
  void erase(const std::string& id);
  std::size_t size() const;

private:
  struct Entry {
    std::string id;
    ComputedResult result;
    std::size_t bytes;
    Clock::time_point expires;
  };
  void trim_locked(Clock::time_point now);
  const std::size_t max_entries_, max_bytes_;
  const std::chrono::milliseconds ttl_;
  mutable std::mutex mutex_;
  std::list<Entry> order_;  // most recently used first
  std::unordered_map<std::string, std::list<Entry>::iterator> by_id_;
  std::size_t bytes_ = 0;
};

// Requests parsed by this replica for jobs not yet started here, oldest dropped first beyond `max_entries`
// (a job another replica took leaves its entry until it ages out this way).
class Handoffs {
public:
  struct Parsed {
    std::shared_ptr<const codec::ParametrizeRequest> request;
    std::shared_ptr<const gltf::Asset> asset;
  };
  explicit Handoffs(std::size_t max_entries) : max_entries_(max_entries) {}
  void put(const std::string& id, Parsed parsed);
  std::optional<Parsed> take(const std::string& id);  // removes it
  std::size_t size() const;

private:
  const std::size_t max_entries_;
  mutable std::mutex mutex_;
  std::unordered_map<std::string, Parsed> by_id_;
  std::list<std::string> order_;  // oldest first; may name ids already taken
};

}  // namespace lipmap::server
