// cdff: the command-line front end of the CDFF framework.
#include <iostream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <CLI/CLI.hpp>

#include "cdff/types/memory.hpp"
#include "commands.hpp"

namespace {

// CLI11 reports a mistyped subcommand as a missing one ("A subcommand is required"); name it
// instead. Walks the words of the command line down the subcommand tree while the current
// command has subcommands; returns false after printing the error.
bool subcommandsAreKnown(CLI::App& app, int argc, char** argv) {
  CLI::App* current = &app;
  std::string path = "cdff";
  for (int i = 1; i < argc; ++i) {
    const std::string word = argv[i];
    if (word.empty() || word[0] == '-') continue;
    const std::vector<CLI::App*> children =
        current->get_subcommands([](CLI::App*) { return true; });
    if (children.empty()) return true;  // a leaf command: the rest are its arguments
    std::vector<std::string> names;
    CLI::App* next = nullptr;
    for (CLI::App* child : children) {
      names.push_back(child->get_name());
      if (child->get_name() == word) next = child;
    }
    if (!next) {
      fmt::print(stderr, "error: unknown subcommand '{}' of `{}`; expected one of {{{}}}\n", word,
                 path, fmt::join(names, ", "));
      fmt::print(stderr, "Run with --help for more information.\n");
      return false;
    }
    current = next;
    path += " " + word;
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  cdff::keepFreedBuffersForReuse();  // image-sized buffers reused frame after frame
  CLI::App app{"CDFF: data fusion for spacecraft relative navigation", "cdff"};
  app.set_version_flag("--version", std::string("cdff ") + CDFF_VERSION);
  app.require_subcommand(1);
  app.fallthrough(false);

  int exit_code = 0;
  cdff::app::addDfnCommands(app, exit_code);
  cdff::app::addDemoCommand(app, exit_code);
  cdff::app::addDfpcCommands(app, exit_code);
  cdff::app::addLogCommands(app, exit_code);
  cdff::app::addRunCommand(app, exit_code);
  cdff::app::addEvalCommand(app, exit_code);
  cdff::app::addInitialStateCommand(app, exit_code);
  cdff::app::addSimCommand(app, exit_code);
  cdff::app::addModelCommands(app, exit_code);
  cdff::app::addTrainCommand(app, exit_code);
  cdff::app::addCampaignCommands(app, exit_code);
  cdff::app::addDdsCommands(app, exit_code);
  cdff::app::addServeCommand(app, exit_code);

  if (!subcommandsAreKnown(app, argc, argv)) return 2;
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);  // prints the message and the usage
    return 2;
  }
  return exit_code;
}
