// The splits of a blocked build (formfactor/matrix/matrix_blocks.h) and the fixed-point row sums
// that let blocks of pairs merge into a one-process build's side files (fixed_sum.h).
#include "formfactor/matrix/matrix_blocks.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "core/error.h"
#include "formfactor/matrix/fixed_sum.h"

namespace radlab {
namespace {

// Blocks of pairs tile the rows [0, n) in order, hold every unordered pair once, and hold equal
// shares of the n (n - 1) / 2 pairs: each block within one row's pairs (at most n - 1) of the
// exact share, since a block boundary moves by whole rows.
TEST(MatrixBlocks, BlocksOfPairsHoldEqualSharesOfEveryPairOnce) {
  for (size_t n : {2, 3, 80, 1001, 53216}) {
    for (size_t count : {1, 2, 3, 7, 64}) {
      if (count > n / 2) continue;
      SCOPED_TRACE(std::to_string(n) + " elements, " + std::to_string(count) + " blocks");
      const double share = double(n) * double(n - 1) / 2.0 / double(count);
      size_t row = 0, pairs = 0;
      for (size_t k = 1; k <= count; ++k) {
        const MatrixBlock b = matrix_block(n, k, count, BlockSplit::kPairs);
        EXPECT_EQ(b.first, row);
        EXPECT_GT(b.end, b.first);  // no empty block
        EXPECT_LE(std::abs(double(b.pairs()) - share), double(n - 1));
        EXPECT_EQ(b.entries(), 2.0 * double(b.pairs()));
        row = b.end;
        pairs += b.pairs();
      }
      EXPECT_EQ(row, n);
      EXPECT_EQ(pairs, n * (n - 1) / 2);
    }
  }
}

TEST(MatrixBlocks, TooManyBlocksAreRefusedBySplit) {
  EXPECT_NO_THROW(matrix_block(80, 40, 40, BlockSplit::kPairs));
  EXPECT_THROW(matrix_block(80, 1, 41, BlockSplit::kPairs), InputError);
  EXPECT_NO_THROW(matrix_block(80, 80, 80, BlockSplit::kRows));
  EXPECT_THROW(matrix_block(80, 1, 81, BlockSplit::kRows), InputError);
  EXPECT_THROW(matrix_block(80, 0, 3, BlockSplit::kPairs), UsageError);
  EXPECT_THROW(matrix_block(80, 4, 3, BlockSplit::kPairs), UsageError);
}

// The labels name the split: a merge's messages say which rows a block's pairs start from.
TEST(MatrixBlocks, LabelsNameTheSplit) {
  EXPECT_EQ(matrix_block(80, 2, 3, BlockSplit::kPairs).label(),
            "block 2/3 (pairs of rows 15 to 33)");
  EXPECT_EQ(matrix_block(80, 2, 3, BlockSplit::kRows).label(), "block 2/3 (rows 26 to 52)");
}

// A row's sum in fixed point has the same bits whatever the order and grouping of its terms
// (what lets blocks add their shares); each term is rounded up, so the sum never falls below
// the exact one; and a sum saved as a double and read back is unchanged.
TEST(FixedSum, SumsAreExactWhateverTheOrderAndNeverBelowTheTerms) {
  std::mt19937_64 random(7);
  std::uniform_real_distribution<double> exponent(-60.0, 0.0);
  std::vector<double> terms(5000);
  long double exact = 0;
  for (double& t : terms) {
    t = std::exp2(exponent(random));
    exact += t;
  }
  FixedSum forward = 0, backward = 0, blocks[7] = {};
  for (size_t k = 0; k < terms.size(); ++k) {
    forward += to_fixed(terms[k]);
    backward += to_fixed(terms[terms.size() - 1 - k]);
    blocks[k % 7] += to_fixed(terms[k]);
  }
  FixedSum merged = 0;
  for (FixedSum b : blocks) merged += b;
  EXPECT_TRUE(forward == backward);
  EXPECT_TRUE(forward == merged);
  // A double sum in the two orders differs in its last bits (why fixed point is needed).
  double ascending = 0, descending = 0;
  for (size_t k = 0; k < terms.size(); ++k) {
    ascending += terms[k];
    descending += terms[terms.size() - 1 - k];
  }
  EXPECT_NE(ascending, descending);
  const double sum = from_fixed(forward);
  EXPECT_GE(static_cast<long double>(sum), exact);
  // Rounding up: at most 2^-80 a term, and the double's own half-ulp.
  EXPECT_LE(static_cast<long double>(sum), exact + 5000.0L * std::exp2(-80.0L) + exact * 2.3e-16L);
  EXPECT_EQ(from_fixed(to_fixed(sum)), sum);
  EXPECT_TRUE(to_fixed(0.0) == 0 && to_fixed(-1.0) == 0);
}

}  // namespace
}  // namespace radlab
