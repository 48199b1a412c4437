// libFuzzer harness for fuzz::run_obj (fuzz/targets.h says what it reads and what counts as a
// finding). Seeds: fuzz/corpus/obj; run with scripts/fuzz.sh.
#include "fuzz/fuzz_support.h"
#include "fuzz/targets.h"

extern "C" int LLVMFuzzerInitialize(int* /*argc*/, char*** /*argv*/) {
  radlab::fuzz::set_fuzz_limits();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  radlab::fuzz::run_obj(data, size);
  return 0;
}
