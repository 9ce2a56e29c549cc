// What every kernel of jaco shares: XLA's FFI, and running the colonies of one call (its leading,
// batch dimensions) on XLA's intra-op threads. Included inside each kernel's anonymous namespace,
// as walk_shared.h is, so no kernel's code is shared with another object compiled with other flags.

// ---- running colonies on the intra-op threads ------------------------------------------------
// Colonies are taken in turn by the calling thread and the pool's threads. State is shared
// through a shared_ptr so that a task that starts after all colonies are done finds nothing to do.
template <typename PerThread>
void for_each_colony(ffi::ThreadPool& pool, int64_t n_colonies, PerThread make_worker) {
  const int64_t n_threads = std::min<int64_t>(std::max<int64_t>(pool.num_threads(), 1), n_colonies);
  if (n_threads <= 1) {
    auto worker = make_worker();
    for (int64_t b = 0; b < n_colonies; ++b) worker(b);
    return;
  }
  struct Shared {
    std::atomic<int64_t> next{0}, done{0};
    std::mutex m;
    std::condition_variable cv;
  };
  auto sh = std::make_shared<Shared>();
  auto task = [sh, n_colonies, make_worker]() {
    auto worker = make_worker();
    int64_t mine = 0;
    for (int64_t b; (b = sh->next.fetch_add(1)) < n_colonies; ++mine) worker(b);
    if (mine && sh->done.fetch_add(mine) + mine == n_colonies) {
      std::lock_guard<std::mutex> lock(sh->m);
      sh->cv.notify_all();
    }
  };
  for (int64_t i = 1; i < n_threads; ++i) {
    auto copy = task;
    pool.Schedule(std::move(copy));
  }
  task();
  std::unique_lock<std::mutex> lock(sh->m);
  sh->cv.wait(lock, [&] { return sh->done.load() == n_colonies; });
}

// The number of colonies: the product of the dimensions before the trailing ones.
inline int64_t leading(const ffi::AnyBuffer::Dimensions& dims, int trailing) {
  int64_t n = 1;
  for (size_t i = 0; i + trailing < dims.size(); ++i) n *= dims[i];
  return n;
}
