// Blocks of pairs of equal estimated work (formfactor/matrix/matrix_blocks.h, PairWorkSplit;
// FormFactorMethod::pair_work): the estimate is the same whatever the thread count (every block,
// the merge and the plan compute it anew and must cut the same rows), each block's work lies
// within one row's work of total / B (a boundary moves by whole rows), a row heavier than a
// share never leaves a block empty, a method without an estimate is split by pair counts, and a
// block cut by other weights is refused by the merge, naming it.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "core/error.h"
#include "formfactor/matrix/matrix_blocks.h"
#include "formfactor/methods/exact.h"
#include "formfactor/methods/raycast.h"
#include "scene/mesh.h"
#include "scene/scene_loader.h"
#include "tests/test_support.h"

namespace radlab {
namespace {

namespace fs = std::filesystem;

// The Cornell box at subdiv 4 (320 elements): its boxes occlude, so raycast's pairs cost 16 to
// 4,096 rays by their form factors (rays_for) and its rows' work differs by far more than their
// pair counts do.
struct Cornell {
  LoadedScene loaded = load_scene("builtin:cornell", false);
  Mesh mesh;
  explicit Cornell(int subdivisions) : mesh(build_mesh(loaded.scene, {subdivisions, 0.0})) {}
};

uint64_t largest_row(const PairWorkSplit& work) {
  uint64_t most = 0;
  for (size_t i = 0; i + 1 < work.cumulative.size(); ++i)
    most = std::max(most, work.cumulative[i + 1] - work.cumulative[i]);
  return most;
}

TEST(PairWorkSplit, TheSameBitsForAnyThreadCount) {
  const Cornell cornell(4);
  const RaycastFormFactors raycast(cornell.loaded.scene, cornell.mesh, {});
  ASSERT_TRUE(raycast.casts_rays());
  std::vector<FormFactorMethod::PairWork> works;
  for (size_t threads : {1, 2, 3}) {
    const tbb::global_control control(tbb::global_control::max_allowed_parallelism, threads);
    works.push_back(raycast.pair_work());
  }
  ASSERT_EQ(works[0].row_weight.size(), cornell.mesh.size());
  for (size_t k = 1; k < works.size(); ++k) {
    EXPECT_EQ(works[k].row_weight, works[0].row_weight);
    EXPECT_EQ(works[k].row_facing, works[0].row_facing);
  }
  // And so the same cut: the blocks of 7 from two computations of the split.
  const PairWorkSplit a = pair_work_split(raycast, cornell.mesh.size());
  const PairWorkSplit b = pair_work_split(raycast, cornell.mesh.size());
  const auto blocks_a = matrix_blocks(cornell.mesh.size(), 7, BlockSplit::kPairs, &a);
  const auto blocks_b = matrix_blocks(cornell.mesh.size(), 7, BlockSplit::kPairs, &b);
  for (size_t k = 0; k < 7; ++k) EXPECT_EQ(blocks_a[k].label(), blocks_b[k].label());
}

// A block boundary at row c splits the total where the work before c first reaches K-1 B-ths, so
// each boundary is within one row's work of its share and each block within that of total / B;
// the blocks tile the rows and their shares add up to the total. By pair counts (the old split)
// the same scene's blocks are further from equal work than one row: the estimate changes the cut.
TEST(PairWorkSplit, EachBlockIsWithinOneRowsWorkOfItsShare) {
  const Cornell cornell(4);
  const size_t n = cornell.mesh.size();
  const RaycastFormFactors raycast(cornell.loaded.scene, cornell.mesh, {});
  const PairWorkSplit work = pair_work_split(raycast, n);
  ASSERT_FALSE(work.unit.empty());
  const double row = double(largest_row(work));
  for (size_t count : {3, 7, 20}) {
    SCOPED_TRACE(std::to_string(count) + " blocks");
    const double share = double(work.total()) / double(count);
    ASSERT_LT(row, share);  // else one row could span a share (the next test)
    size_t next = 0;
    uint64_t sum = 0;
    double worst_by_pairs = 0;
    for (const MatrixBlock& block : matrix_blocks(n, count, BlockSplit::kPairs, &work)) {
      EXPECT_EQ(block.first, next);
      EXPECT_GT(block.end, block.first);
      EXPECT_EQ(block.work, work.cumulative[block.end] - work.cumulative[block.first]);
      EXPECT_LE(std::abs(double(block.work) - share), row);
      // matrix_block gives block K alone with the same rows.
      EXPECT_EQ(matrix_block(n, block.index, count, BlockSplit::kPairs, &work).label(),
                block.label());
      next = block.end;
      sum += block.work;
      const MatrixBlock by_pairs = matrix_block(n, block.index, count, BlockSplit::kPairs);
      worst_by_pairs = std::max(worst_by_pairs, std::abs(double(work.cumulative[by_pairs.end] -
                                                                work.cumulative[by_pairs.first]) -
                                                         share));
    }
    EXPECT_EQ(next, n);
    EXPECT_EQ(sum, work.total());
    EXPECT_GT(worst_by_pairs, row);
  }
}

// Work concentrated in one row: the cuts of blocks 2 to 4 all fall at row 1; the blocks then
// start a row apart (1, 2, 3), none empty, the last taking the rest.
TEST(PairWorkSplit, ARowHeavierThanSharesLeavesNoBlockEmpty) {
  const size_t n = 10;
  PairWorkSplit work;
  work.unit = "test";
  work.cumulative = {0};
  for (size_t i = 0; i < n; ++i) work.cumulative.push_back(work.cumulative.back() + (i ? 1 : 1000));
  const std::vector<MatrixBlock> blocks = matrix_blocks(n, 4, BlockSplit::kPairs, &work);
  const std::vector<size_t> first = {0, 1, 2, 3};
  for (size_t k = 0; k < 4; ++k) {
    EXPECT_EQ(blocks[k].first, first[k]);
    EXPECT_EQ(blocks[k].end, k + 1 < 4 ? first[k + 1] : n);
  }
  // Weight at the end: the last row with work is 8 (row 9 has no pairs); the blocks still end at
  // n and start a row apart before it.
  work.cumulative = {0};
  for (size_t i = 0; i < n; ++i) work.cumulative.push_back(work.cumulative.back() + (i == 8));
  const std::vector<MatrixBlock> late = matrix_blocks(n, 4, BlockSplit::kPairs, &work);
  EXPECT_EQ(late[0].first, 0u);
  for (size_t k = 1; k < 4; ++k) EXPECT_GT(late[k].first, late[k - 1].first);
  EXPECT_EQ(late[3].end, n);
  EXPECT_LE(late[3].first, n - 1);
}

// exact gives no estimate: its split is the pair counts', row for row the split without one.
TEST(PairWorkSplit, WithoutAnEstimateTheBlocksHoldEqualPairs) {
  const Cornell cornell(2);
  const size_t n = cornell.mesh.size();
  ExactOptions options;
  options.visibility_clip = true;
  const ExactFormFactors exact(cornell.loaded.scene, cornell.mesh, options);
  const PairWorkSplit work = pair_work_split(exact, n);
  EXPECT_TRUE(work.unit.empty());
  EXPECT_EQ(work.total(), uint64_t(n) * (n - 1) / 2);
  for (size_t k = 1; k <= 7; ++k) {
    const MatrixBlock a = matrix_block(n, k, 7, BlockSplit::kPairs, &work);
    const MatrixBlock b = matrix_block(n, k, 7, BlockSplit::kPairs);
    EXPECT_EQ(a.first, b.first);
    EXPECT_EQ(a.end, b.end);
    EXPECT_EQ(a.work, uint64_t(a.pairs()));
  }
}

// Every block and the merge cut the same rows; a block cut by other weights (here by pair counts,
// as before the estimate) holds other rows under its key, and the merge refuses it naming the
// file, the block it stands for and the rows its key holds. Nothing is returned.
TEST(PairWorkSplit, ABlockCutByOtherWeightsIsRefusedByName) {
  const Cornell cornell(2);
  const size_t n = cornell.mesh.size();
  RaycastOptions options;
  options.rays = 4;
  const RaycastFormFactors raycast(cornell.loaded.scene, cornell.mesh, options);
  const PairWorkSplit work = pair_work_split(raycast, n);
  const MatrixBlock weighted = matrix_block(n, 2, 3, BlockSplit::kPairs, &work);
  const MatrixBlock by_pairs = matrix_block(n, 2, 3, BlockSplit::kPairs);
  ASSERT_NE(weighted.first, by_pairs.first);  // the estimate moves the cut on this scene
  testing::TempDir dir;
  const MatrixCache cache(dir.path() / "cache"), other(dir.path() / "other");
  CacheKey key;
  key.text = "work split test matrix";
  key.hash = {0x1234, 0x5678};
  for (const MatrixBlock& block : matrix_blocks(n, 3, BlockSplit::kPairs, &work)) {
    BuildReport report;
    build_matrix_block(raycast, cache, key, n, block, report);
  }
  EXPECT_NO_THROW(merge_matrix_blocks(raycast, cache, key, n, 3));  // the same cut: merged
  BuildReport report;
  const fs::path stray = build_matrix_block(raycast, other, key, n, by_pairs, report);
  const fs::path file = matrix_block_file(cache, key, weighted);
  fs::copy_file(stray, file, fs::copy_options::overwrite_existing);
  fs::copy_file(stray.string() + ".pairstate", file.string() + ".pairstate",
                fs::copy_options::overwrite_existing);
  testing::expect_error<InputError>(
      [&] { merge_matrix_blocks(raycast, cache, key, n, 3); },
      {file.string() + ": " + weighted.label(),
       "pairs=" + std::to_string(by_pairs.first) + "-" + std::to_string(by_pairs.end),
       "nothing written"});
}

}  // namespace
}  // namespace radlab
