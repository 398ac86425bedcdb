// The photon maps as PLY point clouds (position, flux) for MeshLab or ParaView.
#pragma once

#include <string>

#include "spm/propagate.h"

namespace spm {

// Writes PREFIX_volume.ply and PREFIX_surface.ply (binary little-endian):
// float x, y, z, float flux_r, flux_g, flux_b, and uchar red, green, blue
// (flux scaled by the map's largest mean flux, for viewers that show colour).
void write_maps_ply(const std::string& prefix, const PhotonMaps& maps);

}  // namespace spm
