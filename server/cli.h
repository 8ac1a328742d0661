// The lipmap command line: `lipmap classify FILE`, and the places of `map` and `serve` to come.
// Everything JSON goes through json_codec; everything else is the engine's.
#pragma once

#include <iosfwd>
#include <string>

namespace lipmap::cli {

// Exit codes. Every classify verdict is an answer (0); only failures are non-zero.
enum ExitCode : int {
  kExitOk = 0,
  kExitInputError = 1,     // unreadable file, malformed JSON, wrong shape, InputError from the engine
  kExitUsageError = 2,     // bad command line; also a subcommand that is not implemented yet
  kExitInternalError = 3,  // a bug or resource exhaustion: InternalError, bad_alloc, anything unexpected
};

// Parses argv and runs the subcommand. Never throws. Answers go to `out`; every failure is exactly one
// line on `err`: "lipmap: error: <code>: <message>".
int run(int argc, const char* const* argv, std::istream& in, std::ostream& out, std::ostream& err);

// `lipmap classify FILE [--pretty]`: FILE holds a /v1/polygons/classify body; "-" reads it from `in`.
int classify_command(const std::string& file, bool pretty, std::istream& in, std::ostream& out, std::ostream& err);

}  // namespace lipmap::cli
