// DICOM through load_volume: the input as one slice file (.dcm), walked here and decoded by GDCM.
#include "fuzz_common.h"
#include "penumbra/data/io/volume_io.h"

// GDCM 3.0.21 leaks on the JPEG-LS codec's error path: it does not free its copy of the codestream when
// CharLS refuses it (a few hundred bytes to a few KB per bad file). That leak is GDCM's and cannot be
// avoided from here short of not decoding JPEG-LS; it is suppressed by the allocating function, so that
// any other leak still fails the run. (JPEG 2000 never reaches GDCM: OpenJPEG decodes it, called from
// jpeg2000_decode.cpp, and no leak of OpenJPEG's is suppressed.)
extern "C" const char* __lsan_default_suppressions() { return "leak:gdcm::JPEGLSCodec::\n"; }

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = penumbra::fuzz::write_input("in.dcm", data, size);
  penumbra::fuzz::expect_error_or_result([&] { (void)penumbra::load_volume(path); });
  penumbra::fuzz::expect_windows_match({path}, {});
  return 0;
}
