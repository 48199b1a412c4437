#include "core/interrupt.h"

#include <atomic>

namespace radlab {
namespace {

// Lock-free, so that storing to it from a signal handler is safe.
std::atomic<bool> g_requested{false};
static_assert(std::atomic<bool>::is_always_lock_free);

}  // namespace

void request_interrupt() noexcept {
  g_requested.store(true, std::memory_order_relaxed);
}

void clear_interrupt() noexcept {
  g_requested.store(false, std::memory_order_relaxed);
}

bool interrupt_requested() noexcept {
  return g_requested.load(std::memory_order_relaxed);
}

void throw_if_interrupted() {
  // A load first: called at every step of a run and from every thread of a matrix build, where
  // an exchange would write the shared flag's cache line each time.
  if (g_requested.load(std::memory_order_relaxed) &&
      g_requested.exchange(false, std::memory_order_relaxed))
    throw Interrupted();
}

}  // namespace radlab
