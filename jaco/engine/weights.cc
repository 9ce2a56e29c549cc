// The roulette weights of every move (jaco.engine.weights.scaled_weights) as an XLA FFI kernel for
// the CPU: the log of the pheromone, α·log τ + log f, each cell's largest, the exponential, in
// weights_lanes.cc (built once per instruction set); this file runs the colonies of a call on
// XLA's threads with the set the dying-ant walk uses.
//
// The call is vmapped with vmap_method="expand_dims": an argument that is the same for every
// colony (the map's neighbours, a planner's factor in a solve) keeps a leading dimension of 1 and
// is read by every colony, not copied once per colony.
#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

#include "weights_lanes.h"
#include "xla/ffi/api/ffi.h"

namespace ffi = xla::ffi;

extern "C" int jaco_isa_get();  // walk.cc: the instruction set in use, an index of JACO_ISA_LIST

namespace {

#include "kernel_threads.h"

struct WeightsKernel {
  void (*weights)(const WeightsColony&);
  void (*log_exp)(const float*, int64_t, bool, float*, float*);
};
#ifdef JACO_HAVE_AVX2
constexpr WeightsKernel kAvx2 = {move_weights_avx2, log_exp_avx2};
#else
constexpr WeightsKernel kAvx2 = {nullptr, nullptr};
#endif
#ifdef JACO_HAVE_AVX512
constexpr WeightsKernel kAvx512 = {move_weights_avx512, log_exp_avx512};
#else
constexpr WeightsKernel kAvx512 = {nullptr, nullptr};
#endif
const WeightsKernel kKernels[] = {{move_weights_baseline, log_exp_baseline}, kAvx2, kAvx512};  // JACO_ISA_LIST's order

const WeightsKernel& kernel() {
  const int i = jaco_isa_get();  // only a set that was built and that this CPU runs
  return i >= 0 && i < 3 && kKernels[i].weights ? kKernels[i] : kKernels[0];
}

// Where colony b's slice of an argument starts: its leading dimensions are the result's, or 1
// where the argument is the same for every colony along that dimension.
struct Slices {
  std::vector<int64_t> sizes, strides;  // per leading dimension: the result's size, the argument's stride
  int64_t at(int64_t b) const {
    int64_t offset = 0;
    for (size_t d = sizes.size(); d-- > 0;) {
      offset += (b % sizes[d]) * strides[d];
      b /= sizes[d];
    }
    return offset;
  }
};

ffi::Error slices(const ffi::AnyBuffer::Dimensions& dims, size_t trailing, const ffi::AnyBuffer::Dimensions& out,
                  Slices& s) {
  const size_t lead = out.size() - 2;
  if (dims.size() != lead + trailing) return ffi::Error::InvalidArgument("jaco_move_weights: leading dimensions differ");
  int64_t stride = 1;
  for (size_t d = lead; d < dims.size(); ++d) stride *= dims[d];
  s.sizes.assign(out.begin(), out.begin() + lead);
  s.strides.assign(lead, 0);
  for (size_t d = lead; d-- > 0;) {
    if (dims[d] != 1 && dims[d] != out[d]) return ffi::Error::InvalidArgument("jaco_move_weights: a batch dimension differs");
    s.strides[d] = dims[d] == 1 ? 0 : stride;
    stride *= dims[d];
  }
  return ffi::Error::Success();
}

ffi::Error MoveWeightsImpl(ffi::ThreadPool pool, ffi::Buffer<ffi::F32> tau, ffi::Buffer<ffi::S32> nbr,
                           ffi::Buffer<ffi::F32> alpha, ffi::Buffer<ffi::F32> factor,
                           ffi::ResultBuffer<ffi::F32> out, bool cells, bool fused) {
  const auto od = out->dimensions();
  const int64_t N = od[od.size() - 2], B = leading(od, 2);
  Slices s_tau, s_nbr, s_alpha, s_factor;
  for (auto err : {slices(tau.dimensions(), 1, od, s_tau), slices(nbr.dimensions(), 2, od, s_nbr),
                   slices(alpha.dimensions(), 0, od, s_alpha), slices(factor.dimensions(), 2, od, s_factor)})
    if (!err.success()) return err;
  const float *T0 = tau.typed_data(), *A0 = alpha.typed_data(), *F0 = factor.typed_data();
  const int32_t* G0 = nbr.typed_data();
  float* W0 = out->typed_data();
  const auto weights = kernel().weights;
  for_each_colony(pool, B, [=]() {
    return [=, log_tau = std::vector<float>(cells ? N : 0)](int64_t b) mutable {
      weights(WeightsColony{T0 + s_tau.at(b), G0 + s_nbr.at(b), F0 + s_factor.at(b), A0[s_alpha.at(b)], N, cells,
                            fused, log_tau.data(), W0 + b * N * 8});
    };
  });
  return ffi::Error::Success();
}

// ---- test entry point: the log and the exp alone -----------------------------------------------
ffi::Error LogExpImpl(ffi::Buffer<ffi::F32> x, ffi::ResultBuffer<ffi::F32> log_out, ffi::ResultBuffer<ffi::F32> exp_out,
                      bool fused) {
  kernel().log_exp(x.typed_data(), int64_t(x.element_count()), fused, log_out->typed_data(), exp_out->typed_data());
  return ffi::Error::Success();
}

}  // namespace

XLA_FFI_DEFINE_HANDLER_SYMBOL(JacoLogExp, LogExpImpl,
                              ffi::Ffi::Bind()
                                  .Arg<ffi::Buffer<ffi::F32>>()   // x
                                  .Ret<ffi::Buffer<ffi::F32>>()   // log(max(x, tiny))
                                  .Ret<ffi::Buffer<ffi::F32>>()   // exp(x), for x in [-inf, 0]
                                  .Attr<bool>("fused"));

XLA_FFI_DEFINE_HANDLER_SYMBOL(JacoMoveWeights, MoveWeightsImpl,
                              ffi::Ffi::Bind()
                                  .Ctx<ffi::ThreadPool>()
                                  .Arg<ffi::Buffer<ffi::F32>>()   // tau (..., 8N) on moves, (..., N) on cells
                                  .Arg<ffi::Buffer<ffi::S32>>()   // neighbours (..., N, 8), -1 where forbidden
                                  .Arg<ffi::Buffer<ffi::F32>>()   // alpha (...)
                                  .Arg<ffi::Buffer<ffi::F32>>()   // log of the factor (..., N, 8)
                                  .Ret<ffi::Buffer<ffi::F32>>()   // weights (..., N, 8)
                                  .Attr<bool>("cells")
                                  .Attr<bool>("fused"));
