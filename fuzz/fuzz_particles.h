// The particle readers (PDB, mmCIF, GRO, XYZ) through load_particles: the deposited coordinates, then
// biological assembly 1 (coloured by B-factor, hydrogens dropped) with the sphere count capped so that
// a large but legal assembly does not exhaust the fuzzer's memory.
#pragma once

#include "fuzz_common.h"
#include "penumbra/data/io/particle_io.h"

namespace penumbra::fuzz {

inline int fuzz_particles(const char* name, const std::uint8_t* data, std::size_t size) {
  const bool gz = size >= 2 && data[0] == 0x1f && data[1] == 0x8b;
  const std::string path = write_input(std::string(name) + (gz ? ".gz" : ""), data, size);
  bool loaded = false;
  expect_error_or_result([&] {
    ParticleFileInfo info;
    (void)load_particles(path, ParticleLoadOptions{}, &info);
    loaded = true;
  });
  if (!loaded) return 0;
  expect_error_or_result([&] {
    ParticleLoadOptions o;
    o.assembly = 1;
    o.coloring = ParticleColoring::Scalar;
    o.hydrogens = false;
    o.max_spheres = 1u << 20;
    (void)load_particles(path, o);
  });
  return 0;
}

}  // namespace penumbra::fuzz
