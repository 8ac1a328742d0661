// The asynchronous jobs of one process (no --queue-url): kept in the in-memory JobStore and run on this
// process's worker pool. The JobQueue that Service::jobs holds by default (job_store.h).
#pragma once

#include <memory>
#include <optional>
#include <string>

#include "server/http/job_store.h"

namespace lipmap::server {

class Service;

class MemoryJobs : public JobQueue {
public:
  explicit MemoryJobs(Service& service);

  Submitted submit(const JobRequest& request) override;
  Found find(const std::string& id) override;
  Cancelled cancel(const std::string& id) override;
  std::shared_ptr<const std::string> result_json(const std::string& id) override;
  std::optional<ComputedResult> computed(const std::string& id) override;
  std::optional<StoredRequest> stored_request(const std::string&) override { return std::nullopt; }
  std::shared_ptr<const std::string> rendering(const std::string& id, const std::string& kind) override;
  void keep_rendering(const std::string& id, const std::string& kind,
                      std::shared_ptr<const std::string> body) override;
  bool uses_local_pool() const override { return true; }
  bool runs_here(const std::string&) override { return true; }
  bool ready() override { return true; }
  void sample(RuntimeGauges& gauges) override;
  void sweep() override { store_.sweep(); }
  void cancel_unfinished(CancelReason reason) override;
  void stop() override {}

private:
  void run(const std::shared_ptr<Job>& job, const codec::ParametrizeRequest& request, const TestHooks& hooks);
  void finished(const std::shared_ptr<Job>& job);
  void end_queued(const std::shared_ptr<Job>& job, nlohmann::ordered_json problem);
  std::shared_ptr<Job> held(const std::string& id);

  Service& service_;
  JobStore store_;
};

}  // namespace lipmap::server
