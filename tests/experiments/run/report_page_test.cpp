// The sweep's page, OUT/index.html (experiments/run/report_page.h; issue 31, item 5): a tiny
// sweep through the command line writes it, plots drawn afterwards join it on `radlab report`,
// and tests/experiments/run/check_report_page.py (Python's standard library only) checks that
// every link resolves inside the folder, every image is a valid PNG, every plot and image is
// shown, nothing is loaded from elsewhere, and every summary row is in the table. Folders that
// are not a complete sweep are refused with exit 3.
#include "experiments/run/report_page.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "tests/test_support.h"

namespace radlab {
namespace {

namespace fs = std::filesystem;
using testing::CommandResult;
using testing::TempDir;

// Three runs on a 24-element cube with 16 x 16 images at step 2: milliseconds each. The
// description carries markup and quotes, which the page must show as text.
const char* kTinyWithImages = R"(name = "tiny"
description = "<b>bold</b> & \"quoted\" 'claims'"
scenes = ["builtin:cube:rho=0.8"]
subdiv = 2
solvers = ["gauss-seidel", "jacobi"]
[form_factors]
rays = 4
[budget]
rows = 200
[parameters.gauss-seidel]
omega = [1.0, 1.3]
[images]
steps = [2]
width = 16
height = 16
)";

CommandResult radlab(const TempDir& dir, const std::string& arguments) {
  return testing::run_command("RADLAB_CACHE_DIR=" + dir.file("cache") + " timeout 120 " +
                              std::string(RADLAB_BINARY) + " " + arguments);
}

CommandResult check_page(const std::string& folder) {
  return testing::run_command("/usr/bin/python3 " + std::string(RADLAB_SOURCE_DIR) +
                              "/tests/experiments/run/check_report_page.py " + folder);
}

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

TEST(ReportPage, EscapesTextAndLinks) {
  EXPECT_EQ(html_escape(R"(<a href="x">&'</a>)"),
            "&lt;a href=&quot;x&quot;&gt;&amp;&#39;&lt;/a&gt;");
  EXPECT_EQ(html_escape("plain text 1.5e-3"), "plain text 1.5e-3");
  // Run stems keep every byte but / : space , = (file_stem); whatever else a link holds must
  // reach the browser percent-encoded, with the folder separator kept.
  EXPECT_EQ(url_path("runs/cube omega=1.3,x#1.run.json"),
            "runs/cube%20omega%3D1.3%2Cx%231.run.json");
  EXPECT_EQ(url_path("images/a-b_c.d~e.png"), "images/a-b_c.d~e.png");
}

TEST(ReportPage, ASweepWritesAPageWhoseLinksAndImagesAreSound) {
  TempDir dir;
  const std::string toml = dir.write("e.toml", kTinyWithImages);
  const std::string out = dir.file("out");
  CommandResult run = radlab(dir, "-q run " + toml + " --out " + out);
  ASSERT_EQ(run.code, 0) << run.output;
  ASSERT_TRUE(fs::exists(out + "/index.html")) << run.output;
  // No plots yet: the page says how to draw them, and is sound as it is.
  const std::string before = read_text(out + "/index.html");
  EXPECT_NE(before.find("scripts/plot_traces.py"), std::string::npos);
  CommandResult checked = check_page(out);
  EXPECT_EQ(checked.code, 0) << checked.output;

  // The description shows as text, not markup.
  EXPECT_NE(before.find("&lt;b&gt;bold&lt;/b&gt; &amp; &quot;quoted&quot; &#39;claims&#39;"),
            std::string::npos);
  EXPECT_EQ(before.find("<b>bold"), std::string::npos);

  // The plots, drawn afterwards as scripts/run-main.sh does, join the page on `radlab report`.
  CommandResult plot =
      testing::run_command("/usr/bin/python3 " + std::string(RADLAB_SOURCE_DIR) +
                           "/scripts/plot_traces.py " + out + " --formats png 2>&1");
  ASSERT_EQ(plot.code, 0) << plot.output << "\n(needs Debian's python3-matplotlib and pandas: "
                          << "scripts/install-deps.sh)";
  CommandResult report = radlab(dir, "report " + out);
  ASSERT_EQ(report.code, 0) << report.output;
  EXPECT_NE(report.output.find("3 runs"), std::string::npos) << report.output;
  const std::string after = read_text(out + "/index.html");
  EXPECT_EQ(after.find("scripts/plot_traces.py"), std::string::npos);
  checked = check_page(out);
  EXPECT_EQ(checked.code, 0) << checked.output;
  // Something to check: the checker saw the plots and the run's images (3 runs x 3 PNGs).
  size_t plots = 0;
  for (const auto& entry : fs::directory_iterator(out + "/plots"))
    plots += entry.path().extension() == ".png";
  EXPECT_GT(plots, 0u);
  size_t images = 0;
  for (const auto& entry : fs::directory_iterator(out + "/images"))
    images += entry.path().extension() == ".png";
  EXPECT_EQ(images, 9u);
}

TEST(ReportPage, ASweepOverSolverSeedsLinksItsAggregate) {
  TempDir dir;
  const std::string toml = dir.write("e.toml", R"(name = "seeds"
scenes = ["builtin:cube:rho=0.8"]
subdiv = 2
solvers = ["stochastic-jacobi"]
repeats = 2
[budget]
steps = 3
)");
  const std::string out = dir.file("out");
  CommandResult run = radlab(dir, "-q run " + toml + " --out " + out);
  ASSERT_EQ(run.code, 0) << run.output;
  ASSERT_TRUE(fs::exists(out + "/aggregate.csv"));
  EXPECT_NE(read_text(out + "/index.html").find("href=\"aggregate.csv\""), std::string::npos);
  CommandResult checked = check_page(out);  // follows the link
  EXPECT_EQ(checked.code, 0) << checked.output;
}

TEST(ReportPage, AMergedSweepHasItsPage) {
  TempDir dir;
  const std::string toml = dir.write("e.toml", kTinyWithImages);
  for (const char* shard : {"0/2", "1/2"}) {
    const std::string folder = dir.file(std::string("s") + shard[0]);
    CommandResult run = radlab(dir, "-q run " + toml + " --shard " + shard + " --out " + folder);
    ASSERT_EQ(run.code, 0) << run.output;
  }
  CommandResult merge =
      radlab(dir, "-q merge " + dir.file("s0") + " " + dir.file("s1") + " --out " + dir.file("m"));
  ASSERT_EQ(merge.code, 0) << merge.output;
  CommandResult checked = check_page(dir.file("m"));
  EXPECT_EQ(checked.code, 0) << checked.output;
  EXPECT_NE(checked.output.find("3 runs"), std::string::npos) << checked.output;
}

TEST(ReportPage, RefusesAFolderThatIsNotACompleteSweep) {
  TempDir dir;
  CommandResult missing = radlab(dir, "report " + dir.file("nowhere"));
  EXPECT_EQ(missing.code, 3) << missing.output;
  EXPECT_NE(missing.output.find("not a folder"), std::string::npos) << missing.output;

  fs::create_directories(dir.file("empty"));
  CommandResult empty = radlab(dir, "report " + dir.file("empty"));
  EXPECT_EQ(empty.code, 3) << empty.output;
  EXPECT_NE(empty.output.find("no sweep.json"), std::string::npos) << empty.output;

  // A sweep that was killed says "running" and has no trace.csv or summary.csv.
  fs::create_directories(dir.file("running"));
  fs::create_directories(dir.file("broken"));
  dir.write("running/sweep.json", R"({"name": "tiny", "status": "running"})");
  CommandResult running = radlab(dir, "report " + dir.file("running"));
  EXPECT_EQ(running.code, 3) << running.output;
  EXPECT_NE(running.output.find("not complete"), std::string::npos) << running.output;
  EXPECT_FALSE(fs::exists(dir.file("running/index.html")));

  dir.write("broken/sweep.json", R"({"name": "tiny", "status": )");
  CommandResult broken = radlab(dir, "report " + dir.file("broken"));
  EXPECT_EQ(broken.code, 3) << broken.output;
  EXPECT_NE(broken.output.find("broken/sweep.json"), std::string::npos) << broken.output;

  CommandResult usage = radlab(dir, "report");
  EXPECT_EQ(usage.code, 2) << usage.output;
}

}  // namespace
}  // namespace radlab
