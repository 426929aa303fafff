// instance_transform.h -- the check every LSNIF instance transform passes (the plugin's
// lsnifMakeInstance, the renderer's triangle instances): a row-major 3x4 object-to-world matrix
// must be finite and invertible, because the intersection shader maps rays into object space.
#pragma once
#include "lsnif/format/status.h"

namespace lsnif {

// Ok when every entry of `m` is finite and |det(linear part)| > 1e-12 x the product of its row
// norms (a scale-free test: a uniform scale of 1e-5 passes, a rank-2 matrix does not); else an
// error naming the entry or the determinant.
Status check_instance_transform(const float m[3][4]);

}  // namespace lsnif
