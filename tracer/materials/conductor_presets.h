// Complex refractive indices η + ik of common metals at three wavelengths standing in for the RGB primaries:
// R = 650 nm, G = 550 nm, B = 450 nm (linear interpolation in wavelength between the tabulated points).
//
// Sources (room-temperature measured data, as tabulated by refractiveindex.info, files
// database/data-nk/main/<metal>/<author>.yml):
// - Gold, silver, copper: P. B. Johnson and R. W. Christy, "Optical constants of the noble metals",
//   Phys. Rev. B 6, 4370–4379 (1972), doi:10.1103/PhysRevB.6.4370.
// - Aluminium: A. D. Rakić, "Algorithm for the determination of intrinsic optical constants of metal films:
//   application to aluminum", Appl. Opt. 34, 4755–4767 (1995), doi:10.1364/AO.34.004755.
// Sampling a spectrum at three wavelengths is a crude colour model (pbrt-v4 renders these spectrally); it gives
// the right normal-incidence tints: F0 = gold (0.957, 0.792, 0.408), silver (0.990, 0.983, 0.980),
// copper (0.935, 0.624, 0.538), aluminium (0.906, 0.915, 0.922).
#pragma once
#include "materials/material.h"

namespace pt {

struct ConductorIor {
  Rgb eta, k;
};

inline ConductorIor conductor_preset(MetalPreset metal) {
  switch (metal) {
    case MetalPreset::Gold:  // J&C 1972
      return {Rgb(0.1556f, 0.4241f, 1.3831f), Rgb(3.6024f, 2.4721f, 1.9155f)};
    case MetalPreset::Silver:  // J&C 1972
      return {Rgb(0.0522f, 0.0596f, 0.0400f), Rgb(4.4094f, 3.5974f, 2.6484f)};
    case MetalPreset::Copper:  // J&C 1972
      return {Rgb(0.2378f, 1.0066f, 1.2404f), Rgb(3.6264f, 2.5823f, 2.3929f)};
    case MetalPreset::Aluminium:  // Rakić 1995
      return {Rgb(1.5580f, 1.0152f, 0.6332f), Rgb(7.7124f, 6.6273f, 5.4544f)};
    case MetalPreset::None:
      break;
  }
  return {Rgb(1.f), Rgb(0.f)};
}

}  // namespace pt
