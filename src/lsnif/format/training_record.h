// training_record.h -- the check a loaded model's training record gets against its header. The
// record (src/lsnif/train/settings_io.h: {"settings": {...}, "mesh": {...}, "threads": N}) is text a
// tool or a person can edit; a model must not carry settings its header contradicts (`lsnif info`
// shows them and `lsnif info --settings` hands them to `lsnif train --config`).
#pragma once
#include <string_view>

#include "lsnif/format/config.h"
#include "lsnif/format/status.h"

namespace lsnif {

// Deepest nesting of arrays and objects a training record may have (the writer's has 3 levels).
inline constexpr int kMaxTrainingRecordDepth = 16;

// Checks the training record `record` of a model whose header holds `header` (parse_model_file calls
// it for every file with a record; an empty record passes). The record must be a JSON object; its
// "settings", when present, an object whose settings of settings_table.h each have a value of their
// kind within their declared range, and whose model settings agree with the header: voxels, points,
// levels, res-min, res-max, table-log2 (of the hashed levels), features, width, layers, hit,
// leaky-slope, grid-bits, indexed, and surface-maps "on" / "off" (surface channels or none). Only
// the settings the record holds are checked (records written by earlier versions lack the newer
// settings); keys the table does not know (a newer writer's) are left alone. Errors name the
// setting and both values ("training record: voxels is 16, the header's voxel resolution is 32").
Status check_training_record(std::string_view record, const Config& header);

}  // namespace lsnif
