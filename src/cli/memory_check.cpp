// The up-front memory check of merge, add and export: refused with the figure rather than killed
// by the kernel part way (issue 19's resource bounds).

#include <spdlog/spdlog.h>

#include <cstdio>

#include "commands.hpp"
#include "mm4mm/atlas/memory_bound.hpp"
#include "mm4mm/io/resources.hpp"

namespace mm4mm::cli {

void addMemoryLimitOption(CLI::App* command, std::optional<double>* limit_gib) {
  command
      ->add_option("--memory-limit", *limit_gib,
                   "refuse, before reading the sessions, a run whose estimated peak memory "
                   "exceeds this (GiB; default: the memory the system has available)")
      ->check(CLI::PositiveNumber);
}

void checkMemory(const std::vector<std::filesystem::path>& session_dirs, const std::string& doing,
                 std::optional<double> limit_gib) {
  std::vector<SessionSize> sizes;
  for (const std::filesystem::path& dir : session_dirs) sizes.push_back(countSession(dir));
  const MemoryEstimate estimate = estimatePeakMemory(sizes);
  constexpr double kGiB = 1024.0 * 1024.0 * 1024.0;
  std::string limit_text;
  double limit_bytes = 0.0;
  if (limit_gib) {
    limit_bytes = *limit_gib * kGiB;
    char text[64];
    std::snprintf(text, sizeof(text), "--memory-limit %.1f GiB", *limit_gib);
    limit_text = text;
  } else if (const std::optional<std::uint64_t> available = availableMemoryBytes()) {
    limit_bytes = static_cast<double>(*available);
    char text[96];
    std::snprintf(text, sizeof(text),
                  "the %.1f GiB this system has available (MemAvailable, cgroup)",
                  limit_bytes / kGiB);
    limit_text = text;
  } else {
    spdlog::info("{} needs {} at its peak; the memory available is unknown", doing,
                 describe(estimate));
    return;
  }
  if (estimate.peak_bytes > limit_bytes)
    throw NotEnoughMemory(doing + " needs " + describe(estimate) + " at its peak, more than " +
                          limit_text +
                          ": refused before reading them; merge fewer sessions, shorten or "
                          "subsample the recordings, or free memory");
  spdlog::info("{} needs {} at its peak, of {}", doing, describe(estimate), limit_text);
}

}  // namespace mm4mm::cli
