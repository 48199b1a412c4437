// Paths confined to a folder: MGF includes, OBJ material libraries and plugin folders may only
// name files inside the folder they are allowed to read (docs/reliability.md).
#pragma once

#include <filesystem>

namespace radlab {

// True when `path` lies inside `root`, both canonical (std::filesystem::weakly_canonical), so
// that ".." and links are resolved before the comparison.
bool path_within(const std::filesystem::path& path, const std::filesystem::path& root);

}  // namespace radlab
