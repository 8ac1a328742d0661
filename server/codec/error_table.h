// The one table of error codes: for every code that lipmap emits (the engine's InputError codes, the JSON and
// glTF codecs' codes, the HTTP layer's own codes, the command line's own codes), the HTTP status and problem
// title of its RFC 7807 answer and the exit code of `lipmap` when the command line reports it.
// docs/api.md lists the codes per endpoint; tests/service/test_error_table.cpp checks the table against the
// sources and proto/.
#pragma once

#include <string_view>
#include <vector>

namespace lipmap::codec {

// The exit codes of `lipmap` (the command line prints one line "lipmap: error: <code>: <message>").
enum ExitCode : int {
  kExitOk = 0,
  kExitInputError = 1,     // the caller's input or files: every 4xx code
  kExitUsageError = 2,     // a bad command line
  kExitInternalError = 3,  // a bug, resource exhaustion or cancellation: every 5xx code
};

struct ErrorInfo {
  std::string_view code;   // stable snake_case code, also the problem's `code` and urn:lipmap:problem:<code>
  int status;              // HTTP status of the problem answer
  std::string_view title;  // the problem's `title`
  int exit_code;           // ExitCode of the command line
};

// The entry of `code`. An unknown code is a bug (tests/service/test_error_table.cpp checks that every code
// the sources emit is listed); it gets the fallback entry {code "internal_error", 500, "Internal error",
// kExitInternalError}, so that a missing entry is never reported as the caller's fault.
const ErrorInfo& error_info(std::string_view code);

// True when the table has an entry for `code`.
bool has_error_info(std::string_view code);

// Every entry, in table order.
const std::vector<ErrorInfo>& error_table();

}  // namespace lipmap::codec
