// Linked into every test executable (tests/CMakeLists.txt): the suite writes its caches under the
// build folder (RADLAB_TEST_CACHE_DIR), never into the user's ~/.cache, unless RADLAB_CACHE_DIR
// is set already. Commands the tests run (radlab through run_command) inherit it.
#include <cstdlib>

namespace {

[[maybe_unused]] const int cache_folder_set = [] {
  return setenv("RADLAB_CACHE_DIR", RADLAB_TEST_CACHE_DIR, /*overwrite=*/0);
}();

}  // namespace
