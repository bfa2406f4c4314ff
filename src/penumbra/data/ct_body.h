// "ct-body": a procedural whole-body CT the size of the Visible Woman (512 x 512 x 1734 uint16, 867 MB
// of voxels), the benchmark of Livnat & Tricoche's point-based isosurface extraction. What makes the
// real one hard is reproduced on purpose: per-voxel noise (the torso isosurface is "noisy"), many
// disconnected components (vertebrae, ribs, phalanges, teeth, about 200 calcifications, lung vessels
// and bowel gas: about 400 bone components without noise, 55 000 with the default noise) and thin
// nested shells (the skull's outer table, diploë and inner table; cortical bone around marrow).
//
// | parameter | default          | meaning                                                            |
// |-----------|------------------|--------------------------------------------------------------------|
// | dims      | [512, 512, 1734] | voxels along x, y, z (each 8..2048); the physical size stays fixed |
// | seed      | 1                | seeds the blobs (calcifications, lung vessels, bowel), the noise   |
// | noise     | 60               | standard deviation of the per-voxel noise, data units (0..10000)   |
//
// Grid: a 500 x 500 x 1734 mm box centred at the origin (units mm): spacing 500/dims_x, 500/dims_y,
// 1734/dims_z; x is the patient's left, y anterior, z up (soles near z = -867, the head's top at +835).
// Values are pseudo-Hounsfield units offset by +1024, the ct_tissue constants below; a smooth
// low-frequency field scales each tissue by up to ±3% and displaces every boundary by up to ±1.5 mm,
// then the noise is added and the result clamped to [0, 65535].
#pragma once

#include <array>
#include <cstdint>
#include <memory>

#include "penumbra/data/volume.h"

namespace penumbra {

struct CtBodyParams {
  std::array<int, 3> dims{512, 512, 1734};
  std::uint64_t seed = 1;
  double noise = 60;  // standard deviation, data units
};

// Tissue values (HU + 1024) before the texture and the noise.
namespace ct_tissue {
constexpr float kAir = 24;          // -1000 HU: outside, airways, sinuses, bowel gas
constexpr float kLung = 174;        // -850 HU: inflated lung parenchyma
constexpr float kFat = 924;         // -100 HU: subcutaneous fat, orbits, breasts
constexpr float kVisceral = 970;    // fat and bowel between the abdominal organs
constexpr float kFluid = 1030;      // CSF, urine, vitreous
constexpr float kSoft = 1050;       // brain, blood, bowel wall, lung vessels
constexpr float kMuscle = 1062;
constexpr float kSkin = 1070;
constexpr float kOrgan = 1080;      // liver, spleen, kidney cortex, uterus, intervertebral discs
constexpr float kCartilage = 1120;  // costal cartilage, trachea
constexpr float kCancellous = 1300; // marrow, diploë, vertebral bodies: below the bone threshold
constexpr float kCortical = 1850;   // compact bone
constexpr float kEnamel = 2600;     // teeth
// Calcifications are 1600-2400. A threshold between cancellous and cortical bone:
constexpr float kBoneThreshold = 1400;
}  // namespace ct_tissue

// The grid's spacing and the first voxel's centre (x, y, z, mm).
struct CtBodyGrid {
  std::array<double, 3> spacing, origin;
};
CtBodyGrid ct_body_grid(const CtBodyParams& params);

// Builds the volume in place (the voxels are written once, slices in parallel; the result does not
// depend on the thread count).
Volume make_ct_body_volume(const CtBodyParams& params);
// The same volume a slab of slices at a time: make(first, count, out) writes slices [first, first +
// count) into `out` (x fastest), exactly the voxels make_ct_body_volume writes there; what `penumbra
// convert` streams a ct-body larger than memory from. It keeps what slabs share (the anatomy, one
// slice's buffers per thread) while it lives.
class CtBodySlices {
public:
  explicit CtBodySlices(const CtBodyParams& params);
  ~CtBodySlices();
  CtBodySlices(const CtBodySlices&) = delete;
  CtBodySlices& operator=(const CtBodySlices&) = delete;
  void make(int first, int count, std::uint16_t* out);  // Error outside the volume's slices

private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace penumbra
