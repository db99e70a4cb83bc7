// How much memory one allocation plan may use: 3/4 of the machine's physical memory, or less under an address-
// space limit (ulimit -v). Large buffers (films, images) are checked against it before they are allocated, so an
// impossible request fails with its figure and the limit instead of an abort in the allocator.
#pragma once
#include <cstdint>
#include <string>

namespace pt {

uint64_t memory_budget_bytes();
// "1.9 GiB"-style text for messages.
std::string format_bytes(uint64_t bytes);

}  // namespace pt
