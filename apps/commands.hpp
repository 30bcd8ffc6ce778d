#pragma once
// Subcommand groups of the `cdff` command. Each adds itself to the root app; its callbacks set
// `exit_code` (0 success, 1 failure, 2 usage error).

#include <CLI/CLI.hpp>

namespace cdff::app {

void addDfnCommands(CLI::App& root, int& exit_code);
void addDemoCommand(CLI::App& root, int& exit_code);
void addLogCommands(CLI::App& root, int& exit_code);
/// `cdff log export` (log_export_command.cpp), under the `log` subcommand.
void addLogExportCommand(CLI::App& log, int& exit_code);
void addSimCommand(CLI::App& root, int& exit_code);
void addDfpcCommands(CLI::App& root, int& exit_code);
void addRunCommand(CLI::App& root, int& exit_code);
void addEvalCommand(CLI::App& root, int& exit_code);
void addInitialStateCommand(CLI::App& root, int& exit_code);
void addModelCommands(CLI::App& root, int& exit_code);
void addTrainCommand(CLI::App& root, int& exit_code);
void addCampaignCommands(CLI::App& root, int& exit_code);
void addDdsCommands(CLI::App& root, int& exit_code);
void addServeCommand(CLI::App& root, int& exit_code);

}  // namespace cdff::app
