// The pixels of a DICOM series decoded into a volume: native data read here, RLE decoded here, JPEG
// and JPEG-LS by GDCM's codecs, JPEG 2000 by OpenJPEG; bits above BitsStored masked or sign-extended,
// the rescale applied per slice. Internal to the DICOM reader (dicom_loader.cpp).
#pragma once

#include "penumbra/data/io/dicom_series.h"
#include "penumbra/data/volume.h"

namespace penumbra::dicom {

// Decodes every slice of the layout into `volume`, rescaled. False when the volume's type is an integer
// type and a rescaled value does not fit it (the caller then uses float32).
bool fill_slices(Volume& volume, const Layout& L);

}  // namespace penumbra::dicom
