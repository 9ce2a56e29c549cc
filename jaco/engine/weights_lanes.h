// The roulette weights of one colony's moves (jaco.engine.weights.scaled_weights), XLA's float32
// log and exp reproduced operation for operation (weights_lanes.cc), built once per instruction
// set like the walk's lanes (walk_lanes.h); weights.cc runs the colonies of a call on XLA's threads
// with the set the dying-ant walk uses (jaco_isa_get).
#pragma once

#include <cstdint>

#include "walk_lanes.h"

struct WeightsColony {     // one colony's slices of the FFI buffers
  const float* tau;        // (N, 8) the pheromone of every move, or (N,) of every cell (cells)
  const int32_t* nbr;      // (N, 8) the cell each move enters, -1 where the map forbids it
  const float* factor;     // (N, 8) the log of the planner's factor (η^β: β·log η)
  float alpha;
  int64_t n_cells;
  bool cells;              // tau is per cell: a move's is that of the cell it enters
  bool fused;              // a·b + c as one fused multiply-add, where XLA's code has one (FMA CPUs)
  float* log_tau;          // (N,) scratch for the log of each cell's pheromone (cells)
  float* out;              // (N, 8) the weights
};

// And, for the tests, the log of max(x, tiny) and the exp of x (x in [-inf, 0]) of n floats.
#define JACO_DECLARE_WEIGHTS(isa)                                  \
  void move_weights_##isa(const WeightsColony& colony);            \
  void log_exp_##isa(const float* x, int64_t n, bool fused, float* log_out, float* exp_out);
JACO_ISA_LIST(JACO_DECLARE_WEIGHTS)
#undef JACO_DECLARE_WEIGHTS
