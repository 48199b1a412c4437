// What `radlab --version` prints and run.json records about the build: radlab's version (from
// project() in CMakeLists.txt, generated as core/version.h), the git revision, the compiler,
// and the version of every library radlab was compiled against (their headers' version macros; TBB
// also at run time).
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace radlab {

// (library, version) pairs in a fixed order.
std::vector<std::pair<std::string, std::string>> dependency_versions();

// "radlab 0.1.0 (git abc123...)" and a line per dependency.
std::string version_text();

}  // namespace radlab
