#pragma once
/// The command-line tools' argument parser: "--name value" options and "--name" flags, taken out
/// of the argument list one by one, so that whatever is left at the end is an unknown argument.
///
///   cli::Args args(std::vector<std::string>(argv + 2, argv + argc));  // after "tool command"
///   std::string data;
///   int steps = 100;
///   double lr = 2e-4;
///   args.Required("--data", "DIR", &data);            // "--data DIR is required"
///   args.Int("--steps", 1, 1000, &steps);             // "--steps must be an integer in 1..1000"
///   args.Number("--lr", cli::Bounds::Above(0), &lr);  // "--lr must be a number > 0"
///   const bool resume = args.Flag("--resume");
///   if (const auto error = args.Finish()) {  // the first problem, or "unknown argument X"
///     std::cerr << "tool: " << error->message << "\n";
///     return 2;
///   }
///
/// Rules:
/// - An option's value is the token after its name, whatever it holds ("-1", "" included), unless
///   that token starts with "--": then the option "needs a value". Write a path that starts
///   with "--" as "./--name".
/// - An option or flag given twice is a problem ("--steps given twice"), except for All(), which
///   takes every occurrence in order.
/// - The first problem sticks: every later getter does nothing and leaves its target as it was,
///   and Finish() returns that problem. So a command reads all its options, then calls Finish()
///   once, and reports the problem a user would meet first in the order the options were read.
/// - A getter leaves its target untouched when the option is absent, so targets hold defaults.
/// - Every problem is a core::Error with code kInvalidArgument, a message that names the option
///   and says what it takes, and the option's name without the dashes as its field.

#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "service/core/status.h"

namespace softgrasp::cli {

/// The largest integer bound: Int(name, lo, kNoLimit, &out) accepts every integer >= lo that
/// `out` can hold, and says "must be an integer >= lo".
inline constexpr long long kNoLimit = std::numeric_limits<long long>::max();

/// The largest count Count() accepts unless told otherwise.
inline constexpr long long kMaxCount = 1'000'000;

/// Which real numbers Number() accepts; every one of them is finite ("inf" and "nan" never are).
struct Bounds {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false;  ///< lo itself is excluded
  bool hi_open = false;  ///< hi itself is excluded

  static Bounds Any() { return {}; }                                       ///< ""
  static Bounds Closed(double lo, double hi) { return {lo, hi}; }          ///< "in [lo, hi]"
  static Bounds LeftOpen(double lo, double hi) { return {lo, hi, true}; }  ///< "in (lo, hi]"
  static Bounds AtLeast(double lo) { return Bounds{lo}; }                  ///< ">= lo"
  static Bounds Above(double lo) { return Bounds{lo, Any().hi, true}; }    ///< "> lo"

  bool Contains(double x) const;
  /// "in [0, 1]", "in (0.05, 5]", ">= 0", "> 0", "<= 3", or "" when every number is accepted.
  std::string Describe() const;
};

/// A whole-string base-10 integer: "12", "-3"; not "", "1.0", "1x", " 1" or out of range.
bool ParseInteger(std::string_view text, long long* out);

/// A whole-string finite decimal number: "0.5", "-1", "1e-3"; not "", "1x", "inf" or "nan".
bool ParseNumber(std::string_view text, double* out);

class Args {
 public:
  explicit Args(std::vector<std::string> args) : rest_(std::move(args)) {}

  /// True when `name` is present (and takes it out).
  bool Flag(std::string_view name);

  /// The option's value into `out`; true when present.
  bool Text(std::string_view name, std::string* out);

  /// As Text(), and a problem "NAME META is required" when absent ("--data DIR is required").
  bool Required(std::string_view name, std::string_view meta, std::string* out);

  /// Every value of a repeatable option, in the order given; empty when absent.
  std::vector<std::string> All(std::string_view name);

