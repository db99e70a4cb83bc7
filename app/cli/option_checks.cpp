#include "cli/option_checks.h"

#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <sstream>

namespace pt {

namespace {

std::string number_text(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// The whole string parsed as T, or false (trailing characters, empty, out of T's range).
template <class T>
bool parse_whole(const std::string& text, T& value) {
  const char* end = text.data() + text.size();
  const auto r = std::from_chars(text.data(), end, value);
  return r.ec == std::errc() && r.ptr == end;
}

}  // namespace

CLI::Validator finite_in(double lo, double hi) {
  const std::string range = "[" + number_text(lo) + ", " + number_text(hi) + "]";
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(text.c_str(), &end);
        if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(v) || v < lo || v > hi)
          return "must be a finite number in " + range + ", not '" + text + "'";
        return {};
      },
      "NUMBER in " + range);
}

CLI::Validator whole_in(long long lo, long long hi) {
  const std::string range = "[" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        long long v = 0;
        if (!parse_whole(text, v) || v < lo || v > hi) return "must be a whole number in " + range + ", not '" + text + "'";
        return {};
      },
      "INT in " + range);
}

CLI::Validator whole_u64() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        uint64_t v = 0;
        if (!parse_whole(text, v)) return "must be a whole number in [0, 18446744073709551615], not '" + text + "'";
        return {};
      },
      "INT in [0, 2^64-1]");
}

}  // namespace pt
