// server/http/job_store.{h,cpp}: a job's state machine against a model written here, the store's retention
// (ttl, count limit, deletion, tombstones) and its behaviour under many threads.
#include "server/http/job_store.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <map>
#include <mutex>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <vector>

namespace lipmap::server {
namespace {

using namespace std::chrono_literals;

// The job life cycle as the service documents it: queued -> running -> succeeded | failed | cancelled, or
// queued -> cancelled; a final state never changes; the first cancel reason wins; cancelling a final job
// does nothing.
struct ModelJob {
  JobState state = JobState::queued;
  CancelReason reason = CancelReason::none;
  bool started = false;
  bool final() const {
    return state == JobState::succeeded || state == JobState::failed || state == JobState::cancelled;
  }
};

TEST(JobStore, RandomOperationSequencesFollowTheLifeCycle) {
  std::mt19937 rng(20240611);
  for (int trial = 0; trial < 2000; ++trial) {
    Job job("job" + std::to_string(trial));
    ModelJob model;
    const int steps = 1 + static_cast<int>(rng() % 8);
    for (int s = 0; s < steps; ++s) {
      switch (rng() % 6) {
        case 0: {
          const bool expected = model.state == JobState::queued;
          if (expected) model.state = JobState::running, model.started = true;
          ASSERT_EQ(job.mark_running(), expected);
          break;
        }
        case 1:
          job.succeed(std::make_shared<const std::string>("{}"), nullptr);
          if (!model.final()) model.state = JobState::succeeded;
          break;
        case 2:
          job.fail(JobState::failed, {{"code", "internal_error"}});
          if (!model.final()) model.state = JobState::failed;
          break;
        case 3:
          job.fail(JobState::cancelled, {{"code", "cancelled"}});
          if (!model.final()) model.state = JobState::cancelled;
          break;
        default: {
          const CancelReason r = rng() % 2 ? CancelReason::client : CancelReason::shutdown;
          const bool expected = !model.final();
          if (expected && model.reason == CancelReason::none) model.reason = r;
          ASSERT_EQ(job.request_cancel(r), expected);
          break;
        }
      }
      ASSERT_EQ(job.state(), model.state) << "trial " << trial << " step " << s;
      ASSERT_EQ(job.cancel_reason(), model.reason);
      const JobSnapshot snap = job.snapshot();
      ASSERT_EQ(snap.state, model.state);
      ASSERT_EQ(snap.finished, model.final());
      ASSERT_EQ(snap.started, model.started);
      ASSERT_EQ(snap.cancel_requested, model.reason != CancelReason::none);
      // A cancel request reaches the engine through the token.
      ASSERT_EQ(job.token().expired(), model.reason != CancelReason::none);
      ASSERT_EQ(snap.problem.has_value(), model.state == JobState::failed || model.state == JobState::cancelled);
      if (model.state == JobState::succeeded) ASSERT_EQ(snap.fraction, 1.0);
    }
  }
}

TEST(JobStore, ProgressIsMonotoneAndInPipelineOrder) {
  const Stage stages[] = {Stage::validate, Stage::classify, Stage::target_mesh, Stage::intermediate_maps,
                          Stage::compose,  Stage::refine,   Stage::verify,      Stage::quality};
  std::mt19937 rng(7);
  for (int trial = 0; trial < 200; ++trial) {
    Job job("p");
    job.report(Stage::validate, 0.5);  // not running yet: ignored
    EXPECT_TRUE(job.snapshot().stages.empty());
    ASSERT_TRUE(job.mark_running());
    double last = 0;
    for (Stage st : stages) {
      const int reports = 1 + static_cast<int>(rng() % 4);
      for (int r = 0; r < reports; ++r) {
        job.report(st, std::uniform_real_distribution<double>(0, 1)(rng));
        const JobSnapshot s = job.snapshot();
        ASSERT_GE(s.fraction, last - 1e-12);
        ASSERT_LE(s.fraction, 1.0);
        ASSERT_EQ(s.current_stage, lipmap::to_string(st));
        for (std::size_t i = 0; i + 1 < s.stages.size(); ++i) ASSERT_TRUE(s.stages[i].done);
        last = s.fraction;
      }
    }
    job.succeed(std::make_shared<const std::string>("{}"), nullptr);
    EXPECT_EQ(job.snapshot().fraction, 1.0);
  }
}

// Runs a job to a final state the way a worker does.
void finish(JobStore& store, const std::shared_ptr<Job>& job) {
  job->mark_running();
  job->succeed(std::make_shared<const std::string>("{}"), nullptr);
  store.finished(job);
}

TEST(JobStore, CountLimitDropsTheOldestFinishedFirst) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 100; ++trial) {
    const std::size_t limit = 1 + rng() % 6;
    const std::size_t n = rng() % 15;
    std::vector<std::string> dropped;
    JobStore store({limit, std::chrono::hours(1), 1000}, [&](const std::string& why) { dropped.push_back(why); });
    std::vector<std::shared_ptr<Job>> jobs;
    for (std::size_t i = 0; i < n; ++i) jobs.push_back(store.create());
    std::shared_ptr<Job> unfinished = store.create();  // never finished: never evicted
    for (const auto& j : jobs) finish(store, j);
    const std::size_t evicted = n > limit ? n - limit : 0;
    for (std::size_t i = 0; i < n; ++i) {
      const JobStore::Found f = store.find(jobs[i]->id());
      if (i < evicted) {
        ASSERT_EQ(f.lookup, JobStore::Lookup::gone);
        ASSERT_EQ(f.gone_reason, "evicted");
      } else {
        ASSERT_EQ(f.lookup, JobStore::Lookup::found);
        ASSERT_EQ(f.job, jobs[i]);
      }
    }
    EXPECT_EQ(store.find(unfinished->id()).lookup, JobStore::Lookup::found);
    EXPECT_EQ(dropped, std::vector<std::string>(evicted, "evicted"));
    EXPECT_EQ(store.counts_by_state().at("succeeded"), n - evicted);
    EXPECT_EQ(store.counts_by_state().at("queued"), 1u);
  }
}

