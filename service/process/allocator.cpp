#include "service/process/allocator.h"

#include <malloc.h>

namespace softgrasp::process {

void KeepFreedMemoryForReuse() {
  // Setting either value also switches off glibc's dynamic mmap threshold. 32 MiB is the
  // largest mmap threshold glibc accepts on 64-bit.
  constexpr int kMmapThresholdBytes = 32 * 1024 * 1024;
  constexpr int kTrimThresholdBytes = 1024 * 1024 * 1024;
  mallopt(M_MMAP_THRESHOLD, kMmapThresholdBytes);
  mallopt(M_TRIM_THRESHOLD, kTrimThresholdBytes);
}

}  // namespace softgrasp::process
