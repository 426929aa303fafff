// convert_write.h -- the converter's last stage: OUT.gltf is the input glTF with
// LSNIF_neural_object on every converted node (docs/scene-format.md), the converted meshes' triangle
// data removed unless --keep-meshes, all remaining binary data compacted into OUT.bin; the .lsnif
// files (written by convert_train) lie beside it.
#pragma once
#include <string>
#include <vector>

#include "lsnif/apps/convert/convert_plan.h"
#include "lsnif/apps/convert/convert_train.h"

namespace lsnif::convert {

struct WriteReport {
  size_t converted_nodes = 0;   // nodes carrying the extension (group nodes counted once)
  size_t group_nodes = 0;       // nodes added for groups
  size_t meshes_removed = 0;    // glTF meshes no node uses any more (dropped)
  uint64_t buffer_bytes_in = 0, buffer_bytes_out = 0;
  std::vector<std::string> notes;  // what was dropped and why, one line each
};

// The output scene in memory, as write_output writes it; with `planned_as_trained`, the models not
// trained yet (Planned) count as made (the converter checks the scene before it trains).
Status build_output(const ConvertSettings& settings, const Plan& plan, const std::vector<ModelResult>& results,
                    bool planned_as_trained, tinygltf::Model& out, WriteReport& report);

// Writes settings.output (must end in .gltf) and OUT.bin beside it from the plan and the models
// that were trained or are up to date; failed models leave their nodes as they were, except that
// a mesh whose triangle data cannot be read (or copied) is left out (a note says so).
Status write_output(const ConvertSettings& settings, const Plan& plan,
                    const std::vector<ModelResult>& results, WriteReport& report);

}  // namespace lsnif::convert
