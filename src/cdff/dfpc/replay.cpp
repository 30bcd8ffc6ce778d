#include "cdff/dfpc/replay.hpp"

#include <algorithm>
#include <cmath>
#include <set>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "cdff/dfpc/designation.hpp"
#include "cdff/dfpc/run_set.hpp"

namespace cdff::dfpc {

Result<ChannelRemap> parseRemap(const std::string& text) {
  const std::size_t eq = text.find('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 == text.size())
    return invalidParameter("remap '{}': expected INPUT=CHANNEL or DFPC.INPUT=CHANNEL", text);
  return ChannelRemap{text.substr(0, eq), text.substr(eq + 1)};
}

namespace {

Status applyRemaps(std::vector<GraphSpec>& graphs, const std::vector<ChannelRemap>& remaps) {
  for (const ChannelRemap& r : remaps) {
    const PortRef ref = PortRef::parse(r.input);
    std::vector<DfpcInputSpec*> matches;
    std::vector<std::string> known;
    for (GraphSpec& g : graphs)
      for (DfpcInputSpec& in : g.inputs) {
        known.push_back(g.name + "." + in.name);
        if (in.name == ref.port && (ref.instance.empty() || ref.instance == g.name))
          matches.push_back(&in);
      }
    if (matches.empty())
      return notFound("remap '{}={}': no DFPC input '{}'; expected one of {{{}}}", r.input,
                      r.channel, r.input, fmt::join(known, ", "));
    if (matches.size() > 1)
      return invalidParameter(
          "remap '{}={}': several DFPCs have an input '{}'; write "
          "DFPC.INPUT",
          r.input, r.channel, r.input);
    matches.front()->channel = r.channel;
  }
  return Status::ok();
}

/// Each `--set` addresses exactly one graph's instance.
Status checkSettingsApplied(const std::vector<ParameterSetting>& settings,
                            const std::vector<std::vector<std::string>>& applied_to,
                            const std::vector<GraphSpec>& graphs) {
  for (std::size_t i = 0; i < settings.size(); ++i) {
    const ParameterSetting& s = settings[i];
    const SourceLocation where{"--set " + s.text, 0, 0};
    if (applied_to[i].size() > 1)
      return Status(StatusCode::kInvalidParameter,
                    fmt::format("the DFPCs {{{}}} all have a node '{}'; expected DFPC/{}",
                                fmt::join(applied_to[i], ", "), s.node, s.text),
                    where);
    if (!applied_to[i].empty()) continue;
    std::vector<std::string> nodes, names;
    for (const GraphSpec& g : graphs) {
      names.push_back(g.name);
      if (s.dfpc.empty() || s.dfpc == g.name)
        for (const InstanceSpec& inst : g.instances) nodes.push_back(inst.name);
    }
    const std::string in = s.dfpc.empty() ? "no DFPC graph" : fmt::format("DFPC '{}'", s.dfpc);
    if (!s.dfpc.empty() && std::find(names.begin(), names.end(), s.dfpc) == names.end())
      return Status(StatusCode::kNotFound,
                    fmt::format("no DFPC '{}' is run; expected one of {{{}}}{}", s.dfpc,
                                fmt::join(names, ", "), schema::didYouMean(s.dfpc, names)),
                    where);
    return Status(StatusCode::kNotFound,
                  fmt::format("{} has a node '{}'; expected one of {{{}}}{}", in, s.node,
                              fmt::join(nodes, ", "), schema::didYouMean(s.node, nodes)),
                  where);
  }
  return Status::ok();
}

}  // namespace

Result<std::vector<GraphSpec>> loadGraphs(const ReplayOptions& options) {
  if (options.graph_files.empty()) return invalidParameter("no DFPC graph to run");
  std::vector<ParameterSetting> settings;
  for (const std::string& text : options.parameter_settings) {
    Result<ParameterSetting> s = parseParameterSetting(text);
    if (!s) return s.status();
    settings.push_back(std::move(s).value());
  }
  std::vector<GraphSpec> graphs;
  std::vector<std::vector<std::string>> applied_to(settings.size());
  for (const std::string& path : options.graph_files) {
    std::vector<bool> applied;
    Result<GraphSpec> spec = loadGraphFile(path, settings, applied);
    if (!spec) return spec.status();
    for (std::size_t i = 0; i < settings.size(); ++i)
      if (applied[i]) applied_to[i].push_back(spec->name);
    graphs.push_back(std::move(spec).value());
  }
  CDFF_RETURN_IF_ERROR(checkSettingsApplied(settings, applied_to, graphs));
  CDFF_RETURN_IF_ERROR(applyRemaps(graphs, options.remaps));
  return graphs;
}

namespace {

/// The orchestrator of a run (options expanded): its graphs loaded, created and added, its
/// rules bound.
Result<std::unique_ptr<Orchestrator>> buildOrchestrator(const ReplayOptions& options,
                                                        const OrchestratorOptions& o) {
  Result<std::vector<GraphSpec>> loaded = loadGraphs(options);
  if (!loaded) return loaded.status();
  auto orchestrator = std::make_unique<Orchestrator>(o);
  for (GraphSpec& g : *loaded) {
    Result<std::unique_ptr<Dfpc>> dfpc = Dfpc::create(std::move(g));
    if (!dfpc) return dfpc.status();
    CDFF_RETURN_IF_ERROR(orchestrator->add(std::move(dfpc).value()));
  }
  for (const ActivationRule& rule : options.run_while)
    CDFF_RETURN_IF_ERROR(orchestrator->runWhile(rule));
  return orchestrator;
}

}  // namespace

Status checkRun(const ReplayOptions& given) {
  Result<ReplayOptions> expanded = expandRunSets(given);
  if (!expanded) return expanded.status();
  return buildOrchestrator(*expanded, {}).status();
}

Result<ReplayOptions> expandRunSets(const ReplayOptions& options) {
  ReplayOptions out = options;
  out.graph_files.clear();
  std::vector<std::string> settings;
  for (const std::string& path : options.graph_files) {
    if (!isRunSetFile(path)) {
      out.graph_files.push_back(path);
      continue;
    }
    Result<RunSet> set = loadRunSet(path);
    if (!set) return set.status();
    out.graph_files.insert(out.graph_files.end(), set->graph_files.begin(), set->graph_files.end());
    settings.insert(settings.end(), set->settings.begin(), set->settings.end());
    out.remaps.insert(out.remaps.end(), set->maps.begin(), set->maps.end());
    out.stereo_pairs.insert(out.stereo_pairs.end(), set->pairs.begin(), set->pairs.end());
    out.run_while.insert(out.run_while.end(), set->run_while.begin(), set->run_while.end());
  }
  // The run sets' settings first: a setting of the command line given later wins.
  settings.insert(settings.end(), options.parameter_settings.begin(),
                  options.parameter_settings.end());
  out.parameter_settings = std::move(settings);
  return out;
}

Result<std::vector<ChannelInfo>> externalInputs(const ReplayOptions& given) {
  Result<ReplayOptions> expanded = expandRunSets(given);
  if (!expanded) return expanded.status();
  const ReplayOptions& options = *expanded;
  Result<std::vector<GraphSpec>> graphs = loadGraphs(options);
  if (!graphs) return graphs.status();
  std::set<std::string> produced;
  for (const GraphSpec& g : *graphs)
    for (const DfpcOutputSpec& out : g.outputs) produced.insert(g.outputChannel(out));
  std::vector<ChannelInfo> inputs;
  std::set<std::string> seen;
  for (const GraphSpec& g : *graphs)
    for (const DfpcInputSpec& in : g.inputs) {
      if (produced.count(in.channel) || !seen.insert(in.channel).second) continue;
      const TypeId type = findType(in.type);
      if (!type) return notFound("input '{}.{}': unknown type '{}'", g.name, in.name, in.type);
      inputs.push_back({in.channel, type, 0});
    }
  return inputs;
}

Result<ReplayResult> replay(InputStream& input, Sink& sink, const ReplayOptions& given) {
  Result<ReplayOptions> expanded = expandRunSets(given);
  if (!expanded) return expanded.status();
  const ReplayOptions& options = *expanded;
  OrchestratorOptions o;
  o.sink = &sink;
  o.record_timing = options.record_timing;
  o.passthrough_prefixes = options.passthrough_prefixes;
  Result<std::unique_ptr<Orchestrator>> built = buildOrchestrator(options, o);
  if (!built) return built.status();
  Orchestrator& orchestrator = **built;
  CDFF_RETURN_IF_ERROR(orchestrator.startAll());
  RunOptions run;
  run.realtime = options.realtime;
  run.speed = options.speed;
  run.clock = options.clock;
  run.progress = options.progress;
  run.cancel = options.cancel;
  StereoPairStream paired(input, options.stereo_pairs);
  InputStream& unmerged = options.stereo_pairs.empty() ? input : paired;
  const std::unique_ptr<InputStream> merged = withMessages(unmerged, options.injected);
  InputStream& source = options.injected.empty() ? unmerged : *merged;
  Result<RunSummary> summary = orchestrator.run(source, run);
  if (!summary) {
    // The DFPCs stop where the input failed, so that what was recorded ends with their stop.
    (void)orchestrator.stopAll();
    return summary.status();
  }
  return ReplayResult{std::move(summary).value(), orchestrator.statuses()};
}

// ---------------------------------------------------------------------------------------------

ProgressBar::ProgressBar(std::FILE* out, bool enabled, double interval_s)
    : out_(out), enabled_(enabled && out), interval_(fromSeconds(interval_s)) {}

std::string ProgressBar::render(const RunProgress& p, int width) {
  const double f = p.fraction();
  std::string line;
  if (f >= 0) {
    const int filled = static_cast<int>(std::lround(f * width));
    line = fmt::format("[{}{}] {:5.1f} %  ", std::string(filled, '#'),
                       std::string(width - filled, '.'), 100.0 * f);
  }
  const double t = p.range ? toSeconds(p.stamp - p.range->first) : toSeconds(p.stamp);
  line += fmt::format("t = {:.2f} s", t);
  if (p.range) line += fmt::format(" of {:.2f} s", toSeconds(p.range->second - p.range->first));
  line += fmt::format("  {} messages", p.messages);
  return line;
}

void ProgressBar::update(const RunProgress& progress) {
  if (!enabled_) return;
  last_ = progress;
  const Timestamp now = SteadyClock().now();
  if (last_draw_ != 0 && now - last_draw_ < interval_) return;
  last_draw_ = now;
  std::fprintf(out_, "\r%s", render(progress).c_str());
  std::fflush(out_);
}

void ProgressBar::finish() {
  if (!enabled_ || !last_) return;
  std::fprintf(out_, "\r%s\n", render(*last_).c_str());
  std::fflush(out_);
}

}  // namespace cdff::dfpc
