/// @file HugePages.h
/// @brief The heap on transparent huge pages: glibc's `glibc.malloc.hugetlb=1`
///        tunable, which makes malloc madvise(MADV_HUGEPAGE) the memory it takes
///        from the kernel, so fresh memory arrives 2 MiB per page fault instead of
///        4 KiB.
///
/// Why: surfacing a frame allocates and fills about a gigabyte of fresh memory
/// (kernel sums, OpenVDB leaves, mesh arrays). On the virtual machines measured here
/// a 4 KiB page fault costs about 10 us, so faults were a third of the CPU of `cascade
/// bench surface` (docs/shot-outputs.md, "Huge pages"). glibc reads its tunables only
/// when a program starts, from the environment; so `cascade` adds the tunable to
/// GLIBC_TUNABLES and executes itself again, once, before it does anything else.
#pragma once

#include <string>

namespace cascade::cli {

/// For the subcommands that surface (surface, run, bench; and --version, which reports
/// it), re-executes this program with glibc.malloc.hugetlb=1 added to GLIBC_TUNABLES
/// (any tunables already there are kept). The others (bake, render, inspect, farm, ...)
/// are not restarted: a start costs about 0.08 s here (the dynamic loader), a bake
/// allocates its arrays once (measured: no gain), render gained 7-8 % (near the noise)
/// and whitewater nothing (docs/cli.md). Returns when it does not restart: another
/// subcommand; the tunable (any value) is already set; CASCADE_HUGE_PAGES=0; the kernel's
/// transparent huge pages are `never` or unknown; glibc is older than 2.35 (no such
/// tunable); a sanitizer's allocator replaces malloc; or the exec failed.
void preferHugePages(const std::string& subcommand, char** argv);

/// One line for `cascade --version`: whether this process's heap is on huge pages (and
/// so surface, run and bench's), with GLIBC_TUNABLES as it is, or why not.
std::string heapPagesText();

} // namespace cascade::cli
