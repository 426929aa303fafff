// lsnif_model.glsl -- device access to one packed LSNIF model (layout: src/lsnif/host_device.h,
// packer: src/lsnif/plugin/gpu_model.cpp). A model is addressed by its buffer device address; its header is
// read once per ray into LsnifModel, every other access is a 32-bit word load.
// Needs (declared here, so include this file before any declaration): GL_EXT_buffer_reference,
// GL_EXT_shader_explicit_arithmetic_types_int64 (device features bufferDeviceAddress, shaderInt64).
#ifndef LSNIF_MODEL_GLSL
#define LSNIF_MODEL_GLSL

#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

#include "lsnif/host_device.h"

layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer LsnifHeaderRef {
  LsnifGpuModelHeader header;
};
layout(buffer_reference, std430, buffer_reference_align = 4) readonly buffer LsnifWordsRef {
  uint w[];
};
layout(buffer_reference, std430, buffer_reference_align = 32) readonly buffer LsnifOctsRef {
  u64vec4 o[];
};

struct LsnifModel {
  LsnifGpuModelHeader h;
  LsnifWordsRef words;  // the whole block; header.*_offset index into it
  LsnifOctsRef octs;    // the same block in 32-byte units (oct i = words 8i .. 8i + 7)
};

// True when the block at `address` starts with this layout's magic and version (host_device.h);
// anything else must not be read as a model.
bool lsnif_model_layout_matches(uint64_t address) {
  LsnifWordsRef w = LsnifWordsRef(address);
  return w.w[0] == LSNIF_GPU_MAGIC && w.w[1] == LSNIF_GPU_VERSION;
}

// The model packed at device address `address` (32-byte aligned).
LsnifModel lsnif_load_model(uint64_t address) {
  LsnifModel m;
  m.h = LsnifHeaderRef(address).header;
  m.words = LsnifWordsRef(address);
  m.octs = LsnifOctsRef(address);
  return m;
}

// The 8 words of oct `i` as two uvec4 (words 0-3, words 4-7).
void lsnif_load_oct(LsnifModel m, uint i, out uvec4 lo, out uvec4 hi) {
  const u64vec4 v = m.octs.o[i];
  lo = uvec4(unpack32(v.x), unpack32(v.y));
  hi = uvec4(unpack32(v.z), unpack32(v.w));
}

// VoxelGrid::occupied: false outside [0, V)^3.
bool lsnif_occupied(LsnifModel m, int i, int j, int k) {
  const int V = int(m.h.voxel_resolution);
  if (i < 0 || j < 0 || k < 0 || i >= V || j >= V || k >= V) return false;
  const uint idx = uint(i) + m.h.voxel_resolution * (uint(j) + m.h.voxel_resolution * uint(k));
  return ((m.words.w[m.h.voxel_offset + (idx >> 5)] >> (idx & 31u)) & 1u) != 0u;
}

// Element e of an fp16 array packed two per word starting at word `base`.
float lsnif_half(LsnifModel m, uint base, uint e) {
  const vec2 pair = unpackHalf2x16(m.words.w[base + (e >> 1)]);
  return (e & 1u) != 0u ? pair.y : pair.x;
}

// Config::grid_resolution[level].
uint lsnif_grid_resolution(LsnifModel m, uint level) {
  return level == 0u ? m.h.grid_resolution0
       : level == 1u ? m.h.grid_resolution1
       : level == 2u ? m.h.grid_resolution2
                     : m.h.grid_resolution3;
}

// Config::index_slots[level] and index_buckets[level] (0: a hashed level).
uint lsnif_index_slots(LsnifModel m, uint level) {
  return level == 0u ? m.h.index_slots0
       : level == 1u ? m.h.index_slots1
       : level == 2u ? m.h.index_slots2
                     : m.h.index_slots3;
}
uint lsnif_index_buckets(LsnifModel m, uint level) {
  return level == 0u ? m.h.index_buckets0
       : level == 1u ? m.h.index_buckets1
       : level == 2u ? m.h.index_buckets2
                     : m.h.index_buckets3;
}

// Hash-grid element e (hash_grid.h order) of level `level`: fp16, or an int8 code times the
// level's scale (grid_bits 8), exactly Model::grid[e] on the CPU.
float lsnif_grid_value(LsnifModel m, uint level, uint e) {
  if (m.h.grid_bits == 16u) return lsnif_half(m, m.h.grid_offset, e);
  const int code = bitfieldExtract(int(m.words.w[m.h.grid_offset + (e >> 2)]), int((e & 3u) * 8u), 8);
  const float scale = level == 0u ? m.h.grid_scale0
                    : level == 1u ? m.h.grid_scale1
                    : level == 2u ? m.h.grid_scale2
                                  : m.h.grid_scale3;
  return float(code) * scale;
}

uint lsnif_input_dim(LsnifModel m) { return m.h.max_points * m.h.grid_levels * m.h.features; }
// Config::output_dim: the fixed outputs, the material logits and, for a model with surface channels,
// LSNIF_OUT_SURFACE_COUNT more (starting at lsnif_surface_output).
uint lsnif_output_dim(LsnifModel m) {
  return LSNIF_OUT_FIXED + m.h.material_count + (m.h.surface_channels != 0u ? LSNIF_OUT_SURFACE_COUNT : 0u);
}
// Config::surface_output: where the surface channels start (LSNIF_OUT_SURFACE_* are offsets from here).
uint lsnif_surface_output(LsnifModel m) { return LSNIF_OUT_MATERIAL + m.h.material_count; }

// Config::reports_uv: hits of `material` report the texture coordinate (the model's uv cells).
bool lsnif_reports_uv(LsnifModel m, uint material) {
  const uint word = material < 32u ? m.h.uv_materials_lo : m.h.uv_materials_hi;
  return material < 64u && ((word >> (material & 31u)) & 1u) != 0u;
}

vec3 lsnif_bounds_lo(LsnifModel m) { return vec3(m.h.bounds_lo_x, m.h.bounds_lo_y, m.h.bounds_lo_z); }
vec3 lsnif_bounds_hi(LsnifModel m) { return vec3(m.h.bounds_hi_x, m.h.bounds_hi_y, m.h.bounds_hi_z); }

// Object units of LSNIF_LEAVING_TMIN_VOXELS voxel edges of the model (host_device.h).
float lsnif_leaving_distance(LsnifModel m) {
  return float(LSNIF_LEAVING_TMIN_VOXELS) * length(lsnif_bounds_hi(m) - lsnif_bounds_lo(m)) /
         (float(m.h.voxel_resolution) * sqrt(3.0));
}

#endif
