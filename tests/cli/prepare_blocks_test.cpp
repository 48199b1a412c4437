// Blocked matrix builds through the command line (`radlab prepare --block K/B`, `--merge-blocks
// B`, `--plan --blocks B`; formfactor/matrix/matrix_blocks.h): the merged cache file holds the
// one-process build's bits (key, payload, side-file payloads) for 3 and 7 blocks, with raycast and
// exact (blocks of pairs) and with the hemicube (blocks of rows); blocks of pairs compute each
// pair once (their rays and pair counts add up to the one-process build's); every refusal (a
// block index or count out of range, a missing block, a block of another split, scene or block
// format, a corrupt block or side file) exits 2 or 3 naming the block and leaves no matrix file in
// the cache.
#include <gtest/gtest.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "tests/test_support.h"

namespace radlab {
namespace {

namespace fs = std::filesystem;
using Result = radlab::testing::CommandResult;
using radlab::testing::TempDir;

#define EXPECT_OUTPUT_HAS(result, text) \
  EXPECT_NE((result).output.find(text), std::string::npos) << (result).output

// builtin:cornell at --subdiv 2: 80 elements, an occluding box (raycast traces rays), emitters.
// exact clips its visibility (the Cornell box occludes; its adaptive integrals stop short of the
// tolerance on some pairs, so its row excesses are exercised too).
std::string experiment(const TempDir& dir, const std::string& method,
                       const std::string& scene = "builtin:cornell") {
  const std::string settings = method == "raycast"    ? "rays = 4\n"
                               : method == "hemicube" ? "resolution = 64\n"
                               : method == "exact"    ? "visibility = \"clip\"\n"
                                                      : "";
  return dir.write(method + "_" + std::to_string(std::hash<std::string>{}(scene)) + ".toml",
                   "name = \"blocks\"\nscenes = [\"" + scene +
                       "\"]\nsubdiv = [2]\nsolvers = [\"gauss-seidel\"]\n\n[form_factors]\n"
                       "method = \"" +
                       method + "\"\n" + settings + "\n[budget]\nrows = 100\n");
}

Result prepare(const std::string& cache, const std::string& arguments,
               const std::string& global = "") {
  return radlab::testing::run_command("RADLAB_CACHE_DIR=" + cache + " timeout 300 " +
                                      std::string(RADLAB_BINARY) + " -q " + global + " prepare " +
                                      arguments);
}

std::string bytes_of(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// The files of `folder` whose names end with `suffix`.
std::vector<fs::path> files_ending(const std::string& folder, const std::string& suffix) {
  std::vector<fs::path> found;
  if (!fs::exists(folder)) return found;
  for (const auto& entry : fs::directory_iterator(folder)) {
    const std::string name = entry.path().filename().string();
    if (name.size() >= suffix.size() &&
        name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0)
      found.push_back(entry.path());
  }
  return found;
}

fs::path only_file(const std::string& folder, const std::string& suffix) {
  const std::vector<fs::path> files = files_ending(folder, suffix);
  EXPECT_EQ(files.size(), 1u) << folder << " *" << suffix;
  return files.empty() ? fs::path() : files[0];
}

// The matrix cache header (formfactor/matrix/matrix_cache.cpp): bytes [0, 64) are the format,
// n, precision, key hash, payload size and payload checksum; [64, 120) the build's record (rays,
// kernel evaluations, the three pair counts, seconds, threads), which differs between any two
// builds (wall time); [120, 128) the header checksum over all of it. Everything from byte 128 on
// is the key text and the payload.
constexpr size_t kIdentityBytes = 64, kHeaderBytes = 128;

// The build's record in a matrix file's header: rays, kernel evaluations, pairs culled,
// unoccluded, traced.
std::vector<uint64_t> header_costs(const fs::path& matrix_file) {
  std::vector<uint64_t> costs(5);
  std::ifstream in(matrix_file, std::ios::binary);
  in.seekg(kIdentityBytes);
  in.read(reinterpret_cast<char*>(costs.data()), std::streamsize(costs.size() * sizeof(uint64_t)));
  return costs;
}

// The "rays" a block's record holds.
uint64_t recorded_rays(const std::string& record) {
  const std::string json = bytes_of(record);
  const size_t at = json.find("\"rays\": ");
  return at == std::string::npos ? 0 : std::stoull(json.substr(at + 8));
}

void expect_same_matrix_file(const fs::path& merged, const fs::path& single) {
  const std::string a = bytes_of(merged), b = bytes_of(single);
  ASSERT_EQ(a.size(), b.size()) << merged << " vs " << single;
  ASSERT_GT(a.size(), kHeaderBytes);
  EXPECT_EQ(a.compare(0, kIdentityBytes, b, 0, kIdentityBytes), 0) << "header identity differs";
  EXPECT_TRUE(a.compare(kHeaderBytes, std::string::npos, b, kHeaderBytes) == 0)
      << "key text or payload differs";
}

// A side file (matrix_cache.h): magic 8, size 8, the matrix file's header and key text, the
// payload, an 8-byte checksum. The payloads must be equal.
void expect_same_side_payload(const fs::path& merged, const fs::path& single, size_t key_bytes) {
  const std::string a = bytes_of(merged), b = bytes_of(single);
  ASSERT_EQ(a.size(), b.size()) << merged;
  const size_t start = 16 + kHeaderBytes + key_bytes;
  ASSERT_GT(a.size(), start + 8);
  EXPECT_TRUE(a.compare(start, a.size() - start - 8, b, start, b.size() - start - 8) == 0)
      << merged << ": side-file payload differs";
}

size_t key_text_bytes(const fs::path& matrix_file) {
  const std::string bytes = bytes_of(matrix_file);
  uint32_t key = 0;
  std::memcpy(&key, bytes.data() + 28, sizeof key);  // after magic, version, order, n, precision
  return key;
}

// Builds the blocks; returns the rays their records hold, summed.
uint64_t blocks_then_merge(const std::string& exp, const std::string& cache, size_t count) {
  uint64_t rays = 0;
  for (size_t k = 1; k <= count; ++k) {
    const std::string record = cache + "_block" + std::to_string(k) + ".json";
    const Result block = prepare(cache, exp + " --problem 0 --block " + std::to_string(k) + "/" +
                                            std::to_string(count) + " --record " + record);
    EXPECT_EQ(block.code, 0) << block.output;
    rays += recorded_rays(record);
  }
  return rays;
}

// `pairs`: blocks of pairs, which compute each pair once: the blocks' rays add up to the
// one-process build's, and so do the pair counts; the kernel evaluations are the one-process
// build's for exact (one integral a pair there too) and at most those for raycast (one process
// integrates F^u once per row, a block of pairs once per pair). Blocks of rows compute each row
// as one process does (the hemicube shares nothing between rows): the same counts.
void expect_merge_equals_one_process(const std::string& method, const std::string& side_suffix,
                                     const std::vector<size_t>& counts) {
  TempDir dir;
  const std::string exp = experiment(dir, method);
  const std::string single = dir.file("single");
  const Result one = prepare(single, exp);
  ASSERT_EQ(one.code, 0) << one.output;
  const fs::path single_matrix = only_file(single, ".ffm");
  for (size_t count : counts) {
    SCOPED_TRACE(method + " in " + std::to_string(count) + " blocks");
    const std::string cache = dir.file("blocks" + std::to_string(count));
    const uint64_t rays = blocks_then_merge(exp, cache, count);
    EXPECT_EQ(files_ending(cache, ".ffb").size(), count);
    EXPECT_TRUE(files_ending(cache, ".ffm").empty());  // blocks alone are not a matrix
    const std::string record = dir.file("record" + std::to_string(count) + ".json");
    const Result merge =
        prepare(cache, exp + " --merge-blocks " + std::to_string(count) + " --record " + record);
    ASSERT_EQ(merge.code, 0) << merge.output;
    const fs::path merged = only_file(cache, ".ffm");
    EXPECT_EQ(merged.filename(), single_matrix.filename());  // the same key
    expect_same_matrix_file(merged, single_matrix);
    expect_same_side_payload(merged.string() + side_suffix, single_matrix.string() + side_suffix,
                             key_text_bytes(single_matrix));
    const std::vector<uint64_t> whole = header_costs(single_matrix), all = header_costs(merged);
    EXPECT_EQ(rays, whole[0]) << "the blocks' recorded rays";
    EXPECT_EQ(all[0], whole[0]) << "rays";
    if (method == "raycast") {
      EXPECT_GT(whole[0], 0u);  // the box occludes: rays were cast
      EXPECT_LE(all[1], whole[1]) << "kernel evaluations";
    } else {
      EXPECT_EQ(all[1], whole[1]) << "kernel evaluations";
    }
    for (size_t c = 2; c < 5; ++c) EXPECT_EQ(all[c], whole[c]) << "pair count " << c;
    // The preparation after the merge used the merged matrix from the cache, and certified.
    const std::string json = bytes_of(record);
    EXPECT_NE(json.find("\"matrix_from_cache\": true"), std::string::npos) << json;
    EXPECT_NE(json.find("certified"), std::string::npos) << json;
  }
}

TEST(PrepareBlocks, RaycastMergedInThreeAndSevenBlocksIsTheOneProcessBuild) {
  expect_merge_equals_one_process("raycast", ".sigma", {3, 7});
}

// exact's side file ".excess" (the count of pairs stopped short of the tolerance, then each row's
// excess) is a matrix side file too; its payload's first double must be nonzero here.
TEST(PrepareBlocks, ExactMergedInThreeAndSevenBlocksIsTheOneProcessBuild) {
  TempDir dir;
  const std::string exp = experiment(dir, "exact");
  const std::string single = dir.file("single");
  ASSERT_EQ(prepare(single, exp).code, 0);
  const fs::path single_matrix = only_file(single, ".ffm");
  const size_t key_bytes = key_text_bytes(single_matrix);
  for (size_t count : {3, 7}) {
    SCOPED_TRACE("exact in " + std::to_string(count) + " blocks");
    const std::string cache = dir.file("blocks" + std::to_string(count));
    const uint64_t rays = blocks_then_merge(exp, cache, count);
    const Result merge = prepare(cache, exp + " --merge-blocks " + std::to_string(count));
    ASSERT_EQ(merge.code, 0) << merge.output;
    const fs::path merged = only_file(cache, ".ffm");
    expect_same_matrix_file(merged, single_matrix);
    const std::string excess = bytes_of(single_matrix.string() + ".excess");
    const size_t start = 16 + kHeaderBytes + key_bytes;  // expect_same_side_payload's layout
    double capped = 0;
    ASSERT_GE(excess.size(), start + sizeof capped + 8);
    std::memcpy(&capped, excess.data() + start, sizeof capped);
    EXPECT_GT(capped, 0.0);  // the row excesses hold something to merge
    expect_same_side_payload(merged.string() + ".excess", single_matrix.string() + ".excess",
                             key_bytes);
    EXPECT_EQ(header_costs(merged), header_costs(single_matrix));
    EXPECT_EQ(rays, header_costs(single_matrix)[0]);
  }
}

TEST(PrepareBlocks, HemicubeMergedInThreeBlocksIsTheOneProcessBuild) {
  expect_merge_equals_one_process("hemicube", ".emitters", {3});
}

TEST(PrepareBlocks, BlockIndexOrCountOutOfRangeIsAUsageError) {
  TempDir dir;
  const std::string exp = experiment(dir, "raycast"), cache = dir.file("cache");
  for (const char* block : {"0/3", "4/3", "1/0", "3", "a/b", "-1/3"}) {
    const Result r = prepare(cache, exp + " --problem 0 --block " + block);
    EXPECT_EQ(r.code, 2) << block << ": " << r.output;
    EXPECT_OUTPUT_HAS(r, "--block");
  }
  EXPECT_EQ(prepare(cache, exp + " --merge-blocks 0").code, 2);
  // More blocks of pairs than half the matrix's 80 rows: a block would hold no pairs (invalid
  // input); the hemicube's blocks of rows go up to the 80 rows.
  const Result many = prepare(cache, exp + " --problem 0 --block 1/41");
  EXPECT_EQ(many.code, 3) << many.output;
  EXPECT_OUTPUT_HAS(many, "at most 40 blocks of pairs");
  const Result rows = prepare(cache, experiment(dir, "hemicube") + " --problem 0 --block 1/81");
  EXPECT_EQ(rows.code, 3) << rows.output;
  EXPECT_OUTPUT_HAS(rows, "at most 80 blocks)");
  EXPECT_TRUE(files_ending(cache, ".ffb").empty());
  EXPECT_TRUE(files_ending(cache, ".ffm").empty());
}

// A block is held to the limits by its own work: block 1 of 3 of 80 elements holds the pairs of
// rows 0 to 4 (raycast's first rows, the large elements, cost most: a third of the estimated
// work), 5 * 79 - 5 * 4 / 2 = 385 of the 3,160 pairs, 770 entries.
TEST(PrepareBlocks, ABlockIsHeldToTheLimitsByItsOwnPairs) {
  TempDir dir;
  const std::string exp = experiment(dir, "raycast"), cache = dir.file("cache");
  const Result refused = prepare(cache, exp + " --problem 0 --block 1/3", "--limits pairs=700");
  EXPECT_EQ(refused.code, 3) << refused.output;
  EXPECT_OUTPUT_HAS(refused,
                    "block 1/3 (pairs of rows 0 to 4) of the form-factor matrix of 80 elements");
  EXPECT_OUTPUT_HAS(refused, "770 pairs, above the limit of 700 pairs");
  EXPECT_TRUE(files_ending(cache, ".ffb").empty());
  EXPECT_EQ(prepare(cache, exp + " --problem 0 --block 1/3", "--limits pairs=800").code, 0);
}

// Each refusal names the block and its file, exits 3 and writes no matrix.
void expect_refused(const std::string& exp, const std::string& cache, size_t count,
                    const std::string& names) {
  const Result r = prepare(cache, exp + " --merge-blocks " + std::to_string(count));
  EXPECT_EQ(r.code, 3) << r.output;
  EXPECT_OUTPUT_HAS(r, names);
  EXPECT_TRUE(files_ending(cache, ".ffm").empty()) << "a refused merge wrote a matrix";
}

TEST(PrepareBlocks, AMissingBlockIsNamed) {
  TempDir dir;
  const std::string exp = experiment(dir, "raycast"), cache = dir.file("cache");
  for (const char* block : {"1/3", "3/3"})
    ASSERT_EQ(prepare(cache, exp + " --problem 0 --block " + block).code, 0);
  expect_refused(exp, cache, 3,
                 "1 missing (nothing written):\n  block 2/3 (pairs of rows 5 to 25)");
  EXPECT_EQ(prepare(cache, exp + " --problem 0 --block 2/3").code, 0);
  EXPECT_EQ(prepare(cache, exp + " --merge-blocks 3").code, 0);  // complete now
}

TEST(PrepareBlocks, ABlockOfAnotherSplitOrSceneIsRefused) {
  TempDir dir;
  const std::string exp = experiment(dir, "raycast"), cache = dir.file("cache");
  blocks_then_merge(exp, cache, 3);
  const fs::path second = only_file(cache, ".block-2-of-3.ffb");
  // Block 2 of a split in 4 where block 2 of 3 belongs: its stored key says block=2/4.
  const std::string other_split = dir.file("split");
  blocks_then_merge(exp, other_split, 4);
  fs::copy_file(only_file(other_split, ".block-2-of-4.ffb"), second,
                fs::copy_options::overwrite_existing);
  expect_refused(exp, cache, 3, second.string() + ": block 2/3 (pairs of rows 5 to 25)");
  expect_refused(exp, cache, 3, "block=2/4");
  // Block 2 of 3 of another scene (another mesh: another key).
  const std::string other_scene = dir.file("scene");
  const std::string other = experiment(dir, "raycast", "builtin:cube");
  ASSERT_EQ(prepare(other_scene, other + " --problem 0 --block 2/3").code, 0);
  fs::copy_file(only_file(other_scene, ".block-2-of-3.ffb"), second,
                fs::copy_options::overwrite_existing);
  expect_refused(exp, cache, 3, second.string() + ": block 2/3");
}

TEST(PrepareBlocks, ACorruptBlockOrSideFileIsRefused) {
  TempDir dir;
  const std::string exp = experiment(dir, "raycast"), cache = dir.file("cache");
  blocks_then_merge(exp, cache, 3);
  const fs::path third = only_file(cache, ".block-3-of-3.ffb");
  const std::string intact = bytes_of(third);
  std::string damaged = intact;
  damaged[damaged.size() - 3] ^= 0x10;  // a bit of the last value
  std::ofstream(third, std::ios::binary | std::ios::trunc) << damaged;
  expect_refused(exp, cache, 3, third.string() + ": block 3/3 (pairs of rows 26 to 79)");
  expect_refused(exp, cache, 3, "checksum mismatch");
  std::ofstream(third, std::ios::binary | std::ios::trunc) << intact;
  const fs::path sigma = third.string() + ".pairstate";
  std::string side = bytes_of(sigma);
  side[side.size() - 12] ^= 0x10;
  std::ofstream(sigma, std::ios::binary | std::ios::trunc) << side;
  expect_refused(exp, cache, 3, "its side file " + sigma.string());
}

TEST(PrepareBlocks, PlanGivesEachBlockAndTheMerge) {
  TempDir dir;
  const std::string exp = experiment(dir, "raycast"), cache = dir.file("cache");
  const Result plan = prepare(cache, exp + " --plan --blocks 3");
  ASSERT_EQ(plan.code, 0) << plan.output;
  // Blocks of 385, 1,344 and 1,431 of the 3,160 pairs (rows 0-4, 5-25, 26-79), cut by raycast's
  // estimated work.
  for (const char* part :
       {"\"block_split\": \"pairs\"", "\"block\": 1,", "\"pairs\": 385,", "\"block\": 3,",
        "\"first_row\": 26,", "\"end_row\": 80,", "\"pairs\": 1431,", "\"merge\": {",
        "\"block_work_unit\": \"ray-equivalents"})
    EXPECT_OUTPUT_HAS(plan, part);
  EXPECT_FALSE(fs::exists(cache));  // --plan builds nothing
  const Result exact = prepare(cache, experiment(dir, "exact") + " --plan --blocks 3");
  ASSERT_EQ(exact.code, 0) << exact.output;
  EXPECT_OUTPUT_HAS(exact, "\"block_split\": \"pairs\"");
  EXPECT_OUTPUT_HAS(exact, "\"first_row\": 34,");  // no estimate: equal pairs
  EXPECT_EQ(exact.output.find("block_work_unit"), std::string::npos) << exact.output;
  const Result hemicube = prepare(cache, experiment(dir, "hemicube") + " --plan --blocks 3");
  ASSERT_EQ(hemicube.code, 0) << hemicube.output;
  EXPECT_OUTPUT_HAS(hemicube, "\"block_split\": \"rows\"");
  EXPECT_OUTPUT_HAS(hemicube, "\"first_row\": 53,");
  EXPECT_OUTPUT_HAS(hemicube, "\"entries\": 2160,");
}

// The values of every `"key": N` in `json`, in order.
std::vector<uint64_t> numbers_of(const std::string& json, const std::string& key) {
  std::vector<uint64_t> values;
  const std::string field = "\"" + key + "\": ";
  for (size_t at = json.find(field); at != std::string::npos; at = json.find(field, at + 1))
    values.push_back(std::stoull(json.substr(at + field.size())));
  return values;
}

// The plan, every block and the merge compute raycast's work estimate anew from the scene and
// cut the same rows: each block's record holds the plan's rows and work share, and the merge
// (which refuses a block of other rows by its key) accepts them.
TEST(PrepareBlocks, ThePlanTheBlocksAndTheMergeCutTheSameRows) {
  TempDir dir;
  const std::string exp = experiment(dir, "raycast"), cache = dir.file("cache");
  const Result plan = prepare(cache, exp + " --plan --blocks 7");
  ASSERT_EQ(plan.code, 0) << plan.output;
  const std::vector<uint64_t> first = numbers_of(plan.output, "first_row"),
                              end = numbers_of(plan.output, "end_row"),
                              work = numbers_of(plan.output, "work");
  ASSERT_EQ(first.size(), 7u);
  ASSERT_EQ(work.size(), 7u);
  blocks_then_merge(exp, cache, 7);
  for (size_t k = 1; k <= 7; ++k) {
    SCOPED_TRACE("block " + std::to_string(k));
    const std::string record = bytes_of(cache + "_block" + std::to_string(k) + ".json");
    EXPECT_EQ(numbers_of(record, "first_row"), std::vector<uint64_t>{first[k - 1]});
    EXPECT_EQ(numbers_of(record, "end_row"), std::vector<uint64_t>{end[k - 1]});
    EXPECT_EQ(numbers_of(record, "work"), std::vector<uint64_t>{work[k - 1]});
  }
  EXPECT_EQ(prepare(cache, exp + " --merge-blocks 7").code, 0);
}

}  // namespace
}  // namespace radlab
