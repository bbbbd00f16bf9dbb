// process::KeepFreedMemoryForReuse: a large block freed on a worker thread is reused by the next
// allocation instead of being unmapped and faulted in again page by page.
#include "service/process/allocator.h"

#include <gtest/gtest.h>
#include <sys/resource.h>

#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <thread>

namespace softgrasp::process {
namespace {

constexpr std::size_t kBlockBytes = 24u << 20;  // about one activation tensor of the U-Nets
constexpr long kPageBytes = 4096;

long MinorFaultsOfThisThread() {
  rusage usage{};
  getrusage(RUSAGE_THREAD, &usage);
  return usage.ru_minflt;
}

// Keeps the compiler from dropping writes to a block that is freed next.
void KeepWrites(void* block) { asm volatile("" : : "r"(block) : "memory"); }

// On a new thread (its own malloc arena, as a server worker): allocates and writes a block,
// frees it, then counts the page faults of allocating and writing a second one.
long FaultsOfSecondBlockOnAWorker() {
  long faults = 0;
  std::thread worker([&] {
    void* first = std::malloc(kBlockBytes);
    std::memset(first, 1, kBlockBytes);
    KeepWrites(first);
    std::free(first);
    const long before = MinorFaultsOfThisThread();
    void* second = std::malloc(kBlockBytes);
    std::memset(second, 2, kBlockBytes);
    KeepWrites(second);
    faults = MinorFaultsOfThisThread() - before;
    std::free(second);
  });
  worker.join();
  return faults;
}

TEST(KeepFreedMemoryForReuse, AFreedBlockIsReusedWithoutPageFaults) {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  GTEST_SKIP() << "the sanitizers bring their own allocator";
#endif
  const long pages = static_cast<long>(kBlockBytes) / kPageBytes;
  const long before = FaultsOfSecondBlockOnAWorker();  // glibc's defaults: mapped again
  KeepFreedMemoryForReuse();
  const long after = FaultsOfSecondBlockOnAWorker();
  // With glibc's defaults the second block is faulted in afresh: about one fault per 4 KiB page
  // here, fewer where transparent huge pages back every mapping.
  EXPECT_GT(before, after) << "defaults: the block is expected to be mapped afresh";
  EXPECT_LT(after, pages / 20) << "kept: the second block reuses the first one's pages";
}

}  // namespace
}  // namespace softgrasp::process
