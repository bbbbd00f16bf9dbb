#pragma once
/// What every softgrasp-train command shares: its failure message and exit status, JSON numbers
/// that may be NaN, and elapsed times on the steady clock.

#include <chrono>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

#include "service/core/status.h"

namespace softgrasp::tools {

/// Prints "softgrasp-train COMMAND: MESSAGE" on stderr ("softgrasp-train: MESSAGE" when `command`
/// is empty) and returns 2, the exit status of a command that failed.
int Fail(std::string_view command, const std::string& message);

/// Fail with the error's message and the field it names, if any: "MESSAGE [FIELD]".
int FailError(std::string_view command, const core::Error& error);

/// `v` as a JSON number, or null when it is NaN or infinite (JSON has no such numbers).
nlohmann::json Num(double v);

/// Milliseconds from `start` to now.
double MillisecondsSince(std::chrono::steady_clock::time_point start);

/// Seconds from `start` to now.
double SecondsSince(std::chrono::steady_clock::time_point start);

}  // namespace softgrasp::tools
