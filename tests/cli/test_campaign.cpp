// Benchmark campaigns (`ctr bench CAMPAIGN.yaml`, `--shard i/N`, `ctr bench merge`): the partition into shards, the
// same runs from one process and from shards, the Planner Arena database, completeness checks, bad campaign files,
// progress lines. Runs the real `ctr` executable.
#include <gtest/gtest.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>

#include "run_process.hpp"

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

using ctr_test::Proc;

fs::path workDir() {
  const fs::path d = fs::temp_directory_path() / ("ctr_campaign_" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d;
}

Proc shell(const std::string& cmd) { return ctr_test::runShell(cmd, workDir()); }

Proc ctr(const std::string& args) {
  return shell("CTR_PROGRESS=plain " + std::string(CTR_EXE) + " " + args);
}

std::string query() {
  return std::string(CTR_SOURCE_DIR) + "/examples/queries/proc_intracardiac.yaml";
}

fs::path writeCampaign(const std::string& name, const std::string& body) {
  const fs::path f = workDir() / (name + ".yaml");
  std::ofstream(f) << body;
  return f;
}

// 2 planners x 1 mode x 2 seeds = 4 units, 1 run each, 1 s.
fs::path smallCampaign() {
  return writeCampaign("small", "name: small\nqueries: [" + query() +
                                    "]\nplanners: [kpiece, rrt]\nmodes: [exact]\nseeds: [2, 1]\ntime_limit: 1\n");
}

json readJson(const fs::path& f) {
  std::ifstream in(f);
  return json::parse(in);
}

// (query, mode, planner, seed, run) of every run in a merged summary.
std::multiset<std::string> runSet(const json& summary) {
  std::multiset<std::string> s;
  for (const auto& r : summary["run_outcomes"])
    s.insert(r["query"].get<std::string>() + "/" + r["mode"].get<std::string>() + "/" +
             r["planner"].get<std::string>() + "/" + std::to_string(r["seed"].get<int>()) + "/" +
             std::to_string(r["run"].get<int>()));
  return s;
}

// Runs per planner in the database (sqlite3 through Debian's python3, which ompl_benchmark_statistics uses too).
std::map<std::string, int> dbRunsPerPlanner(const fs::path& db) {
  const Proc p = shell(
      "/usr/bin/python3 -c \"import sqlite3,sys; c=sqlite3.connect(sys.argv[1]); "
      "[print(n, k) for n, k in c.execute('select p.name, count(*) from runs r join plannerConfigs p "
      "on r.plannerid = p.id group by p.name')]\" " +
      db.string());
  EXPECT_EQ(p.code, 0) << p.err;
  std::map<std::string, int> m;
  std::stringstream ss(p.out);
  std::string name;
  int k = 0;
  while (ss >> name >> k) m[name] = k;
  return m;
}

}  // namespace

TEST(Campaign, BadCampaignFilesNameTheKeyAndLeaveNothing) {
  const fs::path out = workDir() / "bad_out";
  fs::remove_all(out);
  struct Case {
    std::string body, key;
  };
  const std::vector<Case> cases = {
      {"queries: [" + query() + "]\nplanners: [rrt]\nmodes: [exact]\nseeds: [1]\ntime_limit: 1\nfoo: 1\n", "foo"},
      {"queries: [" + query() + "]\nplanners: [rrtconnect]\nmodes: [exact]\nseeds: [1]\ntime_limit: 1\n",
       "planners[0]"},
      {"queries: [" + query() + "]\nplanners: [rrt]\nmodes: [exact, sideways]\nseeds: [1]\ntime_limit: 1\n",
       "modes[1]"},
      {"queries: [" + query() + "]\nplanners: [rrt]\nmodes: [exact]\nseeds: [1, 1]\ntime_limit: 1\n", "seeds[1]"},
      {"queries: [" + query() + "]\nplanners: [rrt]\nmodes: [exact]\nseeds: [1]\ntime_limit: 0\n", "time_limit"},
      {"queries: [nowhere.yaml]\nplanners: [rrt]\nmodes: [exact]\nseeds: [1]\ntime_limit: 1\n", "queries[0]"},
      {"queries: [" + query() + ", " + query() + "]\nplanners: [rrt]\nmodes: [exact]\nseeds: [1]\ntime_limit: 1\n",
       "queries[1]"},
      {"queries: [" + query() + "]\nplanners: [rrt]\nmodes: [exact]\ntime_limit: 1\n", "seeds"},
  };
  for (std::size_t k = 0; k < cases.size(); ++k) {
    const fs::path f = writeCampaign("bad" + std::to_string(k), cases[k].body);
    const Proc r = ctr("bench " + f.string() + " --out " + out.string());
    EXPECT_EQ(r.code, 2) << cases[k].body << r.err;
    EXPECT_NE(r.err.find(f.string()), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("'" + cases[k].key + "'"), std::string::npos) << cases[k].key << ": " << r.err;
    EXPECT_FALSE(fs::exists(out)) << "output left behind by a bad campaign: " << cases[k].body;
  }
  const fs::path good = smallCampaign();
  for (const std::string shard : {"3/3", "1", "-1/2", "a/b", "0/0"}) {
    const Proc r = ctr("bench " + good.string() + " --out " + out.string() + " --shard " + shard);
    EXPECT_EQ(r.code, 2) << shard;
    EXPECT_NE(r.err.find("--shard"), std::string::npos) << r.err;
  }
  const Proc r = ctr("bench " + good.string() + " --out " + out.string() + " --planners rrt");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--planners"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
}

