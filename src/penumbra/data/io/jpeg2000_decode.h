// One frame of DICOM JPEG 2000 pixel data (transfer syntaxes 1.2.840.10008.1.2.4.90, lossless only, and
// .91, lossless or lossy), decoded with OpenJPEG called directly. Not through GDCM's JPEG 2000 codec:
// that read out of bounds on corrupt codestreams under fuzz_dicom, in a way that depended on the state
// of memory, so no check ahead of it could make it safe. Here every step is ours to check: the main
// header (SIZ) is read and compared with the DICOM attributes before OpenJPEG sees a byte (one
// component, Rows x Columns, no subsampling, a bounded tile grid, a precision that fits BitsAllocated),
// OpenJPEG reads from memory through callbacks that never go past the end, its messages are kept (not
// printed), every call's result and the decoded image are checked, and everything is freed on every path.
#pragma once

#include <span>

namespace penumbra::io_detail {

// What the DICOM attributes say a frame is.
struct Jpeg2000Frame {
  int rows = 0, cols = 0;   // Rows, Columns
  int bits_allocated = 0;   // 8, 16 or 32: the size of one value in the output
  bool is_signed = false;   // PixelRepresentation 1
};

// Checks the main header of a J2K codestream, or of the codestream in a JP2 file (told apart by their
// first bytes), against `frame`, without decoding: Error saying what was expected and what was found.
void check_jpeg2000_header(std::span<const unsigned char> data, const Jpeg2000Frame& frame);

// Decodes one frame (a J2K codestream or a JP2 file, the frame's fragments concatenated) into `out`,
// which holds exactly rows * cols * bits_allocated / 8 bytes: row after row, each value in host byte
// order as an unsigned integer of BitsAllocated bits (a negative value as its two's complement), as
// native pixel data is after its byte order is fixed. A signed image may come as an unsigned codestream
// (its values are then the stored bit patterns); an unsigned image as a signed codestream only while no
// value is negative. Error (the caller adds the file) on anything that does not decode to that frame.
void decode_jpeg2000(std::span<const unsigned char> data, const Jpeg2000Frame& frame, std::span<char> out);

}  // namespace penumbra::io_detail
