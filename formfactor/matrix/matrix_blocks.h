// Blocked builds of a form-factor matrix (issue 33, item 3): the matrix split into B blocks, each
// computed by an independent process (a Snakemake job, a Slurm node) into a block file in the
// cache folder, then checked and merged into the ordinary cached matrix, the same bits as a
// one-process build.
//
// Two splits, chosen by the method (FormFactorMethod::builds_in_pair_blocks / _row_blocks):
//   pairs  (raycast, exact: a pair's F_ij and F_ji share its visibility, quadrature or integral)
//          block K of B holds the unordered pairs (i, j > i) with i in [first, end), and stores
//          both entries of each; each pair is computed once over all blocks, as in one process
//          (the blocks' rays add up to a one-process build's). The rows are chosen so that the
//          blocks hold equal shares of the pairs' estimated work (PairWorkSplit): block K starts
//          at the first row whose rows before it hold at least K - 1 B-ths of the total work, so
//          each block's work lies within one row's work of total / B. The work is the method's
//          estimate (FormFactorMethod::pair_work: raycast's rays from a sample of each row's
//          pairs; equal pairs are not equal work, soda.mgf's first block of 64 by pair counts
//          took 10x its middle one: docs/workflow.md), else each row's pair count (equal pairs).
//          Every block, the merge and the plan compute the same estimate from the scene and cut
//          the same rows; the block key records them, so a block of another cut is refused by
//          name. At most n / 2 blocks; where one row's work spans several shares the later
//          blocks start a row apart, so no block is empty.
//   rows   (the hemicube: a row is one z-buffer) block K of B holds rows
//          [floor(n (K-1) / B), floor(n K / B)); at most n blocks. A row's cost does not depend
//          on its index, so equal rows are equal work.
// Every entry is computed by the method's own code from the same inputs (raycast's visibility
// samples are seeded per pair), so every entry of the merged matrix has the one-process bits.
//
// Block file `<matrix key>.block-K-of-B.ffb`: the matrix cache's format (matrix_cache.h: header,
// key text, payload and header checksums), sparse, holding the block's entries where the matrix
// holds them (the others empty), under the block key: the matrix key's text followed by
// ";block-format=2;block=K/B;pairs=FIRST-END" (or ";rows=FIRST-END"). Beside it, bound to it as a
// matrix's side files are (write_matrix_side_file): a pair block's ".pairstate" (the method's
// share of each row's side values, pair_block_state) or a row block's row side files (the
// hemicube's ".emitters").
//
// The merge reads every block before it writes anything: every missing block is named; a block
// whose stored key is not this matrix's block K of B (another scene, mesh, method, code version,
// split, or block format: blocks written before format 2 were of rows) is refused naming the
// file and the key it holds; so is one that fails a checksum or a size, stores an entry outside
// its pairs or rows, or lacks an intact side file. The header of the merged file records the
// blocks' summed costs and build seconds (the rays and pair counts of a one-process build; for
// raycast fewer kernel evaluations, each pair's quadrature once instead of once per row); the
// payload, key and side-file payloads are a one-process build's bits.
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

enum class BlockSplit { kRows, kPairs };

struct MatrixBlock {
  size_t index = 0;  // 1-based
  size_t count = 0;
  BlockSplit split = BlockSplit::kRows;
  size_t first = 0, end = 0;  // rows [first, end): the rows, or the pairs' first elements
  size_t n = 0;
  // Blocks of pairs cut by a PairWorkSplit: the block's share of its work and its estimated
  // facing pairs (those that can hold an entry: the sampled ones times the sample), else 0.
  uint64_t work = 0, total_work = 0;
  double facing_pairs = 0;
  // Unordered pairs held (kPairs), or the rows' entries (kRows: (end - first) n).
  size_t pairs() const;
  // Entries computed: 2 pairs() or (end - first) n.
  double entries() const;
  // "block 3/7 (rows 10 to 14)", "block 3/7 (pairs of rows 10 to 14)"
  std::string label() const;
};

