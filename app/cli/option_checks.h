// Validators for numeric command-line options. CLI11's own converters accept nan and inf as numbers, report
// "32.0" for an integer as out of range, and wrap values past 2^64; these say what is wrong and what is valid:
// "--time: must be a finite number in [0.001, 1e+07]".
#pragma once
#include <CLI/CLI.hpp>

namespace pt {

CLI::Validator finite_in(double lo, double hi);
CLI::Validator whole_in(long long lo, long long hi);
CLI::Validator whole_u64();  // [0, 2^64 − 1]

}  // namespace pt