TEST(JobStore, FinishedJobsExpireAfterTheTtl) {
  std::atomic<int> expired{0};
  JobStore store({100, 60ms, 1000}, [&](const std::string& why) { expired += why == "expired"; });
  std::vector<std::shared_ptr<Job>> jobs;
  for (int i = 0; i < 20; ++i) jobs.push_back(store.create());
  for (int i = 0; i < 10; ++i) finish(store, jobs[i]);
  for (int i = 0; i < 20; ++i) EXPECT_EQ(store.find(jobs[i]->id()).lookup, JobStore::Lookup::found);
  std::this_thread::sleep_for(120ms);
  store.sweep();
  EXPECT_EQ(expired.load(), 10);
  for (int i = 0; i < 20; ++i) {
    const JobStore::Found f = store.find(jobs[i]->id());
    if (i < 10) {
      EXPECT_EQ(f.lookup, JobStore::Lookup::gone);
      EXPECT_EQ(f.gone_reason, "expired");
    } else {
      EXPECT_EQ(f.lookup, JobStore::Lookup::found);  // unfinished jobs have no ttl
    }
  }
}

TEST(JobStore, RemoveDiscardAndTombstones) {
  JobStore store({100, std::chrono::hours(1), 5});
  std::shared_ptr<Job> running = store.create();
  running->mark_running();
  EXPECT_FALSE(store.remove(running->id()));  // only finished jobs can be deleted
  EXPECT_FALSE(store.remove("0123456789abcdef0123456789abcdef"));
  std::shared_ptr<Job> never_queued = store.create();
  store.discard(never_queued->id());
  EXPECT_EQ(store.find(never_queued->id()).lookup, JobStore::Lookup::unknown);  // no tombstone
  std::vector<std::string> deleted;
  for (int i = 0; i < 8; ++i) {
    auto j = store.create();
    finish(store, j);
    EXPECT_TRUE(store.remove(j->id()));
    EXPECT_FALSE(store.remove(j->id()));
    deleted.push_back(j->id());
  }
  // At most 5 tombstones: the 3 oldest deleted ids are forgotten (404 rather than 410).
  for (int i = 0; i < 8; ++i) {
    const JobStore::Found f = store.find(deleted[i]);
    EXPECT_EQ(f.lookup, i < 3 ? JobStore::Lookup::unknown : JobStore::Lookup::gone) << i;
    if (i >= 3) EXPECT_EQ(f.gone_reason, "deleted");
  }
}

