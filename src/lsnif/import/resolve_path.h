// resolve_path.h -- the one policy for files that a scene or mesh file refers to (glTF buffer and
// image URIs, OBJ mtllib files, the LSNIF_neural_object models and the LSNIF_environment image of a
// scene): a reference is resolved against the folder of the file that contains it, and may not
// leave that folder (an absolute path, or a relative one whose `..` components climb out of it)
// unless the user allows it (`--allow-outside-refs`). The check is on the path as written
// (lexical): a symbolic link the user placed inside the folder is followed like any file there.
// Paths given on the command line are the user's own and are not subject to it.
#pragma once
#include <string>

#include "lsnif/format/status.h"

namespace lsnif {

// Resolves reference `ref`, written in a file whose folder is `base_dir` ("" = the working
// folder), into `out` (base_dir joined with ref, normalized). Errors: an empty reference or one
// with a NUL byte; without `allow_outside`, an absolute reference or one leaving base_dir. `what`
// names the reference in the message ("buffer 0 URI", "model"); messages name the reference and
// the folder, and the flag that allows it.
Status resolve_reference(const std::string& base_dir, const std::string& ref, bool allow_outside,
                         const std::string& what, std::string& out);

}  // namespace lsnif
