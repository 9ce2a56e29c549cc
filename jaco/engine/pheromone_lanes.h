// The pheromone's copy into the deposit's result (pheromone_lanes.cc), built once per instruction
// set like the walk's lanes (walk_lanes.h); pheromone.cc calls it with the set the walk uses
// (jaco_isa_get).
#pragma once

#include <cstdint>

#include "walk_lanes.h"

// dst[i] = src[i] for i < M; true when no src[i] is -0.0 or a NaN (an add of +0.0 then changes nothing).
#define JACO_DECLARE_COPY(isa) bool copy_and_check_zero_adds_##isa(const float* src, float* dst, int64_t M);
JACO_ISA_LIST(JACO_DECLARE_COPY)
#undef JACO_DECLARE_COPY
