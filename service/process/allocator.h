#pragma once

namespace softgrasp::process {

/// Makes glibc's allocator keep freed memory of the process for reuse instead of returning it to
/// the kernel after every free: blocks up to 32 MiB come from the heap, not from a mapping of
/// their own, and heaps are trimmed only above 1 GiB free. The networks' activations, FGE's
/// per-slice maps and the renderer's buffers are megabytes each; with glibc's defaults they were
/// mapped and unmapped per request and faulted in again page by page. On virtual machines a page
/// fault is expensive: there the defaults made the segmentation model 4-5x and FGE about 3x slower
/// (docs/performance.md, "The allocator"). The price: the process keeps its peak heap.
/// Process-wide; call once at start, before other threads run.
void KeepFreedMemoryForReuse();

}  // namespace softgrasp::process