  /// An integer in lo..hi: "NAME must be an integer in LO..HI" (">= LO" when hi is kNoLimit).
  /// The bounds are narrowed to what T can hold.
  template <class T>
  bool Int(std::string_view name, long long lo, long long hi, T* out) {
    static_assert(std::is_integral_v<T> && !std::is_same_v<T, bool>);
    long long v = 0;
    if (!TakeInteger(name, Low<T>(lo), High<T>(hi), "an integer", &v)) return false;
    *out = static_cast<T>(v);
    return true;
  }

  /// How many of something, 0..max: "NAME must be a count in 0..MAX".
  template <class T>
  bool Count(std::string_view name, T* out, long long max = kMaxCount) {
    static_assert(std::is_integral_v<T> && !std::is_same_v<T, bool>);
    long long v = 0;
    if (!TakeInteger(name, 0, High<T>(max), "a count", &v)) return false;
    *out = static_cast<T>(v);
    return true;
  }

  /// A finite number within `bounds`: "NAME must be a number in [0, 1]" (Bounds::Describe()).
  template <class T>
  bool Number(std::string_view name, const Bounds& bounds, T* out) {
    static_assert(std::is_floating_point_v<T>);
    double v = 0;
    if (!TakeNumber(name, bounds, &v)) return false;
    *out = static_cast<T>(v);
    return true;
  }

  /// "N" or "MIN-MAX" with lo <= MIN <= MAX <= hi ("N" sets both):
  /// "NAME must be N or MIN-MAX within LO-HI".
  template <class T>
  bool Span(std::string_view name, long long lo, long long hi, T* min, T* max) {
    static_assert(std::is_integral_v<T> && !std::is_same_v<T, bool>);
    long long a = 0, b = 0;
    if (!TakeSpan(name, Low<T>(lo), High<T>(hi), &a, &b)) return false;
    *min = static_cast<T>(a);
    *max = static_cast<T>(b);
    return true;
  }

  /// One of the named values: "NAME must be one of train, val".
  template <class T>
  bool Choice(std::string_view name, const std::vector<std::pair<std::string_view, T>>& choices,
              T* out) {
    std::string value;
    if (!Text(name, &value)) return false;
    for (const auto& [word, v] : choices) {
      if (value == word) {
        *out = v;
        return true;
      }
    }
    std::vector<std::string_view> words;
    for (const auto& choice : choices) words.push_back(choice.first);
    return FailChoice(name, words);
  }

  /// Records a problem the caller found (a value of the wrong form, options that clash) unless
  /// one is recorded already. Returns false, so `return args.Fail(...)` reads naturally.
  bool Fail(std::string message, std::string_view name = {});

  /// No problem so far.
  bool ok() const { return !error_.has_value(); }

  /// The first problem, else "unknown argument X" for the first token left over, else nothing.
  std::optional<core::Error> Finish() const;

  /// The tokens not taken yet.
  const std::vector<std::string>& remaining() const { return rest_; }

 private:
  /// The bounds narrowed to what T holds.
  template <class T>
  static long long Low(long long lo) {
    constexpr auto kMin = static_cast<long long>(std::numeric_limits<T>::min());
    return lo > kMin ? lo : kMin;
  }
  template <class T>
  static long long High(long long hi) {
    constexpr auto kMax = std::numeric_limits<T>::max();
    if constexpr (static_cast<unsigned long long>(kMax) >=
                  static_cast<unsigned long long>(kNoLimit)) {
      return hi;
    } else {
      return hi < static_cast<long long>(kMax) ? hi : static_cast<long long>(kMax);
    }
  }

  /// Finds `name` once: nullopt when absent or after a problem; the value (empty for a flag).
  std::optional<std::string> Take(std::string_view name, bool has_value);
  bool TakeInteger(std::string_view name, long long lo, long long hi, std::string_view what,
                   long long* out);
  bool TakeNumber(std::string_view name, const Bounds& bounds, double* out);
  bool TakeSpan(std::string_view name, long long lo, long long hi, long long* min, long long* max);
  bool FailChoice(std::string_view name, const std::vector<std::string_view>& words);

  std::vector<std::string> rest_;
  std::optional<core::Error> error_;
};

}  // namespace softgrasp::cli
