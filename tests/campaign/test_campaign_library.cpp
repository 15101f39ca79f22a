// ctr::campaign through its C++ API: the partition into shards, parseShard, a campaign run in two shards and merged,
// a shard run again (kept, not rerun), a folder of another campaign refused, and an incomplete merge.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <stdexcept>
#include <string>

#include "ctr/campaign/campaign.hpp"
#include "ctr/campaign/merge.hpp"
#include "ctr/campaign/run.hpp"
#include "ctr/io/input_error.hpp"

namespace fs = std::filesystem;
using namespace ctr;

namespace {

fs::path workDir() {
  const fs::path d = fs::temp_directory_path() / ("ctr_campaign_library_" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d;
}

std::string query() {
  return std::string(CTR_SOURCE_DIR) + "/examples/queries/proc_intracardiac.yaml";
}

fs::path writeCampaign(const std::string& name, const std::string& planners, const std::string& seeds,
                       double time_limit) {
  const fs::path f = workDir() / (name + ".yaml");
  std::ofstream(f) << "name: " << name << "\nqueries: [" << query() << "]\nplanners: [" << planners
                   << "]\nmodes: [exact]\nseeds: [" << seeds << "]\ntime_limit: " << time_limit << "\n";
  return f;
}

// Counts the observer's calls.
struct Counting : campaign::RunObserver {
  std::size_t runs = 0, kept = 0, finished = 0, units = 0;
  void started(std::size_t r, std::size_t k) override {
    runs = r;
    kept = k;
  }
  void unitStarted(const campaign::CampaignUnit&) override { ++units; }
  void runFinished() override { ++finished; }
};

std::set<std::string> ids(const std::vector<campaign::CampaignUnit>& units) {
  std::set<std::string> s;
  for (const auto& u : units) s.insert(u.id());
  return s;
}

}  // namespace

TEST(CampaignLibrary, ShardsPartitionTheUnitsInBalancedParts) {
  const campaign::Campaign c =
      campaign::loadCampaign(writeCampaign("partition", "rrt, kpiece, est", "5, 1, 4, 2, 3", 1).string());
  const auto all = c.units();
  ASSERT_EQ(all.size(), 15u);
  for (std::size_t k = 1; k < all.size(); ++k) EXPECT_LT(all[k - 1].id(), all[k].id()) << "sorted, no duplicate";
  for (std::size_t n = 1; n <= 7; ++n) {
    std::map<std::string, int> seen;
    std::size_t smallest = all.size(), largest = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const auto part = c.shard({i, n});
      smallest = std::min(smallest, part.size());
      largest = std::max(largest, part.size());
      for (const auto& u : part) ++seen[u.id()];
    }
    EXPECT_EQ(seen.size(), all.size()) << n << " shards";
    for (const auto& [id, k] : seen) EXPECT_EQ(k, 1) << id << " in " << k << " of " << n << " shards";
    EXPECT_LE(largest - smallest, 1u) << n << " shards";
  }
  EXPECT_THROW(c.shard({3, 3}), std::invalid_argument);
  EXPECT_THROW(c.shard({0, 0}), std::invalid_argument);

  const campaign::Shard s = campaign::parseShard("2/5");
  EXPECT_EQ(s.index, 2u);
  EXPECT_EQ(s.count, 5u);
  EXPECT_EQ(s.label(), "2/5");
  for (const std::string bad : {"5/5", "1", "-1/2", "a/b", "0/0", "", "1/2/3", " 1/2"})
    EXPECT_THROW(campaign::parseShard(bad), std::invalid_argument) << "'" << bad << "'";
}

