#include "HugePages.h"

#include <gnu/libc-version.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <set>

#if defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || __has_feature(memory_sanitizer)
#define CASCADE_SANITIZER_ALLOCATOR 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define CASCADE_SANITIZER_ALLOCATOR 1
#endif

namespace cascade::cli {

namespace {

constexpr const char* kTunable = "glibc.malloc.hugetlb";

/// Why this process cannot ask for huge pages, or empty when it can.
std::string unavailable() {
#ifdef CASCADE_SANITIZER_ALLOCATOR
  return "a sanitizer's allocator replaces malloc";
#else
  const std::string version = gnu_get_libc_version();
  int major = 0, minor = 0;
  if (std::sscanf(version.c_str(), "%d.%d", &major, &minor) != 2 || major < 2 || (major == 2 && minor < 35))
    return "glibc " + version + " has no " + kTunable;
  std::ifstream modes("/sys/kernel/mm/transparent_hugepage/enabled");  // e.g. "always [madvise] never"
  std::string line;
  if (!std::getline(modes, line)) return "the kernel does not say whether it has transparent huge pages";
  if (line.find("[always]") == std::string::npos && line.find("[madvise]") == std::string::npos)
    return "the kernel's transparent huge pages are off";
  return "";
#endif
}

/// The value of glibc.malloc.hugetlb in GLIBC_TUNABLES (name=value pairs joined by ':'),
/// or nothing when it is not there.
std::optional<std::string> tunableValue() {
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  if (!tunables) return std::nullopt;
  const std::string list = std::string(":") + tunables + ":";
  const std::string key = std::string(":") + kTunable + "=";
  const std::size_t at = list.find(key);
  if (at == std::string::npos) return std::nullopt;
  const std::size_t begin = at + key.size();
  return list.substr(begin, list.find(':', begin) - begin);
}

bool optedOut() {
  const char* value = std::getenv("CASCADE_HUGE_PAGES");
  return value && std::string(value) == "0";
}

} // namespace

void preferHugePages(const std::string& subcommand, char** argv) {
  static const std::set<std::string> surfacing = {"surface", "run", "bench"};
  bool version = false;  // `cascade --version` reports the heap those subcommands get
  for (char** word = argv + 1; *word && subcommand.empty(); ++word) version = version || std::string(*word) == "--version";
  if ((!surfacing.count(subcommand) && !version) || optedOut() || !unavailable().empty()) return;
  if (tunableValue()) return;  // chosen already: by us, or by the caller
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  const std::string before = tunables ? tunables : "";
  const std::string value = (before.empty() ? "" : before + ":") + kTunable + "=1";
  if (::setenv("GLIBC_TUNABLES", value.c_str(), 1) != 0) return;
  ::execv("/proc/self/exe", argv);
  // Still here: the exec failed. Go on as started, on small pages.
  if (tunables) ::setenv("GLIBC_TUNABLES", before.c_str(), 1);
  else ::unsetenv("GLIBC_TUNABLES");
}

std::string heapPagesText() {
  const std::optional<std::string> value = tunableValue();
  const std::string reason = unavailable();
  if (!reason.empty()) return "  heap: 4 KiB pages (" + reason + ")";
  if (value)
    return std::string("  heap: ") + (*value == "0" ? "4 KiB pages" : "transparent huge pages") + " (GLIBC_TUNABLES=" +
           std::getenv("GLIBC_TUNABLES") + ")";
  if (optedOut()) return "  heap: 4 KiB pages (CASCADE_HUGE_PAGES=0)";
  return "  heap: 4 KiB pages (could not restart with " + std::string(kTunable) + "=1)";
}

} // namespace cascade::cli
