// A transfer function chosen from a volume's data, for a volume that comes without one (a data file
// opened directly, a scene volume with no "transfer_function"). It is returned as the scene file's JSON
// form, so a saved scene says what was chosen.
//
// | data                                                        | choice                                   |
// |-------------------------------------------------------------|------------------------------------------|
// | signed (int16, float32) reaching <= -900 and >= +300: a CT   | {"preset": "ct-bone"} (Hounsfield units) |
// | in Hounsfield units (air and bone)                          |                                          |
// | constant                                                    | {"preset": "grayscale"}                  |
// | anything else                                               | a warm ramp over its histogram (below)   |
//
// The ramp: the most common value is taken as background (air, padding) when it holds at least 20% of
// the voxels and lies in the lower half of the range. Over the other voxels, opacity rises from 0 at
// the median to 0.6 at the 99.5th percentile (0.02 and 0.15 at a quarter and three fifths of the way),
// dark red through orange to near-white: the denser half of the data shows, its densest parts opaque,
// like ParaView's opacity ramp over the data range but starting where the material starts.
#pragma once

#include <nlohmann/json.hpp>

#include "penumbra/data/volume.h"
#include "penumbra/data/volume_stats.h"

namespace penumbra {

// Whether data of this type spanning [lo, hi] reads as a CT in Hounsfield units (the table's first row).
bool is_hounsfield_ct(ScalarType type, float lo, float hi);

nlohmann::json choose_transfer_function(const Volume& volume);

// The same choice from the data's histogram (1024 bins over its range; kTransferChoiceBins), for data
// that no one process holds: the histograms of a distributed volume's slices, added up.
constexpr int kTransferChoiceBins = 1024;
nlohmann::json choose_transfer_function(const VolumeHistogram& histogram, ScalarType type);

}  // namespace penumbra
