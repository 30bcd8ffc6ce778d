// cdff: the command-line front end of the CDFF framework.
#include <iostream>

#include <CLI/CLI.hpp>

#include "commands.hpp"

int main(int argc, char** argv) {
  CLI::App app{"CDFF: data fusion for spacecraft relative navigation", "cdff"};
  app.set_version_flag("--version", std::string("cdff ") + CDFF_VERSION);
  app.require_subcommand(1);
  app.fallthrough(false);

  int exit_code = 0;
  cdff::app::addDfnCommands(app, exit_code);
  cdff::app::addDemoCommand(app, exit_code);
#ifdef CDFF_HAVE_LOG_COMMAND
  cdff::app::addLogCommands(app, exit_code);
#endif

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