TEST(JobStore, CancelOfQueuedAndRunningJobs) {
  JobStore store({10, std::chrono::hours(1), 100});
  // Queued: cancelled at once (the service's DELETE), a worker that takes it later skips it.
  std::shared_ptr<Job> queued = store.create();
  EXPECT_TRUE(queued->request_cancel(CancelReason::client));
  queued->fail(JobState::cancelled, {{"code", "cancelled"}});
  EXPECT_FALSE(queued->mark_running());
  EXPECT_EQ(queued->state(), JobState::cancelled);
  // Running: the token is cancelled; the job ends when its worker notices.
  std::shared_ptr<Job> running = store.create();
  ASSERT_TRUE(running->mark_running());
  std::thread worker([&] {
    while (!running->token().expired()) std::this_thread::sleep_for(1ms);
    running->fail(running->cancel_reason() == CancelReason::none ? JobState::failed : JobState::cancelled,
                  {{"code", "cancelled"}});
    store.finished(running);
  });
  EXPECT_EQ(store.unfinished().size(), 2u - 1u);  // the queued one is final already
  EXPECT_TRUE(running->request_cancel(CancelReason::shutdown));
  running->request_cancel(CancelReason::client);  // the first reason wins
  EXPECT_EQ(running->cancel_reason(), CancelReason::shutdown);
  worker.join();
  EXPECT_EQ(running->state(), JobState::cancelled);
  EXPECT_EQ(running->cancel_reason(), CancelReason::shutdown);
  EXPECT_TRUE(store.unfinished().empty());
  EXPECT_FALSE(running->request_cancel(CancelReason::client));  // final: nothing to cancel
}

TEST(JobStore, ManyThreadsCreateFinishFindAndRemove) {
  constexpr int kThreads = 8, kJobsPerThread = 300;
  constexpr std::size_t kLimit = 50;
  std::mutex dropped_mutex;
  std::map<std::string, int> dropped;
  JobStore store({kLimit, std::chrono::hours(1), 1000000}, [&](const std::string& why) {
    std::lock_guard<std::mutex> lock(dropped_mutex);
    ++dropped[why];
  });
  std::mutex ids_mutex;
  std::vector<std::string> all_ids, removed_ids;
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      std::mt19937 rng(static_cast<unsigned>(t));
      std::vector<std::string> mine, removed;
      for (int i = 0; i < kJobsPerThread; ++i) {
        auto job = store.create();
        mine.push_back(job->id());
        if (rng() % 2) job->request_cancel(CancelReason::client);
        finish(store, job);
        if (rng() % 5 == 0 && store.remove(job->id())) removed.push_back(job->id());
        const std::string& probe = mine[rng() % mine.size()];
        const JobStore::Found f = store.find(probe);
        EXPECT_NE(f.lookup, JobStore::Lookup::unknown);  // found, or gone with a reason
        store.counts_by_state();
        store.unfinished();
      }
      std::lock_guard<std::mutex> lock(ids_mutex);
      all_ids.insert(all_ids.end(), mine.begin(), mine.end());
      removed_ids.insert(removed_ids.end(), removed.begin(), removed.end());
    });
  }
  for (auto& th : threads) th.join();
  EXPECT_EQ(std::set<std::string>(all_ids.begin(), all_ids.end()).size(), all_ids.size());  // ids unique
  std::size_t found = 0, gone = 0;
  for (const std::string& id : all_ids) {
    const JobStore::Found f = store.find(id);
    ASSERT_NE(f.lookup, JobStore::Lookup::unknown);
    (f.lookup == JobStore::Lookup::found ? found : gone)++;
  }
  // Every job finished: at most the limit is kept (fewer when the last ones were deleted after it was
  // enforced, at most one per thread).
  EXPECT_LE(found, kLimit);
  EXPECT_GE(found + kThreads, kLimit);
  EXPECT_EQ(static_cast<std::size_t>(dropped["deleted"]), removed_ids.size());
  EXPECT_EQ(static_cast<std::size_t>(dropped["deleted"] + dropped["evicted"]), gone);
  std::size_t held = 0;
  for (const auto& [state, n] : store.counts_by_state()) held += n;
  EXPECT_EQ(held, found);
}

TEST(JobStore, JobIdsAreLongRandomHex) {
  std::set<std::string> ids;
  for (int i = 0; i < 5000; ++i) {
    const std::string id = new_job_id();
    ASSERT_EQ(id.size(), 32u);
    for (char c : id) ASSERT_TRUE((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'));
    ASSERT_TRUE(looks_like_job_id(id));
    ids.insert(id);
  }
  EXPECT_EQ(ids.size(), 5000u);
  EXPECT_FALSE(looks_like_job_id(""));
  EXPECT_FALSE(looks_like_job_id(std::string(32, 'g')));
  EXPECT_FALSE(looks_like_job_id(std::string(31, 'a')));
  EXPECT_FALSE(looks_like_job_id(std::string(32, 'A')));
}

}  // namespace
}  // namespace lipmap::server
