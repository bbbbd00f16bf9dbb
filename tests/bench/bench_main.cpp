// The main() of every Google Benchmark program here. It applies the process-wide settings that
// softgrasp-server, softgrasp-sim and softgrasp-train apply at start, so a benchmark times what
// the programs run:
//   --glibc-default-malloc   leave glibc's allocator at its defaults (the baseline of
//                            docs/performance.md, "The allocator"), instead of
//                            process::KeepFreedMemoryForReuse().
// The setting is recorded in the benchmark's context ("malloc") in every output format.
#include <benchmark/benchmark.h>

#include <cstring>

#include "service/process/allocator.h"

int main(int argc, char** argv) {
  bool glibc_default_malloc = false;
  int kept = 1;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--glibc-default-malloc") == 0) {
      glibc_default_malloc = true;
    } else {
      argv[kept++] = argv[i];
    }
  }
  argc = kept;
  argv[argc] = nullptr;
  if (!glibc_default_malloc) softgrasp::process::KeepFreedMemoryForReuse();
  benchmark::AddCustomContext("malloc",
                              glibc_default_malloc ? "glibc defaults" : "freed memory kept");
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