TEST(CampaignLibrary, TwoShardsRunAndMergeIntoOneCompleteDatabase) {
  const fs::path file = writeCampaign("two_shards", "rrt", "1, 2, 3", 0.5);
  const campaign::Campaign c = campaign::loadCampaign(file.string());
  const fs::path a = workDir() / "shard_a", b = workDir() / "shard_b", merged = workDir() / "merged";
  for (const auto& d : {a, b, merged}) fs::remove_all(d);

  Counting first;
  campaign::RunOptions options;
  options.out = a.string();
  options.shard = {0, 2};
  options.observer = &first;
  const campaign::RunSummary sa = campaign::runCampaign(c, options);
  const auto shard0 = c.shard({0, 2});
  EXPECT_EQ(sa.shard, "0/2");
  EXPECT_EQ(sa.units, shard0.size());
  EXPECT_EQ(sa.units_run.size(), shard0.size());
  EXPECT_EQ(sa.units_kept, 0u);
  EXPECT_EQ(first.runs, shard0.size());
  EXPECT_EQ(first.kept, 0u);
  EXPECT_EQ(first.finished, shard0.size()) << "one runFinished per run";
  EXPECT_EQ(first.units, shard0.size());
  for (const auto& u : shard0) EXPECT_TRUE(fs::exists(a / "units" / (u.stem() + ".json"))) << u.id();
  EXPECT_TRUE(fs::exists(sa.shard_record));

  // The same shard again (an interrupted array task restarted): every unit is kept, none run twice.
  Counting again;
  options.observer = &again;
  const campaign::RunSummary sa2 = campaign::runCampaign(c, options);
  EXPECT_TRUE(sa2.units_run.empty());
  EXPECT_EQ(sa2.units_kept, shard0.size());
  EXPECT_EQ(again.kept, again.runs);
  EXPECT_EQ(again.finished, 0u);

  // Only the first shard: the merge names the missing units and writes nothing.
  try {
    campaign::mergeCampaign({a.string()}, merged.string(), {});
    ADD_FAILURE() << "an incomplete campaign was merged";
  } catch (const io::InputError& e) {
    for (const auto& u : c.shard({1, 2}))
      EXPECT_NE(std::string(e.what()).find("missing: " + u.id()), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(merged / "benchmark.db"));
  campaign::MergeOptions partial;
  partial.allow_incomplete = true;
  const campaign::MergeSummary incomplete = campaign::mergeCampaign({a.string()}, merged.string(), partial);
  EXPECT_FALSE(incomplete.complete());
  EXPECT_EQ(std::set<std::string>(incomplete.missing.begin(), incomplete.missing.end()), ids(c.shard({1, 2})));
  EXPECT_EQ(incomplete.runs, shard0.size());

  options.out = b.string();
  options.shard = {1, 2};
  options.observer = nullptr;
  campaign::runCampaign(c, options);
  const campaign::MergeSummary m = campaign::mergeCampaign({a.string(), b.string()}, merged.string(), {});
  EXPECT_TRUE(m.complete());
  EXPECT_EQ(m.units, 3u);
  EXPECT_EQ(m.expected_runs, 3u);
  EXPECT_EQ(m.runs, 3u);
  EXPECT_EQ(m.experiments, std::vector<std::string>{"proc_intracardiac_exact"});
  EXPECT_TRUE(fs::exists(m.database));
  const auto summary = nlohmann::json::parse(m.summary_json);
  EXPECT_EQ(summary, nlohmann::json::parse(std::ifstream(m.summary_file)));
  EXPECT_EQ(summary["run_outcomes"].size(), 3u);
  EXPECT_TRUE(summary["complete"].get<bool>());

  // A folder of another campaign is refused before any work, naming its campaign.json.
  const campaign::Campaign other = campaign::loadCampaign(writeCampaign("other", "rrt", "7", 0.5).string());
  options.out = a.string();
  options.shard = {};
  try {
    campaign::runCampaign(other, options);
    ADD_FAILURE() << "runs of two campaigns mixed in one folder";
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find((a / "campaign.json").string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("another campaign"), std::string::npos) << e.what();
  }
  std::ifstream manifest(a / "campaign.json");
  const std::string text((std::istreambuf_iterator<char>(manifest)), std::istreambuf_iterator<char>());
  EXPECT_EQ(campaign::campaignFromJson(text, "campaign.json").fingerprint, c.fingerprint) << "left as it was";
}
