// Frame buffers stay mapped. Every frame allocates and frees the same large buffers (images, per-pixel
// arrays, hit buffers, the shadow maps' per-sphere arrays: megabytes at 512², tens at 1920×1200). By
// default glibc gives such blocks back to the kernel when they are freed, so the next frame takes a
// page fault on every 4 KiB page it writes again: measured on this project's 2-core VM, a 1 M-sphere
// frame 400 → 170 ms (2026-11), and the cranium's 512² frame through Python 164 → 134 ms (2026-12,
// ~2,500 faults a frame). keep_frame_memory_mapped() raises glibc's mmap and trim thresholds to 1 GiB,
// so that freed blocks below that stay in the process for the next frame. The size matters: with the
// mmap threshold at 32 MiB, 1M4X's 16 M-sphere ISSM arrays (65–260 MB each) were mapped and unmapped
// every frame and its page faults tripled (650 k against 250 k over four frames).
//
// The price is memory kept after it is freed (up to the trim threshold); a program calls it once, first
// thing (the CLI's main, the Python module's import). Without glibc it does nothing.
#pragma once

namespace penumbra {

void keep_frame_memory_mapped();

}  // namespace penumbra
