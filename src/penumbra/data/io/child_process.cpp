#include "penumbra/data/io/child_process.h"

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <thread>

namespace penumbra::io_detail {

namespace {

#if defined(__SANITIZE_ADDRESS__)
constexpr bool kAddressSanitizer = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool kAddressSanitizer = true;
#else
constexpr bool kAddressSanitizer = false;
#endif
#else
constexpr bool kAddressSanitizer = false;
#endif

std::string mib(std::uint64_t bytes) { return std::to_string(bytes >> 20) + " MiB"; }

}  // namespace

ChildLimits child_limits(const std::string& path, std::uint64_t extra_bytes) {
  std::error_code ec;
  const std::uint64_t file = std::filesystem::file_size(path, ec);
  const std::uint64_t page = static_cast<std::uint64_t>(::sysconf(_SC_PAGE_SIZE));
  const std::uint64_t physical = static_cast<std::uint64_t>(::sysconf(_SC_PHYS_PAGES)) * page;
  ChildLimits l;
  l.memory_budget = std::min(physical, std::max<std::uint64_t>(std::uint64_t{256} << 20, (ec ? 0 : 1100 * file) + extra_bytes));
  std::ifstream statm("/proc/self/statm");
  std::uint64_t size = 0, resident = 0;
  if (statm >> size >> resident) {
    l.base_address_space = size * page;
    l.base_resident = resident * page;
  }
  l.seconds = 30.0 + 2.0 * static_cast<double>(ec ? 0 : file) / (1 << 20);
  return l;
}

void limit_child(const ChildLimits& l) {
  if (!kAddressSanitizer && l.base_address_space > 0) {
    const rlim_t as = static_cast<rlim_t>(l.base_address_space + l.memory_budget);
    const rlimit r{as, as};
    ::setrlimit(RLIMIT_AS, &r);
  }
  std::thread([l] {  // a thread, not a signal: AddressSanitizer's builds cannot bound address space
    const auto start = std::chrono::steady_clock::now();
    const std::uint64_t page = static_cast<std::uint64_t>(::sysconf(_SC_PAGE_SIZE));
    for (;;) {
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
      std::ifstream statm("/proc/self/statm");
      std::uint64_t size = 0, resident = 0;
      if (statm >> size >> resident && resident * page > l.base_resident + l.memory_budget) ::_exit(4);
      if (std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() > l.seconds) ::_exit(5);
    }
  }).detach();
}

std::string child_exit_text(int status, const ChildLimits& l) {
  if (WIFEXITED(status) && WEXITSTATUS(status) == 4) return "ran out of its memory budget (" + mib(l.memory_budget) + " for a file of this size: a corrupt size?)";
  if (WIFEXITED(status) && WEXITSTATUS(status) == 5) return "took longer than " + std::to_string(static_cast<int>(l.seconds)) + " s";
  if (WIFEXITED(status)) return "ended with exit status " + std::to_string(WEXITSTATUS(status));
  if (WIFSIGNALED(status)) return std::string("was killed by signal ") + std::to_string(WTERMSIG(status)) + " (" + ::strsignal(WTERMSIG(status)) + ")";
  return "ended abnormally";
}

}  // namespace penumbra::io_detail
