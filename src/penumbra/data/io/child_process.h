// Readers that hand a file to a library not hardened against corrupt input (OpenVDB, libhdf5) run the
// library in a forked child process with a memory budget and a time limit, and take its answer back;
// a crash, a limit or a short answer becomes an Error in the parent (a child out of time is tried once
// more: a fork of a threaded process can inherit a lock another thread held). These are the child's limits.
#pragma once

#include <cstdint>
#include <string>

namespace penumbra::io_detail {

// What the child may use beyond what the process held when it forked. A library allocates what a
// corrupt header says before it finds the data missing, so memory is bounded by what the file can
// hold: zlib and Blosc expand at most about 1000:1, so 1100 times the file's size plus `extra_bytes`
// (at least 256 MiB, at most the machine's memory). Time: 30 s plus 2 s per MiB of file.
struct ChildLimits {
  std::uint64_t memory_budget = 0;       // bytes beyond the fork-time size
  std::uint64_t base_resident = 0;       // resident bytes at fork
  std::uint64_t base_address_space = 0;  // address space at fork
  double seconds = 30;
};
ChildLimits child_limits(const std::string& path, std::uint64_t extra_bytes = 0);

// In the child: bounds its address space (a huge allocation then fails at once; not under
// AddressSanitizer, which reserves terabytes) and starts a watchdog thread that ends the child when its
// resident memory passes the budget (exit 4) or its time runs out (exit 5).
void limit_child(const ChildLimits& limits);

// The child's exit, in words for an Error: "ran out of its memory budget (…)", "was killed by signal 11", ...
std::string child_exit_text(int wait_status, const ChildLimits& limits);

}  // namespace penumbra::io_detail