// "K/B" as given to `--block`: UsageError naming `option` unless two integers with B >= 1 and
// 1 <= K <= B.
std::pair<size_t, size_t> parse_block_option(const std::string& text, const std::string& option);

// The work a split of pairs divides, row by row: cumulative[i] the estimated work of the pairs
// of rows [0, i) (n + 1 values; cumulative[n] the total), from the method's pair_work, or the
// pair counts when it gives none (`unit` empty). Also the sampled facing pairs, cumulated.
struct PairWorkSplit {
  std::vector<uint64_t> cumulative;
  std::vector<uint64_t> cumulative_facing;  // empty without an estimate
  uint32_t sample = 1;
  std::string unit;
  double seconds_per_unit = 0.0;
  uint64_t total() const { return cumulative.empty() ? 0 : cumulative.back(); }
};
// Calls method.pair_work() (deterministic; seconds at soda.mgf) and cumulates it.
PairWorkSplit pair_work_split(const FormFactorMethod& method, size_t n);

// Block `index` of `count` of an n-row matrix. UsageError when count < 1 or index is outside
// 1..count; InputError when count is above n (rows) or n / 2 (pairs): a block would be empty.
// Blocks of pairs are cut by `work` (PairWorkSplit of this n), or by pair counts without it.
MatrixBlock matrix_block(size_t n, size_t index, size_t count, BlockSplit split = BlockSplit::kRows,
                         const PairWorkSplit* work = nullptr);
// Every block of the split, in order (one pass: for the merge and the plan).
std::vector<MatrixBlock> matrix_blocks(size_t n, size_t count, BlockSplit split,
                                       const PairWorkSplit* work = nullptr);

// The method's split; UsageError naming the method when it is not built in blocks.
BlockSplit block_split(const FormFactorMethod& method, const std::string& method_name);

CacheKey matrix_block_key(const CacheKey& matrix_key, const MatrixBlock& block);
std::filesystem::path matrix_block_file(const MatrixCache& cache, const CacheKey& matrix_key,
                                        const MatrixBlock& block);

// Computes the block's entries (in double), refuses negative or non-finite entries
// (NumericalError, nothing stored), stores the block file and its side files; returns the file.
// `progress` counts rows (pair blocks: the rows of their first elements).
std::filesystem::path build_matrix_block(
    const FormFactorMethod& method, const MatrixCache& cache, const CacheKey& matrix_key, size_t n,
    const MatrixBlock& block, BuildReport& report,
    const std::function<void(size_t done, size_t total)>& progress = {});

// The matrix assembled from `count` verified blocks, with the blocks' row side files merged (row
// blocks) or the method's side state restored from the blocks' (pair blocks).
struct MergedMatrix {
  FormFactorMatrix matrix;
  BuildReport report;  // costs and seconds summed over the blocks
  std::vector<std::pair<std::string, std::vector<float>>> side_files;  // suffix, payload
  bool method_side_files = false;  // the method's save_side_files writes them (pair blocks)
};
// Reads and verifies every block (InputError naming each missing block, or the block and file
// at fault and why) and assembles the matrix; writes nothing. Pair blocks: restores the
// method's side state (restore_pair_block_states); they are cut by `work` (computed from the
// method when null, as every block computes it).
MergedMatrix merge_matrix_blocks(const FormFactorMethod& method, const MatrixCache& cache,
                                 const CacheKey& matrix_key, size_t n, size_t count,
                                 const PairWorkSplit* work = nullptr);
// Stores the merged matrix under `matrix_key` and its side files beside it; false when the
// cache could not be written (a warning says why).
bool store_merged_matrix(const FormFactorMethod& method, const MatrixCache& cache,
                         const MatrixCacheKey& matrix_key, const MergedMatrix& merged);

}  // namespace radlab
