// Bindings of ctr::campaign: benchmark campaigns (load, shard, run, merge into the Planner Arena database) and the
// benchmark of one query, the same library calls as `ctr bench` and `ctr bench merge`.
#include "ctr/campaign/campaign.hpp"

#include "common.hpp"
#include "ctr/campaign/merge.hpp"
#include "ctr/campaign/run.hpp"
#include "ctr/planner/query.hpp"

namespace ctr::py {

namespace {

using pyb::arg;

// A shard from "I/N" or (I, N); None is the whole campaign.
campaign::Shard toShard(const pyb::handle& h) {
  if (h.is_none()) return {};
  if (pyb::isinstance<pyb::str>(h)) return campaign::parseShard(h.cast<std::string>());
  if (pyb::isinstance<pyb::tuple>(h) || pyb::isinstance<pyb::list>(h)) {
    const auto s = h.cast<pyb::sequence>();
    if (s.size() != 2) throw pyb::value_error("shard: (index, count) or 'I/N'");
    const long long i = s[0].cast<long long>(), n = s[1].cast<long long>();
    if (n < 1 || i < 0 || i >= n) throw pyb::value_error("shard: (index, count) with 0 <= index < count");
    return campaign::Shard{static_cast<std::size_t>(i), static_cast<std::size_t>(n)};
  }
  throw pyb::type_error("shard: 'I/N', (index, count) or None");
}

pyb::dict unitDict(const campaign::CampaignUnit& u) {
  pyb::dict d;
  d["id"] = u.id();
  d["query"] = u.query_name;
  d["mode"] = u.mode;
  d["planner"] = u.planner;
  d["seed"] = u.seed;
  return d;
}

pyb::list unitList(const std::vector<campaign::CampaignUnit>& units) {
  pyb::list l;
  for (const auto& u : units) l.append(unitDict(u));
  return l;
}

}  // namespace

void registerCampaign(pyb::module_& m) {
  pyb::class_<campaign::Campaign>(m, "Campaign",
                                  "A benchmark campaign (docs/formats.md \"Campaign\"): queries x planners x modes x "
                                  "seeds, each unit run runs_per_seed times. Load with ctr.load_campaign(path).")
      .def_readonly("file", &campaign::Campaign::file)
      .def_readonly("name", &campaign::Campaign::name)
      .def_property_readonly("queries",
                             [](const campaign::Campaign& c) {
                               pyb::list l;
                               for (const auto& q : c.queries) {
                                 pyb::dict d;
                                 d["file"] = q.file;
                                 d["name"] = q.name;
                                 l.append(d);
                               }
                               return l;
                             })
      .def_readonly("planners", &campaign::Campaign::planners)
      .def_readonly("modes", &campaign::Campaign::modes)
      .def_readonly("seeds", &campaign::Campaign::seeds)
      .def_readonly("time_limit", &campaign::Campaign::time_limit)
      .def_readonly("runs_per_seed", &campaign::Campaign::runs_per_seed)
      .def_readonly("cpu_time", &campaign::Campaign::cpu_time)
      .def_readonly("fingerprint", &campaign::Campaign::fingerprint,
                    "Hash of everything that defines the runs (campaign values and query, robot, map contents).")
      .def(
          "units", [](const campaign::Campaign& c) { return unitList(c.units()); },
          "Every unit (dicts: id, query, mode, planner, seed), sorted by (query, mode, planner, seed).")
      .def(
          "shard",
          [](const campaign::Campaign& c, const pyb::object& shard) { return unitList(c.shard(toShard(shard))); },
          arg("shard"), "The units of a shard ('I/N' or (index, count)): unit k goes to shard k mod N.")
      .def("to_json", &campaign::Campaign::toJson, "The campaign as written to OUT/campaign.json.")
      .def("__repr__", [](const campaign::Campaign& c) {
        return "<ctr.Campaign '" + c.name + "', " + std::to_string(c.units().size()) + " units x " +
               std::to_string(c.runs_per_seed) + " runs>";
      });

  m.def(
      "load_campaign", [](const std::filesystem::path& path) { return campaign::loadCampaign(path.string()); },
      arg("path"), "Parses and checks a campaign file. Raises ctr.InputError naming the file, line and key.");
  m.def(
      "is_campaign_file", [](const std::filesystem::path& path) { return campaign::isCampaignFile(path.string()); },
      arg("path"), "True when the YAML file is a campaign (a top-level `queries:` key) rather than a query.");

  m.def(
      "run_campaign",
      [](const pyb::object& c, const std::filesystem::path& out, const pyb::object& shard) {
        const campaign::Campaign loaded = pyb::isinstance<campaign::Campaign>(c)
                                              ? c.cast<campaign::Campaign>()
                                              : campaign::loadCampaign(c.cast<std::filesystem::path>().string());
        campaign::RunOptions options;
        options.out = out.string();
        options.shard = toShard(shard);
        campaign::RunSummary s;
        {
          pyb::gil_scoped_release release;
          s = campaign::runCampaign(loaded, options);
        }
        pyb::dict d;
        d["shard"] = s.shard;
        d["units"] = s.units;
        d["units_run"] = s.units_run;
        d["units_kept"] = s.units_kept;
        d["seconds"] = s.seconds;
        d["records"] = s.records;
        d["shard_record"] = s.shard_record;
        return d;
      },
      arg("campaign"), arg("out"), arg("shard") = pyb::none(),
      "Runs a campaign (a ctr.Campaign or its file) or one shard of it ('I/N' or (index, count)) into the folder "
      "`out`, as `ctr bench CAMPAIGN.yaml --out OUT --shard I/N`: per unit an OMPL log and a record; units already "
      "recorded there are kept. Returns dict(shard, units, units_run, units_kept, seconds, records, shard_record). "
      "ctr.InputError when `out` holds another campaign's runs. No GIL while running.");

  m.def(
      "merge_campaign",
      [](const std::vector<std::filesystem::path>& dirs, const std::filesystem::path& out, bool allow_incomplete,
         const std::optional<std::filesystem::path>& statistics_tool) {
        std::vector<std::string> ds;
        for (const auto& d : dirs) ds.push_back(d.string());
        campaign::MergeOptions options;
        options.allow_incomplete = allow_incomplete;
        if (statistics_tool) options.statistics_tool = statistics_tool->string();
        campaign::MergeSummary s;
        {
          pyb::gil_scoped_release release;
          s = campaign::mergeCampaign(ds, out.string(), options);
        }
        return jsonLoads(s.summary_json);
      },
      arg("dirs"), arg("out"), arg("allow_incomplete") = false, arg("statistics_tool") = pyb::none(),
      "Merges the output folders of a campaign's shards into `out` (benchmark.db for Planner Arena, summary.json, "
      "logs/), as `ctr bench merge`. Returns summary.json as a dict (its `missing` lists the units not there, with "
      "allow_incomplete). ctr.InputError names each missing, duplicated or foreign record. statistics_tool: OMPL's "
      "ompl_benchmark_statistics (default: CTR_OMPL_BENCHMARK_STATISTICS, else PATH).");

  m.def(
      "benchmark",
      [](const planner::Query& q, const std::optional<std::vector<std::string>>& planners, int runs, double time_limit,
         const std::filesystem::path& out) {
        campaign::BenchmarkOptions options;
        if (planners) options.planners = *planners;
        options.runs = runs;
        options.time_limit = time_limit;
        options.out = out.string();
        campaign::BenchmarkSummary s;
        {
          pyb::gil_scoped_release release;
          s = campaign::benchmarkQuery(q, options);
        }
        pyb::dict d;
        d["rows"] = jsonLoads(s.toJson());
        d["goal_pool"] = s.goal_pool;
        d["log"] = s.log;
        d["summary_file"] = s.summary_file;
        return d;
      },
      arg("query"), arg("planners") = pyb::none(), arg("runs") = 10, arg("time_limit") = 5.0, arg("out"),
      "Benchmarks planners on one query (ompl::tools::Benchmark, `runs` runs per planner, every solution replayed), "
      "as `ctr bench QUERY.yaml`. Returns dict(rows (summary.json: one dict per planner), goal_pool, log, "
      "summary_file). No GIL while running.");
}

}  // namespace ctr::py
