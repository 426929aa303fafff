// off_reader.h -- a minimal OFF reader for the unit tests that must not depend on the mesh importers
// (the walk's and the voxelizer's): positions and fan-triangulated faces, nothing else; false on
// anything it cannot read. Header only.
#pragma once
#include <cstddef>
#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include "lsnif/import/mesh.h"

namespace lsnif::test {

inline bool read_off(const std::string& path, Mesh& mesh) {
  std::ifstream in(path);
  std::string magic;
  size_t nv = 0, nf = 0, ne = 0;
  if (!(in >> magic >> nv >> nf >> ne) || magic != "OFF") return false;
  mesh.positions.resize(nv);
  for (auto& p : mesh.positions)
    if (!(in >> p.x >> p.y >> p.z)) return false;
  for (size_t f = 0; f < nf; ++f) {
    size_t k = 0;
    if (!(in >> k) || k < 3) return false;
    std::vector<uint32_t> idx(k);
    for (auto& i : idx)
      if (!(in >> i)) return false;
    for (size_t i = 1; i + 1 < k; ++i) mesh.triangles.push_back({idx[0], idx[i], idx[i + 1]});
  }
  return true;
}

}  // namespace lsnif::test
