// The Lua scripts of the shared job queue (redis_jobs.cpp; keys and stream in redis_jobs.h). Redis runs each
// atomically: a job's state changes in one step, so that a DELETE and a worker starting the same job never
// both win. The consumer group is "workers".
#pragma once

namespace lipmap::server::redis_scripts {

// KEYS stream, job; ARGV cap, id, created, deadline, delay_ms, fault, pexpire, consumer, started.
// {0, waiting}: refused, the queue is full. {1, entry}: queued for any replica. {2, entry}: started at once
// on `consumer` (the accepting replica, which has a free worker): read from the stream for that consumer in
// the same step, so that the entry is in its pending list (taken over if the replica dies, as any running
// job) and no other replica's fetcher can be handed it. Only when no job waits before it (first in, first
// out); {3, entry, id}: another entry was read instead (not expected), the caller runs that one.
inline const char* const kSubmit = R"(
local waiting = redis.call('XLEN', KEYS[1])
local p = redis.pcall('XPENDING', KEYS[1], 'workers')
if type(p) == 'table' and p.err == nil then waiting = waiting - p[1] end
if waiting >= tonumber(ARGV[1]) then return {0, waiting} end
local entry = redis.call('XADD', KEYS[1], '*', 'id', ARGV[2])
redis.call('HSET', KEYS[2], 'state', 'queued', 'created', ARGV[3], 'deadline', ARGV[4], 'delay_ms', ARGV[5],
           'fault', ARGV[6], 'entry', entry, 'attempts', 0)
redis.call('PEXPIRE', KEYS[2], ARGV[7])
if ARGV[8] == '' or waiting > 0 then return {1, entry} end
local r = redis.pcall('XREADGROUP', 'GROUP', 'workers', ARGV[8], 'COUNT', '1', 'STREAMS', KEYS[1], '>')
if type(r) ~= 'table' or r.err ~= nil or not r[1] then return {1, entry} end
local got = r[1][2][1]
if got[1] ~= entry then return {3, got[1], got[2][2] or ''} end
redis.call('HSET', KEYS[2], 'state', 'running', 'started', ARGV[9], 'owner', ARGV[8], 'attempts', 1)
return {2, entry})";

// KEYS job; ARGV started, owner. {'run', attempts} or {state, 0}.
inline const char* const kStart = R"(
local s = redis.call('HGET', KEYS[1], 'state')
if not s then return {'missing', 0} end
if s ~= 'queued' and s ~= 'running' then return {s, 0} end
redis.call('HSET', KEYS[1], 'state', 'running', 'started', ARGV[1], 'owner', ARGV[2])
return {'run', redis.call('HINCRBY', KEYS[1], 'attempts', 1)})";

// KEYS job, result, req, gone, stream; ARGV state, problem, result_sent ('1' or ''), finished, result_bytes,
// progress, keep_ms, gone_ms, entry. The stream entry is acknowledged and deleted once the job is final.
// The result itself is SET just before (a megabyte handed to a script as an argument costs milliseconds of
// copying into Lua; a plain SET does not). A job deleted, cancelled or failed meanwhile drops it again; one
// that another replica finished first (it had taken the job over) keeps it: the same job gives the same answer.
inline const char* const kFinish = R"(
local s = redis.call('HGET', KEYS[1], 'state')
local function ack()
  redis.call('XACK', KEYS[5], 'workers', ARGV[9])
  redis.call('XDEL', KEYS[5], ARGV[9])
end
if not s then redis.call('DEL', KEYS[2]) ack() return 'missing' end
if s ~= 'running' then
  if s ~= 'succeeded' then redis.call('DEL', KEYS[2]) end
  ack()
  return s
end
if ARGV[3] == '1' and redis.call('EXISTS', KEYS[2]) == 0 then return 'no_result' end
redis.call('HSET', KEYS[1], 'state', ARGV[1], 'finished', ARGV[4], 'result_bytes', ARGV[5], 'progress', ARGV[6])
if ARGV[2] ~= '' then redis.call('HSET', KEYS[1], 'problem', ARGV[2]) end
redis.call('PEXPIRE', KEYS[1], ARGV[7])
redis.call('PEXPIRE', KEYS[3], ARGV[7])
redis.call('SET', KEYS[4], 'expired', 'PX', ARGV[8])
ack()
return 'ok')";

// KEYS job; ARGV problem, finished. The state before: 'queued' (now cancelled), 'running' (flag set), ...
inline const char* const kCancel = R"(
local s = redis.call('HGET', KEYS[1], 'state')
if not s then return 'missing' end
if s == 'queued' then
  redis.call('HSET', KEYS[1], 'state', 'cancelled', 'cancel', '1', 'problem', ARGV[1], 'finished', ARGV[2])
elseif s == 'running' then
  redis.call('HSET', KEYS[1], 'cancel', '1')
end
return s)";

// KEYS job; ARGV progress. A running job's progress (never written on a job that finished or was dropped
// meanwhile, which would leave a key without expiry); returns its cancel flag.
inline const char* const kBeat = R"(
if redis.call('HGET', KEYS[1], 'state') ~= 'running' then return '' end
redis.call('HSET', KEYS[1], 'progress', ARGV[1])
return redis.call('HGET', KEYS[1], 'cancel') or '')";

// KEYS stream, job; ARGV entry, id. A running job goes back to the queue (its replica shuts down).
inline const char* const kHandBack = R"(
local s = redis.call('HGET', KEYS[2], 'state')
if s ~= 'running' then return 0 end
local e = redis.call('XADD', KEYS[1], '*', 'id', ARGV[2])
redis.call('HSET', KEYS[2], 'state', 'queued', 'entry', e, 'progress', '')
redis.call('HINCRBY', KEYS[2], 'attempts', -1)
redis.call('XACK', KEYS[1], 'workers', ARGV[1])
redis.call('XDEL', KEYS[1], ARGV[1])
return 1)";

}  // namespace lipmap::server::redis_scripts