TEST(Campaign, BenchCampaignOneProcessAndShardsGiveTheSameRunsAndDatabase) {
  const fs::path c = smallCampaign();
  const fs::path one = workDir() / "one", sharded = workDir() / "sharded";
  fs::remove_all(one);
  fs::remove_all(sharded);
  const Proc a = ctr("bench " + c.string() + " --out " + one.string());
  ASSERT_EQ(a.code, 0) << a.err;
  // Progress when stderr is not a terminal: plain done/total lines, the last one complete.
  EXPECT_NE(a.err.find("bench shard 0/1: 4/4 runs, elapsed"), std::string::npos) << a.err;
  // Three shards in separate processes (as a job array would), each writing into the same folder.
  std::set<std::string> seen;
  std::size_t sizes = 0;
  for (int i = 0; i < 3; ++i) {
    const Proc s = ctr("bench " + c.string() + " --out " + sharded.string() + " --shard " + std::to_string(i) + "/3");
    ASSERT_EQ(s.code, 0) << s.err;
    const json sj = readJson(sharded / "shards" / ("shard-" + std::to_string(i) + "-of-3.json"));
    EXPECT_EQ(sj["units"], i == 0 ? 2 : 1) << "round robin over 4 units: 2, 1, 1";
    for (const auto& id : sj["units_run"]) EXPECT_TRUE(seen.insert(id.get<std::string>()).second) << id;
    sizes += sj["units"].get<std::size_t>();
  }
  EXPECT_EQ(sizes, 4u);
  EXPECT_EQ(seen.size(), 4u);
  const Proc ma = ctr("bench merge " + one.string() + " --out " + (one / "merged").string());
  ASSERT_EQ(ma.code, 0) << ma.err;
  const Proc mb = ctr("bench merge " + sharded.string() + " --out " + (sharded / "merged").string());
  ASSERT_EQ(mb.code, 0) << mb.err;
  const json sa = readJson(one / "merged" / "summary.json"), sb = readJson(sharded / "merged" / "summary.json");
  EXPECT_TRUE(sa["complete"]);
  EXPECT_EQ(sa["runs"], 4);
  EXPECT_EQ(runSet(sa), runSet(sb));
  EXPECT_EQ(runSet(sa).size(), 4u);
  EXPECT_EQ(sa["experiments"], json::array({"proc_intracardiac_exact"}));
  ASSERT_EQ(sa["rows"].size(), 2u);
  for (const auto& row : sa["rows"]) {
    EXPECT_EQ(row["runs"], 2);
    EXPECT_EQ(row["seeds"], json::array({1, 2}));
  }
  const auto pa = dbRunsPerPlanner(one / "merged" / "benchmark.db");
  const auto pb = dbRunsPerPlanner(sharded / "merged" / "benchmark.db");
  EXPECT_EQ(pa, pb);
  ASSERT_EQ(pa.size(), 2u);
  for (const auto& [name, n] : pa) EXPECT_EQ(n, 2) << name;
  // Running a shard again keeps the recorded units (an interrupted array task resubmitted).
  const Proc again = ctr("bench " + c.string() + " --out " + sharded.string() + " --shard 1/3");
  ASSERT_EQ(again.code, 0) << again.err;
  EXPECT_NE(again.out.find("0 run, 1 already recorded"), std::string::npos) << again.out;
}

