// Frame buffers stay mapped. Every frame allocates and frees a few images and per-pixel arrays (3 MB
// each at 512², 27 MB at 1920×1200). glibc gives such blocks back to the kernel when they are freed
// (munmap above its mmap threshold, a heap trim when the free top passes its trim threshold), so the
// next frame takes a page fault on every 4 KiB page it writes again: about 2,500 faults a 512² frame,
// 30 ms of a 160 ms frame on a virtual machine. Raising both thresholds keeps freed blocks in the
// process to be reused. The setting is process-wide and made once; other C libraries are left alone.
#pragma once

namespace penumbra {

// mmap threshold 32 MiB (glibc's own dynamic ceiling), trim threshold 256 MiB. Idempotent.
void keep_frame_memory_mapped();

}  // namespace penumbra
