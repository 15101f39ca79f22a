// Bindings of ctr::design: ctr.design(queries, ...) returns the `ctr design` result (result.json) as a dict.
#include <filesystem>

#include "common.hpp"
#include "ctr/design/output.hpp"
#include "ctr/design/search.hpp"

namespace ctr::py {

void registerDesign(pyb::module_& m) {
  using pyb::arg;
  m.def(
      "design",
      [](const std::vector<std::filesystem::path>& queries, const std::optional<std::filesystem::path>& space,
         const std::optional<std::filesystem::path>& out, std::uint64_t seed, int evaluations, int population,
         int starts, double time_limit, int threads, double probe_time, double plan_time, const std::string& planner,
         int confirm, int finalists, int finalist_plans, double finalist_rate) {
        std::vector<planner::Query> qs;
        for (const auto& q : queries) qs.push_back(planner::loadQuery(q.string()));
        std::optional<design::DesignSpace> sp;
        if (space) sp = design::loadSpace(space->string());
        design::DesignOptions o;
        o.seed = seed;
        o.evaluations = evaluations;
        o.population = population;
        o.starts = starts;
        o.time_limit = time_limit;
        o.threads = threads;
        o.probe_time = probe_time;
        o.plan_time = plan_time;
        o.planner = planner;
        o.confirm_seeds = confirm;
        o.finalists = finalists;
        o.finalist_plans = finalist_plans;
        o.finalist_rate = finalist_rate;
        std::string text;
        {
          pyb::gil_scoped_release release;
          const design::Designer d(std::move(qs), std::move(sp));
          const design::DesignResult r = d.run(o);
          if (out) design::writeDesign(d, r, o, "0/1", out->string());
          text = design::resultJson(d, r, o, "0/1");
        }
        return pyb::module_::import("json").attr("loads")(text);
      },
      arg("queries"), arg("space") = pyb::none(), arg("out") = pyb::none(), arg("seed") = 1, arg("evaluations") = 40,
      arg("population") = 8, arg("starts") = 1, arg("time_limit") = 0.0, arg("threads") = 0, arg("probe_time") = 2.0,
      arg("plan_time") = 0.0, arg("planner") = "", arg("confirm") = 1, arg("finalists") = 3, arg("finalist_plans") = 8,
      arg("finalist_rate") = 0.8,
      "Designs one robot for the query files (docs/design.md): the dict of `ctr design`'s result.json (solved, "
      "message, design with its robot YAML, per query the plan result of `ctr plan --json`, the finalists' "
      "independent plans and the kept design's success rate (confirmation), every evaluation). "
      "space: a design space YAML (None: derived from the first query's robot); out: also write the output folder "
      "(robot.yaml, queries/, paths/, result.json). Raises ctr.InputError for bad files.");
}

}  // namespace ctr::py