TEST(Campaign, CpuTimeCampaignStopsEachRunAfterItsCpuSeconds) {
  // `cpu_time: true`: the limit and Planner Arena's time axis are process CPU seconds. SST keeps optimising until its
  // limit, so its run must stop at 1 CPU s (not earlier, not much later), and report that time.
  const fs::path c = writeCampaign("cpu", "name: cpu\nqueries: [" + query() +
                                              "]\nplanners: [sst]\nmodes: [exact]\nseeds: [1]\ntime_limit: 1\n"
                                              "cpu_time: true\n");
  const fs::path out = workDir() / "cpu";
  fs::remove_all(out);
  const Proc a = ctr("bench " + c.string() + " --out " + out.string() + " --quiet");
  ASSERT_EQ(a.code, 0) << a.err;
  const json u = readJson(out / "units" / "proc_intracardiac__exact__sst__seed-1.json");
  EXPECT_EQ(u["clock"], "cpu");
  ASSERT_EQ(u["runs"].size(), 1u);
  const json& o = u["runs"][0]["ompl"];
  const double cpu = std::stod(o["cpu_time REAL"].get<std::string>());
  const double t = std::stod(o["time REAL"].get<std::string>());
  EXPECT_EQ(t, cpu) << "the time axis is the CPU clock";
  EXPECT_GE(cpu, 1.0);
  EXPECT_LT(cpu, 1.5);
  const Proc m = ctr("bench merge " + out.string() + " --out " + (out / "merged").string() + " --quiet");
  ASSERT_EQ(m.code, 0) << m.err;
  const json sum = readJson(out / "merged" / "summary.json");
  EXPECT_TRUE(sum["complete"]);
  EXPECT_NE(sum.dump().find("\"clock\":\"cpu\""), std::string::npos) << sum.dump();
}

TEST(Campaign, BenchCampaignMergeNamesMissingAndDuplicatedRuns) {
  const fs::path c = smallCampaign();
  const fs::path part = workDir() / "part", other = workDir() / "other", merged = workDir() / "merged_bad";
  fs::remove_all(part);
  fs::remove_all(other);
  fs::remove_all(merged);
  const Proc s = ctr("bench " + c.string() + " --out " + part.string() + " --shard 1/3 --quiet");
  ASSERT_EQ(s.code, 0) << s.err;
  EXPECT_EQ(s.err, "") << "--quiet prints nothing on stderr";
  const json sj = readJson(part / "shards" / "shard-1-of-3.json");
  ASSERT_EQ(sj["units_run"].size(), 1u);
  const std::string have = sj["units_run"][0];
  // Missing: the three other units are named, nothing is written.
  const Proc m = ctr("bench merge " + part.string() + " --out " + merged.string());
  EXPECT_EQ(m.code, 2) << m.err;
  EXPECT_NE(m.err.find("missing 3 unit(s), 3 run(s)"), std::string::npos) << m.err;
  int named = 0;
  for (const std::string id : {"proc_intracardiac/exact/kpiece/seed-1", "proc_intracardiac/exact/kpiece/seed-2",
                               "proc_intracardiac/exact/rrt/seed-1", "proc_intracardiac/exact/rrt/seed-2"})
    if (id != have) {
      EXPECT_NE(m.err.find("missing: " + id), std::string::npos) << id << "\n" << m.err;
      ++named;
    }
  EXPECT_EQ(named, 3);
  EXPECT_FALSE(fs::exists(merged / "benchmark.db"));
  EXPECT_FALSE(fs::exists(merged / "summary.json"));
  // Duplicated: the same unit in two folders.
  fs::create_directories(other / "units");
  fs::copy_file(part / "campaign.json", other / "campaign.json");
  for (const auto& e : fs::directory_iterator(part / "units"))
    fs::copy_file(e.path(), other / "units" / e.path().filename());
  const Proc d =
      ctr("bench merge " + part.string() + " " + other.string() + " --out " + merged.string() + " --allow-incomplete");
  EXPECT_EQ(d.code, 2) << d.err;
  EXPECT_NE(d.err.find("duplicated: " + have), std::string::npos) << d.err;
  EXPECT_FALSE(fs::exists(merged / "benchmark.db"));
  // --allow-incomplete merges what is there and says what is missing.
  const Proc ok = ctr("bench merge " + part.string() + " --out " + merged.string() + " --allow-incomplete");
  ASSERT_EQ(ok.code, 0) << ok.err;
  EXPECT_NE(ok.err.find("warning: missing"), std::string::npos);
  const json sum = readJson(merged / "summary.json");
  EXPECT_FALSE(sum["complete"]);
  EXPECT_EQ(sum["missing"].size(), 3u);
  EXPECT_EQ(sum["runs"], 1);
  // A folder of another campaign is refused before any work.
  const fs::path c2 = writeCampaign("small2", "name: small2\nqueries: [" + query() +
                                                  "]\nplanners: [rrt]\nmodes: [exact]\nseeds: [7]\ntime_limit: 1\n");
  const Proc mix = ctr("bench " + c2.string() + " --out " + part.string());
  EXPECT_EQ(mix.code, 2);
  EXPECT_NE(mix.err.find("another campaign"), std::string::npos) << mix.err;
}
