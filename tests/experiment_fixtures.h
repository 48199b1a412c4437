// Experiment files and CSV helpers shared by the sweep tests (tests/experiments/sweep/,
// tests/workflow/): one definition, so a change of the format changes them
// together.
#pragma once

#include <algorithm>
#include <string>
#include <vector>

#include "core/csv_reader.h"

namespace radlab::testing {

// The table's rows without the named columns (e.g. the ones that measure time), for comparing
// two runs that must agree in everything else.
inline std::vector<std::vector<std::string>> without_columns(
    const CsvTable& table, const std::vector<std::string>& columns) {
  std::vector<size_t> keep;
  for (size_t k = 0; k < table.header.size(); ++k)
    if (std::find(columns.begin(), columns.end(), table.header[k]) == columns.end())
      keep.push_back(k);
  std::vector<std::vector<std::string>> out;
  for (const auto& row : table.rows) {
    std::vector<std::string> kept;
    for (size_t k : keep) kept.push_back(row[k]);
    out.push_back(kept);
  }
  return out;
}

// Two gauss-seidel runs (omega 1 and 1.3) on a small cube, 200 rows each.
inline constexpr const char* kTwoRuns = R"(name = "tiny"
scenes = ["builtin:cube:rho=0.8"]
subdiv = 2
solvers = ["gauss-seidel"]
[form_factors]
rays = 4
[budget]
rows = 200
[parameters.gauss-seidel]
omega = [1.0, 1.3]
)";

// A closed unit box read from an OBJ and its material library (box.mtl): five white walls
// (Kd 0.5) facing in, and a ceiling that emits (Ke 1). The sweep tests edit the Kd to check that a
// sweep's identity covers the files a scene reads.
inline constexpr const char* kBoxObj = R"(mtllib box.mtl
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
v 0 0 1
v 1 0 1
v 1 1 1
v 0 1 1
usemtl white
f 1 5 6 2
f 1 4 8 5
f 2 6 7 3
f 1 2 3 4
f 5 8 7 6
usemtl light
f 4 3 7 8
)";
inline constexpr const char* kBoxMtl = R"(newmtl white
Kd 0.5 0.5 0.5
newmtl light
Kd 0 0 0
Ke 1 1 1
)";

}  // namespace radlab::testing
