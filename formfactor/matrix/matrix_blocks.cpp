#include "formfactor/matrix/matrix_blocks.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <optional>

#include "core/error.h"
#include "core/hash.h"
#include "core/text.h"

namespace radlab {

std::string MatrixBlock::label() const {
  return "block " + std::to_string(index) + "/" + std::to_string(count) + " (rows " +
         std::to_string(first) + " to " + std::to_string(end - 1) + ")";
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

MatrixBlock matrix_block(size_t n, size_t index, size_t count) {
  if (count < 1) throw UsageError("blocks: the block count must be >= 1");
  if (index < 1 || index > count)
    throw UsageError("blocks: block " + std::to_string(index) + " is outside 1.." +
                     std::to_string(count));
  if (count > n)
    throw InputError("blocks: " + std::to_string(count) + " blocks of a matrix of " +
                     std::to_string(n) + " rows: a block would hold no rows (at most " +
                     std::to_string(n) + " blocks)");
  MatrixBlock block;
  block.index = index;
  block.count = count;
  // n index <= n^2 fits in 64 bits for any n below 2^32 (the cache allows 2^24).
  block.first = size_t(uint64_t(n) * (index - 1) / count);
  block.end = size_t(uint64_t(n) * index / count);
  return block;
}

CacheKey matrix_block_key(const CacheKey& matrix_key, const MatrixBlock& block) {
  CacheKey key;
  key.text = matrix_key.text + ";block=" + std::to_string(block.index) + "/" +
             std::to_string(block.count) + ";rows=" + std::to_string(block.first) + "-" +
             std::to_string(block.end);
  key.hash[0] = hash_bytes(key.text.data(), key.text.size(), 0xb10c0001);
  key.hash[1] = hash_bytes(key.text.data(), key.text.size(), 0xb10c0002);
  return key;
}

std::filesystem::path matrix_block_file(const MatrixCache& cache, const CacheKey& matrix_key,
                                        const MatrixBlock& block) {
  return cache.folder() / (matrix_key.hex() + ".block-" + std::to_string(block.index) + "-of-" +
                           std::to_string(block.count) + ".ffb");
}

void require_row_blocks(const FormFactorMethod& method, const std::string& method_name) {
  if (!method.builds_in_row_blocks())
    throw UsageError("form factors '" + method_name +
                     "': not built in blocks (it integrates each pair once for both rows; blocks "
                     "of rows would integrate every pair twice): build its matrix in one process");
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

std::filesystem::path build_matrix_block(const FormFactorMethod& method, const MatrixCache& cache,
                                         const CacheKey& matrix_key, size_t n,
                                         const MatrixBlock& block, BuildReport& report,
                                         const std::function<void(size_t, size_t)>& progress) {
  require_row_blocks(method, method.name());
  const FormFactorMatrix rows = build_matrix_rows(
      method, n, block.first, block.end, Precision::kDouble, Layout::kSparse, report, progress);
  if (const std::string bad = bad_entry(rows, block.first, block.end); !bad.empty())
    throw NumericalError("form factors '" + method.name() + "', " + block.label() +
                         ": a negative or non-finite entry (" + bad + "); the block is not stored");
  const std::filesystem::path file = matrix_block_file(cache, matrix_key, block);
  if (!cache.write(file, matrix_block_key(matrix_key, block), rows, report))
    throw InputError(file.string() + ": cannot write the block file (see the warning above)");
  method.save_side_files(file.string());
  report.cache_file = file.string();
  return file;
}

MergedMatrix merge_matrix_blocks(const FormFactorMethod& method, const MatrixCache& cache,
                                 const CacheKey& matrix_key, size_t n, size_t count) {
  require_row_blocks(method, method.name());
  std::vector<MatrixBlock> blocks;
  std::string missing;
  size_t missing_count = 0;
  for (size_t k = 1; k <= count; ++k) {
    blocks.push_back(matrix_block(n, k, count));
    const std::filesystem::path file = matrix_block_file(cache, matrix_key, blocks.back());
    std::error_code ec;
    if (!std::filesystem::exists(file, ec)) {
      missing += "\n  " + blocks.back().label() + ": " + file.string();
      ++missing_count;
    }
  }
  if (missing_count > 0)
    throw InputError("merge of " + std::to_string(count) + " blocks: " +
                     std::to_string(missing_count) + " missing (nothing written):" + missing);

  MergedMatrix merged;
  merged.matrix = FormFactorMatrix(n, Precision::kDouble, Layout::kSparse);
  const std::vector<FormFactorMethod::RowSideFile> side_files = method.row_side_files();
  for (const auto& side : side_files)
    merged.side_files.emplace_back(side.suffix, std::vector<float>(side.arrays * n, 0.0f));
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
    merged.report.cost += report.cost;
    merged.report.seconds += report.seconds;
    merged.report.threads = std::max(merged.report.threads, report.threads);
  }
  return merged;
}

bool store_merged_matrix(const MatrixCache& cache, const MatrixCacheKey& matrix_key,
                         const MergedMatrix& merged) {
  if (!cache.store(matrix_key, merged.matrix, merged.report)) return false;
  const std::filesystem::path file = cache.path(matrix_key);
  for (const auto& [suffix, values] : merged.side_files)
    write_matrix_side_file(file, suffix, values.data(), values.size() * sizeof(float));
  return true;
}

}  // namespace radlab
