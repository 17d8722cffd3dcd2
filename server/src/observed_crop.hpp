#pragma once
// Crops an observed octree to one tile for download: a tile's observed area is the merge of
// its sessions' octrees, which cover whole drives; the .bt of tile t must describe tile t only.
#include <string>

namespace mapdelta::server {

// octree_bt: an OctoMap binary stream (ObservedArea::SerializeBinary). Returns one with
// exactly the voxels whose cube overlaps min_x < x < max_x, min_y < y < max_y (any z), each
// with its occupancy, so a query inside the box answers as in the input and every voxel of
// the output touches the box. Throws Error(kParse) if the input is not an octree.
std::string CropOctreeXY(const std::string& octree_bt, double min_x, double min_y, double max_x,
                         double max_y);

}  // namespace mapdelta::server
