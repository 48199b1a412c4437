// Blocked builds of a form-factor matrix (issue 33, item 3): the rows split into B blocks, each
// computed by an independent process (a Snakemake job, a Slurm node) into a block file in the
// cache folder, then checked and merged into the ordinary cached matrix, the same bits as a
// one-process build.
//
// The unit is rows. Block K of B (1-based) holds rows [floor(n (K-1) / B), floor(n K / B)), so
// every row lies in exactly one block, and each row is computed as build_matrix computes it (the
// same code; raycast's visibility samples are seeded per pair), so every entry of the merged
// matrix has the bits of the one-process build, and each ordered pair is computed once, as there.
// A method that integrates each unordered pair once (exact's symmetric build) shares a pair's
// integral between two rows, which blocks of rows would compute twice: it is not built in blocks
// (FormFactorMethod::builds_in_row_blocks(); a usage error says so).
//
// Block file `<matrix key>.block-K-of-B.ffb`: the matrix cache's format (matrix_cache.h: header,
// key text, payload and header checksums), sparse, holding the block's rows (the others empty),
// under the block key: the matrix key's text followed by ";block=K/B;rows=FIRST-END". Its row side
// files (raycast's ".sigma", the hemicube's ".emitters") are saved beside it and bound to it as a
// matrix's are (write_matrix_side_file).
//
// The merge reads every block before it writes anything: every missing block is named; a block
// whose stored key is not this matrix's block K of B (another scene, mesh, method, code version
// or split) is refused naming the file and the key it holds; so is one that fails a checksum or
// a size, stores rows outside its range, or lacks an intact side file. The header of the merged
// file records the blocks' summed costs and build seconds (a one-process build shares raycast's
// visibility between the two rows of a pair within its process, so its ray count is smaller);
// the payload, key and side-file payloads are a one-process build's bits.
#pragma once

#include <cstddef>
#include <filesystem>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "formfactor/form_factor_method.h"
#include "formfactor/matrix/matrix.h"
#include "formfactor/matrix/matrix_cache.h"

namespace radlab {

struct MatrixBlock {
  size_t index = 0;  // 1-based
  size_t count = 0;
  size_t first = 0, end = 0;  // rows [first, end)
  // "block 3/7 (rows 10 to 14)"
  std::string label() const;
};

// "K/B" as given to `--block`: UsageError naming `option` unless two integers with B >= 1 and
// 1 <= K <= B.
std::pair<size_t, size_t> parse_block_option(const std::string& text, const std::string& option);

// Block `index` of `count` of an n-row matrix. UsageError when count < 1 or index is outside
// 1..count; InputError when count > n (a block would hold no rows).
MatrixBlock matrix_block(size_t n, size_t index, size_t count);

CacheKey matrix_block_key(const CacheKey& matrix_key, const MatrixBlock& block);
std::filesystem::path matrix_block_file(const MatrixCache& cache, const CacheKey& matrix_key,
                                        const MatrixBlock& block);

// UsageError naming the method when it cannot be built in blocks.
void require_row_blocks(const FormFactorMethod& method, const std::string& method_name);

// Computes the block's rows (in double), refuses negative or non-finite entries
// (NumericalError, nothing stored), stores the block file and its side files; returns the file.
std::filesystem::path build_matrix_block(
    const FormFactorMethod& method, const MatrixCache& cache, const CacheKey& matrix_key, size_t n,
    const MatrixBlock& block, BuildReport& report,
    const std::function<void(size_t done, size_t total)>& progress = {});

// The matrix assembled from `count` verified blocks, with the blocks' row side files merged.
struct MergedMatrix {
  FormFactorMatrix matrix;
  BuildReport report;  // costs and seconds summed over the blocks
  std::vector<std::pair<std::string, std::vector<float>>> side_files;  // suffix, payload
};
// Reads and verifies every block (InputError naming each missing block, or the block and file
// at fault and why) and assembles the matrix; writes nothing.
MergedMatrix merge_matrix_blocks(const FormFactorMethod& method, const MatrixCache& cache,
                                 const CacheKey& matrix_key, size_t n, size_t count);
// Stores the merged matrix under `matrix_key` and its side files beside it; false when the
// cache could not be written (a warning says why).
bool store_merged_matrix(const MatrixCache& cache, const MatrixCacheKey& matrix_key,
                         const MergedMatrix& merged);

}  // namespace radlab
