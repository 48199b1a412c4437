#include "formfactor/matrix/matrix_blocks.h"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <mutex>
#include <optional>
#include <stdexcept>

#include "core/error.h"
#include "core/hash.h"
#include "core/text.h"

namespace radlab {

namespace {

// The unordered pairs (a, b > a) with a < i, of an n-element matrix.
uint64_t pairs_before(size_t n, size_t i) {
  return uint64_t(i) * (n - 1) - uint64_t(i) * (i - std::min<size_t>(i, 1)) / 2;
}

// The cumulative work of rows [0, i): the split's, or the pair count.
uint64_t work_before(size_t n, size_t i, const PairWorkSplit* work) {
  return work ? work->cumulative[i] : pairs_before(n, i);
}

// The least row i whose work before it reaches (index - 1) / count of the total (128-bit
// products: n^2 count overflows 64 bits past n = 2^21).
size_t work_cut(size_t n, size_t index, size_t count, const PairWorkSplit* work) {
  __extension__ typedef unsigned __int128 Wide;
  const Wide target = Wide(work_before(n, n, work)) * (index - 1);
  size_t lo = 0, hi = n;  // the answer lies in [lo, hi]
  while (lo < hi) {
    const size_t mid = (lo + hi) / 2;
    if (Wide(work_before(n, mid, work)) * count >= target)
      hi = mid;
    else
      lo = mid + 1;
  }
  return lo;
}

// The first row of every pair block, in order, from the cuts c_K of the work: f_K =
// min(max over m <= K of c_m + K - m, n - 1 - (count - K)), so that the blocks start at
// strictly increasing rows (a row whose work spans several shares opens the next block one row
// later) and leave a row for every later block. Where the cuts already increase (pair counts
// with count <= n / 2 always do) f_K = c_K.
std::vector<size_t> first_pair_rows(size_t n, size_t count, const PairWorkSplit* work) {
  std::vector<size_t> first(count + 1, n);
  size_t running = 0;  // max over m <= K of c_m + K - m
  for (size_t k = 1; k <= count; ++k) {
    running =
        k == 1 ? work_cut(n, 1, count, work) : std::max(running + 1, work_cut(n, k, count, work));
    first[k - 1] = std::min(running, n - 1 - (count - k));
  }
  return first;  // first[count] = n: the end of the last block
}

// The block's share of the split's work and its estimated facing pairs.
void add_work(MatrixBlock& block, const PairWorkSplit& work) {
  block.work = work.cumulative[block.end] - work.cumulative[block.first];
  block.total_work = work.total();
  block.facing_pairs =
      work.cumulative_facing.empty()
          ? 0.0
          : double(work.cumulative_facing[block.end] - work.cumulative_facing[block.first]) *
                double(work.sample);
}

}  // namespace

size_t MatrixBlock::pairs() const {
  if (split == BlockSplit::kPairs) return size_t(pairs_before(n, end) - pairs_before(n, first));
  return (end - first) * n;
}

double MatrixBlock::entries() const {
  return split == BlockSplit::kPairs ? 2.0 * double(pairs()) : double(end - first) * double(n);
}

std::string MatrixBlock::label() const {
  return "block " + std::to_string(index) + "/" + std::to_string(count) +
         (split == BlockSplit::kPairs ? " (pairs of rows " : " (rows ") + std::to_string(first) +
         " to " + std::to_string(end - 1) + ")";
}

std::pair<size_t, size_t> parse_block_option(const std::string& text, const std::string& option) {
  const size_t slash = text.find('/');
  const std::optional<long long> index =
      slash == std::string::npos ? std::nullopt : text::parse_int(text.substr(0, slash));
  const std::optional<long long> count =
      slash == std::string::npos ? std::nullopt : text::parse_int(text.substr(slash + 1));
  if (!index || !count)
    throw UsageError(option + " " + text + ": expected K/B, block K of B (e.g. 3/8)");
  if (*count < 1) throw UsageError(option + " " + text + ": the block count B must be >= 1");
  if (*index < 1 || *index > *count)
    throw UsageError(option + " " + text + ": the block K must be in 1.." + std::to_string(*count));
  return {size_t(*index), size_t(*count)};
}

PairWorkSplit pair_work_split(const FormFactorMethod& method, size_t n) {
  PairWorkSplit split;
  FormFactorMethod::PairWork work = method.pair_work();
  split.cumulative.assign(n + 1, 0);
  if (work.row_weight.empty()) {
    for (size_t i = 0; i <= n; ++i) split.cumulative[i] = pairs_before(n, i);
    return split;
  }
  if (work.row_weight.size() != n || work.row_facing.size() != n)
    throw std::logic_error("pair_work of '" + method.name() + "': not one weight a row");
  split.cumulative_facing.assign(n + 1, 0);
  for (size_t i = 0; i < n; ++i) {
    split.cumulative[i + 1] = split.cumulative[i] + work.row_weight[i];
    split.cumulative_facing[i + 1] = split.cumulative_facing[i] + work.row_facing[i];
  }
  split.sample = std::max<uint32_t>(work.sample, 1);
  split.unit = work.unit;
  split.seconds_per_unit = work.seconds_per_unit;
  return split;
}

std::vector<MatrixBlock> matrix_blocks(size_t n, size_t count, BlockSplit split,
                                       const PairWorkSplit* work) {
  std::vector<MatrixBlock> blocks;
  if (split != BlockSplit::kPairs || count < 1 || count > n / 2) {
    for (size_t k = 1; k <= count; ++k) blocks.push_back(matrix_block(n, k, count, split, work));
    return blocks;
  }
  const MatrixBlock last = matrix_block(n, count, count, split, work);  // validates the arguments
  const std::vector<size_t> first = first_pair_rows(n, count, work);
  for (size_t k = 1; k <= count; ++k) {
    MatrixBlock block = last;
    block.index = k;
    block.first = first[k - 1];
    block.end = first[k];
    if (work) add_work(block, *work);
    blocks.push_back(block);
  }
  return blocks;
}

MatrixBlock matrix_block(size_t n, size_t index, size_t count, BlockSplit split,
                         const PairWorkSplit* work) {
  if (count < 1) throw UsageError("blocks: the block count must be >= 1");
  if (index < 1 || index > count)
    throw UsageError("blocks: block " + std::to_string(index) + " is outside 1.." +
                     std::to_string(count));
  const bool pairs = split == BlockSplit::kPairs;
  // Pairs: with count <= n / 2 every block's share of the n (n - 1) / 2 pairs is at least the
  // n - 1 of the longest row, so no two blocks start at the same row (matrix_blocks.h).
  const size_t most = pairs ? n / 2 : n;
  if (count > most)
    throw InputError("blocks: " + std::to_string(count) + " blocks of a matrix of " +
                     std::to_string(n) + " rows: a block would hold no " +
                     (pairs ? "pairs" : "rows") + " (at most " + std::to_string(most) + " blocks" +
                     (pairs ? " of pairs)" : ")"));
  MatrixBlock block;
  block.index = index;
  block.count = count;
  block.split = split;
  block.n = n;
  if (pairs) {
    if (work && work->cumulative.size() != n + 1)
      throw std::logic_error("matrix_block: a work split of another matrix");
    // Block `index` needs the cuts before it (first_pair_rows); O(count log n).
    const std::vector<size_t> first = first_pair_rows(n, count, work);
    block.first = first[index - 1];
    block.end = first[index];
    if (work) add_work(block, *work);
  } else {
    // n index <= n^2 fits in 64 bits for any n below 2^32 (the cache allows 2^24).
    block.first = size_t(uint64_t(n) * (index - 1) / count);
    block.end = size_t(uint64_t(n) * index / count);
  }
  return block;
}

BlockSplit block_split(const FormFactorMethod& method, const std::string& method_name) {
  if (method.builds_in_pair_blocks()) return BlockSplit::kPairs;
  if (method.builds_in_row_blocks()) return BlockSplit::kRows;
  throw UsageError("form factors '" + method_name +
                   "': not built in blocks (it integrates each pair once for both rows without "
                   "giving its pairs: blocks of rows would integrate every pair twice): build its "
                   "matrix in one process");
}

CacheKey matrix_block_key(const CacheKey& matrix_key, const MatrixBlock& block) {
  CacheKey key;
  // Format 2: blocks of pairs beside blocks of rows (format 1, unnamed, held rows only).
  key.text = matrix_key.text + ";block-format=2;block=" + std::to_string(block.index) + "/" +
             std::to_string(block.count) +
             (block.split == BlockSplit::kPairs ? ";pairs=" : ";rows=") +
             std::to_string(block.first) + "-" + std::to_string(block.end);
  key.hash[0] = hash_bytes(key.text.data(), key.text.size(), 0xb10c0001);
  key.hash[1] = hash_bytes(key.text.data(), key.text.size(), 0xb10c0002);
  return key;
}

std::filesystem::path matrix_block_file(const MatrixCache& cache, const CacheKey& matrix_key,
                                        const MatrixBlock& block) {
  return cache.folder() / (matrix_key.hex() + ".block-" + std::to_string(block.index) + "-of-" +
                           std::to_string(block.count) + ".ffb");
}

namespace {

// The first stored entry of rows [first, end) that is negative or not finite, as "row i, column
// j: value", or empty.
std::string bad_entry(const FormFactorMatrix& m, size_t first, size_t end) {
  for (size_t i = first; i < end; ++i) {
    std::string found;
    m.visit_row(i, [&](const auto* row) {
      for (size_t j = 0; j < m.size() && found.empty(); ++j)
        if (!(row[j] >= 0) || !std::isfinite(double(row[j])))
          found = "row " + std::to_string(i) + ", column " + std::to_string(j) + ": " +
                  std::to_string(double(row[j]));
    });
    if (!found.empty()) return found;
  }
  return {};
}

}  // namespace

namespace {

// The side file of a pair block: the method's share of each row's side values.
constexpr const char* kPairStateSuffix = ".pairstate";

// "row i, column j: value" of a negative or non-finite entry, or empty.
std::string bad_value(size_t i, size_t j, double value) {
  if (value >= 0 && std::isfinite(value)) return {};
  return "row " + std::to_string(i) + ", column " + std::to_string(j) + ": " +
         std::to_string(value);
}

// Block `block` of pairs: both entries of every pair (i, j > i), i in [first, end), where the
// matrix holds them (row i's columns above i; row j's columns [first, min(j, end))). Two passes,
// as build_matrix_symmetric: first each i's pairs (rows in parallel) into `upper` (row i: F_ij)
// and `lower` (row i: F_ji at column j), then every row of the block from them (rows in
// parallel, each task writing its own row). `bad` receives the first negative or non-finite
// entry by (i, j).
FormFactorMatrix build_pair_block(const FormFactorMethod& method, size_t n,
                                  const MatrixBlock& block, BuildReport& report, std::string& bad,
                                  const std::function<void(size_t, size_t)>& progress) {
  const auto start = std::chrono::steady_clock::now();
  FormFactorMatrix upper(n, Precision::kDouble, Layout::kSparse);
  FormFactorMatrix lower(n, Precision::kDouble, Layout::kSparse);
  tbb::combinable<RowCost> costs;
  std::mutex bad_mutex;
  size_t bad_row = n;
  const size_t rows = block.end - block.first;
  std::atomic<size_t> done{0};
  std::atomic<int> last_reported{-1};
  tbb::parallel_for(
      tbb::blocked_range<size_t>(block.first, block.end, 1),
      [&](const tbb::blocked_range<size_t>& r) {
        thread_local std::vector<double> up, down;
        up.assign(n, 0.0);
        down.assign(n, 0.0);
        for (size_t i = r.begin(); i != r.end(); ++i) {
          std::fill(up.begin() + std::ptrdiff_t(i), up.end(), 0.0);
          std::fill(down.begin() + std::ptrdiff_t(i), down.end(), 0.0);
          method.pair_entries(i, up, down, costs.local());
          for (size_t j = i + 1; j < n; ++j) {
            std::string found = bad_value(i, j, up[j]);
            if (found.empty()) found = bad_value(j, i, down[j]);
            if (found.empty()) continue;
            const std::lock_guard<std::mutex> lock(bad_mutex);
            if (i < bad_row) bad_row = i, bad = found;
            break;
          }
          upper.set_row(i, up);
          lower.set_row(i, down);
          const size_t now = ++done;
          // Report at most ~200 times; only one thread reports a given step.
          const int step = int(200 * now / std::max<size_t>(rows, 1));
          int seen = last_reported.load();
          if (progress && step > seen && last_reported.compare_exchange_strong(seen, step))
            progress(now, rows);
        }
      });
  FormFactorMatrix matrix(n, Precision::kDouble, Layout::kSparse);
  tbb::parallel_for(tbb::blocked_range<size_t>(block.first, n, 16),
                    [&](const tbb::blocked_range<size_t>& r) {
                      thread_local std::vector<double> row;
                      row.assign(n, 0.0);
                      for (size_t j = r.begin(); j != r.end(); ++j) {
                        const size_t hi = std::min(j, block.end);
                        for (size_t i = block.first; i < hi; ++i) row[i] = lower.at(i, j);
                        if (j < block.end)
                          upper.visit_row(j, [&](const auto* u) {
                            std::copy(u + j + 1, u + n, row.begin() + std::ptrdiff_t(j) + 1);
                          });
                        matrix.set_row(j, row);
                        std::fill(row.begin() + std::ptrdiff_t(block.first), row.end(), 0.0);
                      }
                    });
  report.cost = costs.combine([](RowCost x, const RowCost& y) { return x += y; });
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  report.threads =
      int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
  return matrix;
}

}  // namespace

std::filesystem::path build_matrix_block(const FormFactorMethod& method, const MatrixCache& cache,
                                         const CacheKey& matrix_key, size_t n,
                                         const MatrixBlock& block, BuildReport& report,
                                         const std::function<void(size_t, size_t)>& progress) {
  if (block.split != block_split(method, method.name()))
    throw std::logic_error("build_matrix_block: " + block.label() + " is not of the split of '" +
                           method.name() + "'");
  std::string bad;
  FormFactorMatrix entries;
  if (block.split == BlockSplit::kPairs) {
    entries = build_pair_block(method, n, block, report, bad, progress);
  } else {
    entries = build_matrix_rows(method, n, block.first, block.end, Precision::kDouble,
                                Layout::kSparse, report, progress);
    bad = bad_entry(entries, block.first, block.end);
  }
  if (!bad.empty())
    throw NumericalError("form factors '" + method.name() + "', " + block.label() +
                         ": a negative or non-finite entry (" + bad + "); the block is not stored");
  const std::filesystem::path file = matrix_block_file(cache, matrix_key, block);
  if (!cache.write(file, matrix_block_key(matrix_key, block), entries, report))
    throw InputError(file.string() + ": cannot write the block file (see the warning above)");
  if (block.split == BlockSplit::kPairs) {
    const std::vector<char> state = method.pair_block_state();
    if (!write_matrix_side_file(file, kPairStateSuffix, state.data(), state.size()))
      throw InputError(file.string() + kPairStateSuffix + ": cannot write the block's side file");
  } else {
    method.save_side_files(file.string());
  }
  report.cache_file = file.string();
  return file;
}

namespace {

// Appends `value` at column `column` (above every column appended so far) to `row`.
void append_entry(FormFactorMatrix::SparseRow& row, size_t column, double value) {
  const size_t runs = row.run.size() / 2;
  if (runs == 0 || row.run[2 * runs - 2] + (row.f64.size() - row.run[2 * runs - 1]) != column) {
    row.run.push_back(uint32_t(column));
    row.run.push_back(uint32_t(row.f64.size()));
  }
  row.f64.push_back(value);
}

// Calls fn(column, value) for every entry row r of `m` stores.
template <class Fn>
void each_stored(const FormFactorMatrix& m, size_t r, Fn&& fn) {
  const FormFactorMatrix::SparseRow& row = m.sparse_row(r);
  if (m.whole_row(r)) {
    for (size_t j = 0; j < row.f64.size(); ++j) fn(j, row.f64[j]);
    return;
  }
  for (size_t k = 0; k < row.run.size(); k += 2) {
    const size_t end = k + 2 < row.run.size() ? row.run[k + 3] : row.f64.size();
    for (size_t v = row.run[k + 1]; v < end; ++v) fn(row.run[k] + (v - row.run[k + 1]), row.f64[v]);
  }
}

}  // namespace

MergedMatrix merge_matrix_blocks(const FormFactorMethod& method, const MatrixCache& cache,
                                 const CacheKey& matrix_key, size_t n, size_t count,
                                 const PairWorkSplit* work) {
  const BlockSplit split = block_split(method, method.name());
  const bool pairs = split == BlockSplit::kPairs;
  std::optional<PairWorkSplit> computed;
  if (pairs && !work) work = &computed.emplace(pair_work_split(method, n));
  const std::vector<MatrixBlock> blocks = matrix_blocks(n, count, split, pairs ? work : nullptr);
  std::string missing;
  size_t missing_count = 0;
  for (const MatrixBlock& block : blocks) {
    const std::filesystem::path file = matrix_block_file(cache, matrix_key, block);
    std::error_code ec;
    if (!std::filesystem::exists(file, ec)) {
      missing += "\n  " + block.label() + ": " + file.string();
      ++missing_count;
    }
  }
  if (missing_count > 0)
    throw InputError("merge of " + std::to_string(count) + " blocks: " +
                     std::to_string(missing_count) + " missing (nothing written):" + missing);

  MergedMatrix merged;
  merged.matrix = FormFactorMatrix(n, Precision::kDouble, Layout::kSparse);
  merged.method_side_files = pairs;
  const std::vector<FormFactorMethod::RowSideFile> side_files =
      pairs ? std::vector<FormFactorMethod::RowSideFile>{} : method.row_side_files();
  for (const auto& side : side_files)
    merged.side_files.emplace_back(side.suffix, std::vector<float>(side.arrays * n, 0.0f));
  // Pair blocks: each row's entries gathered block by block (each block's columns of a row lie
  // above the previous blocks', so they append in order), then stored as a one-process build
  // stores the row.
  std::vector<FormFactorMatrix::SparseRow> gathered(pairs ? n : 0);
  std::vector<std::vector<char>> states;
  for (const MatrixBlock& block : blocks) {
    const std::filesystem::path file = matrix_block_file(cache, matrix_key, block);
    auto refuse = [&](const std::string& why) {
      return InputError(file.string() + ": " + block.label() + " of the matrix " +
                        matrix_key.hex() + ": " + why +
                        "; nothing written (delete the file and rebuild the block)");
    };
    BuildReport report;
    std::string why;
    const std::optional<FormFactorMatrix> rows =
        MatrixCache::read(file, matrix_block_key(matrix_key, block), &report, why);
    if (!rows) throw refuse(why.empty() ? "vanished or unreadable" : why);
    if (rows->size() != n || rows->precision() != Precision::kDouble || !rows->sparse())
      throw refuse("not a sparse double matrix of " + std::to_string(n) + " rows");
    if (pairs) {
      for (size_t r = 0; r < n; ++r) {
        // Row r's columns in this block: [first, min(r, end)), and above r when r is one of
        // the block's first elements.
        const size_t lower_end = std::min(r, block.end);
        const bool own_row = r >= block.first && r < block.end;
        std::string outside, bad;
        each_stored(*rows, r, [&](size_t j, double value) {
          const bool owned = (j >= block.first && j < lower_end) || (own_row && j > r);
          if (!owned) {
            if (value != 0.0 && outside.empty())
              outside = "row " + std::to_string(r) + ", column " + std::to_string(j);
            return;
          }
          if (bad.empty()) bad = bad_value(r, j, value);
          append_entry(gathered[r], j, value);
        });
        if (!outside.empty())
          throw refuse("it stores an entry outside its pairs (" + outside + ")");
        if (!bad.empty()) throw refuse("a negative or non-finite entry (" + bad + ")");
      }
      auto state = read_matrix_side_file(file, kPairStateSuffix, method.pair_block_state_bytes(n));
      if (!state)
        throw refuse("its side file " + file.string() + kPairStateSuffix +
                     " is missing, damaged or not this block's");
      states.push_back(std::move(*state));
    } else {
      for (size_t i = 0; i < n; ++i) {
        if (i >= block.first && i < block.end) continue;
        const FormFactorMatrix::SparseRow& row = rows->sparse_row(i);
        if (!row.run.empty() || !row.f64.empty())
          throw refuse("it stores row " + std::to_string(i) + ", outside its rows");
      }
      if (const std::string bad = bad_entry(*rows, block.first, block.end); !bad.empty())
        throw refuse("a negative or non-finite entry (" + bad + ")");
      for (size_t s = 0; s < side_files.size(); ++s) {
        const size_t arrays = side_files[s].arrays;
        const auto bytes =
            read_matrix_side_file(file, side_files[s].suffix, arrays * n * sizeof(float));
        if (!bytes)
          throw refuse("its side file " + file.string() + side_files[s].suffix +
                       " is missing, damaged or not this block's");
        std::vector<float> values(arrays * n);
        std::memcpy(values.data(), bytes->data(), bytes->size());
        std::vector<float>& out = merged.side_files[s].second;
        for (size_t a = 0; a < arrays; ++a)
          std::copy(values.begin() + std::ptrdiff_t(a * n + block.first),
                    values.begin() + std::ptrdiff_t(a * n + block.end),
                    out.begin() + std::ptrdiff_t(a * n + block.first));
      }
      for (size_t i = block.first; i < block.end; ++i)
        merged.matrix.set_sparse_row(i, rows->sparse_row(i));
    }
    merged.report.cost += report.cost;
    merged.report.seconds += report.seconds;
    merged.report.threads = std::max(merged.report.threads, report.threads);
  }
  if (pairs) {
    if (!method.restore_pair_block_states(states))
      throw InputError("merge of " + std::to_string(count) + " blocks of the matrix " +
                       matrix_key.hex() + ": their side files (" + kPairStateSuffix +
                       ") hold values form factors '" + method.name() +
                       "' never write; nothing written");
    // Each row as a one-process build stores it: from its n values (set_row).
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 16),
                      [&](const tbb::blocked_range<size_t>& r) {
                        thread_local std::vector<double> row;
                        row.assign(n, 0.0);
                        for (size_t i = r.begin(); i != r.end(); ++i) {
                          FormFactorMatrix::SparseRow& g = gathered[i];
                          for (size_t k = 0; k < g.run.size(); k += 2) {
                            const size_t end = k + 2 < g.run.size() ? g.run[k + 3] : g.f64.size();
                            std::copy(g.f64.begin() + std::ptrdiff_t(g.run[k + 1]),
                                      g.f64.begin() + std::ptrdiff_t(end),
                                      row.begin() + std::ptrdiff_t(g.run[k]));
                          }
                          merged.matrix.set_row(i, row);
                          std::fill(row.begin(), row.end(), 0.0);
                          g = FormFactorMatrix::SparseRow();  // freed as the merged rows grow
                        }
                      });
  }
  return merged;
}

bool store_merged_matrix(const FormFactorMethod& method, const MatrixCache& cache,
                         const MatrixCacheKey& matrix_key, const MergedMatrix& merged) {
  if (!cache.store(matrix_key, merged.matrix, merged.report)) return false;
  const std::filesystem::path file = cache.path(matrix_key);
  if (merged.method_side_files) method.save_side_files(file.string());
  for (const auto& [suffix, values] : merged.side_files)
    write_matrix_side_file(file, suffix, values.data(), values.size() * sizeof(float));
  return true;
}

}  // namespace radlab
