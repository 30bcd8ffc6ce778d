#include "cdff/dfpc/run_set.hpp"

#include <filesystem>
#include <type_traits>

#include <yaml-cpp/yaml.h>

#include "cdff/dfpc/graph.hpp"
#include "cdff/dfpc/orchestrator.hpp"
#include "cdff/dfpc/replay.hpp"
#include "cdff/dfpc/stereo_pairing.hpp"
#include "cdff/schema/field.hpp"

namespace cdff::dfpc {

namespace fs = std::filesystem;

bool isRunSetFile(const std::string& path) {
  try {
    const YAML::Node root = YAML::LoadFile(path);
    return root.IsMap() && root["graphs"].IsDefined();
  } catch (const std::exception&) {
    return false;  // not YAML, or unreadable: the graph reader says why
  }
}

namespace {

/// The words of `field` (a list of strings), each parsed by `parse` (the command line's), an
/// error at its own line.
template <typename Parse, typename T>
Status readWords(const schema::Field& field, std::string_view expected, Parse parse,
                 std::vector<T>& out) {
  if (!field.defined()) return Status::ok();
  if (!field.isList()) return field.fail(expected, field.notA("list"));
  for (const schema::Field& word : field.elements()) {
    std::string text;
    CDFF_RETURN_IF_ERROR(word.read(text));
    auto parsed = parse(text);
    if (!parsed) return word.fail(expected, parsed.status().message());
    if constexpr (std::is_same_v<T, std::string>)
      out.push_back(std::move(text));  // a setting: graph loading applies the text
    else
      out.push_back(std::move(parsed).value());
  }
  return Status::ok();
}

}  // namespace

Result<RunSet> loadRunSet(const std::string& path) {
  Result<schema::Document> document = schema::Document::loadFile(path, "run set file");
  if (!document) return document.status();
  const schema::Field root = document->root();
  if (!root.isMap())
    return root.fail("a map with graphs, and optionally map, set, pair, run_while");
  const std::vector<std::string> keys{"name", "doc", "graphs", "map", "set", "pair", "run_while"};
  for (const schema::Field::Entry& e : root.entries())
    if (std::find(keys.begin(), keys.end(), e.key) == keys.end())
      return e.key_field.unknownKey(keys);
  RunSet set;
  if (root.has("name")) CDFF_RETURN_IF_ERROR(root["name"].read(set.name));
  if (root.has("doc")) CDFF_RETURN_IF_ERROR(root["doc"].read(set.doc));
  const schema::Field graphs = root["graphs"];
  if (!graphs.isList() || graphs.size() == 0)
    return graphs.fail("a list of DFPC graph files, relative to the run set's folder",
                       graphs.isList() ? "empty" : graphs.notA("list"));
  const fs::path folder = fs::path(path).parent_path();
  for (const schema::Field& g : graphs.elements()) {
    std::string file;
    CDFF_RETURN_IF_ERROR(g.read(file));
    const fs::path resolved = fs::path(file).is_absolute() ? fs::path(file) : folder / file;
    if (!fs::is_regular_file(resolved))
      return g.fail("a DFPC graph file, relative to the run set's folder",
                    fmt::format("no file '{}'", resolved.string()), StatusCode::kNotFound);
    set.graph_files.push_back(resolved.lexically_normal().string());
  }
  CDFF_RETURN_IF_ERROR(
      readWords(root["map"], "DFPC.INPUT=/channel, as cdff run --map", parseRemap, set.maps));
  CDFF_RETURN_IF_ERROR(readWords(root["set"], "[DFPC/]NODE.PARAMETER=VALUE, as cdff run --set",
                                 parseParameterSetting, set.settings));
  CDFF_RETURN_IF_ERROR(readWords(root["pair"], "/PAIR=/LEFT,/RIGHT, as cdff run --pair",
                                 parseStereoPairing, set.pairs));
  CDFF_RETURN_IF_ERROR(readWords(root["run_while"], "a rule, as cdff run --run-while",
                                 parseActivationRule, set.run_while));
  return set;
}

}  // namespace cdff::dfpc
